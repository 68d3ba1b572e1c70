#include "species/model/form.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "species/model/reference_metrics.h"
#include "volumes/point_grid.h"
#include "volumes/shadow_grid.h"

namespace sylva {

bool FormOptions::turnsBranches() const {
    return angleSdRad > 0 || angleShiftRad != 0 || bendRadPerM != 0 || bendSdRadPerM > 0 ||
           lengthSd > 0;
}

bool FormOptions::active() const {
    return clearBole > 0 || shadeShed > 0 || pipeExponent > 0 || turnsBranches() || scale != 1.0 ||
           width != 1.0 || asymmetry > 0 || leanRad > 0 || ground != GroundRule::kNone;
}

namespace {

bool isShoot(const SkeletonNode& n) { return n.part == kShootPart; }

// Drops the nodes without keep[i] (a dropped node's children must be dropped too), their
// leaves and endpoints; the rest keep their order, so parents stay before children.
std::vector<int32_t> compact(Tree& tree, const std::vector<char>& keep) {
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
    leaves.reserve(tree.leaves.size());
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
    return index;
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

// Nodes that lose every child when `keep` drops some are tips afterwards: endpoints, as the
// method's tips are.
void compactKeepingTips(Tree& tree, const std::vector<char>& keep) {
    const auto& nodes = tree.nodes;
    std::vector<char> hadChild(nodes.size(), 0), hasChild(nodes.size(), 0);
    for (size_t i = 1; i < nodes.size(); ++i) {
        hadChild[nodes[i].parent] = 1;
        if (keep[i]) hasChild[nodes[i].parent] = 1;
    }
    const std::vector<int32_t> index = compact(tree, keep);
    for (size_t i = 0; i < index.size(); ++i) {
        if (index[i] >= 0 && hadChild[i] && !hasChild[i]) tree.endpoints.push_back(index[i]);
    }
}

}  // namespace

ShadeShedResult shedShadedBranches(Tree& tree, const FormOptions& o) {
    ShadeShedResult result;
    auto& nodes = tree.nodes;
    const size_t n = nodes.size();
    if (!(o.shadeShed > 0) || n < 2) return result;
    // The tips: shoot nodes with no shoot child, where the foliage is. Each casts Palubicki et
    // al. 2009's shadow pyramid (§4, shadow propagation) on what grows below it.
    std::vector<char> hasShootChild(n, 0);
    Aabb box;
    for (size_t i = 0; i < n; ++i) {
        if (!isShoot(nodes[i])) continue;
        box.extend(nodes[i].position);
        if (i > 0 && isShoot(nodes[nodes[i].parent])) hasShootChild[nodes[i].parent] = 1;
    }
    const Vec3 pad{o.shadeVoxel, o.shadeVoxel, o.shadeVoxel};
    box.lo = box.lo - pad;
    box.hi = box.hi + pad;
    ShadowGrid grid(box, o.shadeVoxel, o.shadeStrength, o.shadeDecay, o.shadeDepth);
    auto isTip = [&](size_t i) { return i > 0 && isShoot(nodes[i]) && !hasShootChild[i]; };
    for (size_t i = 0; i < n; ++i) {
        if (isTip(i)) grid.cast(nodes[i].position, +1);
    }
    // Each node's sum and count of the exposures of the tips it carries (children after their
    // parents, so one sweep from the end).
    std::vector<double> sum(n, 0.0);
    std::vector<int32_t> count(n, 0);
    for (size_t i = n; i-- > 1;) {
        if (!isShoot(nodes[i]) || !isShoot(nodes[nodes[i].parent])) continue;
        if (isTip(i)) {
            sum[i] += grid.exposure(nodes[i].position);
            count[i] += 1;
        }
        sum[nodes[i].parent] += sum[i];
        count[nodes[i].parent] += count[i];
    }
    // A branch (a shoot node of higher order than its parent: where a lateral leaves) whose tips
    // see less than the threshold on average is shed with everything it carries (§4's shedding,
    // here once, on the grown tree). The stem (order 0) always stays.
    std::vector<char> keep(n, 1);
    for (size_t i = 1; i < n; ++i) {
        const SkeletonNode& node = nodes[i];
        const SkeletonNode& parent = nodes[node.parent];
        if (!keep[node.parent]) {
            keep[i] = 0;
        } else if (isShoot(node) && isShoot(parent) && node.order > parent.order &&
                   node.order >= o.shadeMinOrder && count[i] > 0 &&
                   sum[i] < o.shadeShed * count[i]) {
            keep[i] = 0;
            result.branches += 1;
        }
        if (!keep[i]) result.nodes += 1;
    }
    if (result.nodes == 0) return result;
    // The shed shoots' pipes stay in what carried them (run after the pipe model: Shinozaki et
    // al.'s disused pipes), except that under pipeMinChildRatio no node that lost a child stays
    // thicker than its thickest remaining child ÷ the ratio, nor any ancestor that the thinning
    // of such a node leaves so: the bound the pipe model keeps at every fork.
    if (o.pipeMinChildRatio > 0) {
        std::vector<char> lost(n, 0);
        for (size_t i = 1; i < n; ++i) {
            if (!keep[i] && keep[nodes[i].parent]) lost[nodes[i].parent] = 1;
        }
        std::vector<double> thickest(n, 0.0);
        for (size_t i = n; i-- > 0;) {
            if (!keep[i] || !isShoot(nodes[i])) continue;
            if (lost[i] && thickest[i] > 0) {
                const double bound = thickest[i] / o.pipeMinChildRatio;
                if (nodes[i].radius > bound) {
                    nodes[i].radius = bound;
                    if (i > 0) lost[nodes[i].parent] = 1;  // its parent is checked in turn
                }
            }
            if (i > 0 && isShoot(nodes[nodes[i].parent])) {
                thickest[nodes[i].parent] = std::max(thickest[nodes[i].parent], nodes[i].radius);
            }
        }
    }
    compactKeepingTips(tree, keep);
    return result;
}

namespace {

// Steps 3–5 as one map of shoot positions; `turn` is the lean alone (for leaf offsets and
// directions).
struct ShootMap {
    double scale = 1.0;
    double width = 1.0;  // × horizontal, over scale
    double asymmetry = 0.0;
    Vec3 along{1, 0, 0}, across{0, 0, 1};  // the asymmetry's horizontal axes
    Vec3 leanAxis{0, 0, 1};
    double lean = 0.0;

    Vec3 turn(const Vec3& v) const { return lean > 0 ? rotate(v, leanAxis, lean) : v; }
    Vec3 operator()(Vec3 p) const {
        p = p * scale;
        p.x *= width;
        p.z *= width;
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
    leaves.reserve(tree.leaves.size());
    for (const Leaf& leaf : tree.leaves) {
        if (leaf.node != -2) leaves.push_back(leaf);
    }
    tree.leaves = std::move(leaves);
    // A node that loses every child to the ground (a branch cut there, or one whose children
    // went below) is a tip now.
    compactKeepingTips(tree, keep);
}

}  // namespace

void pipeModelRadii(Tree& tree, double exponent, double tipRadius, double taper, double baseRadius,
                    double exponentSd, const Rng* rng, ForkSpread spread, double logMedian,
                    double minChildRatio) {
    auto& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());
    if (n == 0) return;
    const ChildIndex children(tree);
    const bool drawn = exponentSd > 0 && rng != nullptr;
    const bool logNormal = drawn && spread == ForkSpread::kLogNormal;
    const bool bounded = logNormal && minChildRatio > 0;
    // Right-skewed as measured forks are (the TreeQSM reference: median 2.8–3.0, a tenth at its
    // bound of 6, where a child is nearly as thick as its parent); held at the reference's bounds
    // rather than redrawn, so that tail stays.
    auto logNormalDraw = [&](Rng& draw) {
        const double median = logMedian > 0 ? logMedian : exponent;
        return std::clamp(median * std::exp(exponentSd * draw.normal(0.0, 1.0)),
                          kMinLogForkExponent, kMaxForkExponent);
    };
    // The exponent of each fork: the mean, or a draw of its own keyed by the fork's index.
    auto forkExponent = [&](int32_t i) {
        if (!drawn) return exponent;
        Rng draw = rng->derive(static_cast<uint64_t>(i));
        if (logNormal) return logNormalDraw(draw);
        for (int attempt = 0; attempt < 8; ++attempt) {
            const double e = draw.normal(exponent, exponentSd);
            if (e >= kMinForkExponent && e <= kMaxForkExponent) return e;
        }
        return exponent;
    };
    // Radii from the tips with the exponents `exponentAt` gives; children have larger indices
    // than their parents, so one reverse sweep sees them first.
    std::vector<double> r(n, 0.0);
    auto forkRadius = [&](int32_t i, double e) {
        double sum = 0.0;
        for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
            const int32_t c = children.child[k];
            if (isShoot(nodes[c])) sum += std::pow(r[c], e);
        }
        return std::pow(sum, 1.0 / e);
    };
    // A fork under the bound on its thickest child (measured forks keep it: of the TreeQSM trees'
    // forks at least 2 cm thick, 0.4 % have their thickest child under half the fork's radius):
    // the fork's own stream draws again while its radius would exceed it, then the fork is held
    // to it. `mean`: the rescaling sweep, whose exponent is the species' n.
    auto boundedForkRadius = [&](int32_t i, bool mean) {
        double thickest = 0.0;
        for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
            const int32_t c = children.child[k];
            if (isShoot(nodes[c])) thickest = std::max(thickest, r[c]);
        }
        const double limit = thickest / minChildRatio;
        if (mean) return std::min(forkRadius(i, exponent), limit);
        Rng draw = rng->derive(static_cast<uint64_t>(i));
        for (int attempt = 0; attempt < kChildRatioDraws; ++attempt) {
            const double radius = forkRadius(i, logNormalDraw(draw));
            if (radius <= limit) return radius;
        }
        return limit;
    };
    // `mean`: every fork takes the species' n (the sweep the rescaling measures the base with).
    auto sweep = [&](bool mean) {
        for (int32_t i = n - 1; i >= 0; --i) {
            if (!isShoot(nodes[i]) && i != 0) continue;
            int shootChildren = 0;
            double only = 0.0;
            int32_t onlyChild = -1;
            for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
                const int32_t c = children.child[k];
                if (!isShoot(nodes[c])) continue;
                ++shootChildren;
                only = r[c];
                onlyChild = c;
            }
            if (shootChildren == 0) {
                r[i] = i == 0 ? nodes[0].radius : tipRadius;  // a rootless base keeps its radius
            } else if (shootChildren == 1) {
                r[i] =
                    only * (1.0 + taper * distance(nodes[i].position, nodes[onlyChild].position));
            } else if (bounded) {
                r[i] = boundedForkRadius(i, mean);
            } else {
                r[i] = forkRadius(i, mean ? exponent : forkExponent(i));
            }
        }
    };
    double base = baseRadius;
    if (drawn && !(baseRadius > 0)) {
        sweep(true);
        base = r[0];
    }
    sweep(false);
    const double k = base > 0 && r[0] > 0 ? base / r[0] : 1.0;
    for (int32_t i = 0; i < n; ++i) {
        if (isShoot(nodes[i]) || i == 0) nodes[i].radius = r[i] * k;
    }
}

namespace {

// A rotation as the images of the axes (Frame's toWorld applies it).
Frame identityRotation() { return {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}; }
Frame rotated(const Frame& f, const Vec3& axis, double angle) {
    return {rotate(f.u, axis, angle), rotate(f.v, axis, angle), rotate(f.w, axis, angle)};
}

constexpr double kDeg = kPi / 180.0;
constexpr double kMaxElevation = 80 * kDeg;  // a bending segment stops this far from vertical
constexpr double kMinInsertion = 5 * kDeg, kMaxInsertion = 150 * kDeg;
constexpr double kFreeLeafReach = 1.0;  // metres: a free leaf moves with a shoot node this near
constexpr double kMinStretch = 0.25;    // the shortest a branch's drawn length factor makes it
constexpr double kMedianAbsNormal = 0.6744897501960817;  // median of |z|, z ~ N(0, 1)

}  // namespace

void turnBranches(Tree& tree, const FormOptions& o, const Rng& rng) {
    auto& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());
    if (n < 2) return;
    const Vec3 up{0, 1, 0};
    std::vector<Vec3> was(n);
    for (int32_t i = 0; i < n; ++i) was[i] = nodes[i].position;
    std::vector<Frame> turn(n, identityRotation());
    std::vector<double> bend(n, 0.0);     // the branch's rate, radians per metre (down > 0)
    std::vector<double> stretch(n, 1.0);  // the branch's length factor
    const Rng branches = rng.derive("form-branches");
    // How far each node's subtree reaches (the longest path down to a tip) and the tree's
    // height: a branch's turn and shortening fall with its size (the big limbs hold the crown
    // the method grew; small shoots vary freely).
    std::vector<double> reach(n, 0.0);
    double top = was[0].y;
    for (int32_t i = n - 1; i > 0; --i) {
        if (!isShoot(nodes[i])) continue;
        top = std::max(top, was[i].y);
        const int32_t p = nodes[i].parent;
        reach[p] = std::max(reach[p], reach[i] + distance(was[i], was[p]));
    }
    const double freeReach = o.spreadReach * (top - was[0].y);
    // Three draws per branch (a node whose order field rises above its parent's), keyed by the
    // node and always taken in this order, so that each option's draw does not depend on the
    // others being set.
    // Each node's continuing child, as the reference distributions define it (the child of the
    // node's own order reaching furthest, or, where none has it — a grammar stem whose rule
    // changes the state, scaffold limbs from the top of a trunk — the thickest, which the turns
    // and length factors below leave the thickest), and each node's branch order counted along
    // them (TreeQSM's: the stem 0, a branch leaving a branch of order k, k + 1).
    const std::vector<int32_t> cont = continuingChildren(tree, reach);
    const std::vector<int32_t> branchOrder = branchOrders(tree, cont);
    for (int32_t i = 1; i < n; ++i) {
        SkeletonNode& node = nodes[i];
        const int32_t p = node.parent;
        if (!isShoot(node)) continue;  // roots: applyForm moves hanging ones with their node
        Vec3 d = turn[p].toWorld(was[i] - was[p]);  // the segment as its parent left it
        Frame t = turn[p];
        if (node.order > nodes[p].order && isShoot(nodes[p])) {  // a branch begins
            Rng draw = branches.derive(static_cast<uint64_t>(i));
            const double zAngle = draw.normal(), zBend = draw.normal(), zLength = draw.normal();
            // 1 for a small branch, less for one reaching far: its vigour (length factor) and
            // its turn.
            const double size = reach[i] + distance(was[i], was[p]);
            const double weight = size > freeReach ? freeReach / size : 1.0;
            bend[i] = o.bendRadPerM + o.bendSdRadPerM * zBend;
            stretch[i] = std::max(kMinStretch, std::exp(weight * o.lengthSd *
                                                        (kMedianAbsNormal - std::abs(zLength))));
            // Turned at its insertion only when it leaves the stem (not the one continuing it).
            const double dAngle = branchOrder[i] == 1 && i != cont[p]
                                      ? weight * (o.angleShiftRad + o.angleSdRad * zAngle)
                                      : 0.0;
            const int32_t pp = nodes[p].parent;
            const Vec3 stem = pp >= 0 ? nodes[p].position - nodes[pp].position : up;
            if (dAngle != 0 && length(d) > 0 && length(stem) > 0) {
                const double a0 = angleBetween(stem, d);
                const double a1 = std::clamp(a0 + dAngle, std::min(a0, kMinInsertion),
                                             std::max(a0, kMaxInsertion));
                Vec3 axis = cross(stem, d);
                axis = length(axis) > 1e-9 * length(stem) * length(d)
                           ? normalize(axis)
                           : anyPerpendicular(normalize(stem));
                t = rotated(t, axis, a1 - a0);
                d = rotate(d, axis, a1 - a0);
            }
        } else if (node.order == nodes[p].order) {
            bend[i] = bend[p];
            stretch[i] = stretch[p];
        }
        d = d * stretch[i];
        const double len = length(d);
        if (node.order >= 1 && bend[i] != 0 && len > 0) {
            const double e0 = std::asin(std::clamp(d.y / len, -1.0, 1.0));
            const double e1 = std::clamp(e0 - bend[i] * len, std::min(e0, -kMaxElevation),
                                         std::max(e0, kMaxElevation));
            const Vec3 axis = cross(d, up);  // turning about it by +a raises the segment
            if (length(axis) > 1e-9 * len) {
                t = rotated(t, normalize(axis), e1 - e0);
                d = rotate(d, normalize(axis), e1 - e0);
            }
        }
        turn[i] = t;
        node.position = nodes[p].position + d;
    }

    // Leaves follow the node that carries them, or the shoot node nearest a free one.
    PackedPointGrid grid;
    bool gridBuilt = false;
    for (Leaf& leaf : tree.leaves) {
        int32_t k = leaf.node;
        if (k < 0) {
            if (!gridBuilt) {
                grid.assign(was, kFreeLeafReach);
                gridBuilt = true;
            }
            double best = kFreeLeafReach * kFreeLeafReach;
            grid.forEachWithin(leaf.position, kFreeLeafReach, [&](int32_t id, const Vec3& q) {
                const double d2 = distance2(q, leaf.position);
                if (isShoot(nodes[id]) && (d2 < best || (d2 == best && id < k))) best = d2, k = id;
            });
            if (k < 0) continue;
        }
        leaf.position = nodes[k].position + turn[k].toWorld(leaf.position - was[k]);
        leaf.normal = turn[k].toWorld(leaf.normal);
        leaf.tangent = turn[k].toWorld(leaf.tangent);
    }
}

void applyForm(Tree& tree, const FormOptions& o, const Rng& rng) {
    if (!o.active() || tree.nodes.empty()) return;
    if (o.clearBole > 0) clearBole(tree, o.clearBole);
    if (o.pipeExponent > 0) {
        const Rng forks = rng.derive("form-forks");
        const bool logNormal = o.pipeExponentLogSd > 0;
        pipeModelRadii(tree, o.pipeExponent, o.tipRadius, o.pipeTaper, o.baseRadius,
                       logNormal ? o.pipeExponentLogSd : o.pipeExponentSd, &forks,
                       logNormal ? ForkSpread::kLogNormal : ForkSpread::kNormal,
                       o.pipeExponentLogMedian, o.pipeMinChildRatio);
    }
    if (o.shadeShed > 0) shedShadedBranches(tree, o);
    // Where each node was before the branches turned: a hanging root follows its node from there.
    std::vector<Vec3> grown;
    if (o.turnsBranches()) {
        for (const SkeletonNode& node : tree.nodes) grown.push_back(node.position);
        turnBranches(tree, o, rng);
    }

    ShootMap map;
    map.scale = o.scale;
    map.width = o.width;
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
            const Vec3 was = (grown.empty() ? before : grown)[anchor[i]] * o.scale;
            const Vec3 now = tree.nodes[anchor[i]].position;
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
