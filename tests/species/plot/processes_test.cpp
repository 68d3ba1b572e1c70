// The stem point processes against their known answers (species/plot/point_process.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/rng.h"
#include "species/plot/point_process.h"

namespace sylva {
namespace {

PlotArea square(double side) {
    PlotArea a;
    a.width = a.depth = side;
    return a;
}

// Pairs closer than r, by brute force.
int64_t pairsWithin(const std::vector<Vec2>& p, double r) {
    int64_t n = 0;
    for (size_t i = 0; i < p.size(); ++i)
        for (size_t j = i + 1; j < p.size(); ++j)
            if (std::hypot(p[i].x - p[j].x, p[i].y - p[j].y) < r) ++n;
    return n;
}

double minPairDistance(const std::vector<Vec2>& p) {
    double best = INFINITY;
    for (size_t i = 0; i < p.size(); ++i)
        for (size_t j = i + 1; j < p.size(); ++j)
            best = std::min(best, std::hypot(p[i].x - p[j].x, p[i].y - p[j].y));
    return best;
}

void expectInside(const std::vector<Vec2>& pts, const PlotArea& a) {
    for (const Vec2& p : pts) ASSERT_TRUE(a.contains(p.x, p.y)) << p.x << ", " << p.y;
}

// A Poisson count of mean λA = 100 over 400 draws: mean and variance both ≈ 100 (the standard
// error of the mean is 0.5, of the variance about 7); small means too (Knuth's method exactly).
TEST(PoissonProcess, CountHasPoissonMeanAndVariance) {
    for (double mean : {100.0, 3.5}) {
        Rng root(11);
        double sum = 0, sum2 = 0;
        const int draws = 400;
        for (int k = 0; k < draws; ++k) {
            Rng r = root.derive(static_cast<uint64_t>(k));
            const double n = static_cast<double>(poissonCount(mean, r));
            sum += n;
            sum2 += n * n;
        }
        const double m = sum / draws, var = (sum2 - draws * m * m) / (draws - 1);
        EXPECT_NEAR(m, mean, 4 * std::sqrt(mean / draws)) << mean;
        EXPECT_NEAR(var, mean, 5 * mean * std::sqrt(2.0 / (draws - 1)) + 0.2) << mean;
    }
    Rng r(1);
    EXPECT_EQ(poissonCount(0, r), 0);
}

// Complete spatial randomness: the Clark–Evans index averages 1 over repeated plots (its
// standard error per plot of 200 points is 0.037; over 40 plots 0.006), in a rectangle and a
// circle; every point inside.
TEST(PoissonProcess, ClarkEvansAboutOneOverRepeatedPlots) {
    PlotArea circle;
    circle.shape = PlotArea::Shape::kCircle;
    circle.radius = 40;
    for (const PlotArea& a : {square(100), circle}) {
        double sum = 0;
        const int plots = 40;
        for (int k = 0; k < plots; ++k) {
            Rng r = Rng(5).derive(static_cast<uint64_t>(k));
            const std::vector<Vec2> p = poissonPoints(200, a, r);
            ASSERT_EQ(p.size(), 200u);
            expectInside(p, a);
            sum += clarkEvans(p, a);
        }
        EXPECT_NEAR(sum / plots, 1.0, 0.03);
    }
}

// Matérn hard core / sequential inhibition: the exact count, no pair closer than the spacing,
// up to the refused coverage (0.40: 318 stems 2 m apart on 50 × 50 m), and regular (R > 1).
TEST(HardCoreProcess, ExactCountNoPairCloserThanTheSpacing) {
    const PlotArea a = square(50);
    EXPECT_EQ(hardCoreCapacity(2.0, a), 318);
    for (int64_t n : {int64_t(50), int64_t(200), int64_t(318)}) {
        Rng r(static_cast<uint64_t>(n));
        const std::vector<Vec2> p = hardCorePoints(n, 2.0, a, r);
        ASSERT_EQ(static_cast<int64_t>(p.size()), n);
        expectInside(p, a);
        EXPECT_GE(minPairDistance(p), 2.0) << n;
        if (n >= 200) {
            EXPECT_GT(clarkEvans(p, a), 1.2) << n;
        }
    }
}

// Strauss: at the same count, fewer pairs within r than Poisson (whose expectation is
// n(n−1)/2 · πr²/A less an edge loss), the more so the smaller γ; γ = 0 leaves almost none.
TEST(StraussProcess, FewerClosePairsThanPoisson) {
    const PlotArea a = square(60);
    const int64_t n = 200;
    const double r = 3;
    double poisson = 0, strauss = 0, hard = 0;
    for (int k = 0; k < 5; ++k) {
        Rng p = Rng(21).derive(static_cast<uint64_t>(k));
        poisson += static_cast<double>(pairsWithin(poissonPoints(n, a, p), r));
        Rng s = Rng(22).derive(static_cast<uint64_t>(k));
        const std::vector<Vec2> sp = straussPoints(n, r, 0.2, a, s);
        ASSERT_EQ(static_cast<int64_t>(sp.size()), n);
        expectInside(sp, a);
        strauss += static_cast<double>(pairsWithin(sp, r));
        Rng h = Rng(23).derive(static_cast<uint64_t>(k));
        hard += static_cast<double>(pairsWithin(straussPoints(n, r, 0.0, a, h), r));
    }
    const double expected = 5 * n * (n - 1) / 2.0 * kPi * r * r / a.area();
    EXPECT_NEAR(poisson, expected, 0.15 * expected);
    EXPECT_LT(strauss, 0.5 * poisson);
    EXPECT_LT(hard, 0.05 * poisson);
}

// Thomas clusters: R clearly below 1 (tight clusters of σ = 2 m around 15 parents per ha).
TEST(ThomasProcess, ClusteredClarkEvansBelowOne) {
    const PlotArea a = square(100);
    double sum = 0;
    for (int k = 0; k < 10; ++k) {
        Rng r = Rng(31).derive(static_cast<uint64_t>(k));
        const std::vector<Vec2> p = thomasPoints(300, 15, 2, a, r);
        ASSERT_EQ(p.size(), 300u);
        expectInside(p, a);
        sum += clarkEvans(p, a);
    }
    EXPECT_LT(sum / 10, 0.7);
}

// Rows: every place on the turned lattice (its coordinates along and across the rows are
// multiples of the spacings), the count of places known for an unturned grid, nearest
// neighbours one stem spacing apart; a subset keeps row order; jitter stays inside.
TEST(RowProcess, PlacesOnTheTurnedLattice) {
    PointProcessOptions o;
    o.kind = PointProcessOptions::Kind::kRows;
    o.rowSpacing = 3;
    o.stemSpacing = 2;
    const PlotArea a = square(30);
    EXPECT_EQ(rowSites(o, a).size(), size_t(11 * 15));  // |z| ≤ 15 at 3 m, |x| ≤ 15 at 2 m
    o.rowAzimuthRad = 30 * kPi / 180;
    const Vec2 u(std::sin(o.rowAzimuthRad), -std::cos(o.rowAzimuthRad));
    const Vec2 v(std::cos(o.rowAzimuthRad), std::sin(o.rowAzimuthRad));
    Rng r(41);
    const std::vector<Vec2> p = rowPoints(100, o, a, r);
    ASSERT_EQ(p.size(), 100u);
    expectInside(p, a);
    for (const Vec2& q : p) {
        const double along = dot(q, u) / o.stemSpacing, across = dot(q, v) / o.rowSpacing;
        EXPECT_NEAR(along, std::round(along), 1e-9);
        EXPECT_NEAR(across, std::round(across), 1e-9);
    }
    const std::vector<Vec2> all = rowPoints(static_cast<int64_t>(rowSites(o, a).size()), o, a, r);
    for (double d : nearestNeighbourDistances(all)) EXPECT_NEAR(d, 2.0, 1e-9);
    o.jitter = 0.3;
    Rng j(42);
    const std::vector<Vec2> jittered = rowPoints(100, o, a, j);
    expectInside(jittered, a);
    EXPECT_THROW(rowPoints(static_cast<int64_t>(all.size()) + 1, o, a, j), std::invalid_argument);
}

// Every process draws only from the stream it is given: the same seed, the same points.
TEST(PointProcesses, SameSeedSamePoints) {
    const PlotArea a = square(40);
    for (auto kind : {PointProcessOptions::Kind::kPoisson, PointProcessOptions::Kind::kHardCore,
                      PointProcessOptions::Kind::kStrauss, PointProcessOptions::Kind::kThomas,
                      PointProcessOptions::Kind::kRows}) {
        PointProcessOptions o;
        o.kind = kind;
        o.minSpacing = 2;
        o.interaction = 0.3;
        o.parentDensity = 30;
        o.clusterSigma = 3;
        o.rowSpacing = o.stemSpacing = 2.5;
        o.jitter = 0.2;
        Rng a1(9), a2(9), b(10);
        const std::vector<Vec2> p1 = drawPoints(60, o, a, a1), p2 = drawPoints(60, o, a, a2);
        const std::vector<Vec2> q = drawPoints(60, o, a, b);
        ASSERT_EQ(p1.size(), 60u);
        EXPECT_TRUE(p1 == p2) << static_cast<int>(kind);
        EXPECT_FALSE(p1 == q) << static_cast<int>(kind);
    }
}

}  // namespace
}  // namespace sylva
