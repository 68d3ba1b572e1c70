#include "species/plot/point_process.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/rng.h"

namespace sylva {
namespace {

// A square lattice of spacing s: every nearest neighbour is at s, and R = s / E with Donnelly's
// expectation, computed by hand here.
TEST(ClarkEvans, SquareLatticeHasKnownDistancesAndIndex) {
    std::vector<Vec2> pts;
    for (int i = 0; i < 10; ++i)
        for (int j = 0; j < 10; ++j) pts.push_back({-45.0 + 10 * i, -45.0 + 10 * j});
    for (double d : nearestNeighbourDistances(pts)) EXPECT_NEAR(d, 10.0, 1e-12);
    PlotArea a;
    a.width = a.depth = 100;
    const double expected = 0.5 / std::sqrt(100 / 1e4) + (0.0514 + 0.041 / 10) * 400 / 100;
    EXPECT_NEAR(clarkEvans(pts, a), 10.0 / expected, 1e-12);
}

// Uniform random points (complete spatial randomness) give R ≈ 1 with the edge correction;
// the nearest-neighbour distances agree with brute force.
TEST(ClarkEvans, UniformRandomPointsGiveAboutOne) {
    PlotArea a;
    a.width = 100;
    a.depth = 60;
    double sum = 0;
    const int trials = 40;
    for (int t = 0; t < trials; ++t) {
        Rng rng(1000 + t);
        std::vector<Vec2> pts;
        for (int k = 0; k < 300; ++k) pts.push_back({rng.uniform(-50, 50), rng.uniform(-30, 30)});
        if (t == 0) {
            const auto nn = nearestNeighbourDistances(pts);
            for (size_t i = 0; i < pts.size(); ++i) {
                double best = 1e300;
                for (size_t j = 0; j < pts.size(); ++j)
                    if (i != j)
                        best = std::min(best, std::hypot(pts[i].x - pts[j].x, pts[i].y - pts[j].y));
                EXPECT_DOUBLE_EQ(nn[i], best);
            }
        }
        sum += clarkEvans(pts, a);
    }
    EXPECT_NEAR(sum / trials, 1.0, 0.02);
}

}  // namespace
}  // namespace sylva
