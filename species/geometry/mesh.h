// Triangle meshes made from a tree: branch tubes (tube_mesh.h), leaf cards (leaf_mesh.h) and
// the watertight union of branch capsules (watertight.h). Frame: +y up, metres. Indices are
// 32-bit, so meshes of any size (well past 65,535 vertices) stay correct.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

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

}  // namespace sylva
