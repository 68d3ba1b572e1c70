// Shape metrics of a skeleton: Horton–Strahler orders and bifurcation ratios, fork angles,
// the radius exponent at forks, tip tortuosity, crown dimensions and asymmetry, leaf area.
// Every metric is defined once here and documented in README "Metrics".
#include "species/model/tree_metrics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "species/model/leaf_shape.h"

namespace sylva {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;

double meanOf(const std::vector<double>& v) {
    if (v.empty()) return kNaN;
    double sum = 0;
    for (double x : v) sum += x;
    return sum / static_cast<double>(v.size());
}

// Population standard deviation (two-pass).
double stdOf(const std::vector<double>& v) {
    if (v.empty()) return kNaN;
    double m = meanOf(v), sum = 0;
    for (double x : v) sum += (x - m) * (x - m);
    return std::sqrt(sum / static_cast<double>(v.size()));
}

double angleDeg(const Vec3& a, const Vec3& b) {
    double la = length(a), lb = length(b);
    if (!(la > 0) || !(lb > 0)) return kNaN;
    double c = std::clamp(dot(a, b) / (la * lb), -1.0, 1.0);
    return std::acos(c) * 180.0 / kPi;
}
}  // namespace

double quantile(std::vector<double> values, double q) {
    if (values.empty()) return kNaN;
    std::sort(values.begin(), values.end());
    double h = q * static_cast<double>(values.size() - 1);
    size_t lo = static_cast<size_t>(std::floor(h));
    size_t hi = std::min(lo + 1, values.size() - 1);
    return values[lo] + (h - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

double radiusExponent(double parentRadius, const std::vector<double>& childRadii) {
    if (!(parentRadius > 0) || childRadii.size() < 2) return kNaN;
    for (double r : childRadii) {
        if (!(r > 0) || !(r < parentRadius)) return kNaN;
    }
    // f(n) = Σ (r_i / r_p)^n − 1 is strictly decreasing in n when every ratio is below 1.
    auto f = [&](double n) {
        double sum = 0;
        for (double r : childRadii) sum += std::pow(r / parentRadius, n);
        return sum - 1.0;
    };
    double lo = 0.5, hi = 6.0;
    if (f(lo) <= 0) return lo;
    if (f(hi) >= 0) return hi;
    // The answer is the bisection's below, whose every step asks only which side of f's sign
    // change the midpoint lies on. Newton's method on f (convex and decreasing: from the left
    // its steps rise to the root without passing it) finds that change to ~1e-15 in a few
    // steps of exp; once f itself confirms a sign on each side of it, a midpoint outside
    // [root − margin, root + margin] is decided without evaluating f, and the bisection
    // evaluates f only in its last dozen steps. The result is the same to the bit: the
    // decisions are. (The forks' exponents were 2% of a library build's CPU.)
    constexpr double kMargin = 1e-10;
    double near = std::nan("");
    std::array<double, 8> logs;
    if (childRadii.size() <= logs.size()) {
        for (size_t i = 0; i < childRadii.size(); ++i)
            logs[i] = std::log(childRadii[i] / parentRadius);
        double x = lo;
        for (int it = 0; it < 60; ++it) {
            double g = -1.0, dg = 0.0;
            for (size_t i = 0; i < childRadii.size(); ++i) {
                const double e = std::exp(x * logs[i]);
                g += e;
                dg += logs[i] * e;
            }
            if (!(dg < 0)) break;
            const double step = g / dg;
            x -= step;
            if (!(std::abs(step) > 1e-15 * x)) break;
        }
        near = x;  // whatever it is, f must confirm it below
    }
    if (!(near > lo + kMargin && near < hi - kMargin && f(near - kMargin) > 0 &&
          !(f(near + kMargin) > 0))) {
        near = std::nan("");  // unconfirmed: every step evaluates f
    }
    for (int it = 0; it < 100 && hi - lo > 1e-13; ++it) {
        double mid = 0.5 * (lo + hi);
        const bool positive = mid <= near - kMargin   ? true
                              : mid >= near + kMargin ? false
                                                      : f(mid) > 0;  // (NaN near: here)
        (positive ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

void addShapeMetrics(const Tree& tree, TreeStats& s) {
    const auto& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());

    s.leaves = static_cast<int64_t>(tree.leaves.size());
    s.leafArea = 0;
    for (const Leaf& l : tree.leaves) s.leafArea += leafArea(l);

    s.strahlerOrder = 0;
    s.strahlerBranches.clear();
    s.strahlerBranchLength.clear();
    s.bifurcationRatios.clear();
    s.bifurcationRatioMean = kNaN;
    s.forks = 0;
    s.forkAngleMean = s.forkAngleStd = kNaN;
    s.radiusExponentForks = 0;
    s.radiusExponentMedian = s.radiusExponentIqr = kNaN;
    s.tortuosityMean = s.tortuosityMax = kNaN;
    s.crownBaseHeight = s.crownHeight = s.crownWidthMajor = s.crownDepth = kNaN;
    s.crownAsymmetry = kNaN;
    if (n == 0 || nodes[0].part != kShootPart) return;

    // Shoot children only (the root system hangs off the same root node).
    auto isShoot = [&](int32_t i) { return nodes[i].part == kShootPart; };
    (void)ChildIndex(tree);  // validates the parent invariant (throws std::invalid_argument)
    std::vector<std::vector<int32_t>> kids(n);
    for (int32_t i = 1; i < n; ++i) {
        if (isShoot(i) && isShoot(nodes[i].parent)) kids[nodes[i].parent].push_back(i);
    }
    // A shoot segment is a shoot node i > 0 with a shoot parent; it takes node i's values.
    auto isSegment = [&](int32_t i) { return i > 0 && isShoot(i) && isShoot(nodes[i].parent); };
    auto segLength = [&](int32_t i) {
        return distance(nodes[i].position, nodes[nodes[i].parent].position);
    };

    // Horton–Strahler (Strahler 1957): a tip is 1; a node takes the largest child order, plus
    // one if two or more children share it. Children have larger indices than their parent.
    std::vector<int32_t> order(n, 0);
    for (int32_t i = n - 1; i >= 0; --i) {
        if (!isShoot(i)) continue;
        int32_t m = 0, count = 0;
        for (int32_t c : kids[i]) {
            if (order[c] > m) {
                m = order[c];
                count = 1;
            } else if (order[c] == m) {
                ++count;
            }
        }
        order[i] = kids[i].empty() ? 1 : (count >= 2 ? m + 1 : m);
    }
    for (int32_t i = 1; i < n; ++i) {
        if (isSegment(i)) s.strahlerOrder = std::max<int64_t>(s.strahlerOrder, order[i]);
    }
    // A Strahler branch is a maximal chain of segments of one order; it ends at the segment
    // whose parent node is the root or has a different order (at most one child of a node
    // shares the node's order, so branches are chains).
    const size_t K = static_cast<size_t>(s.strahlerOrder);
    s.strahlerBranches.assign(K, 0);
    std::vector<double> lengthSum(K, 0.0);
    for (int32_t i = 1; i < n; ++i) {
        if (!isSegment(i)) continue;
        const int32_t p = nodes[i].parent;
        lengthSum[order[i] - 1] += segLength(i);
        if (p == 0 || order[p] != order[i]) ++s.strahlerBranches[order[i] - 1];
    }
    for (size_t k = 0; k < K; ++k) {
        s.strahlerBranchLength.push_back(
            s.strahlerBranches[k] > 0 ? lengthSum[k] / static_cast<double>(s.strahlerBranches[k])
                                      : kNaN);
    }
    for (size_t k = 0; k + 1 < K; ++k) {
        s.bifurcationRatios.push_back(s.strahlerBranches[k + 1] > 0
                                          ? static_cast<double>(s.strahlerBranches[k]) /
                                                static_cast<double>(s.strahlerBranches[k + 1])
                                          : kNaN);
    }
    if (!s.bifurcationRatios.empty()) s.bifurcationRatioMean = meanOf(s.bifurcationRatios);

    // Forks: branching angles and the radius exponent.
    std::vector<double> angles, exponents;
    for (int32_t i = 0; i < n; ++i) {
        if (!isShoot(i) || kids[i].size() < 2) continue;
        ++s.forks;
        const Vec3 in = i > 0 ? nodes[i].position - nodes[nodes[i].parent].position : Vec3{0, 1, 0};
        std::vector<double> childRadii;
        for (int32_t c : kids[i]) {
            double a = angleDeg(in, nodes[c].position - nodes[i].position);
            if (std::isfinite(a)) angles.push_back(a);
            childRadii.push_back(nodes[c].radius);
        }
        double e = radiusExponent(nodes[i].radius, childRadii);
        if (std::isfinite(e)) exponents.push_back(e);
    }
    s.forkAngleMean = meanOf(angles);
    s.forkAngleStd = stdOf(angles);
    s.radiusExponentForks = static_cast<int64_t>(exponents.size());
    s.radiusExponentMedian = quantile(exponents, 0.5);
    if (!exponents.empty())
        s.radiusExponentIqr = quantile(exponents, 0.75) - quantile(exponents, 0.25);

    // Tortuosity: skeleton path length from each shoot tip to the root over the chord.
    std::vector<double> pathLength(n, 0.0), tort;
    for (int32_t i = 1; i < n; ++i) {
        if (!isSegment(i)) continue;
        pathLength[i] = pathLength[nodes[i].parent] + segLength(i);
        if (!kids[i].empty()) continue;
        double chord = distance(nodes[i].position, nodes[0].position);
        if (chord > 0) tort.push_back(pathLength[i] / chord);
    }
    s.tortuosityMean = meanOf(tort);
    if (!tort.empty()) s.tortuosityMax = *std::max_element(tort.begin(), tort.end());

    // Crown: the shoot nodes at or above the first fork of the trunk (follow single children
    // up from the root; the first node with two or more shoot children is the crown base).
    int32_t fork = 0;
    while (kids[fork].size() == 1) fork = kids[fork][0];
    if (kids[fork].size() < 2) return;  // no fork: a single chain has no crown
    const Vec3 base = nodes[fork].position;
    std::vector<Vec3> crown;
    for (int32_t i = 0; i < n; ++i) {
        if (isShoot(i) && nodes[i].position.y >= base.y) crown.push_back(nodes[i].position);
    }
    s.crownBaseHeight = base.y;
    Vec3 centroid{0, 0, 0};
    double top = base.y;
    for (const Vec3& p : crown) {
        centroid = centroid + p;
        top = std::max(top, p.y);
    }
    centroid = centroid * (1.0 / static_cast<double>(crown.size()));
    s.crownHeight = top - base.y;
    // Horizontal principal axes of the crown nodes: major axis angle from the 2×2 covariance.
    double cxx = 0, czz = 0, cxz = 0;
    for (const Vec3& p : crown) {
        double dx = p.x - centroid.x, dz = p.z - centroid.z;
        cxx += dx * dx;
        czz += dz * dz;
        cxz += dx * dz;
    }
    const double theta = 0.5 * std::atan2(2.0 * cxz, cxx - czz);
    const double ux = std::cos(theta), uz = std::sin(theta);
    double uMin = 0, uMax = 0, vMin = 0, vMax = 0;
    for (size_t k = 0; k < crown.size(); ++k) {
        double dx = crown[k].x - centroid.x, dz = crown[k].z - centroid.z;
        double u = dx * ux + dz * uz, v = -dx * uz + dz * ux;
        if (k == 0) {
            uMin = uMax = u;
            vMin = vMax = v;
        }
        uMin = std::min(uMin, u);
        uMax = std::max(uMax, u);
        vMin = std::min(vMin, v);
        vMax = std::max(vMax, v);
    }
    s.crownWidthMajor = uMax - uMin;
    s.crownDepth = vMax - vMin;
    // Trunk axis: the line from the root node through the crown base (vertical through the root
    // when the fork is at the root); asymmetry is the centroid's distance from it.
    Vec3 axis = base - nodes[0].position;
    axis = length(axis) > 0 ? axis * (1.0 / length(axis)) : Vec3{0, 1, 0};
    const Vec3 d = centroid - nodes[0].position;
    s.crownAsymmetry = length(d - axis * dot(d, axis));
}

}  // namespace sylva
