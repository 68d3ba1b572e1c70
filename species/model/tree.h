// The shared tree model every growth method produces: a rooted skeleton plus (later) leaves.
// Frame: +y up, metres; the tree stands on the ground plane y = 0 with its root node at
// the origin. Nodes below ground (y < 0) belong to the root system (part == kRootPart).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/math.h"

namespace sylva {

enum : uint8_t { kShootPart = 0, kRootPart = 1 };

struct SkeletonNode {
    Vec3 position;
    double radius = 0.0;  // metres
    int32_t parent = -1;  // index of the parent node, -1 for the root (node 0)
    int32_t order = 0;    // branch order: 0 = trunk (or taproot), +1 at every lateral fork
    int32_t level = 0;    // growth level/iteration that created the node (method-specific)
    uint8_t part = kShootPart;
};

// A leaf's outline on its card (species/model/leaf_shape.h): the whole card, or a leaf form.
enum class LeafShape : uint8_t { kCard, kSimple, kLobed, kPalmate, kCompound, kNeedles, kFrond };

// A leaf card (Jain et al.'s particle leaves and Shesh's canopy leaves use the same model).
struct Leaf {
    Vec3 position;          // card centre, metres
    Vec3 normal{0, 1, 0};   // unit; the card faces it
    Vec3 tangent{1, 0, 0};  // unit, perpendicular to normal: the card's long axis
    double size = 0.1;      // card length along the tangent, metres
    double aspect = 0.6;    // width / length
    uint8_t colour = 0;     // colour class (species-defined: e.g. 0 dark green … 3 yellow)
    LeafShape shape = LeafShape::kCard;  // the outline drawn on the card
    int32_t node = -1;  // skeleton node that carries it, −1 if none (canopy method)
};

struct Tree {
    // Node 0 is the root; every other node's parent has a smaller index.
    std::vector<SkeletonNode> nodes;
    // Graph endpoints of the method (Xu & Mould: every endpoint reached by a path).
    std::vector<int32_t> endpoints;
    std::vector<Leaf> leaves;
};

// Children lists in CSR form (children of node i are child[offset[i] .. offset[i+1])).
struct ChildIndex {
    std::vector<int32_t> offset;
    std::vector<int32_t> child;
    explicit ChildIndex(const Tree& tree);
    int count(int i) const { return offset[i + 1] - offset[i]; }
};

// Branch order from topology: at every fork the child carrying the longest downstream path
// continues its parent's order, every other child gets parent order + 1.
void assignBranchOrder(Tree& tree);

// Cuts every node (but the root) where keep(position) is false, with everything above it, and
// the leaves on cut nodes or at positions keep rejects; the kept nodes stay in
// order, their parents and the leaves' nodes renumbered, the endpoints recomputed (nodes
// without children; untouched when nothing is cut). Plots cut crowns at the planes between
// neighbours with it.
void pruneTree(Tree& tree, const std::function<bool(const Vec3&)>& keep);

}  // namespace sylva
