#include "species/plot/terrain.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sylva {
namespace {

// A plane y = 0.5·x − 0.25·z sampled on a 1 m grid: bilinear heights are exact on it, the
// normal is (−0.5, 1, 0.25) normalised, and the mesh's triangles face up.
TEST(Terrain, PlaneIsInterpolatedExactlyAndMeshedFacingUp) {
    const int nx = 5, nz = 4;
    std::vector<float> h;
    for (int j = 0; j < nz; ++j)
        for (int i = 0; i < nx; ++i) h.push_back(float(0.5 * (-2 + i) - 0.25 * (-1 + j)));
    const Terrain t(-2, -1, 1.0, nx, nz, h);
    EXPECT_NEAR(t.height(0.3, 0.7), 0.5 * 0.3 - 0.25 * 0.7, 1e-6);
    EXPECT_NEAR(t.height(-10, 0), t.height(-2, 0), 1e-9);  // clamped outside
    const Vec3 n = t.normal(0.1, 0.2);
    const Vec3 want = normalize(Vec3(-0.5, 1, 0.25));
    EXPECT_NEAR(n.x, want.x, 1e-6);
    EXPECT_NEAR(n.y, want.y, 1e-6);
    EXPECT_NEAR(n.z, want.z, 1e-6);
    const Mesh m = terrainMesh(t);
    EXPECT_EQ(m.vertexCount(), size_t(nx * nz));
    ASSERT_EQ(m.triangleCount(), size_t((nx - 1) * (nz - 1) * 2));
    for (size_t k = 0; k < m.triangleCount(); ++k) {
        auto p = [&](int c) {
            const uint32_t v = m.indices[k * 3 + c];
            return Vec3(m.positions[v * 3], m.positions[v * 3 + 1], m.positions[v * 3 + 2]);
        };
        EXPECT_GT(cross(p(1) - p(0), p(2) - p(0)).y, 0.0) << k;
    }
}

TEST(PlotArea, AreaAndContainment) {
    PlotArea r;
    r.width = 100;
    r.depth = 40;
    EXPECT_DOUBLE_EQ(r.area(), 4000);
    EXPECT_TRUE(r.contains(49.9, -19.9));
    EXPECT_FALSE(r.contains(0, 20.1));
    PlotArea c;
    c.shape = PlotArea::Shape::kCircle;
    c.radius = 10;
    EXPECT_NEAR(c.area(), 314.159265, 1e-5);
    EXPECT_TRUE(c.contains(7, 7));
    EXPECT_FALSE(c.contains(7.1, 7.1));
}

}  // namespace
}  // namespace sylva
