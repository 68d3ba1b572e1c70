// Leaf cards as triangles. Frame: +y up, metres.
#pragma once

#include "species/geometry/mesh.h"
#include "species/model/tree.h"

namespace sylva {

// Leaf cards: one quad (two triangles, both faces) per leaf, centred on the leaf position,
// spanning `size` along the leaf's tangent and size·aspect across, facing its normal.
Mesh leafMesh(const Tree& tree);

}  // namespace sylva
