// Summary measurements of one tree skeleton (written to the dataset's per-tree stats).
#pragma once

#include <cstdint>
#include <vector>

#include "species/model/tree.h"

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

    // Shape metrics (tree_metrics.h; definitions in README "Metrics"). They are taken
    // over the shoot (part == kShootPart) only. NaN marks a metric that is undefined for this
    // tree (written as JSON null), e.g. a bifurcation ratio when the Strahler order is < 2.
    int64_t strahlerOrder = 0;  // Horton–Strahler order of the shoot: max over segments
    // Index k-1 holds order k (k = 1 .. strahlerOrder): number of Strahler branches (maximal
    // chains of segments of one order) and their mean length along the skeleton, m.
    std::vector<int64_t> strahlerBranches;
    std::vector<double> strahlerBranchLength;
    // Index k-1 holds R_k = N_k / N_{k+1}, k = 1 .. strahlerOrder-1; the mean is over them.
    std::vector<double> bifurcationRatios;
    double bifurcationRatioMean = 0;
    int64_t forks = 0;                // shoot nodes with >= 2 shoot children
    double forkAngleMean = 0;         // degrees, over every (fork, child) pair
    double forkAngleStd = 0;          // degrees, population standard deviation
    int64_t radiusExponentForks = 0;  // forks with well-defined radii (see README)
    double radiusExponentMedian = 0;  // n with r_parent^n = sum r_child^n, per fork
    double radiusExponentIqr = 0;     // Q3 - Q1 (linear interpolation)
    double tortuosityMean = 0;        // tip-to-root path length / chord, over shoot tips
    double tortuosityMax = 0;
    double crownBaseHeight = 0;  // y of the first fork of the trunk, m
    double crownHeight = 0;      // max y of crown nodes - crown base height, m
    double crownWidthMajor = 0;  // horizontal extent along the crown's major principal axis, m
    double crownDepth = 0;       // horizontal extent along the perpendicular (minor) axis, m
    double crownAsymmetry = 0;   // distance of the crown-node centroid from the trunk axis, m
    int64_t leaves = 0;
    double leafArea = 0;  // sum of the leaves' outline areas (size² · aspect · shape area), m²

    // Realism measures (realism_metrics.h; definitions in docs/metrics.md), NaN if undefined.
    double lowestShootY = 0;         // min y of the shoot system, m (≥ 0: nothing underground)
    double belowGroundFraction = 0;  // shoot nodes (root node excluded) with y < 0, fraction
    int64_t stemsAtBase = 0;         // shoot segments leaving the base ball outward
    double leaderLeanDeg = 0;        // top fifth of the order-0 axis from the vertical, degrees
    double leafWoodDistanceP95 = 0;  // 95th percentile leaf attachment → wood surface, m
};

// Uses the orders already stored in the nodes (call assignBranchOrder first if needed).
// Throws std::invalid_argument on a tree whose parents are not all smaller indices.
TreeStats computeStats(const Tree& tree);

// Volume (m³) of the convex hull of the points; 0 for fewer than 4 distinct points or
// coplanar input. Exposed for tests and for other hull measurements.
double convexHullVolume(const std::vector<Vec3>& points);

}  // namespace sylva
