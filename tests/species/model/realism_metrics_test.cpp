// Realism measures (species/model/realism_metrics.h) on hand-built trees with known answers.
#include "species/model/realism_metrics.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/rng.h"
#include "species/model/tree_stats.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

// A vertical trunk of `n` unit segments from the origin.
Tree trunk(int n, double radius = 0.1) {
    Tree t;
    int32_t p = addNode(t, -1, {0, 0, 0}, radius);
    for (int i = 1; i <= n; ++i) p = addNode(t, p, {0, double(i), 0}, radius);
    return t;
}

TEST(RealismMetrics, GroundLowestShootAndShareBelow) {
    Tree t = trunk(3);                                // y = 0, 1, 2, 3
    addNode(t, 1, {1, -0.5, 0}, 0.02, 1);             // a shoot dipping underground
    addNode(t, 0, {0, -1.5, 0}, 0.05, 0, kRootPart);  // roots do not count
    const TreeStats s = computeStats(t);
    EXPECT_DOUBLE_EQ(s.lowestShootY, -0.5);
    EXPECT_DOUBLE_EQ(s.belowGroundFraction, 1.0 / 4.0);  // 4 shoot nodes besides the root
    const TreeStats above = computeStats(trunk(2));
    EXPECT_DOUBLE_EQ(above.lowestShootY, 0.0);
    EXPECT_DOUBLE_EQ(above.belowGroundFraction, 0.0);
}

TEST(RealismMetrics, StemsLeavingTheBase) {
    EXPECT_EQ(computeStats(trunk(3)).stemsAtBase, 1);
    // Three stems from the root (a clump), one forking higher up (not a stem at the base).
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1);
    for (double x : {-1.0, 0.0, 1.0}) {
        const int32_t a = addNode(t, 0, {x * 0.5, 1, 0}, 0.05);
        addNode(t, a, {x, 2, 0}, 0.03, 1);
        addNode(t, a, {x, 2, 1}, 0.03, 1);
    }
    EXPECT_EQ(computeStats(t).stemsAtBase, 3);
    // A first node inside the base ball (r = 0.1 m): the stem leaves from there, counted once.
    Tree u;
    addNode(u, -1, {0, 0, 0}, 0.1);
    const int32_t inside = addNode(u, 0, {0, 0.05, 0}, 0.1);
    addNode(u, inside, {0, 1, 0}, 0.08);
    addNode(u, inside, {0.5, 1, 0}, 0.05, 1);
    EXPECT_EQ(computeStats(u).stemsAtBase, 2);
    // A twig hanging from a limb down past the foot of the trunk, into the base ball and out
    // again: still one stem.
    Tree v = trunk(3);
    const int32_t limb = addNode(v, 2, {0.5, 1.5, 0}, 0.03, 1);
    const int32_t low = addNode(v, limb, {0.3, 0.2, 0}, 0.01, 2);
    const int32_t in = addNode(v, low, {0.05, 0.02, 0}, 0.005, 2);  // inside r = 0.1 m
    addNode(v, in, {-0.3, 0.01, 0}, 0.004, 2);                      // and out
    EXPECT_EQ(computeStats(v).stemsAtBase, 1);
}

TEST(RealismMetrics, LeaderLeanFromTheTopFifthOfTheOrderZeroAxis) {
    EXPECT_DOUBLE_EQ(computeStats(trunk(5)).leaderLeanDeg, 0.0);
    // Straight up 4 m, then the last 1 m (the top fifth of 5 m) leans 45°.
    Tree t = trunk(4);
    addNode(t, 4, {std::sqrt(0.5), 4 + std::sqrt(0.5), 0}, 0.05);
    EXPECT_NEAR(computeStats(t).leaderLeanDeg, 45.0, 1e-9);
    // The order-0 axis ends at 1 m in a tree 4 m tall: a fork, no leader.
    Tree d = trunk(1);
    addNode(d, 1, {-1, 4, 0}, 0.05, 1);
    addNode(d, 1, {1, 4, 0}, 0.05, 1);
    EXPECT_TRUE(std::isnan(computeStats(d).leaderLeanDeg));
}

TEST(RealismMetrics, WoodDistanceToTaperedCapsules) {
    const Tree t = trunk(2, 0.1);  // a cylinder of radius 0.1 from y = 0 to 2
    const std::vector<double> d =
        woodDistances(t, {{0.5, 1, 0}, {0.05, 1, 0}, {0, 2.5, 0}, {0, -0.3, 0}, {3, 1, 4}});
    EXPECT_NEAR(d[0], 0.4, 1e-12);
    EXPECT_EQ(d[1], 0.0);           // inside the wood
    EXPECT_NEAR(d[2], 0.4, 1e-12);  // beyond the top: the end sphere
    EXPECT_NEAR(d[3], 0.2, 1e-12);
    EXPECT_NEAR(d[4], 5.0 - 0.1, 1e-12);  // far outside the grid
    // Against brute force on a random tree.
    Tree r;
    Rng rng(3);
    addNode(r, -1, {0, 0, 0}, 0.2);
    for (int i = 1; i < 300; ++i) {
        const int32_t parent = static_cast<int32_t>(rng.uniform(0, i - 1e-9));
        const Vec3 p = r.nodes[parent].position;
        addNode(r, parent, p + Vec3{rng.uniform(-1, 1), rng.uniform(0, 1), rng.uniform(-1, 1)},
                rng.uniform(0.01, 0.2));
    }
    std::vector<Vec3> q;
    for (int i = 0; i < 200; ++i) {
        q.push_back({rng.uniform(-8, 8), rng.uniform(-2, 30), rng.uniform(-8, 8)});
    }
    const std::vector<double> fast = woodDistances(r, q);
    for (size_t k = 0; k < q.size(); ++k) {
        double best = 1e300;
        for (size_t i = 1; i < r.nodes.size(); ++i) {
            const SkeletonNode& n = r.nodes[i];
            const SkeletonNode& p = r.nodes[n.parent];
            const Vec3 ab = n.position - p.position;
            const double t2 = std::clamp(dot(q[k] - p.position, ab) / length2(ab), 0.0, 1.0);
            const double rad = p.radius + (n.radius - p.radius) * t2;
            best = std::min(best, std::max(0.0, distance(q[k], p.position + ab * t2) - rad));
        }
        EXPECT_NEAR(fast[k], best, 1e-12) << k;
    }
    // A node near each point bounds the search and changes no result, to the bit: the point's
    // own nearest node, a random one (a loose bound), none (−1, the root), or out of range.
    std::vector<int32_t> near(q.size());
    std::vector<Vec3> onWood;
    for (size_t k = 0; k < q.size(); ++k) {
        near[k] = static_cast<int32_t>(k % 5 == 0   ? -1
                                       : k % 5 == 1 ? 0
                                       : k % 5 == 2 ? 100000
                                                    : 1 + k % 299);
    }
    EXPECT_EQ(woodDistances(r, q, near), fast);
    // Points beside their carriers (as leaves are): the box search, checked against the rings.
    std::vector<int32_t> carriers;
    for (int i = 1; i < 300; ++i) {
        onWood.push_back(r.nodes[i].position + Vec3{rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3),
                                                    rng.uniform(-0.3, 0.3)});
        carriers.push_back(i);
    }
    EXPECT_EQ(woodDistances(r, onWood, carriers), woodDistances(r, onWood));
}

TEST(RealismMetrics, LeafWoodDistanceIsThe95thPercentileFromTheCardsNearEdge) {
    Tree t = trunk(2, 0.1);
    EXPECT_TRUE(std::isnan(computeStats(t).leafWoodDistanceP95));  // no leaves
    // 20 cards whose near edges lie 0, 0.01, …, 0.19 m from the bark (along +x, tangent +x).
    for (int k = 0; k < 20; ++k) {
        Leaf l;
        l.size = 0.1;
        l.tangent = {1, 0, 0};
        l.position = {0.1 + 0.01 * k + 0.05, 1, 0};
        t.leaves.push_back(l);
    }
    // Type-7 quantile at 0.95 of 0, 0.01, …, 0.19: 0.18 + 0.05 · 0.01.
    EXPECT_NEAR(computeStats(t).leafWoodDistanceP95, 0.1805, 1e-12);
}

}  // namespace
}  // namespace sylva
