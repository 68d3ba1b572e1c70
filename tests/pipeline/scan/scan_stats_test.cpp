// The scan-statistics block: counts, class shares, multiple returns, density and the wood
// surface hit per tree, on hand-made points with known answers.
#include "pipeline/scan/scan_stats.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

ScanPoint point(uint64_t pulse, uint8_t ret, uint8_t of, uint8_t cls, int32_t tree = 0,
                int32_t node = -1, uint16_t channel = 0, Vec3 at = {0.1, 0.5, 0}) {
    ScanPoint p;
    p.x = at.x;
    p.y = at.y;
    p.z = at.z;
    p.pulse = pulse;
    p.returnNumber = ret;
    p.numberOfReturns = of;
    p.classification = cls;
    p.channel = static_cast<uint8_t>(channel % 4);    // as the scanner: the station modulo 4
    p.sourceId = static_cast<uint16_t>(channel + 1);  // the station, counted from 1
    p.label.treeId = tree;
    p.label.nodeId = node;
    return p;
}

// A trunk of two segments (1 m at r 0.1, 1 m at r 0.1 → 0.05) and a root below: the first
// segment's area is 2π·0.1·1, the second's 2π·0.075·1; roots do not count.
Tree twoSegments() {
    Tree t;
    const int32_t r = addNode(t, -1, {0, 0, 0}, 0.1);
    const int32_t a = addNode(t, r, {0, 1, 0}, 0.1);
    addNode(t, a, {0, 2, 0}, 0.05);
    addNode(t, r, {0, -1, 0}, 0.05, 0, kRootPart);
    return t;
}

TEST(ScanStats, CountsSharesAndOcclusionHaveKnownAnswers) {
    ScanStats s(0, 50.0, 4);
    s.addTree(7, twoSegments());
    // Pulse 0: two returns (stem node 1, then terrain); pulse 1: one (stem node 1 again);
    // pulse 2: one leaf return; a point of an unknown tree is ignored for occlusion.
    s.addPoints({point(0, 1, 2, kForStem, 7, 1), point(0, 2, 2, kForTerrain)});
    s.addPoints({point(1, 1, 1, kForStem, 7, 1), point(2, 1, 1, kForLiveBranches, 9, 4)});
    const nlohmann::json j = s.json(10);
    EXPECT_EQ(j["pulses"], 10);
    EXPECT_EQ(j["points"], 4);
    EXPECT_EQ(j["pulses_with_returns"], 3);
    EXPECT_NEAR(j["multiple_return_share"].get<double>(), 1.0 / 3, 1e-12);
    EXPECT_NEAR(j["points_per_m2"].get<double>(), 4 / 50.0, 1e-12);
    EXPECT_FALSE(j.contains("points_per_station"));
    EXPECT_NEAR(j["class_fraction"]["stem"].get<double>(), 0.5, 1e-12);
    EXPECT_NEAR(j["class_fraction"]["terrain"].get<double>(), 0.25, 1e-12);
    EXPECT_NEAR(j["class_fraction"]["live_branches"].get<double>(), 0.25, 1e-12);
    EXPECT_EQ(j["class_fraction"]["woody_branches"].get<double>(), 0.0);
    // Both stem points lie on the first segment's +x side: one sector of eight.
    const double first = 2 * kPi * 0.1, second = 2 * kPi * 0.075;
    EXPECT_NEAR(s.woodSurfaceHit(7), first / 8 / (first + second), 1e-12);
    EXPECT_EQ(s.woodSurfaceHit(9), 0.0);  // not a tree of the scene
    ASSERT_EQ(j["trees"].size(), 1u);
    EXPECT_EQ(j["trees"][0]["tree"], 7);
    EXPECT_NEAR(j["wood_surface_hit_mean"].get<double>(), first / 8 / (first + second), 1e-12);

    // Points all around both segments (eight directions, at mid height): all wood hit; the
    // near half seen from one side (the +x half: four sectors): half of it.
    ScanStats all(0, 1, 1), half(0, 1, 1);
    all.addTree(7, twoSegments());
    half.addTree(7, twoSegments());
    for (int k = 0; k < 8; ++k) {
        const double a = (k + 0.5) * kPi / 4;
        for (int32_t node : {1, 2}) {
            const Vec3 at{0.1 * std::cos(a), node - 0.5, 0.1 * std::sin(a)};
            all.addPoints({point(k, 1, 1, kForStem, 7, node, 0, at)});
            if (at.x > 0) half.addPoints({point(k, 1, 1, kForStem, 7, node, 0, at)});
        }
    }
    EXPECT_NEAR(all.woodSurfaceHit(7), 1.0, 1e-12);
    EXPECT_NEAR(half.woodSurfaceHit(7), 0.5, 1e-12);
}

TEST(ScanStats, TlsCountsPointsPerStation) {
    ScanStats s(2, 0.0, 1);
    s.addPoints({point(0, 1, 1, kForTerrain, 0, -1, 0), point(1, 1, 1, kForTerrain, 0, -1, 1),
                 point(2, 1, 1, kForTerrain, 0, -1, 1)});
    const nlohmann::json j = s.json(3);
    EXPECT_EQ(j["points_per_station"], nlohmann::json({1, 2}));
    EXPECT_FALSE(j.contains("points_per_m2"));
    EXPECT_EQ(j["multiple_return_share"].get<double>(), 0.0);
}

// A plot's density counts the points above its area, not the margin's (scanPlot sets the area).
TEST(ScanStats, DensityCountsOnlyPointsAboveTheArea) {
    ScanStats s(0, 100.0, 4);
    s.setArea([](double x, double z) { return std::abs(x) <= 5 && std::abs(z) <= 5; });
    s.addPoints({point(0, 1, 1, kForTerrain, 0, -1, 0, {0, 0, 0}),
                 point(1, 1, 1, kForTerrain, 0, -1, 0, {4.9, 0, -4.9}),
                 point(2, 1, 1, kForStem, 0, -1, 0, {-5, 3, 5}),
                 point(3, 1, 1, kForTerrain, 0, -1, 0, {5.5, 0, 0}),
                 point(4, 1, 1, kForLiveBranches, 0, -1, 0, {0, 20, -7})});
    const nlohmann::json j = s.json(5);
    EXPECT_EQ(j["points"].get<uint64_t>(), 5u);
    EXPECT_NEAR(j["points_per_m2"].get<double>(), 3 / 100.0, 1e-12);
}

// More than four stations: each keeps its own count (the LAS channel repeats modulo 4, the
// point source ID does not).
TEST(ScanStats, TlsCountsEveryStationBeyondFour) {
    ScanStats s(6, 0.0, 1);
    std::vector<ScanPoint> points;
    for (uint16_t station = 0; station < 6; ++station) {
        for (int k = 0; k <= station; ++k) {
            points.push_back(point(points.size(), 1, 1, kForTerrain, 0, -1, station));
        }
    }
    s.addPoints(points);
    const nlohmann::json j = s.json(points.size());
    EXPECT_EQ(j["points_per_station"], nlohmann::json({1, 2, 3, 4, 5, 6}));
}

}  // namespace
}  // namespace sylva
