// Leaves as triangles: each leaf's outline (species/model/leaf_shape.h) on its card, both
// faces. Frame: +y up, metres.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "species/geometry/mesh.h"
#include "species/model/tree.h"

namespace sylva {

// Per leaf, the outline of its shape (the card: one quad) placed on the card — `size` along
// the leaf's tangent, size·aspect across, facing its normal — as two faces: the outline's
// points twice (front normal +leaf.normal, back −leaf.normal) and its triangles twice (the
// back ones reversed). The renderer draws the same triangles (leafPoints).
Mesh leafMesh(const Tree& tree);

// The size of leafMesh's mesh of these leaves, without making it: 2 × the outlines' points
// (vertices) and 2 × their triangles.
struct LeafMeshSize {
    size_t vertices = 0;
    size_t triangles = 0;
};
LeafMeshSize leafMeshSize(const std::vector<Leaf>& leaves);

// One leaf of a leafMesh: its front face is vertices [first, first + count), its back face the
// next `count` (same positions, normal negated).
struct LeafSpan {
    uint32_t first = 0;
    uint32_t count = 0;
};

// The leaves of a leafMesh, read back from its layout alone (the writers that colour each leaf
// have the mesh, not the tree): span k is leaf k of the tree it was made from, its faces
// found by their normals (every vertex of a face has the face's normal, the back the front's
// negation) and checked against the positions. Leaves with no outline points would leave no
// vertices and so shift the count; no leaf shape has none. Throws std::invalid_argument for a
// mesh not laid out as leafMesh lays it out (no normals, a back face that does not mirror its
// front).
std::vector<LeafSpan> leafSpans(const Mesh& leaves);

}  // namespace sylva
