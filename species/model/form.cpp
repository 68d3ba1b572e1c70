#include "species/model/form.h"

#include <cmath>
#include <vector>

namespace sylva {

bool FormOptions::active() const {
    return clearBole > 0 || pipeExponent > 0 || scale != 1.0 || asymmetry > 0 || leanRad > 0 ||
           ground != GroundRule::kNone;
}

namespace {

bool isShoot(const SkeletonNode& n) { return n.part == kShootPart; }

// Drops the nodes without keep[i] (a dropped node's children must be dropped too), their
// leaves and endpoints; the rest keep their order, so parents stay before children.
void compact(Tree& tree, const std::vector<char>& keep) {
    const size_t n = tree.nodes.size();
    std::vector<int32_t> index(n, -1);
    std::vector<SkeletonNode> nodes;
    nodes.reserve(n);
    for (size_t i = 0; i < n; ++i) {
        if (!keep[i]) continue;
        index[i] = static_cast<int32_t>(nodes.size());
        SkeletonNode node = tree.nodes[i];
        if (node.parent >= 0) node.parent = index[node.parent];
        nodes.push_back(node);
    }
    tree.nodes = std::move(nodes);
    std::vector<Leaf> leaves;
    for (Leaf leaf : tree.leaves) {
        if (leaf.node >= 0) {
            if (index[leaf.node] < 0) continue;
            leaf.node = index[leaf.node];
        }
        leaves.push_back(leaf);
    }
    tree.leaves = std::move(leaves);
    std::vector<int32_t> endpoints;
    for (int32_t e : tree.endpoints) {
        if (e >= 0 && static_cast<size_t>(e) < n && index[e] >= 0) endpoints.push_back(index[e]);
    }
    tree.endpoints = std::move(endpoints);
}

// Step 1: the laterals that leave the order-0 axis below `height`, with their subtrees.
void clearBole(Tree& tree, double height) {
    auto& nodes = tree.nodes;
    std::vector<char> keep(nodes.size(), 1);
    bool removed = false;
    for (size_t i = 1; i < nodes.size(); ++i) {
        const SkeletonNode& node = nodes[i];
        const SkeletonNode& parent = nodes[node.parent];
        const bool lateralOffBole = isShoot(node) && isShoot(parent) && node.order > 0 &&
                                    parent.order == 0 && parent.position.y < height;
        if (!keep[node.parent] || lateralOffBole) {
            keep[i] = 0;
            removed = true;
        }
    }
    if (removed) compact(tree, keep);
}

// Steps 3–5 as one map of shoot positions; `turn` is the lean alone (for leaf offsets and
// directions).
struct ShootMap {
    double scale = 1.0;
    double asymmetry = 0.0;
    Vec3 along{1, 0, 0}, across{0, 0, 1};  // the asymmetry's horizontal axes
    Vec3 leanAxis{0, 0, 1};
    double lean = 0.0;

    Vec3 turn(const Vec3& v) const { return lean > 0 ? rotate(v, leanAxis, lean) : v; }
    Vec3 operator()(Vec3 p) const {
        p = p * scale;
        if (asymmetry > 0) {
            p += along * (asymmetry * dot(p, along)) - across * (asymmetry * dot(p, across));
        }
        return turn(p);
    }
};

// Step 6: shoot branches below y = 0 cut at the ground; the order-0 axis lifted to it.
void pruneAtGround(Tree& tree) {
    auto& nodes = tree.nodes;
    std::vector<char> keep(nodes.size(), 1);
    std::vector<char> cut(nodes.size(), 0);  // a tip made at the ground: its subtree goes
    for (size_t i = 1; i < nodes.size(); ++i) {
        SkeletonNode& node = nodes[i];
        const SkeletonNode& parent = nodes[node.parent];
        if (!keep[node.parent] || cut[node.parent]) {
            keep[i] = 0;
            continue;
        }
        if (!isShoot(node) || node.position.y >= 0) continue;
        if (node.order == 0) {
            node.position.y = 0;
        } else if (parent.position.y > 0) {
            const double t = parent.position.y / (parent.position.y - node.position.y);
            node.position = parent.position + (node.position - parent.position) * t;
            node.position.y = 0;
            node.radius = parent.radius + (node.radius - parent.radius) * t;
            cut[i] = 1;
        } else {
            keep[i] = 0;
        }
    }
    for (Leaf& leaf : tree.leaves) {
        const bool shootLeaf = leaf.node < 0 || isShoot(nodes[leaf.node]);
        if (shootLeaf && leaf.position.y < 0) leaf.node = -2;  // dropped below
    }
    std::vector<Leaf> leaves;
    for (const Leaf& leaf : tree.leaves) {
        if (leaf.node != -2) leaves.push_back(leaf);
    }
    tree.leaves = std::move(leaves);
    compact(tree, keep);
}

}  // namespace

void pipeModelRadii(Tree& tree, double exponent, double tipRadius, double taper,
                    double baseRadius) {
    auto& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());
    if (n == 0) return;
    const ChildIndex children(tree);
    std::vector<double> r(n, 0.0);
    // Children have larger indices than their parents: one reverse sweep sees them first.
    for (int32_t i = n - 1; i >= 0; --i) {
        if (!isShoot(nodes[i]) && i != 0) continue;
        int shootChildren = 0;
        double sum = 0.0, only = 0.0;
        int32_t onlyChild = -1;
        for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
            const int32_t c = children.child[k];
            if (!isShoot(nodes[c])) continue;
            ++shootChildren;
            sum += std::pow(r[c], exponent);
            only = r[c];
            onlyChild = c;
        }
        if (shootChildren == 0) {
            r[i] = i == 0 ? nodes[0].radius : tipRadius;  // a rootless base keeps its radius
        } else if (shootChildren == 1) {
            r[i] = only * (1.0 + taper * distance(nodes[i].position, nodes[onlyChild].position));
        } else {
            r[i] = std::pow(sum, 1.0 / exponent);
        }
    }
    const double k = baseRadius > 0 && r[0] > 0 ? baseRadius / r[0] : 1.0;
    for (int32_t i = 0; i < n; ++i) {
        if (isShoot(nodes[i]) || i == 0) nodes[i].radius = r[i] * k;
    }
}

void applyForm(Tree& tree, const FormOptions& o, const Rng& rng) {
    if (!o.active() || tree.nodes.empty()) return;
    if (o.clearBole > 0) clearBole(tree, o.clearBole);
    if (o.pipeExponent > 0) {
        pipeModelRadii(tree, o.pipeExponent, o.tipRadius, o.pipeTaper, o.baseRadius);
    }

    ShootMap map;
    map.scale = o.scale;
    map.asymmetry = o.asymmetry;
    if (o.asymmetry > 0) {
        const double phi = 2.0 * kPi * rng.derive("form-asymmetry").uniform();
        map.along = {std::cos(phi), 0, std::sin(phi)};
        map.across = {-std::sin(phi), 0, std::cos(phi)};
    }
    if (o.leanRad > 0) {
        // Up turns toward the horizontal direction d about the axis up × d.
        const double psi = 2.0 * kPi * rng.derive("form-lean").uniform();
        map.leanAxis = {std::sin(psi), 0, -std::cos(psi)};
        map.lean = o.leanRad;
    }
    // An aerial root (a root-part chain hanging from a shoot node other than the base: prop
    // roots) follows its attachment: moved with it horizontally and stretched vertically so
    // that what stood on the ground stays on it and a vertical root stays vertical.
    const size_t n = tree.nodes.size();
    std::vector<int32_t> anchor(n, -1);
    for (size_t i = 1; i < n; ++i) {
        const SkeletonNode& node = tree.nodes[i];
        if (isShoot(node)) continue;
        const int32_t p = node.parent;
        anchor[i] = !isShoot(tree.nodes[p]) ? anchor[p] : (p != 0 ? p : -1);
    }
    std::vector<Vec3> before(n);
    for (size_t i = 0; i < n; ++i) {
        SkeletonNode& node = tree.nodes[i];
        before[i] = node.position;
        node.radius *= o.scale;
        node.position = isShoot(node) ? map(node.position) : node.position * o.scale;
        if (anchor[i] >= 0) {  // its anchor, a shoot node, has a smaller index: already moved
            const Vec3 was = before[anchor[i]] * o.scale, now = tree.nodes[anchor[i]].position;
            const double stretch = was.y > 0 ? now.y / was.y : 1.0;
            node.position = {now.x + node.position.x - was.x, node.position.y * stretch,
                             now.z + node.position.z - was.z};
        }
    }
    for (Leaf& leaf : tree.leaves) {
        if (leaf.node >= 0) {  // keeps its offset from its twig
            leaf.position =
                tree.nodes[leaf.node].position + map.turn(leaf.position - before[leaf.node]);
        } else {
            leaf.position = map(leaf.position);
        }
        leaf.normal = map.turn(leaf.normal);
        leaf.tangent = map.turn(leaf.tangent);
    }
    if (o.ground == GroundRule::kPrune) pruneAtGround(tree);
}

}  // namespace sylva
