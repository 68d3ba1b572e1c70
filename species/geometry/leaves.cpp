#include "species/geometry/leaves.h"

#include <algorithm>
#include <cmath>

namespace sylva {

namespace {
// The lowest height of the tree's shoot nodes and their span (at least 1e-9 m): where a leaf's
// relative height is measured from.
void shootHeights(const Tree& tree, double& lo, double& span) {
    double hi = -1e300;
    lo = 1e300;
    for (const SkeletonNode& n : tree.nodes) {
        if (n.part != kShootPart) continue;
        lo = std::min(lo, n.position.y);
        hi = std::max(hi, n.position.y);
    }
    span = std::max(1e-9, hi - lo);
}
}  // namespace

void placeLeaves(Tree& tree, const LeafOptions& o, Rng& rng, const GrowthGuard& guard) {
    if (!o.enabled || tree.nodes.size() < 2) return;
    const ChildIndex children(tree);
    int64_t tips = 0;
    for (int32_t i = 1; i < static_cast<int32_t>(tree.nodes.size()); ++i) {
        tips += tree.nodes[i].part == kShootPart && children.count(i) == 0;
    }
    guard.leaves(static_cast<int64_t>(tree.leaves.size()) + tips * o.perTip,
                 " ([leaves] per_tip = " + std::to_string(o.perTip) + " at " +
                     std::to_string(tips) + " tips)");
    tree.leaves.reserve(tree.leaves.size() + static_cast<size_t>(tips) * std::max(0, o.perTip));
    double yLo, ySpan;
    shootHeights(tree, yLo, ySpan);
    const Vec3 sun = normalize(o.sun);
    std::vector<int32_t> path;
    std::vector<double> along;  // path length from the tip at each path node
    for (int32_t tip = 1; tip < static_cast<int32_t>(tree.nodes.size()); ++tip) {
        const SkeletonNode& t = tree.nodes[tip];
        if (t.part != kShootPart || children.count(tip) > 0) continue;
        // The twig: from the tip back towards the root until alongTwig metres are covered.
        path.assign(1, tip);
        along.assign(1, 0.0);
        while (along.back() < o.alongTwig && tree.nodes[path.back()].parent >= 0) {
            int32_t p = tree.nodes[path.back()].parent;
            along.push_back(along.back() +
                            distance(tree.nodes[p].position, tree.nodes[path.back()].position));
            path.push_back(p);
        }
        const double span = std::min(o.alongTwig, along.back());
        for (int k = 0; k < o.perTip; ++k) {
            // A point on the twig, uniformly by path length.
            const double s = span * rng.uniform();
            size_t seg = 1;
            while (seg + 1 < along.size() && along[seg] < s) ++seg;
            Vec3 a = tree.nodes[path[seg - 1]].position, b = tree.nodes[path[seg]].position;
            double segLen = along[seg] - along[seg - 1];
            double t01 = segLen > 0 ? (s - along[seg - 1]) / segLen : 0.0;
            Vec3 onTwig = a + (b - a) * t01;
            Vec3 twigDir = segLen > 0 ? normalize(a - b) : Vec3{0, 1, 0};

            Leaf leaf;
            leaf.size = rng.uniform(o.sizeMin, o.sizeMax);
            leaf.aspect = o.aspect;
            leaf.shape = o.shape;
            // The blade points away from the twig, half a leaf off its axis.
            Vec3 side = rng.unitVector();
            side = side - twigDir * dot(side, twigDir);
            if (length(side) < 1e-6) side = anyPerpendicular(twigDir);
            side = normalize(side);
            leaf.tangent = normalize(side + twigDir * 0.5);
            if (isInclinationDistribution(o.orientation)) {
                // The normal drawn first, so the card's inclination is the distribution's;
                // the blade then points as near away from the twig as that plane lets it.
                leaf.normal = inclinedLeafNormal(o.orientation, rng);
                Vec3 t = leaf.tangent - leaf.normal * dot(leaf.tangent, leaf.normal);
                leaf.tangent = length(t) > 1e-6 ? normalize(t) : anyPerpendicular(leaf.normal);
                leaf.position = onTwig + leaf.tangent * (0.5 * leaf.size);
            } else {
                leaf.position = onTwig + leaf.tangent * (0.5 * leaf.size);
                Vec3 n = rng.unitVector();
                if (o.orientation == LeafOrientation::kSun) {
                    n = sun * o.sunWeight + n * (1.0 - o.sunWeight);
                }
                n = n - leaf.tangent * dot(n, leaf.tangent);
                if (length(n) < 1e-6) n = anyPerpendicular(leaf.tangent);
                leaf.normal = normalize(n);
            }
            double frac = (leaf.position.y - yLo) / ySpan + o.colourJitter * rng.uniform(-1, 1);
            leaf.colour = static_cast<uint8_t>(
                std::clamp(static_cast<int>(frac * o.colourClasses), 0, o.colourClasses - 1));
            leaf.node = tip;
            tree.leaves.push_back(leaf);
        }
    }
}

bool isInclinationDistribution(LeafOrientation o) {
    return o != LeafOrientation::kRandom && o != LeafOrientation::kSun;
}

Vec3 inclinedLeafNormal(LeafOrientation o, Rng& rng) {
    constexpr double kHalfPi = 1.57079632679489661923;
    // θ by rejection under each density's maximum (g = f / max f); two tries on average, and
    // the 64th is taken whatever it is (a bias below 2⁻⁶⁴).
    double theta = 0;
    for (int tries = 0; tries < 64; ++tries) {
        theta = kHalfPi * rng.uniform();
        double g = 1;
        switch (o) {
            case LeafOrientation::kPlanophile:
                g = 0.5 * (1 + std::cos(2 * theta));
                break;
            case LeafOrientation::kErectophile:
                g = 0.5 * (1 - std::cos(2 * theta));
                break;
            case LeafOrientation::kPlagiophile:
                g = 0.5 * (1 - std::cos(4 * theta));
                break;
            case LeafOrientation::kExtremophile:
                g = 0.5 * (1 + std::cos(4 * theta));
                break;
            case LeafOrientation::kSpherical:
                g = std::sin(theta);
                break;
            default:  // kUniform (kRandom and kSun have no inclination distribution)
                break;
        }
        if (rng.uniform() < g) break;
    }
    const double phi = 4 * kHalfPi * rng.uniform();
    return {std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
}

void applySeason(Tree& tree, const SeasonPalette& palette, const Rng& rng) {
    if (palette.asGrown && palette.density >= 1.0) return;
    const int classes = static_cast<int>(palette.classes.size());
    if (!palette.asGrown && classes == 0) {
        tree.leaves.clear();
        return;
    }
    double yLo, ySpan;
    shootHeights(tree, yLo, ySpan);
    size_t kept = 0;
    for (size_t i = 0; i < tree.leaves.size(); ++i) {
        Rng lr = rng.derive(static_cast<uint64_t>(i));
        if (lr.uniform() >= palette.density) continue;
        Leaf leaf = tree.leaves[i];
        if (!palette.asGrown) {
            const double h = std::clamp((leaf.position.y - yLo) / ySpan, 0.0, 1.0);
            const int ci = std::clamp(
                static_cast<int>(std::floor(h * classes - 0.5 + lr.uniform())), 0, classes - 1);
            leaf.colour = palette.classes[ci];
        }
        tree.leaves[kept++] = leaf;
    }
    tree.leaves.resize(kept);
}

}  // namespace sylva
