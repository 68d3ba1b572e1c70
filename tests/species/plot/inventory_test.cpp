#include "species/plot/inventory.h"

#include <gtest/gtest.h>

#include <cmath>

#include "species/plot/point_process.h"
#include "tests/plot_fixture.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

// A vertical trunk from `base` with nodes every 0.5 m up to `height`, radius r(y above base).
template <typename F>
Tree trunk(const Vec3& base, double height, F radius) {
    Tree t;
    int32_t p = addNode(t, -1, base, radius(0.0), 0);
    for (double y = 0.5; y <= height + 1e-9; y += 0.5)
        p = addNode(t, p, base + Vec3{0, y, 0}, radius(y), 0);
    return t;
}

TEST(Inventory, CylinderTrunkGivesItsDiameterAtBreastHeight) {
    const Vec3 base{3, 5, -2};  // on a terrain 5 m up
    const TreeRecord r = measureTree(trunk(base, 4.0, [](double) { return 0.15; }), base);
    EXPECT_NEAR(r.dbh, 0.30, 1e-12);
    EXPECT_NEAR(r.height, 4.0, 1e-12);
    EXPECT_TRUE(std::isnan(r.crownBase));  // no leaves
}

TEST(Inventory, TaperedTrunkIsInterpolatedAt1_3m) {
    const Vec3 base{0, -1, 0};
    // r = 0.2 − 0.05·y: 0.135 at 1.3 m (nodes at 1.0 and 1.5 m: linear in between).
    const TreeRecord r =
        measureTree(trunk(base, 3.0, [](double y) { return 0.2 - 0.05 * y; }), base);
    EXPECT_NEAR(r.dbh, 0.27, 1e-12);
}

TEST(Inventory, ShortTreeHasNoDbh) {
    const TreeRecord r = measureTree(trunk({}, 1.0, [](double) { return 0.05; }), {});
    EXPECT_EQ(r.dbh, 0.0);
}

// A fork at 1 m: the order-0 leader (radius 0.1) is measured, not the order-1 stem (0.12).
TEST(Inventory, ForkBelowBreastHeightMeasuresTheLeader) {
    Tree t;
    int32_t a = addNode(t, -1, {0, 0, 0}, 0.2, 0);
    int32_t b = addNode(t, a, {0, 1, 0}, 0.15, 0);
    int32_t side = addNode(t, b, {0.3, 1.5, 0}, 0.12, 1);
    addNode(t, side, {0.6, 3, 0}, 0.1, 1);
    int32_t c = addNode(t, b, {0, 2, 0}, 0.1, 0);
    addNode(t, c, {0, 3, 0}, 0.08, 0);
    const TreeRecord r = measureTree(t, {});
    // Leader between (1 m, 0.15) and (2 m, 0.1): r(1.3) = 0.135.
    EXPECT_NEAR(r.dbh, 0.27, 1e-12);
}

// Leaves at known offsets from the stem: each sector's radius is its farthest point; shoot
// nodes count too; empty sectors are 0. +x east, −z north.
TEST(Inventory, CrownRadiiPerSector) {
    const Vec3 base{10, 2, 10};
    Tree t = trunk(base, 6.0, [](double) { return 0.1; });
    auto leafAt = [&](double dx, double y, double dz) {
        Leaf l;
        l.position = base + Vec3{dx, y, dz};
        t.leaves.push_back(l);
    };
    leafAt(0, 4, -2.0);                                // N 2
    leafAt(0, 5, -1.0);                                // N, nearer
    leafAt(3, 4, 0);                                   // E 3
    leafAt(-1, 4, 1);                                  // SW √2
    leafAt(1, 4, -1.1);                                // NE √(1 + 1.21) (azimuth 42.3°)
    leafAt(-2.5, 4, -0.9);                             // W (azimuth 289.8°): √(6.25 + 0.81)
    addNode(t, 6, base + Vec3{0, 3.2, 1.5}, 0.02, 1);  // a branch tip S 1.5
    const TreeRecord r = measureTree(t, base);
    const double expected[8] = {
        2.0, std::sqrt(2.21), 3.0, 0.0, 1.5, std::sqrt(2.0), std::sqrt(7.06), 0.0};
    for (int k = 0; k < 8; ++k)
        EXPECT_NEAR(r.crownRadius[k], expected[k], 1e-12) << kCrownSectors[k];
    EXPECT_NEAR(r.height, 6.0, 1e-12);
}

// Crown base: the lowest leaf, or the attachment of the lowest first-order branch that
// carries leaves; a leafless branch lower down does not count.
TEST(Inventory, CrownBaseIsLowestLeafOrLeafyBranch) {
    const Vec3 base{0, 1, 0};
    Tree t = trunk(base, 6.0, [](double) { return 0.1; });
    // Trunk nodes: index k at 0.5·k m. A bare branch at 1 m (node 2), a leafy one at 3 m (6).
    int32_t bare = addNode(t, 2, base + Vec3{1, 1.5, 0}, 0.02, 1);
    (void)bare;
    int32_t leafy = addNode(t, 6, base + Vec3{1, 3.6, 0}, 0.02, 1);
    int32_t twig = addNode(t, leafy, base + Vec3{1.5, 4.2, 0}, 0.01, 2);
    Leaf l;
    l.position = base + Vec3{1.5, 4.3, 0};
    l.node = twig;
    t.leaves.push_back(l);
    EXPECT_NEAR(measureTree(t, base).crownBase, 3.0, 1e-12);
    // A leaf lower than the branch: it decides.
    Leaf low;
    low.position = base + Vec3{0.2, 2.4, 0};
    low.node = 5;
    t.leaves.push_back(low);
    EXPECT_NEAR(measureTree(t, base).crownBase, 2.4, 1e-12);
}

// A 10 × 10 lattice, 10 m apart, in a 1 ha square: 100 stems/ha, basal area 100·π·0.3²/4,
// nearest neighbours 10 m, the Clark–Evans index of the lattice.
TEST(Inventory, LatticeGivesStemsBasalAreaAndSpacing) {
    PlotSpec spec;
    spec.area.width = spec.area.depth = 100;
    GrownPlot plot;
    plot.spec = &spec;
    std::vector<Vec2> pts;
    for (int i = 0; i < 10; ++i) {
        for (int j = 0; j < 10; ++j) {
            PlotTree t;
            t.stem.id = i * 10 + j + 1;
            t.stem.base = {-45.0 + 10 * i, 0, -45.0 + 10 * j};
            t.grown.tree = trunk(t.stem.base, 3.0 + (i % 4), [](double) { return 0.15; });
            plot.trees.push_back(std::move(t));
            pts.push_back({-45.0 + 10 * i, -45.0 + 10 * j});
        }
    }
    const auto table = treeTable(plot);
    ASSERT_EQ(table.size(), 100u);
    for (const TreeRecord& r : table) EXPECT_NEAR(r.nearestNeighbour, 10.0, 1e-12);
    EXPECT_EQ(table[7].name, "tree-0008");
    EXPECT_EQ(table[7].species, "species-0");
    const PlotStatistics s = plotStatistics(plot, table);
    EXPECT_NEAR(s.stemsPerHa, 100.0, 1e-9);
    EXPECT_NEAR(s.basalAreaM2PerHa, 100 * kPi * 0.09 / 4, 1e-9);
    EXPECT_NEAR(s.clarkEvans, clarkEvans(pts, spec.area), 1e-12);
    EXPECT_GT(s.clarkEvans, 1.5);  // regular
    EXPECT_NEAR(s.meanNearestNeighbour, 10.0, 1e-12);
    // Heights 3, 4, 5, 6 m over i = 0 … 9: 30 × 3, 30 × 4, 20 × 5, 20 × 6.
    EXPECT_EQ(s.heights.min, 3.0);
    EXPECT_EQ(s.heights.max, 6.0);
    EXPECT_NEAR(s.heights.mean, (90 + 120 + 100 + 120) / 100.0, 1e-12);
    EXPECT_EQ(s.heights.median, 4.0);
    ASSERT_EQ(s.heights.histogram.size(), 4u);  // [0,2) [2,4) [4,6) [6,8)
    EXPECT_EQ(s.heights.histogram[1], 30);
    EXPECT_EQ(s.heights.histogram[2], 50);
    EXPECT_EQ(s.heights.histogram[3], 20);
    EXPECT_EQ(s.perSpecies.at("species-0"), 100);
    EXPECT_NEAR(s.canopyCover, 0.0, 0.01);  // trunks only: 100 · π 0.15² / 10⁴ ≈ 0.7%
}

// One horizontal 2 m × 1 m card over a 10 m × 10 m plot covers 200 of its 10⁴ cells.
TEST(Inventory, CanopyCoverOfOneCard) {
    Tree t;
    Leaf l;
    l.position = {0, 3, 0};
    l.normal = {0, 1, 0};
    l.tangent = {1, 0, 0};
    l.size = 2.0;
    l.aspect = 0.5;
    t.leaves.push_back(l);
    PlotArea area;
    area.width = area.depth = 10;
    EXPECT_NEAR(canopyCover({&t}, area, 0.1), 0.02, 1e-12);
    // A circle of radius 5 (area 78.5 m²): the same card, ≈ 2 / 78.5 of it.
    area.shape = PlotArea::Shape::kCircle;
    area.radius = 5;
    EXPECT_NEAR(canopyCover({&t}, area, 0.1), 2.0 / (kPi * 25), 0.001);
}

// The raster is bounded: 0.1 m cells up to about 40 ha, coarser beyond so that it never holds
// more than 4 × 10⁷ cells (a 10 km square at 0.1 m would be 10¹⁰ cells, 10 GB: a plot of two
// stems ran out of memory in its statistics). The same card on a 10 km square, at the coarser
// cell, still covers its 2 m² of 10⁸ m² to within a cell's rounding.
TEST(Inventory, TheCanopyRasterHasAtMostFortyMillionCells) {
    PlotArea small, large, round;
    small.width = small.depth = 10;
    EXPECT_EQ(canopyCoverCell(small, 0.1), 0.1);
    large.width = large.depth = 10000;
    const double cell = canopyCoverCell(large, 0.1);
    EXPECT_NEAR(cell, 1.5814, 1e-4);
    const double cells = std::ceil(10000 / cell) * std::ceil(10000 / cell);
    EXPECT_LE(cells, kMaxCoverCells);
    EXPECT_GT(cells, 0.999 * kMaxCoverCells);  // no coarser than it must be
    round.shape = PlotArea::Shape::kCircle;
    round.radius = 5000;
    EXPECT_EQ(canopyCoverCell(round, 0.1), cell);
    Tree t;
    Leaf l;
    l.position = {0.3, 3, 0.2};
    l.normal = {0, 1, 0};
    l.tangent = {1, 0, 0};
    l.size = 20.0;
    l.aspect = 0.5;  // 20 m × 10 m
    t.leaves.push_back(l);
    EXPECT_NEAR(canopyCover({&t}, large, 0.1), 200.0 / 1e8, 0.25 * 200.0 / 1e8);
}

TEST(Inventory, HandPlotTableHasEveryTree) {
    PlotSpec spec;
    GrownPlot plot = test::handPlot(spec, {{-5, -5}, {4, -3}, {0, 5}});
    const auto table = treeTable(plot);
    ASSERT_EQ(table.size(), 3u);
    for (size_t k = 0; k < 3; ++k) {
        EXPECT_EQ(table[k].id, static_cast<int32_t>(k + 1));
        EXPECT_DOUBLE_EQ(table[k].base.y,
                         plot.layout.terrain.height(table[k].base.x, table[k].base.z));
        EXPECT_NEAR(table[k].height, 5.0 + k % 3 + 0.1, 0.5);
        EXPECT_GT(table[k].dbh, 0.1);
        EXPECT_GT(table[k].crownBase, 2.0);
    }
    const PlotStatistics s = plotStatistics(plot, table);
    EXPECT_NEAR(s.stemsPerHa, 3 / 400.0 * 1e4, 1e-9);
    EXPECT_GT(s.canopyCover, 0.0);
    EXPECT_LT(s.canopyCover, 0.5);
}

}  // namespace
}  // namespace sylva
