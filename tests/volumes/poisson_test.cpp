// Poisson-disc sampling and the point grid: spacing, count, containment, determinism,
// saturation (must throw quickly, never hang), degenerate inputs.
#include "volumes/poisson.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

#include "volumes/point_grid.h"
#include "volumes/volume.h"

namespace sylva {
namespace {

double minPairDistance(const std::vector<Vec3>& pts) {
    double best = 1e300;
    for (size_t i = 0; i < pts.size(); ++i)
        for (size_t j = i + 1; j < pts.size(); ++j)
            best = std::min(best, distance2(pts[i], pts[j]));
    return std::sqrt(best);
}

void expectValidSampling(const Volume& v, int count, double d, uint64_t seed) {
    Rng rng(seed);
    PoissonOptions opt;
    opt.count = count;
    opt.minDistance = d;
    std::vector<Vec3> pts = poissonSample(v, opt, rng);
    ASSERT_EQ(static_cast<int>(pts.size()), count) << v.describe();
    for (const Vec3& p : pts) EXPECT_LE(v.signedDistance(p), 1e-9) << v.describe();
    EXPECT_GE(minPairDistance(pts), d) << v.describe();
}

TEST(Poisson, SpacingCountAndContainment) {
    expectValidSampling(*makeSphere(1.0), 200, 0.2, 1);
    expectValidSampling(*makeSphereSector(2.0, kPi / 4), 300, 0.2, 2);
    expectValidSampling(*makeCone(1.0, 2.0, 0.3), 150, 0.2, 3);
    expectValidSampling(*makeHemisphere(1.0), 120, 0.2, 4);
    Placement pl;
    pl.axis = {1, 0.5, 0.2};
    pl.position = {3, 1, 0};
    expectValidSampling(*makePlaced(makeCylinder(0.4, 3.0), pl), 150, 0.15, 5);
    expectValidSampling(*makeUnion({makeCylinder(0.2, 1.0), makeSphere(0.8)}), 150, 0.15, 6);
}

TEST(Poisson, TwoThousandPointsBruteForce) {
    auto box = makeBox({10, 10, 10});  // capacity 0.7·1000/0.125 = 5600
    expectValidSampling(*box, 2000, 0.5, 7);
}

TEST(Poisson, UniformCentroid) {
    auto s = makeSphereSector(1.0, kPi / 3);
    Rng rng(8);
    PoissonOptions opt{1000, 0.05};
    auto pts = poissonSample(*s, opt, rng);
    Vec3 mean;
    for (const Vec3& p : pts) mean += p;
    mean = mean / pts.size();
    EXPECT_NEAR(mean.y, 3.0 * (1 + std::cos(kPi / 3)) / 8.0, 0.02);
    EXPECT_NEAR(mean.x, 0.0, 0.02);
    EXPECT_NEAR(mean.z, 0.0, 0.02);
}

TEST(Poisson, Deterministic) {
    auto v = makeEllipsoid({1, 2, 1});
    PoissonOptions opt{300, 0.2};
    Rng a(99), b(99), c(100);
    auto pa = poissonSample(*v, opt, a);
    auto pb = poissonSample(*v, opt, b);
    auto pc = poissonSample(*v, opt, c);
    EXPECT_EQ(pa, pb);
    EXPECT_NE(pa, pc);
}

// A volume that counts the darts drawn from it.
class CountingVolume : public Volume {
  public:
    explicit CountingVolume(VolumePtr inner) : inner_(std::move(inner)) {}
    double signedDistance(const Vec3& p) const override { return inner_->signedDistance(p); }
    Aabb bounds() const override { return inner_->bounds(); }
    std::optional<Vec3> sample(Rng& rng, int maxTries) const override {
        ++darts;
        return inner_->sample(rng, maxTries);
    }
    double measure() const override { return inner_->measure(); }
    std::string describe() const override { return inner_->describe(); }
    mutable int64_t darts = 0;

  private:
    VolumePtr inner_;
};

// More points than fit: the search gives up after a bounded number of darts — at most
// maxConsecutiveRejections rejected in a row before each placed point and before giving up —
// rather than running on (a bound on work, not on the clock).
TEST(Poisson, SaturationGivesUpAfterBoundedDarts) {
    CountingVolume s(makeSphere(1.0));  // capacity ≈ 0.7·4.19/0.008 ≈ 367
    PoissonOptions opt{5000, 0.2};
    Rng rng(1);
    std::string msg;
    try {
        poissonSample(s, opt, rng);
        FAIL() << "expected PoissonSaturated";
    } catch (const PoissonSaturated& e) {
        msg = e.what();
    }
    EXPECT_NE(msg.find(" of 5000 points at spacing 0.2 m in sphere r=1 m"), std::string::npos)
        << msg;
    EXPECT_NE(msg.find("capacity"), std::string::npos) << msg;
    EXPECT_NE(msg.find("lower the count or the spacing"), std::string::npos) << msg;
    ASSERT_EQ(msg.rfind("placed ", 0), 0u) << msg;
    const int64_t placed = std::stoll(msg.substr(7));
    EXPECT_GT(placed, 100);  // about the capacity: the sphere did fill up
    EXPECT_LT(placed, 600);
    EXPECT_GT(s.darts, placed + opt.maxConsecutiveRejections - 1);
    EXPECT_LE(s.darts, placed + (placed + 1) * int64_t{opt.maxConsecutiveRejections});
}

TEST(Poisson, DegenerateInputs) {
    Rng rng(1);
    EXPECT_TRUE(poissonSample(*makeSphere(1.0), PoissonOptions{0, 0.1}, rng).empty());
    EXPECT_TRUE(poissonSample(*makeSphere(1.0), PoissonOptions{-3, 0.1}, rng).empty());
    // A zero-radius sphere holds exactly one point at spacing d > 0.
    auto dot = makeSphere(0.0);
    auto one = poissonSample(*dot, PoissonOptions{1, 0.1}, rng);
    ASSERT_EQ(one.size(), 1u);
    EXPECT_EQ(one[0], (Vec3{0, 0, 0}));
    EXPECT_THROW(poissonSample(*dot, PoissonOptions{2, 0.1}, rng), PoissonSaturated);
    // No spacing: any count of plain uniform samples.
    auto many = poissonSample(*makeSphere(1.0), PoissonOptions{50, 0.0}, rng);
    EXPECT_EQ(many.size(), 50u);
    // A volume that cannot be sampled at all reports that, not a hang.
    Placement left, right;
    left.position = {-3, 0, 0};
    right.position = {3, 0, 0};
    auto empty =
        makeIntersection({makePlaced(makeSphere(1), left), makePlaced(makeSphere(1), right)});
    try {
        poissonSample(*empty, PoissonOptions{5, 0.1}, rng);
        FAIL() << "expected PoissonSaturated";
    } catch (const PoissonSaturated& e) {
        EXPECT_NE(std::string(e.what()).find("no point could be drawn"), std::string::npos);
    }
}

TEST(Poisson, Capacity) {
    EXPECT_NEAR(poissonCapacity(1.0, 0.1), 700.0, 1e-9);
    EXPECT_NEAR(poissonCapacity(8.0, 0.5), 0.7 * 8.0 / 0.125, 1e-9);
    EXPECT_EQ(poissonCapacity(0.0, 0.5), 0.0);
}

// --- point grid ----------------------------------------------------------------------------

TEST(PointGrid, QueriesMatchBruteForce) {
    const Aabb box{{0, 0, 0}, {4, 2, 3}};
    // Dense (several points a cell) and sparse (most cells empty), and empty.
    for (int n : {2000, 40, 0}) {
        PointGrid grid(box, 0.3);
        Rng rng(12 + n);
        std::vector<Vec3> pts;
        for (int i = 0; i < n; ++i) {
            // Some points lie outside the bounds: they are clamped into border cells.
            Vec3 p{rng.uniform(-1, 5), rng.uniform(-1, 3), rng.uniform(-1, 4)};
            pts.push_back(p);
            grid.insert(i * 3, p);  // ids need not be dense
        }
        EXPECT_EQ(grid.size(), pts.size());
        int hits = 0;
        for (int k = 0; k < 300; ++k) {
            Vec3 q{rng.uniform(-2, 6), rng.uniform(-2, 4), rng.uniform(-2, 5)};
            const double r = rng.uniform(0.05, 1.0);
            std::set<int> expected, got;
            for (size_t i = 0; i < pts.size(); ++i)
                if (distance(pts[i], q) < r) expected.insert(static_cast<int>(i) * 3);
            grid.forEachWithin(q, r, [&](int32_t id, const Vec3& p) {
                got.insert(id);
                EXPECT_EQ(p, pts[id / 3]);
            });
            EXPECT_EQ(got, expected);
            EXPECT_EQ(grid.anyWithin(q, r), !expected.empty()) << n << " points, query " << k;
            hits += !expected.empty();
        }
        if (n > 0) {  // both answers are exercised
            EXPECT_GT(hits, 10) << n;
            EXPECT_LT(hits, 290) << n;
        }
    }
}

TEST(PackedPointGrid, BoxQueriesVisitEveryPointInsideOnce) {
    Rng rng(13);
    std::vector<Vec3> pts;
    for (int i = 0; i < 3000; ++i) {
        pts.push_back({rng.uniform(-1, 5), rng.uniform(0, 2), rng.uniform(-1, 4)});
    }
    PackedPointGrid grid;
    grid.assign(pts, 0.25);
    for (int k = 0; k < 200; ++k) {
        // Boxes inside, across and outside the points' bounds (clamped to the border cells).
        const Vec3 a{rng.uniform(-3, 7), rng.uniform(-2, 4), rng.uniform(-3, 6)};
        const Vec3 lo = a, hi = a + Vec3{rng.uniform(0, 2), rng.uniform(0, 1), rng.uniform(0, 2)};
        std::vector<int> seen(pts.size(), 0);
        grid.forEachInBox(lo, hi, [&](int32_t id, const Vec3& p) {
            ++seen[id];
            EXPECT_EQ(p, pts[id]);
        });
        for (size_t i = 0; i < pts.size(); ++i) {
            const Vec3& p = pts[i];
            const bool inside = p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y &&
                                p.z >= lo.z && p.z <= hi.z;
            if (inside) {
                EXPECT_EQ(seen[i], 1) << i;
            }
            EXPECT_LE(seen[i], 1);
            // Only the cells the box touches: nothing beyond a cell from it, for boxes within
            // the points' bounds (outside, the border cells answer for everything beyond).
            const bool within =
                lo.x >= -1 && hi.x <= 5 && lo.y >= 0 && hi.y <= 2 && lo.z >= -1 && hi.z <= 4;
            if (seen[i] && within) {
                EXPECT_TRUE(p.x >= lo.x - 0.26 && p.x <= hi.x + 0.26 && p.y >= lo.y - 0.26 &&
                            p.y <= hi.y + 0.26 && p.z >= lo.z - 0.26 && p.z <= hi.z + 0.26)
                    << i;
            }
        }
    }
    PackedPointGrid empty;
    empty.assign({}, 0.25);
    int n = 0;
    empty.forEachInBox({0, 0, 0}, {1, 1, 1}, [&](int32_t, const Vec3&) { ++n; });
    EXPECT_EQ(n, 0);
}

// The packed grid's radius query (a row of cells read as one run of slots) lists the points
// within the radius, each once, in the order the documented contract gives: that of a
// PointGrid over the same cells filled in index order (cell by cell, z slowest; each cell's
// points by descending index). Callers' floating-point sums follow this order.
TEST(PackedPointGrid, RadiusQueriesListWhatAPointGridListsInItsOrder) {
    Rng rng(14);
    std::vector<Vec3> pts;
    Aabb box;
    for (int i = 0; i < 3000; ++i) {
        pts.push_back({rng.uniform(-1, 5), rng.uniform(0, 2), rng.uniform(-1, 4)});
        box.extend(pts.back());
    }
    const double cell = 0.3;
    PackedPointGrid packed;
    packed.assign(pts, cell);
    PointGrid linked(box, cell);
    for (size_t i = 0; i < pts.size(); ++i) linked.insert(static_cast<int32_t>(i), pts[i]);
    size_t found = 0;
    for (int k = 0; k < 300; ++k) {
        // Queries inside, across and outside the bounds, radii from a fraction of a cell to
        // several cells.
        const Vec3 q{rng.uniform(-2, 6), rng.uniform(-1, 3), rng.uniform(-2, 5)};
        const double r = rng.uniform(0.05, 1.2);
        std::vector<int32_t> a, b;
        packed.forEachWithin(q, r, [&](int32_t id, const Vec3& p) {
            a.push_back(id);
            EXPECT_EQ(p, pts[id]);
        });
        linked.forEachWithin(q, r, [&](int32_t id, const Vec3&) { b.push_back(id); });
        ASSERT_EQ(a, b) << "query " << k;
        size_t inside = 0;
        for (const Vec3& p : pts) inside += distance(p, q) < r;
        EXPECT_EQ(a.size(), inside) << "query " << k;
        found += a.size();
    }
    EXPECT_GT(found, 3000u);  // the queries do find points
    PackedPointGrid never;    // never assigned: nothing to visit, no out-of-range read
    int n = 0;
    never.forEachWithin({0, 0, 0}, 1.0, [&](int32_t, const Vec3&) { ++n; });
    EXPECT_EQ(n, 0);
}

TEST(PointGrid, HugeBoundsTinyCellStaysSmall) {
    // 10⁴ m box at 1 mm cells would be 10²¹ cells; the grid caps its cell count instead.
    PointGrid grid({{-5000, -5000, -5000}, {5000, 5000, 5000}}, 0.001);
    grid.insert(0, {1, 2, 3});
    grid.insert(1, {1.0005, 2, 3});
    EXPECT_TRUE(grid.anyWithin({1, 2, 3.0001}, 0.001));
    EXPECT_FALSE(grid.anyWithin({4000, 2, 3}, 0.001));
    EXPECT_FALSE(grid.anyWithin({1e30, -1e30, 0}, 1.0));  // far outside: no overflow
    int n = 0;
    grid.forEachWithin({1, 2, 3}, 0.01, [&](int32_t, const Vec3&) { ++n; });
    EXPECT_EQ(n, 2);
}

TEST(PointGrid, EmptyAndDegenerateBounds) {
    PointGrid a(Aabb{}, 0.1);  // empty bounds: a single cell
    a.insert(7, {1, 1, 1});
    EXPECT_TRUE(a.anyWithin({1, 1, 1.05}, 0.1));
    PointGrid b({{0, 0, 0}, {0, 0, 0}}, 0.0);  // zero-size bounds, zero cell
    b.insert(1, {0, 0, 0});
    EXPECT_TRUE(b.anyWithin({0.01, 0, 0}, 0.1));
    EXPECT_FALSE(b.anyWithin({1, 0, 0}, 0.1));
    const double inf = HUGE_VAL;
    PointGrid c({{-inf, 0, 0}, {inf, 1, 1}}, 0.1);  // unbounded: must not loop or overflow
    c.insert(2, {1e6, 0.5, 0.5});
    EXPECT_TRUE(c.anyWithin({1e6, 0.5, 0.55}, 0.1));
    EXPECT_FALSE(c.anyWithin({0, 0.5, 0.5}, 0.1));
}

}  // namespace
}  // namespace sylva
