// Reference distributions of a skeleton, each defined as scripts/reference_from_treeqsm.py
// defines it on TreeQSM cylinders: a cylinder there is a segment (parent node → node) here,
// taking the node's radius; a cylinder's parent is the segment ending at the node the segment
// leaves; a TreeQSM branch is a branch here (the chain of continuing children).
#include "species/model/reference_metrics.h"

#include <algorithm>
#include <cmath>

#include "species/model/tree_metrics.h"

namespace sylva {

const std::array<const char*, kReferenceDistributions> kReferenceDistributionNames = {
    "radius_ratio",         "radius_exponent",      "branch_angle_deg",     "tip_path_ratio",
    "branch_length_order1", "branch_length_order2", "branch_length_order3", "tip_height_ratio"};

namespace {
constexpr double kPi = 3.14159265358979323846;

double angleDeg(const Vec3& a, const Vec3& b) {
    double la = length(a), lb = length(b);
    if (!(la > 0) || !(lb > 0)) return std::nan("");
    double c = std::clamp(dot(a, b) / (la * lb), -1.0, 1.0);
    return std::acos(c) * 180.0 / kPi;
}
}  // namespace

std::vector<int32_t> continuingChildren(const Tree& tree, const std::vector<double>& reach) {
    const auto& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());
    std::vector<int32_t> cont(n, -1), thickest(n, -1);
    std::vector<double> best(n, -1.0);
    auto isShoot = [&](int32_t i) { return nodes[i].part == kShootPart; };
    auto reachOf = [&](int32_t i) {
        return reach[i] + distance(nodes[i].position, nodes[nodes[i].parent].position);
    };
    for (int32_t i = 1; i < n; ++i) {
        const int32_t p = nodes[i].parent;
        if (p < 0 || !isShoot(i) || !isShoot(p)) continue;
        const double r = reachOf(i);
        if (nodes[i].order == nodes[p].order && r > best[p]) best[p] = r, cont[p] = i;
        const int32_t t = thickest[p];
        if (t < 0 || nodes[i].radius > nodes[t].radius ||
            (nodes[i].radius == nodes[t].radius && r > reachOf(t))) {
            thickest[p] = i;
        }
    }
    for (int32_t i = 0; i < n; ++i) {
        if (cont[i] < 0) cont[i] = thickest[i];
    }
    return cont;
}

std::vector<int32_t> branchOrders(const Tree& tree, const std::vector<int32_t>& cont) {
    // TreeQSM's numbering; parents precede children, so one pass suffices.
    const auto& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());
    std::vector<int32_t> order(n, 0);
    for (int32_t i = 1; i < n; ++i) {
        const int32_t p = nodes[i].parent;
        if (nodes[i].part != kShootPart || nodes[p].part != kShootPart) continue;
        order[i] = order[p] + (i == cont[p] ? 0 : 1);
    }
    return order;
}

ReferenceValues referenceValues(const Tree& tree) {
    ReferenceValues out;
    const auto& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());
    if (n == 0 || nodes[0].part != kShootPart) return out;
    (void)ChildIndex(tree);  // validates the parent invariant (throws std::invalid_argument)

    auto isShoot = [&](int32_t i) { return nodes[i].part == kShootPart; };
    auto isSegment = [&](int32_t i) { return i > 0 && isShoot(i) && isShoot(nodes[i].parent); };
    auto segLength = [&](int32_t i) {
        return distance(nodes[i].position, nodes[nodes[i].parent].position);
    };
    std::vector<std::vector<int32_t>> kids(n);
    for (int32_t i = 1; i < n; ++i) {
        if (isSegment(i)) kids[nodes[i].parent].push_back(i);
    }
    // Longest path from each node down to a tip (children have larger indices).
    std::vector<double> reach(n, 0.0);
    for (int32_t i = n - 1; i > 0; --i) {
        if (isSegment(i)) {
            double& r = reach[nodes[i].parent];
            r = std::max(r, reach[i] + segLength(i));
        }
    }
    // The continuing child: the child of the node's own order reaching furthest, or, where no
    // child has the node's order (a grammar stem whose rule changes the state), the thickest
    // child, the one reaching furthest among equals: a branch runs on to a tip, as TreeQSM
    // makes every branch and the stem "as long as possible" (correct_segments.m,
    // modify_topology), never ending at a fork. Thickness, not reach, decides there: under the
    // pipe model it is the child carrying most of the crown, and the form stage's turns, length
    // factors and width leave it as it was (the form stage turns branches about the same stem).
    const std::vector<int32_t> cont = continuingChildren(tree, reach);
    const std::vector<int32_t> branchOrder = branchOrders(tree, cont);

    // (a), (b): forks. TreeQSM's cap on a branch's radius (0.95 × its parent cylinder's) makes
    // the ratio of a capped lateral meaningless, so a fork with a lateral at the cap is left out.
    for (int32_t i = 0; i < n; ++i) {
        if (!isShoot(i) || kids[i].size() < 2) continue;
        const double rp = nodes[i].radius;
        if (!(rp > 0)) continue;
        std::vector<double> childRadii, ratios;
        bool defined = true, capped = false;
        for (int32_t c : kids[i]) {
            const double r = nodes[c].radius;
            defined = defined && r > 0;
            childRadii.push_back(r);
            if (c == cont[i]) continue;
            ratios.push_back(r / rp);
            capped = capped || r / rp >= kReferenceCapRatio;
        }
        if (!defined || capped) continue;
        out[kRadiusRatio].insert(out[kRadiusRatio].end(), ratios.begin(), ratios.end());
        const double e = radiusExponent(rp, childRadii);
        if (std::isfinite(e)) out[kRadiusExponent].push_back(e);
    }

    // (c): an order-1 branch, leaving the stem at node a: the angle between the stem's direction
    // at a — the segment into a (the cylinder the branch leaves, in a QSM), or at the root node
    // the stem's first segment — and the branch's first segment.
    for (int32_t c = 1; c < n; ++c) {
        if (!isSegment(c)) continue;
        const int32_t a = nodes[c].parent;
        if (c == cont[a] || branchOrder[c] != 1) continue;
        Vec3 stem{0, 1, 0};
        if (isSegment(a)) {
            stem = nodes[a].position - nodes[nodes[a].parent].position;
        } else if (cont[a] >= 0) {
            stem = nodes[cont[a]].position - nodes[a].position;
        }
        const double angle = angleDeg(stem, nodes[c].position - nodes[a].position);
        if (std::isfinite(angle)) out[kBranchAngle].push_back(angle);
    }

    double top = nodes[0].position.y;
    for (int32_t i = 0; i < n; ++i) {
        if (isShoot(i)) top = std::max(top, nodes[i].position.y);
    }
    const double height = top - nodes[0].position.y;
    if (!(height > 0)) return out;

    // (d), (f): path length from the root node to every tip, and the tip's height above the
    // root node, over the height.
    std::vector<double> path(n, 0.0);
    for (int32_t i = 1; i < n; ++i) {
        if (!isSegment(i)) continue;
        path[i] = path[nodes[i].parent] + segLength(i);
        if (!kids[i].empty()) continue;
        out[kTipPathRatio].push_back(path[i] / height);
        out[kTipHeightRatio].push_back((nodes[i].position.y - nodes[0].position.y) / height);
    }

    // (e): every branch of order 1–3: the segment from the node it leaves plus its chain.
    for (int32_t c = 1; c < n; ++c) {
        if (!isSegment(c) || c == cont[nodes[c].parent]) continue;
        const int32_t order = branchOrder[c];
        if (order < 1 || order > 3) continue;
        double len = segLength(c);
        for (int32_t x = cont[c]; x >= 0; x = cont[x]) len += segLength(x);
        out[kBranchLengthOrder1 + order - 1].push_back(len / height);
    }
    return out;
}

}  // namespace sylva
