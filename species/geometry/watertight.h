// The watertight union of a tree's branch capsules (OpenVDB level set, meshed). Frame: +y up,
// metres.
#pragma once

#include <string>

#include "species/geometry/mesh.h"
#include "species/model/tree.h"

namespace sylva {

struct WatertightOptions {
    double voxelSize = 0.02;  // metres; twigs thinner than ~1 voxel are thickened to it
    double halfWidth = 3.0;   // narrow band, voxels
};

// The union of all branch capsules (tapered, sphere-swept segments) as an OpenVDB level
// set, meshed with volumeToMesh into one closed manifold triangle mesh (order per vertex
// from the nearest segment). If vdbPath is non-empty the level set is also written there.
Mesh watertightMesh(const Tree& tree, const WatertightOptions& options,
                    const std::string& vdbPath = "");

}  // namespace sylva
