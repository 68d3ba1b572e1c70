// Reader of the species' [form] table: the form stage every method's tree goes through
// (species/model/form.h). Keys, units, defaults and ranges: docs/specs.md ("Form").
#pragma once

#include "core/params.h"
#include "species/model/form.h"

namespace sylva {

// The species' [form] table (every step off when it has none).
FormOptions readForm(Params& species);

}  // namespace sylva
