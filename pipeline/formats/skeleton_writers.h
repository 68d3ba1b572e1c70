// Skeleton file formats. Both outputs are byte-deterministic for a given Tree.
#pragma once

#include <string>

#include "species/model/tree.h"

namespace sylva {

// Binary little-endian PLY 1.0:
//   element vertex N: float x, y, z, radius (m); int order; uchar part (0 shoot, 1 root)
//   element edge M:   int vertex1 (parent), int vertex2 (child), one per non-root node,
//                     in node order (M = N - 1).
std::string skeletonPly(const Tree& tree);

// SWC text: "id type x y z radius parent", ids 1-based (= node index + 1), parent -1 for
// the root. Types: 1 (soma) = root node 0, 3 (basal dendrite) = shoot, 2 (axon) = root
// system. Numbers use %.6g formatting (locale-independent). Starts with '#' comment lines.
std::string skeletonSwc(const Tree& tree);

}  // namespace sylva
