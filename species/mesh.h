// Triangle meshes shared by every growth method: branch tubes, leaf cards, and the watertight
// union of branch capsules. Frame: +y up, metres. Indices are 32-bit, so meshes of any size
// (well past 65,535 vertices) stay correct.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "species/tree.h"
#include "volumes/math.h"

namespace sylva {

struct Mesh {
    std::vector<float> positions;   // xyz per vertex, metres
    std::vector<float> normals;     // xyz per vertex, unit (may be empty: not computed)
    std::vector<float> uvs;         // uv per vertex (may be empty)
    std::vector<int32_t> order;     // branch order per vertex (wood), −1 for leaves
    std::vector<uint8_t> colour;    // leaf colour class per vertex (0 for wood)
    std::vector<uint32_t> indices;  // 3 per triangle, counter-clockwise seen from outside

    size_t vertexCount() const { return positions.size() / 3; }
    size_t triangleCount() const { return indices.size() / 3; }
    bool empty() const { return indices.empty(); }
};

// The meshes of one tree: wood and leaves apart (separate materials in GLB).
struct TreeMesh {
    Mesh wood;
    Mesh leaves;
};

// Level of detail for branch tubes.
struct TubeOptions {
    int minSides = 3;          // sides of the thinnest tube
    int maxSides = 16;         // sides of the thickest tube
    double edgeLength = 0.03;  // target length of a ring edge, metres: sides ≈ 2πr / edge
    double minRadius = 0.0;    // branches thinner than this (metres) are ...
    bool dropThin = false;     // ... dropped (true) or drawn as minSides tubes of minRadius
};

// Every branch chain (fork to tip) swept as one tapered generalised cylinder along the
// skeleton with rotation-minimising frames (double reflection, Wang et al. 2008); child
// tubes start at the fork node, inside their parent, so forks have no gaps; tips and the
// root base are closed. Per-vertex normals, bark UVs (u around, v along in units of the
// circumference) and branch order.
Mesh tubeMesh(const Tree& tree, const TubeOptions& options);

// Leaf cards: one quad (two triangles, both faces) per leaf, centred on the leaf position,
// spanning `size` along the leaf's tangent and size·aspect across, facing its normal.
Mesh leafMesh(const Tree& tree);

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
