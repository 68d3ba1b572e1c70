// Shape metrics (species/model/tree_metrics.cpp) on hand-built skeletons with known answers.
#include "species/model/tree_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/rng.h"
#include "pipeline/formats/stats_json.h"
#include "species/model/leaf_shape.h"
#include "species/model/tree_stats.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;
constexpr double kPi = 3.14159265358979323846;

// Symmetric binary tree: a vertical trunk of length 1 from the root, then `depth` levels of
// forks; each child turns ±angle from its parent's direction in the vertical plane at azimuth
// `azimuth` (radians from +x towards +z) and is 0.6 times as long. Radii follow
// r_parent = (2 r_childⁿ)^(1/n) from tips of radius 0.01.
struct Built {
    Tree tree;
    double tipLength = 0;
};

Built symmetricTree(int depth, double angleDeg, double n, double azimuth = 0) {
    Built b;
    const Vec3 h{std::cos(azimuth), 0, std::sin(azimuth)};
    const double a = angleDeg * kPi / 180.0;
    // Radius at level l (0 = trunk, depth = tips): r_l = 0.01 · 2^((depth − l)/n).
    auto radius = [&](int level) { return 0.01 * std::pow(2.0, (depth - level) / n); };
    addNode(b.tree, -1, {0, 0, 0}, radius(0));
    int32_t trunkTop = addNode(b.tree, 0, {0, 1, 0}, radius(0));
    // dir as (horizontal, vertical) components in the plane.
    struct Item {
        int32_t node;
        double dh, dv, len;
        int level;
    };
    std::vector<Item> stack{{trunkTop, 0, 1, 1, 0}};
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        if (it.level == depth) continue;
        for (double sgn : {-1.0, 1.0}) {
            double c = std::cos(sgn * a), s = std::sin(sgn * a);
            double dh = it.dh * c + it.dv * s, dv = -it.dh * s + it.dv * c;
            double len = it.len * 0.6;
            Vec3 p = b.tree.nodes[it.node].position + (h * dh + Vec3{0, dv, 0}) * len;
            int32_t c2 = addNode(b.tree, it.node, p, radius(it.level + 1), it.level + 1);
            stack.push_back({c2, dh, dv, len, it.level + 1});
            b.tipLength = len;
        }
    }
    return b;
}

TEST(TreeMetrics, SymmetricBinaryTree) {
    for (int depth : {1, 3, 5}) {
        Built b = symmetricTree(depth, 35.0, 2.5);
        TreeStats s = computeStats(b.tree);
        EXPECT_EQ(s.strahlerOrder, depth + 1);
        ASSERT_EQ(s.strahlerBranches.size(), static_cast<size_t>(depth + 1));
        for (int k = 1; k <= depth + 1; ++k) {
            EXPECT_EQ(s.strahlerBranches[k - 1], int64_t{1} << (depth + 1 - k)) << k;
        }
        ASSERT_EQ(s.bifurcationRatios.size(), static_cast<size_t>(depth));
        for (double r : s.bifurcationRatios) EXPECT_EQ(r, 2.0);
        EXPECT_EQ(s.bifurcationRatioMean, 2.0);
        // Order-1 branches are the tip segments; the single top-order branch is the trunk.
        EXPECT_NEAR(s.strahlerBranchLength.front(), b.tipLength, 1e-12);
        EXPECT_NEAR(s.strahlerBranchLength.back(), 1.0, 1e-12);
        EXPECT_EQ(s.forks, (int64_t{1} << depth) - 1);
        EXPECT_NEAR(s.forkAngleMean, 35.0, 1e-9);
        EXPECT_NEAR(s.forkAngleStd, 0.0, 1e-6);
        EXPECT_EQ(s.radiusExponentForks, s.forks);
        EXPECT_NEAR(s.radiusExponentMedian, 2.5, 1e-9);
        EXPECT_NEAR(s.radiusExponentIqr, 0.0, 1e-9);
        // Crown: base at the trunk top, symmetric about the trunk axis, flat in z.
        EXPECT_EQ(s.crownBaseHeight, 1.0);
        EXPECT_NEAR(s.crownHeight, s.height - 1.0, 1e-12);
        EXPECT_NEAR(s.crownAsymmetry, 0.0, 1e-12);
        EXPECT_NEAR(s.crownWidthMajor, s.crownWidth, 1e-12);
        EXPECT_NEAR(s.crownDepth, 0.0, 1e-12);
        EXPECT_EQ(s.leaves, 0);
        EXPECT_EQ(s.leafArea, 0.0);
    }
}

TEST(TreeMetrics, ForkAnglesAndExponentTrackTheBuiltValues) {
    for (double angle : {10.0, 45.0, 80.0}) {
        for (double n : {1.0, 2.0, 3.0, 5.5}) {
            TreeStats s = computeStats(symmetricTree(3, angle, n).tree);
            EXPECT_NEAR(s.forkAngleMean, angle, 1e-9);
            EXPECT_NEAR(s.radiusExponentMedian, n, 1e-9);
        }
    }
}

TEST(TreeMetrics, CrownAxesDoNotDependOnAzimuth) {
    TreeStats a = computeStats(symmetricTree(4, 30.0, 2.0, 0.0).tree);
    TreeStats b = computeStats(symmetricTree(4, 30.0, 2.0, 0.7).tree);
    EXPECT_GT(a.crownWidthMajor, 1.0);
    EXPECT_NEAR(b.crownWidthMajor, a.crownWidthMajor, 1e-9);
    EXPECT_NEAR(b.crownDepth, 0.0, 1e-9);
    EXPECT_LT(b.crownWidth, a.crownWidth);  // the axis-aligned extent does depend on it
}

TEST(TreeMetrics, StraightChainHasTortuosityOneAndNoCrown) {
    Tree t;
    int32_t p = addNode(t, -1, {0, 0, 0});
    for (int i = 1; i <= 5; ++i) p = addNode(t, p, {0, 0.5 * i, 0});
    TreeStats s = computeStats(t);
    EXPECT_EQ(s.tortuosityMean, 1.0);
    EXPECT_EQ(s.tortuosityMax, 1.0);
    EXPECT_EQ(s.strahlerOrder, 1);
    EXPECT_EQ(s.strahlerBranches, std::vector<int64_t>{1});
    EXPECT_NEAR(s.strahlerBranchLength[0], 2.5, 1e-12);
    EXPECT_TRUE(s.bifurcationRatios.empty());
    EXPECT_TRUE(std::isnan(s.bifurcationRatioMean));
    EXPECT_EQ(s.forks, 0);
    EXPECT_TRUE(std::isnan(s.forkAngleMean));
    EXPECT_TRUE(std::isnan(s.radiusExponentMedian));
    EXPECT_TRUE(std::isnan(s.crownHeight));
    EXPECT_TRUE(std::isnan(s.crownAsymmetry));
    // Undefined metrics are JSON null, defined ones numbers.
    nlohmann::json j = toJson(s);
    EXPECT_TRUE(j.at("crown_asymmetry_m").is_null());
    EXPECT_TRUE(j.at("bifurcation_ratio_mean").is_null());
    EXPECT_EQ(j.at("tortuosity_mean"), 1.0);
    EXPECT_EQ(j.at("strahler_order"), 1);
    EXPECT_EQ(j.dump().find("NaN"), std::string::npos);
}

TEST(TreeMetrics, ZigZagTortuosity) {
    // Root → (1,1,0) → (0,2,0) → (1,3,0) → (0,4,0): path 4√2 over chord 4. A second tip
    // (0,3,0) off (0,2,0): path 2√2 + 1 over chord 3.
    Tree t;
    addNode(t, -1, {0, 0, 0});
    addNode(t, 0, {1, 1, 0});
    int32_t mid = addNode(t, 1, {0, 2, 0});
    addNode(t, mid, {1, 3, 0});
    addNode(t, 3, {0, 4, 0});
    addNode(t, mid, {0, 3, 0});
    TreeStats s = computeStats(t);
    const double t1 = std::sqrt(2.0), t2 = (2 * std::sqrt(2.0) + 1) / 3;
    EXPECT_NEAR(s.tortuosityMax, t1, 1e-12);
    EXPECT_NEAR(s.tortuosityMean, 0.5 * (t1 + t2), 1e-12);
    // The fork (0,2,0) is reached along (−1,1,0); its children leave along (1,1,0) (90°) and
    // (0,1,0) (45°).
    EXPECT_EQ(s.forks, 1);
    EXPECT_NEAR(s.forkAngleMean, 67.5, 1e-9);
    EXPECT_NEAR(s.forkAngleStd, 22.5, 1e-9);
}

TEST(TreeMetrics, LopsidedCrownAsymmetry) {
    // Trunk to (0,2,0), fork into two twigs 1 m either side of x = dx, shifted by dz; a root
    // node below ground that must not count. Crown = fork + two twigs: centroid offset
    // (2/3)(dx, dz) from the vertical trunk axis.
    const double dx = 0.6, dz = -0.45;
    Tree t;
    addNode(t, -1, {0, 0, 0});
    addNode(t, 0, {0, -1, 0}, 0.01, 0, kRootPart);
    int32_t fork = addNode(t, 0, {0, 2, 0});
    addNode(t, fork, {1 + dx, 3, dz});
    addNode(t, fork, {-1 + dx, 3.5, dz});
    TreeStats s = computeStats(t);
    EXPECT_NEAR(s.crownAsymmetry, 2.0 / 3.0 * std::hypot(dx, dz), 1e-12);
    EXPECT_EQ(s.crownBaseHeight, 2.0);
    EXPECT_EQ(s.crownHeight, 1.5);
    EXPECT_EQ(s.strahlerOrder, 2);  // the root-system node is not part of the shoot
    EXPECT_EQ(s.strahlerBranches, (std::vector<int64_t>{2, 1}));
    // A trunk leaning towards the crown centroid: asymmetry is measured from the leaning axis.
    Tree lean;
    addNode(lean, -1, {0, 0, 0});
    int32_t f2 = addNode(lean, 0, {1, 2, 0});
    addNode(lean, f2, {0, 3, 1});
    addNode(lean, f2, {2, 3, -1});
    TreeStats l = computeStats(lean);
    // Centroid (1, 8/3, 0); axis direction (1,2,0)/√5: offset = |c × a| = 2/(3√5).
    EXPECT_NEAR(l.crownAsymmetry, 2.0 / (3.0 * std::sqrt(5.0)), 1e-12);
}

TEST(TreeMetrics, LeafCountAndArea) {
    Tree t;
    addNode(t, -1, {0, 0, 0});
    Leaf a;
    a.size = 0.2;
    a.aspect = 0.5;
    Leaf b;
    b.size = 0.1;
    b.aspect = 1.0;
    t.leaves = {a, b, a};
    TreeStats s = computeStats(t);
    EXPECT_EQ(s.leaves, 3);
    EXPECT_NEAR(s.leafArea, 0.02 + 0.01 + 0.02, 1e-15);
    EXPECT_EQ(toJson(s).at("leaves"), 3);
    // Shaped leaves count their outline's area, not the card's: a frond covers 0.166 of its
    // card (species/model/leaf_shape.h), a compound leaf 0.266.
    t.leaves[0].shape = LeafShape::kFrond;
    t.leaves[1].shape = LeafShape::kCompound;
    s = computeStats(t);
    EXPECT_NEAR(s.leafArea,
                0.02 * leafOutline(LeafShape::kFrond).area +
                    0.01 * leafOutline(LeafShape::kCompound).area + 0.02,
                1e-15);
    EXPECT_NEAR(s.leafArea, 0.02 * 0.1657 + 0.01 * 0.2656 + 0.02, 1e-5);
}

TEST(TreeMetrics, RadiusExponentBisection) {
    // Three equal children: r_p = 3^(1/n) r_c.
    for (double n : {0.75, 2.0, 4.2}) {
        EXPECT_NEAR(radiusExponent(std::pow(3.0, 1.0 / n), {1, 1, 1}), n, 1e-9);
    }
    // Unequal children with a known exponent 2: 5² = 3² + 4².
    EXPECT_NEAR(radiusExponent(5, {3, 4}), 2.0, 1e-9);
    // Ill-defined: one child, a child as thick as the parent, zero radii.
    EXPECT_TRUE(std::isnan(radiusExponent(1, {0.5})));
    EXPECT_TRUE(std::isnan(radiusExponent(1, {1, 0.5})));
    EXPECT_TRUE(std::isnan(radiusExponent(0, {0.5, 0.5})));
    EXPECT_TRUE(std::isnan(radiusExponent(1, {0, 0.5})));
    // Roots outside [0.5, 6] clamp to the ends.
    EXPECT_EQ(radiusExponent(1, {0.9, 0.9}), 6.0);
    EXPECT_EQ(radiusExponent(1, {0.1, 0.1}), 0.5);
}

// The exponent skips the bisection's evaluations away from the root (decided by a Newton
// estimate confirmed on both sides); its result must be the plain bisection's to the bit.
TEST(TreeMetrics, RadiusExponentIsThePlainBisectionToTheBit) {
    auto plain = [](double rp, const std::vector<double>& rc) {
        auto f = [&](double n) {
            double sum = 0;
            for (double r : rc) sum += std::pow(r / rp, n);
            return sum - 1.0;
        };
        double lo = 0.5, hi = 6.0;
        if (f(lo) <= 0) return lo;
        if (f(hi) >= 0) return hi;
        for (int it = 0; it < 100 && hi - lo > 1e-13; ++it) {
            const double mid = 0.5 * (lo + hi);
            (f(mid) > 0 ? lo : hi) = mid;
        }
        return 0.5 * (lo + hi);
    };
    Rng rng(7);
    int inside = 0;
    for (int k = 0; k < 20000; ++k) {
        const int children = 2 + k % 9;  // 2 … 10: past the fast path's 8 too
        const double rp = rng.uniform(0.001, 1.0);
        std::vector<double> rc;
        for (int c = 0; c < children; ++c) {
            // Mostly plausible forks; every tenth with a child at a hair below the parent.
            rc.push_back(k % 10 == 0 && c == 0 ? rp * (1 - 1e-12) : rp * rng.uniform(0.02, 0.99));
        }
        const double e = radiusExponent(rp, rc);
        ASSERT_EQ(e, plain(rp, rc)) << k;
        inside += e > 0.5 && e < 6.0;
    }
    EXPECT_GT(inside, 10000);  // most of them solved, not clamped to an end
}

TEST(TreeMetrics, QuantileInterpolates) {
    EXPECT_EQ(quantile({4, 1, 3, 2}, 0.5), 2.5);
    EXPECT_EQ(quantile({4, 1, 3, 2}, 0.25), 1.75);
    EXPECT_EQ(quantile({4, 1, 3, 2}, 0.75), 3.25);
    EXPECT_EQ(quantile({7}, 0.25), 7.0);
    EXPECT_TRUE(std::isnan(quantile({}, 0.5)));
}

}  // namespace
}  // namespace sylva
