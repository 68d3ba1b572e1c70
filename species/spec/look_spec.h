// Reader of a species' [look] table: how its trees look in colour (species/model/look.h).
// Keys, units and defaults: docs/specs.md ("Look").
#pragma once

#include "core/params.h"
#include "species/model/look.h"

namespace sylva {

// The [look] table (every key checked; plain numbers only: a look is the species', not drawn
// per tree).
Look readLook(Params& look);

}  // namespace sylva
