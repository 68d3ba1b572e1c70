#include "species/model/realism_metrics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "species/model/tree_metrics.h"

namespace sylva {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The region a stem leaves the base through: the ball of the base radius (at least 1 cm)
// around the root node.
constexpr double kMinBaseRadius = 0.01;  // metres
// The top of the leader: the last fifth of its length.
constexpr double kLeaderTopFraction = 0.2;
// A leader must reach half the tree's height (otherwise the trunk ends in a fork: no leader).
constexpr double kLeaderMinHeightFraction = 0.5;

// Distance from p to the surface of the tapered capsule a(ra) – b(rb), ≥ 0. The axis point
// nearest p, with the radius interpolated there: exact for a cylinder, a close upper bound for
// a cone (within the taper's slope).
double capsuleDistance(const Vec3& p, const Vec3& a, double ra, const Vec3& b, double rb) {
    const Vec3 ab = b - a;
    const double len2 = length2(ab);
    const double t = len2 > 0 ? std::clamp(dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
    const double r = ra + (rb - ra) * t;
    return std::max(0.0, distance(p, a + ab * t) - r);
}

// Segments bucketed in a uniform grid of their bounding boxes (radius included), searched from
// the query's cell outward until no unsearched segment can be nearer. The cells are one packed
// array (counted, then filled), about 8 per segment (half the cube root of the volume per
// segment: twigs crowd the crown, and a query's own cell should hold few of them), at most 128
// along the longest side: a vector per cell at 64 per side (262,144 of them per tree) cost
// more than the queries.
class SegmentGrid {
  public:
    explicit SegmentGrid(const Tree& tree) : tree_(tree) {
        for (size_t i = 1; i < tree.nodes.size(); ++i) {
            const SkeletonNode& n = tree.nodes[i];
            const SkeletonNode& p = tree.nodes[n.parent];
            const double r = std::max(n.radius, p.radius);
            const Vec3 pad{r, r, r};
            bounds_.extend(vmin(n.position, p.position) - pad);
            bounds_.extend(vmax(n.position, p.position) + pad);
            segments_.push_back(static_cast<int32_t>(i));
        }
        if (segments_.empty()) return;
        const Vec3 size = bounds_.size();
        const double extent = std::max({size.x, size.y, size.z, 1e-6});
        const double perSegment = std::max(size.x, 1e-6) * std::max(size.y, 1e-6) *
                                  std::max(size.z, 1e-6) / static_cast<double>(segments_.size());
        cell_ = std::max({extent / 128.0, 0.5 * std::cbrt(perSegment), 0.01});
        for (int a = 0; a < 3; ++a) {
            dims_[a] = std::max(1, static_cast<int>(std::ceil(size[a] / cell_)));
        }
        start_.assign(static_cast<size_t>(dims_[0]) * dims_[1] * dims_[2] + 1, 0);
        auto forEachCell = [&](int32_t i, auto&& visit) {
            const SkeletonNode& n = tree.nodes[i];
            const SkeletonNode& p = tree.nodes[n.parent];
            const double r = std::max(n.radius, p.radius);
            const Vec3 pad{r, r, r};
            const auto lo = cellOf(vmin(n.position, p.position) - pad);
            const auto hi = cellOf(vmax(n.position, p.position) + pad);
            for (int x = lo[0]; x <= hi[0]; ++x)
                for (int y = lo[1]; y <= hi[1]; ++y)
                    for (int z = lo[2]; z <= hi[2]; ++z) visit(index(x, y, z));
        };
        for (int32_t i : segments_) forEachCell(i, [&](size_t cell) { ++start_[cell + 1]; });
        for (size_t k = 1; k < start_.size(); ++k) start_[k] += start_[k - 1];
        items_.resize(start_.back());
        std::vector<uint32_t> next(start_.begin(), start_.end() - 1);
        for (int32_t i : segments_) forEachCell(i, [&](size_t cell) { items_[next[cell]++] = i; });
    }

    // The distance from q to the nearest capsule. `hint` is the distance to one of them (a
    // leaf's own segment), an upper bound. q's own cell is searched first (ring 0). Then only
    // segments nearer than the best so far matter, and their padded boxes overlap the box
    // q ± best, so when that box spans a few cells those cells are all that is searched;
    // otherwise rings of cells grow until nothing unsearched can be nearer. The minimum is over
    // the same values either way: the result is the same to the bit with or without the hint.
    double distanceTo(const Vec3& q, double hint = kInf) const {
        if (segments_.empty()) return kInf;
        if (!(hint < kInf)) hint = kInf;  // NaN: no hint
        const auto c = cellOf(q);
        double best = std::min(hint, nearestInCell(q, c[0], c[1], c[2]));
        // Cells outside the grid hold nothing: the rings start from the nearest cell.
        const double outside = std::max(0.0, distanceToBox(q));
        // Inside the grid, an unsearched segment after ring r lies beyond the searched block
        // of cells: at least r cells plus q's distance to its own cell's nearest face away.
        double inCell = 0.0;
        if (outside == 0.0) {
            inCell = kInf;
            for (int a = 0; a < 3; ++a) {
                const double lo = bounds_.lo[a] + c[a] * cell_;
                inCell = std::min({inCell, q[a] - lo, lo + cell_ - q[a]});
            }
            inCell = std::max(0.0, inCell);
        }
        // Every segment not yet seen lies in cells at least `ring` cells from q's cell (the
        // bounding boxes include the radii).
        auto done = [&](int ring) { return best <= std::max(outside, ring * cell_ + inCell); };
        if (done(0)) return best;
        if (best < kInf) {
            const Vec3 pad{best, best, best};
            const auto lo = cellOf(q - pad), hi = cellOf(q + pad);
            const int64_t cells =
                int64_t(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1);
            if (cells <= kBoxCells) {
                for (int z = lo[2]; z <= hi[2]; ++z)
                    for (int y = lo[1]; y <= hi[1]; ++y)
                        for (int x = lo[0]; x <= hi[0]; ++x) {
                            if (x != c[0] || y != c[1] || z != c[2]) {
                                best = std::min(best, nearestInCell(q, x, y, z));
                            }
                        }
                return best;
            }
        }
        const int maxRing = std::max({dims_[0], dims_[1], dims_[2]});
        for (int ring = 1; ring <= maxRing && !done(ring - 1); ++ring) {
            // The cells of the ring (Chebyshev distance `ring` from c) inside the grid: whole
            // rows where y or z is on the ring's face, else only the two x ends.
            for (int z = std::max(0, c[2] - ring); z <= std::min(dims_[2] - 1, c[2] + ring); ++z) {
                for (int y = std::max(0, c[1] - ring); y <= std::min(dims_[1] - 1, c[1] + ring);
                     ++y) {
                    const bool face = std::abs(y - c[1]) == ring || std::abs(z - c[2]) == ring;
                    const int step = face ? 1 : std::max(1, 2 * ring);
                    for (int x = c[0] - ring; x <= c[0] + ring; x += step) {
                        if (x < 0 || x >= dims_[0]) continue;
                        best = std::min(best, nearestInCell(q, x, y, z));
                    }
                }
            }
        }
        return best;
    }

  private:
    // The box search's limit: beyond it (a bound far larger than a cell) the rings are cheaper.
    static constexpr int64_t kBoxCells = 64;

    // The nearest capsule among those registered in cell (x, y, z); +infinity if none.
    double nearestInCell(const Vec3& q, int x, int y, int z) const {
        const size_t cell = index(x, y, z);
        double best = kInf;
        for (uint32_t k = start_[cell]; k < start_[cell + 1]; ++k) {
            const SkeletonNode& n = tree_.nodes[items_[k]];
            const SkeletonNode& p = tree_.nodes[n.parent];
            best = std::min(best, capsuleDistance(q, p.position, p.radius, n.position, n.radius));
        }
        return best;
    }

    std::array<int, 3> cellOf(const Vec3& p) const {
        std::array<int, 3> c{};
        for (int a = 0; a < 3; ++a) {
            c[a] = std::clamp(static_cast<int>(std::floor((p[a] - bounds_.lo[a]) / cell_)), 0,
                              dims_[a] - 1);
        }
        return c;
    }
    size_t index(int x, int y, int z) const {
        return (static_cast<size_t>(z) * dims_[1] + y) * dims_[0] + x;
    }
    double distanceToBox(const Vec3& q) const {
        const Vec3 d = vmax(vmax(bounds_.lo - q, q - bounds_.hi), Vec3{0, 0, 0});
        return length(d);
    }

    const Tree& tree_;
    std::vector<int32_t> segments_;
    Aabb bounds_;
    double cell_ = 1.0;
    std::array<int, 3> dims_{1, 1, 1};
    std::vector<uint32_t> start_;  // cell k holds items_[start_[k], start_[k + 1])
    std::vector<int32_t> items_;
};

// The order-0 axis from the root: at each node the shoot child of order 0 (the highest one if
// several), as long as there is one.
std::vector<Vec3> leaderAxis(const Tree& tree, const ChildIndex& children) {
    std::vector<Vec3> axis = {tree.nodes[0].position};
    int32_t i = 0;
    for (;;) {
        int32_t next = -1;
        for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
            const int32_t c = children.child[k];
            const SkeletonNode& n = tree.nodes[c];
            if (n.part != kShootPart || n.order != 0) continue;
            if (next < 0 || n.position.y > tree.nodes[next].position.y) next = c;
        }
        if (next < 0) return axis;
        axis.push_back(tree.nodes[next].position);
        i = next;
    }
}

}  // namespace

std::vector<double> woodDistances(const Tree& tree, const std::vector<Vec3>& points,
                                  const std::vector<int32_t>& near) {
    const SegmentGrid grid(tree);
    std::vector<double> out;
    out.reserve(points.size());
    for (size_t k = 0; k < points.size(); ++k) {
        const int32_t i = k < near.size() ? near[k] : -1;
        double hint = kInf;
        if (i > 0 && static_cast<size_t>(i) < tree.nodes.size()) {
            const SkeletonNode& n = tree.nodes[i];
            const SkeletonNode& p = tree.nodes[n.parent];
            hint = capsuleDistance(points[k], p.position, p.radius, n.position, n.radius);
        }
        out.push_back(grid.distanceTo(points[k], hint));
    }
    return out;
}

void addRealismMetrics(const Tree& tree, TreeStats& s) {
    s.lowestShootY = s.belowGroundFraction = s.leaderLeanDeg = s.leafWoodDistanceP95 = kNaN;
    s.stemsAtBase = 0;
    const auto& nodes = tree.nodes;
    if (nodes.empty() || nodes[0].part != kShootPart) return;

    // Ground: the shoot system's lowest point and its share of nodes below y = 0.
    int64_t shoot = 0, below = 0;
    s.lowestShootY = nodes[0].position.y;
    double top = nodes[0].position.y;
    for (size_t i = 1; i < nodes.size(); ++i) {
        if (nodes[i].part != kShootPart) continue;
        ++shoot;
        below += nodes[i].position.y < 0.0;
        s.lowestShootY = std::min(s.lowestShootY, nodes[i].position.y);
        top = std::max(top, nodes[i].position.y);
    }
    if (shoot > 0) s.belowGroundFraction = static_cast<double>(below) / static_cast<double>(shoot);

    // Stems: shoot segments leaving the base ball outward from a node reached from the root
    // within the ball (a twig hanging down into the ball from the crown and out again is no
    // stem). Parents come before their children, so one pass settles which nodes are reached.
    const Vec3 root = nodes[0].position;
    const double baseRadius = std::max(nodes[0].radius, kMinBaseRadius);
    std::vector<char> fromBase(nodes.size(), 0);
    fromBase[0] = 1;
    for (size_t i = 1; i < nodes.size(); ++i) {
        const SkeletonNode& n = nodes[i];
        if (n.part != kShootPart || nodes[n.parent].part != kShootPart || !fromBase[n.parent]) {
            continue;
        }
        if (distance(n.position, root) <= baseRadius) {
            fromBase[i] = 1;
        } else {
            ++s.stemsAtBase;
        }
    }

    // Leader: the direction of the order-0 axis over its last fifth, from the vertical; none
    // when the axis stops below half the tree's height.
    const ChildIndex children(tree);
    const std::vector<Vec3> axis = leaderAxis(tree, children);
    double axisLength = 0.0;
    for (size_t k = 1; k < axis.size(); ++k) axisLength += distance(axis[k - 1], axis[k]);
    if (axis.size() >= 2 && axisLength > 0 &&
        axis.back().y - root.y >= kLeaderMinHeightFraction * (top - root.y)) {
        const double from = (1.0 - kLeaderTopFraction) * axisLength;
        double walked = 0.0;
        Vec3 start = axis.front();
        for (size_t k = 1; k < axis.size(); ++k) {
            const double seg = distance(axis[k - 1], axis[k]);
            if (walked + seg >= from) {
                const double t = seg > 0 ? (from - walked) / seg : 0.0;
                start = axis[k - 1] + (axis[k] - axis[k - 1]) * t;
                break;
            }
            walked += seg;
        }
        const Vec3 d = axis.back() - start;
        if (length(d) > 0) {
            const double c = std::clamp(d.y / length(d), -1.0, 1.0);
            s.leaderLeanDeg = std::acos(c) * 180.0 / kPi;
        }
    }

    // Leaves: the distance from each card's attachment (the middle of its near edge) to the
    // wood; the 95th percentile.
    if (!tree.leaves.empty() && nodes.size() > 1) {
        std::vector<Vec3> attach;
        std::vector<int32_t> carriers;
        attach.reserve(tree.leaves.size());
        carriers.reserve(tree.leaves.size());
        for (const Leaf& l : tree.leaves) {
            attach.push_back(l.position - l.tangent * (0.5 * l.size));
            carriers.push_back(l.node);
        }
        s.leafWoodDistanceP95 = quantile(woodDistances(tree, attach, carriers), 0.95);
    }
}

}  // namespace sylva
