// Leaves as triangles: each leaf's outline (species/model/leaf_shape.h) on its card, both
// faces. Frame: +y up, metres.
#pragma once

#include "species/geometry/mesh.h"
#include "species/model/tree.h"

namespace sylva {

// Per leaf, the outline of its shape (the card: one quad) placed on the card — `size` along
// the leaf's tangent, size·aspect across, facing its normal — as two faces: the outline's
// points twice (front normal +leaf.normal, back −leaf.normal) and its triangles twice (the
// back ones reversed). The renderer draws the same triangles (leafPoints).
Mesh leafMesh(const Tree& tree);

}  // namespace sylva
