// Volume specs in species files: a table with `type` and the primitive's dimensions, placed by
// position/axis/scale, composed with union/intersection/difference:
//
//   [crown]
//   type = "union"
//   parts = [ { type = "cylinder", radius = 0.3, height = 4 },
//             { type = "sphere-sector", radius = 5, alpha_deg = 54, position = [0, 3, 0] } ]
//   voxel_size = 0.05   # optional, top level only: realise as an OpenVDB level set
#pragma once

#include <cmath>

#include "core/params.h"
#include "volumes/mask.h"
#include "volumes/volume.h"

namespace sylva {

// The most voxels a level set may span over its bounds (voxel_size, level_set_voxel): 2·10⁹, as
// the errors say. The fuzz build (libFuzzer's FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION, set by
// SYLVA_FUZZ) allows 2·10⁷, so a level set at the limit builds within the fuzzer's per-input
// time limit: one near 2·10⁹ takes ~20 s and 800 MB to validate.
#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
constexpr double kMaxLevelSetVoxels = 2e7;
#else
constexpr double kMaxLevelSetVoxels = 2e9;
#endif
// How far from the origin, in voxels, a level set may reach: OpenVDB indexes voxels with 32-bit
// integers and meshes with floats (24-bit mantissa), so a crown 3·10⁹ m up overflowed the index
// (undefined behaviour) or hung building the level set. 2²⁰ voxels: 50 km at 5 cm.
constexpr double kMaxVoxelReach = 1048576.0;
inline bool withinVoxelReach(double coordinate, double voxel) {
    return std::abs(coordinate) / voxel < kMaxVoxelReach;
}
constexpr const char* kVoxelReachMessage =
    "the level set would lie over 2²⁰ voxels from the origin: move the volume nearer to it or "
    "use a coarser voxel";

// Parses a volume table (and its parts); errors name file, line and key path. The kinds are
// one table in volume_spec.cpp.
VolumePtr parseVolume(Params& p, bool topLevel = true);

// The `type` of every volume kind, in the table's order.
std::vector<std::string> volumeTypeNames();

// The sketched and envelope kinds, one file each (species/volume_spec_<kind>.cpp). Each
// reads the keys of its own type (not `type`, placement or `voxel_size`, which parseVolume
// handles) and reports bad values at their key with file:line.
// The pixel size of mask images: `height` (metres an image's full height represents) or
// `metres_per_pixel`, exactly one; `images` names them in the error ("the mask's", "each
// mask's"). Shared by the mask volumes and the space-colonization silhouette guide.
struct PixelScale {
    bool byHeight = false;
    double value = 0.0;  // metres of the full image height, or metres per pixel
    double metresPerPixel(int imageHeight) const { return byHeight ? value / imageHeight : value; }
};
PixelScale readPixelScale(Params& p, const std::string& images);
// The image at `mask` (relative to the species file), inverted when `invert = true`; a file
// that cannot be read as a mask fails at `mask`. Shared like readPixelScale.
Mask readMaskKeys(Params& p);
// Liu 2020's fall-off of samples at a mask's border: soft_edge, falloff_radius, falloff_k.
MaskFalloff readMaskFalloff(Params& p);

VolumePtr parseRevolutionVolume(Params& p);       // type = "revolution"
VolumePtr parseMaskRevolutionVolume(Params& p);   // type = "mask-revolution"
VolumePtr parseVisualHullVolume(Params& p);       // type = "visual-hull"
VolumePtr parseCanopyEnvelopeVolume(Params& p);   // type = "canopy-envelope"
VolumePtr parseCrownRefinementVolume(Params& p);  // type = "crown-refinement"

}  // namespace sylva
