// Small helpers shared by the tests: hand-built skeletons and whole-file reads.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "species/tree.h"

namespace sylva::test {

// Appends a skeleton node and returns its index.
inline int32_t addNode(Tree& t, int32_t parent, Vec3 p, double radius = 0.01, int32_t order = 0,
                       uint8_t part = kShootPart) {
    SkeletonNode n;
    n.position = p;
    n.radius = radius;
    n.parent = parent;
    n.order = order;
    n.part = part;
    t.nodes.push_back(n);
    return static_cast<int32_t>(t.nodes.size() - 1);
}

inline std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace sylva::test
