// Spec reader for `type = "canopy-envelope"` (Shesh et al. §3.2, Eq. 1; volumes/canopy_envelope.h
// defines the angles, the layer tiling and the jitter).
//
// Keys, units, defaults and ranges: docs/specs.md, "canopy-envelope"
// (tests/project/spec_keys_test.cpp checks them against this reader); defaults are
// CanopyEnvelopeOptions' and CanopyLayer's.
#pragma once

#include <memory>

#include "core/params.h"
#include "volumes/canopy_envelope.h"

namespace sylva {

// Reads the keys above (not `type` or placement, which parseVolume handles).
std::shared_ptr<const CanopyEnvelope> parseCanopyEnvelope(Params& p);

}  // namespace sylva
