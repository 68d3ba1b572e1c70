// Summary measurements of one tree skeleton (written to the dataset's per-tree stats).
#pragma once

#include <cstdint>
#include <vector>

#include "species/tree.h"

namespace sylva {

struct TreeStats {
    int64_t nodes = 0;
    int64_t segments = 0;        // parent->child edges (every non-root node)
    int64_t endpoints = 0;       // tips: nodes without children, excluding the root
    int64_t highestOrder = 0;    // max SkeletonNode::order over all nodes (0 for an empty tree)
    double height = 0;           // max y of shoot nodes, m
    double rootDepth = 0;        // -min y of root-system nodes, m; 0 if there are none
    double crownWidth = 0;       // max of the x- and z-extent of shoot nodes, m
    double totalLength = 0;      // sum of all segment lengths (shoot and root), m
    double crownHullVolume = 0;  // convex hull of all shoot node positions, m³; 0 if degenerate
    // Segment counts indexed by branch order; a segment takes its child node's order.
    // Size highestOrder + 1 (empty for an empty tree).
    std::vector<int64_t> segmentsPerOrder;
};

// Uses the orders already stored in the nodes (call assignBranchOrder first if needed).
// Throws std::invalid_argument on a tree whose parents are not all smaller indices.
TreeStats computeStats(const Tree& tree);

// Volume (m³) of the convex hull of the points; 0 for fewer than 4 distinct points or
// coplanar input. Exposed for tests and for other hull measurements.
double convexHullVolume(const std::vector<Vec3>& points);

}  // namespace sylva
