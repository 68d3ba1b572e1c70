// Spec reader for `type = "canopy-envelope"` (Shesh et al. §3.2, Eq. 1; volumes/canopy_envelope.h
// defines the angles, the layer tiling and the jitter).
//
// clang-format off
// | key          | type          | default     | meaning                                          |
// |--------------|---------------|-------------|--------------------------------------------------|
// | domain       | string        | "ellipsoid" | "ellipsoid" (centred) or "cone" (base at y = 0)  |
// | radii        | [kx, ky, kz]  | required    | k, metres (cone: base radii kx, kz; height ky)   |
// | persistence  | number [0, 1] | 0.7         | p in f = Σ pⁱ gᵢ(2ⁱφ, 2ⁱθ)                       |
// | jitter_deg   | degrees       | 2           | white-noise perturbation of (φ, θ); 0 = off      |
// | seed         | integer ≥ 0   | per tree    | fixes blobs/noise/jitter (the same envelope for  |
// |              |               |             | every tree); absent: drawn per tree              |
// | base_image   | file          | (g₀ = 1)    | g₀ from an image (grey in [0, 1]), relative to   |
// |              |               |             | the species file                                 |
// | base_channel | integer 0–3   | 0           | which channel of base_image                      |
// | layers       | [ {…}, … ]    | []          | g₁ … gₙ (at most 10), one table each:            |
// clang-format on
//
// layer tables (`type` first):
// | type = "blobs" | count (12), sigma (0.08, uv units of the layer's tile, ≤ 0.5), amplitude (1),|
// |                | centres = [[u, v], …] (optional, instead of count: blobs at given places)  |
// | type = "noise" | resolution (32), interpolation ("bilinear" or "nearest"), amplitude (1)    |
// | type = "image" | image (file), channel (0–3, default 0; up to four gᵢ packed in one image),  |
// |                | amplitude (1)                                                              |
//
// Example (Shesh Figure 2: three layers of Gaussian blobs over a constant base):
//   [crown]
//   type = "canopy-envelope"
//   radii = [3, 2.5, 3]
//   layers = [ { type = "blobs", count = 12, sigma = 0.08 },
//              { type = "blobs", count = 10, sigma = 0.1 },
//              { type = "noise", resolution = 16, amplitude = 0.5 } ]
#pragma once

#include <memory>

#include "core/params.h"
#include "volumes/canopy_envelope.h"

namespace sylva {

// Reads the keys above (not `type` or placement, which parseVolume handles).
std::shared_ptr<const CanopyEnvelope> parseCanopyEnvelope(Params& p);

}  // namespace sylva
