// Volume specs in species files: a table with `type` and the primitive's dimensions, placed by
// position/axis/scale, composed with union/intersection/difference:
//
//   [crown]
//   type = "union"
//   parts = [ { type = "cylinder", radius = 0.3, height = 4 },
//             { type = "sphere-sector", radius = 5, alpha_deg = 54, position = [0, 3, 0] } ]
//   voxel_size = 0.05   # optional, top level only: realise as an OpenVDB level set
#pragma once

#include "core/params.h"
#include "volumes/mask.h"
#include "volumes/volume.h"

namespace sylva {

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
