// The sky grid: open sky where nothing occludes, Beer–Lambert through a uniform slab.
#include "pipeline/render/sky_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace sylva {
namespace {

TEST(SkyGrid, NothingToOccludeLeavesTheSkyOpen) {
    SkyGrid grid({0, 0, 0}, {4, 8, 4}, 16, 1.0);
    grid.finish();
    float t[SkyGrid::kDirections];
    for (const Vec3& p : {Vec3{2, 4, 2}, Vec3{0, 0, 0}, Vec3{-5, 20, 3}}) {
        grid.transmittance(p, t);
        for (float v : t) EXPECT_FLOAT_EQ(v, 1.0f);
    }
}

// A level slab 2 m thick of extinction 0.5 /m filling a 20 × 20 m grid across: from under it, a
// direction of elevation θ sees exp(−0.5 · 2 / sin θ) of the sky; from over it, all of the sky
// above and exp(−1 / sin θ) below; the directions spread evenly and are unit vectors.
TEST(SkyGrid, ASlabAttenuatesByBeerLambert) {
    const double h = 0.5;  // 20 m / 40 cells
    const double sigma = 0.5;
    SkyGrid grid({0, 0, 0}, {20, 10, 20}, 40, 1.0);
    ASSERT_DOUBLE_EQ(grid.cellSize(), h);
    // Cell centres are at −h + (i + ½)h; the slab's cells are those with centres in (4, 6).
    for (int i = 0; i < 42; ++i) {
        for (int k = 0; k < 42; ++k) {
            for (int j = 0; j < 22; ++j) {
                const Vec3 c{-h + (i + 0.5) * h, -h + (j + 0.5) * h, -h + (k + 0.5) * h};
                if (c.y > 4 && c.y < 6) grid.addArea(c, sigma * h * h * h);
            }
        }
    }
    grid.finish();
    EXPECT_NEAR(grid.extinction({10, 5, 10}), sigma, 1e-6);
    EXPECT_NEAR(grid.extinction({10, 3, 10}), 0.0, 1e-9);
    Vec3 mean;
    for (const Vec3& d : grid.directions()) {
        EXPECT_NEAR(length(d), 1.0, 1e-12);
        mean += d;
    }
    EXPECT_LT(length(mean / SkyGrid::kDirections), 0.02);
    float below[SkyGrid::kDirections], above[SkyGrid::kDirections];
    grid.transmittance({10, 2.25, 10}, below);
    grid.transmittance({10, 7.75, 10}, above);
    int steep = 0;
    for (int k = 0; k < SkyGrid::kDirections; ++k) {
        const Vec3& d = grid.directions()[k];
        const double through = std::exp(-sigma * 2.0 / std::abs(d.y));
        // Steep enough that the path crosses the slab inside the grid (10 m each side).
        if (std::abs(d.y) < 0.5) continue;
        ++steep;
        // Along a grid axis the sweep is exact but for the slab's edges (3 %); across the
        // axes, interpolating transmittance between cells blurs the paths and lets a little more
        // light through (numerical diffusion: up to 10 % here).
        const bool alongY = std::abs(d.y) >= std::max(std::abs(d.x), std::abs(d.z));
        const double tol = (alongY ? 0.03 : 0.12) * through;
        if (d.y > 0) {
            EXPECT_NEAR(below[k], through, tol) << k;
            EXPECT_GE(below[k], through - 0.03 * through) << k;
            EXPECT_NEAR(above[k], 1.0, 1e-3) << k;
        } else {
            EXPECT_NEAR(below[k], 1.0, 1e-3) << k;
            EXPECT_NEAR(above[k], through, tol) << k;
        }
    }
    EXPECT_GE(steep, 14);
}

TEST(SkyGrid, ClumpingLetsMoreLightThrough) {
    {
        const SkyGrid g({0, 0, 0}, {1, 1, 1}, 2, 1.0);
        for (const Vec3& d : g.directions()) EXPECT_LE(d.y, g.directions()[0].y);
    }
    auto straightUp = [](double clumping) {
        SkyGrid grid({0, 0, 0}, {2, 2, 2}, 4, clumping);
        for (double x = 0.25; x < 2; x += 0.5) {
            for (double z = 0.25; z < 2; z += 0.5) grid.addArea({x, 1.25, z}, 0.2);
        }
        grid.finish();
        float t[SkyGrid::kDirections];
        grid.transmittance({1, 0.25, 1}, t);
        return double(t[0]);  // directions()[0]: the one nearest straight up
    };
    EXPECT_LT(straightUp(1.0), straightUp(0.5));
    EXPECT_NEAR(std::log(straightUp(0.5)) / std::log(straightUp(1.0)), 0.5, 0.02);
    EXPECT_THROW(SkyGrid({0, 0, 0}, {1, 1, 1}, 4, 0.0), std::invalid_argument);
    EXPECT_THROW(SkyGrid({0, 0, 0}, {1, 1, 1}, 0, 1.0), std::invalid_argument);
}

}  // namespace
}  // namespace sylva
