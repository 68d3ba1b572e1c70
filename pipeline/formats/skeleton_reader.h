// Reading a skeleton back from the binary PLY that skeletonPly (skeleton_writers.h) writes, for
// the analyses of a built dataset (`sylva stats --reference`).
#pragma once

#include <string>

#include "species/model/tree.h"

namespace sylva {

// Parses a binary little-endian PLY 1.0 skeleton: `element vertex N` with float (or any
// scalar type) x, y, z, radius and optional order (default 0) and part (default 0, shoot),
// then `element edge M` with vertex1 (parent) and vertex2 (child); other scalar properties and
// comments are skipped. Node 0 is the root; every other node must be the child of exactly one
// edge whose parent has a smaller index (the Tree invariant). Throws InputError
// "<name>: <what is wrong>" on anything else (ASCII or big-endian PLY, list properties,
// truncated data, a missing property, an edge out of range).
Tree readSkeletonPly(const std::string& bytes, const std::string& name);

}  // namespace sylva
