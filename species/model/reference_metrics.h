// The architecture distributions that `sylva stats --reference` compares with measured trees
// (published TreeQSM cylinder models; species/reference/): radius ratio and radius exponent at
// forks, first-order branch angle from the stem, path length from the base to each tip,
// branch length by order and each tip's height above the base, relative to the tree's height.
// Defined on the skeleton exactly as scripts/reference_from_treeqsm.py defines them on the
// cylinders (docs/metrics.md, "Reference distributions"). Metres and degrees; +y up.
#pragma once

#include <array>
#include <vector>

#include "species/model/tree.h"

namespace sylva {

enum ReferenceDistribution : int {
    kRadiusRatio,         // r_lateral / r_parent per lateral child of an uncapped fork
    kRadiusExponent,      // n with r_parent^n = Σ r_child^n per uncapped fork (radiusExponent)
    kBranchAngle,         // degrees between the stem and an order-1 branch's first segment
    kTipPathRatio,        // path length from the root node to a tip / tree height
    kBranchLengthOrder1,  // length of an order-1 branch / tree height
    kBranchLengthOrder2,
    kBranchLengthOrder3,
    kTipHeightRatio,         // a tip's height above the root node / tree height
    kReferenceDistributions  // count
};

// Names as in the reference files and in reference.csv ("radius_ratio", …, in enum order).
extern const std::array<const char*, kReferenceDistributions> kReferenceDistributionNames;

// TreeQSM caps a branch's cylinders at 0.95 × the radius of the cylinder it leaves, so forks
// with a lateral at or above this ratio are left out of the radius distributions (in the
// reference, and the same here so both are truncated alike).
constexpr double kReferenceCapRatio = 0.949;

// One value per fork, lateral, branch or tip, by distribution (in skeleton order).
using ReferenceValues = std::array<std::vector<double>, kReferenceDistributions>;

// The distributions of one tree's shoot (part == kShootPart; the root system is left out).
// Definitions: a *fork* is a shoot node with ≥ 2 shoot children. At every shoot node, the
// *continuing child* is the shoot child of the node's own order (SkeletonNode::order) with the
// longest path to a tip below it (ties: the smaller index), or, where no child has the node's
// order, the thickest shoot child (ties: the longest path, then the smaller index), so that a
// branch, and the stem, runs on to a tip, as TreeQSM makes them "as long as possible"; every
// other shoot child
// begins a *branch*, the maximal chain that follows continuing children. The *stem* is the
// chain from the root node, of order 0; a branch leaving a branch of order k has order k + 1
// (TreeQSM's numbering; a method may keep its order field at a fork where two children go on).
// A fork's *laterals* are its children other than the continuing one. The tree height is max y over
// shoot nodes − the root node's y. Empty distributions for an empty tree or one whose root node is
// not a shoot node; (d), (e) and (f) are empty when the height is not positive. Throws
// std::invalid_argument when a parent index is not smaller than its child's (as ChildIndex does).
ReferenceValues referenceValues(const Tree& tree);

// Every node's continuing child as defined above (−1 at a tip and for non-shoot nodes), given
// each node's longest path down to a tip over shoot segments (`reach`, one per node). The form
// stage turns branches about the same stem.
std::vector<int32_t> continuingChildren(const Tree& tree, const std::vector<double>& reach);

// Every node's branch order counted along `cont` (continuingChildren's answer): the stem 0, a
// branch leaving a branch of order k, k + 1; 0 for non-shoot nodes and the shoot nodes hanging
// from them.
std::vector<int32_t> branchOrders(const Tree& tree, const std::vector<int32_t>& cont);

}  // namespace sylva
