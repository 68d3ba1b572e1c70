// Reference distributions of a skeleton (species/model/reference_metrics.cpp) on hand-built
// trees with known radii, angles and lengths.
#include "species/model/reference_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "species/model/tree_metrics.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;
constexpr double kPi = 3.14159265358979323846;

Vec3 dirDeg(double fromVerticalDeg) {  // in the x–y plane, tilted towards +x
    const double a = fromVerticalDeg * kPi / 180.0;
    return {std::sin(a), std::cos(a), 0};
}

// A Y: a 1 m vertical trunk (radius 0.1) forking into a continuing order-0 limb tilted 30°
// (1 m, radius 0.08) and an order-1 branch tilted 45° the other way (0.5 m, radius `lateral`).
Tree yFork(double lateral) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1);
    const int32_t fork = addNode(t, 0, {0, 1, 0}, 0.1);
    addNode(t, fork, Vec3{0, 1, 0} + dirDeg(30), 0.08, 0);
    addNode(t, fork, Vec3{0, 1, 0} + dirDeg(-45) * 0.5, lateral, 1);
    return t;
}

TEST(ReferenceMetrics, NamesInEnumOrder) {
    EXPECT_STREQ(kReferenceDistributionNames[kRadiusRatio], "radius_ratio");
    EXPECT_STREQ(kReferenceDistributionNames[kRadiusExponent], "radius_exponent");
    EXPECT_STREQ(kReferenceDistributionNames[kBranchAngle], "branch_angle_deg");
    EXPECT_STREQ(kReferenceDistributionNames[kTipPathRatio], "tip_path_ratio");
    EXPECT_STREQ(kReferenceDistributionNames[kBranchLengthOrder1], "branch_length_order1");
    EXPECT_STREQ(kReferenceDistributionNames[kBranchLengthOrder3], "branch_length_order3");
    EXPECT_STREQ(kReferenceDistributionNames[kTipHeightRatio], "tip_height_ratio");
}

TEST(ReferenceMetrics, YForkWithKnownRadiiAnglesAndLengths) {
    // 0.1² = 0.08² + 0.06²: the exponent is exactly 2; the lateral's ratio 0.6.
    const ReferenceValues v = referenceValues(yFork(0.06));
    ASSERT_EQ(v[kRadiusRatio].size(), 1u);
    EXPECT_NEAR(v[kRadiusRatio][0], 0.6, 1e-12);
    ASSERT_EQ(v[kRadiusExponent].size(), 1u);
    EXPECT_NEAR(v[kRadiusExponent][0], 2.0, 1e-9);
    // The stem arrives vertical; the branch leaves at 45°.
    ASSERT_EQ(v[kBranchAngle].size(), 1u);
    EXPECT_NEAR(v[kBranchAngle][0], 45.0, 1e-9);
    // Height 1 + cos 30°; tips at path 2 (limb) and 1.5 (branch), in node order.
    const double h = 1 + std::cos(30 * kPi / 180);
    ASSERT_EQ(v[kTipPathRatio].size(), 2u);
    EXPECT_NEAR(v[kTipPathRatio][0], 2 / h, 1e-12);
    EXPECT_NEAR(v[kTipPathRatio][1], 1.5 / h, 1e-12);
    // Their heights: the limb's tip is the top (1), the branch's 1 + 0.5 cos 45° up.
    ASSERT_EQ(v[kTipHeightRatio].size(), 2u);
    EXPECT_NEAR(v[kTipHeightRatio][0], 1.0, 1e-12);
    EXPECT_NEAR(v[kTipHeightRatio][1], (1 + 0.5 * std::cos(45 * kPi / 180)) / h, 1e-12);
    ASSERT_EQ(v[kBranchLengthOrder1].size(), 1u);
    EXPECT_NEAR(v[kBranchLengthOrder1][0], 0.5 / h, 1e-12);
    EXPECT_TRUE(v[kBranchLengthOrder2].empty());
    EXPECT_TRUE(v[kBranchLengthOrder3].empty());
}

TEST(ReferenceMetrics, ForksWithALateralAtTheQsmCapAreLeftOutOfTheRadiusDistributions) {
    // 0.095 / 0.1 = 0.95 ≥ 0.949: as TreeQSM would have capped it, the fork is left out; the
    // other distributions keep the branch.
    ReferenceValues capped = referenceValues(yFork(0.095));
    EXPECT_TRUE(capped[kRadiusRatio].empty());
    EXPECT_TRUE(capped[kRadiusExponent].empty());
    EXPECT_EQ(capped[kBranchAngle].size(), 1u);
    EXPECT_EQ(capped[kBranchLengthOrder1].size(), 1u);
    // Just below the cap it counts.
    ReferenceValues below = referenceValues(yFork(0.0948));
    ASSERT_EQ(below[kRadiusRatio].size(), 1u);
    EXPECT_NEAR(below[kRadiusRatio][0], 0.948, 1e-12);
    // A child of zero radius makes the fork's radii undefined.
    EXPECT_TRUE(referenceValues(yFork(0.0))[kRadiusRatio].empty());
    // A continuing child thicker than its parent: no exponent (as radiusExponent), but the
    // lateral's ratio is kept.
    Tree thick = yFork(0.06);
    thick.nodes[2].radius = 0.12;
    ReferenceValues t = referenceValues(thick);
    EXPECT_EQ(t[kRadiusRatio].size(), 1u);
    EXPECT_TRUE(t[kRadiusExponent].empty());
}

TEST(ReferenceMetrics, StraightStemWithTwoLateralsAtKnownAnglesAndLengths) {
    // A vertical stem of 4 m (nodes every metre); at 1 m an order-1 branch at 60° from the stem,
    // two straight segments of 0.5 m; at 2 m a horizontal one (90°) of 2 m, with an order-2
    // twig of 0.3 m at its middle and an order-3 twig of 0.2 m on that.
    Tree t;
    int32_t s = addNode(t, -1, {0, 0, 0}, 0.2);
    std::vector<int32_t> stem{s};
    for (int k = 1; k <= 4; ++k) stem.push_back(addNode(t, stem.back(), {0, 1.0 * k, 0}, 0.1));
    const Vec3 b1 = t.nodes[stem[1]].position;
    int32_t a = addNode(t, stem[1], b1 + dirDeg(60) * 0.5, 0.02, 1);
    addNode(t, a, b1 + dirDeg(60) * 1.0, 0.015, 1);
    const Vec3 b2 = t.nodes[stem[2]].position;
    int32_t m = addNode(t, stem[2], b2 + Vec3{-1, 0, 0}, 0.03, 1);
    addNode(t, m, b2 + Vec3{-2, 0, 0}, 0.02, 1);
    int32_t tw = addNode(t, m, t.nodes[m].position + Vec3{0, 0, 0.3}, 0.01, 2);
    addNode(t, tw, t.nodes[tw].position + Vec3{0, 0.2, 0}, 0.005, 3);

    const ReferenceValues v = referenceValues(t);
    ASSERT_EQ(v[kBranchAngle].size(), 2u);
    EXPECT_NEAR(v[kBranchAngle][0], 60.0, 1e-9);
    EXPECT_NEAR(v[kBranchAngle][1], 90.0, 1e-9);
    // Height 4: branch lengths 1 and 2 (order 1) and 0.5 (order 2): the order-3 node is the
    // order-2 twig's only child, so it continues the twig (a branch runs on to a tip, as
    // TreeQSM's do) rather than beginning a branch of order 3.
    ASSERT_EQ(v[kBranchLengthOrder1].size(), 2u);
    EXPECT_NEAR(v[kBranchLengthOrder1][0], 1.0 / 4, 1e-12);
    EXPECT_NEAR(v[kBranchLengthOrder1][1], 2.0 / 4, 1e-12);
    ASSERT_EQ(v[kBranchLengthOrder2].size(), 1u);
    EXPECT_NEAR(v[kBranchLengthOrder2][0], 0.5 / 4, 1e-12);
    EXPECT_TRUE(v[kBranchLengthOrder3].empty());
    // Tips in node order: stem top (4), first branch (1 + 1), second (2 + 2), the order-3 twig
    // (2 + 1 + 0.3 + 0.2).
    ASSERT_EQ(v[kTipPathRatio].size(), 4u);
    EXPECT_NEAR(v[kTipPathRatio][0], 4.0 / 4, 1e-12);
    EXPECT_NEAR(v[kTipPathRatio][1], 2.0 / 4, 1e-12);
    EXPECT_NEAR(v[kTipPathRatio][2], 4.0 / 4, 1e-12);
    EXPECT_NEAR(v[kTipPathRatio][3], 3.5 / 4, 1e-12);
    // Their heights: 4, 1 + 0.5 (cos 60° of 1 m), 2 (the horizontal branch), 2 + 0.2; the
    // horizontal branch's tip has a path twice its height.
    ASSERT_EQ(v[kTipHeightRatio].size(), 4u);
    EXPECT_NEAR(v[kTipHeightRatio][0], 4.0 / 4, 1e-12);
    EXPECT_NEAR(v[kTipHeightRatio][1], 1.5 / 4, 1e-12);
    EXPECT_NEAR(v[kTipHeightRatio][2], 2.0 / 4, 1e-12);
    EXPECT_NEAR(v[kTipHeightRatio][3], 2.2 / 4, 1e-12);
    // Forks: stem[1] (0.1 → 0.1, 0.02), stem[2] (0.1 → 0.1, 0.03), m (0.03 → 0.02, 0.01). The
    // stem forks have a continuing child as thick as the parent: ratios of the laterals only.
    ASSERT_EQ(v[kRadiusRatio].size(), 3u);
    EXPECT_NEAR(v[kRadiusRatio][0], 0.2, 1e-12);
    EXPECT_NEAR(v[kRadiusRatio][1], 0.3, 1e-12);
    EXPECT_NEAR(v[kRadiusRatio][2], 1.0 / 3, 1e-12);
    ASSERT_EQ(v[kRadiusExponent].size(), 1u);  // the stem forks have r_child = r_parent
    EXPECT_NEAR(v[kRadiusExponent][0], radiusExponent(0.03, {0.02, 0.01}), 1e-12);
}

TEST(ReferenceMetrics, StemDirectionIsTheSegmentIntoTheAttachmentOrTheFirstAtTheRoot) {
    // The stem bends 45° at (0, 1, 0); a branch leaving there along +x is 90° from the segment
    // arriving (vertical), not 45° from the one leaving. A branch at the root node along +x is
    // measured against the stem's first segment (vertical): 90°; one at 30° from it: 30°.
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.2);
    int32_t bend = addNode(t, 0, {0, 1, 0}, 0.1);
    addNode(t, bend, {1, 2, 0}, 0.1);
    addNode(t, bend, {1.5, 1, 0}, 0.02, 1);
    addNode(t, 0, {0.7, 0, 0}, 0.02, 1);
    addNode(t, 0, dirDeg(-30) * 0.5, 0.02, 1);
    const ReferenceValues v = referenceValues(t);
    ASSERT_EQ(v[kBranchAngle].size(), 3u);
    EXPECT_NEAR(v[kBranchAngle][0], 90.0, 1e-9);
    EXPECT_NEAR(v[kBranchAngle][1], 90.0, 1e-9);
    EXPECT_NEAR(v[kBranchAngle][2], 30.0, 1e-9);
}

TEST(ReferenceMetrics, TheLongerChildOfTheSameOrderContinuesTheBranch) {
    // An order-1 branch leaving a 3-m stem at 2 m forks into two children that keep order 1,
    // 0.4 and 1.0 m long: the longer continues (a branch of 0.5 + 1.0 m), the shorter is the
    // fork's lateral and begins a branch of order 2, as TreeQSM numbers a branch leaving an
    // order-1 branch.
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.2);
    int32_t top = addNode(t, 0, {0, 2, 0}, 0.1);
    int32_t b = addNode(t, top, {0.5, 2, 0}, 0.05, 1);
    addNode(t, b, {0.5, 2.4, 0}, 0.02, 1);
    addNode(t, b, {1.5, 2, 0}, 0.04, 1);
    addNode(t, top, {0, 3, 0}, 0.1);
    const ReferenceValues v = referenceValues(t);
    ASSERT_EQ(v[kBranchLengthOrder1].size(), 1u);
    EXPECT_NEAR(v[kBranchLengthOrder1][0], 1.5 / 3, 1e-12);
    ASSERT_EQ(v[kBranchLengthOrder2].size(), 1u);
    EXPECT_NEAR(v[kBranchLengthOrder2][0], 0.4 / 3, 1e-12);
    ASSERT_EQ(v[kRadiusRatio].size(), 2u);  // the branch on the stem, the twig on the branch
    EXPECT_NEAR(v[kRadiusRatio][0], 0.05 / 0.1, 1e-12);
    EXPECT_NEAR(v[kRadiusRatio][1], 0.02 / 0.05, 1e-12);
    // Only the branch leaving the stem is measured against it.
    EXPECT_EQ(v[kBranchAngle].size(), 1u);

    // Two order-0 stems from the root, 3 m and 1 m: the taller is the stem, the other an
    // order-1 branch leaving it at the root, at 30° from the stem's first segment.
    Tree two;
    addNode(two, -1, {0, 0, 0}, 0.2);
    addNode(two, 0, {0, 3, 0}, 0.1);
    addNode(two, 0, dirDeg(30), 0.05);
    const ReferenceValues w = referenceValues(two);
    ASSERT_EQ(w[kBranchAngle].size(), 1u);
    EXPECT_NEAR(w[kBranchAngle][0], 30.0, 1e-9);
    ASSERT_EQ(w[kBranchLengthOrder1].size(), 1u);
    EXPECT_NEAR(w[kBranchLengthOrder1][0], 1.0 / 3, 1e-12);
}

TEST(ReferenceMetrics, AStemWhoseChildrenAllChangeOrderGoesOnInTheFarthestReaching) {
    // A grammar stem changes its order field where its rule changes the state: here a 1-m
    // order-0 trunk whose top carries only order-1 children — a 2-m leader straight up (with a
    // 0.5-m order-2 twig at 45° halfway) and a 0.5-m limb at 45°. As TreeQSM makes the stem as
    // long as possible, the leader continues the stem (height 3 m): two branches leave it, the
    // limb and the twig, both of order 1 at 45°; the stem is not cut at the trunk's top into
    // two order-1 branches (the leader then 2 m long, the twig of order 2).
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.2);
    const int32_t top = addNode(t, 0, {0, 1, 0}, 0.15);
    const int32_t mid = addNode(t, top, {0, 2, 0}, 0.1, 1);
    addNode(t, mid, {0, 3, 0}, 0.05, 1);
    addNode(t, mid, Vec3{0, 2, 0} + dirDeg(45) * 0.5, 0.02, 2);
    addNode(t, top, Vec3{0, 1, 0} + dirDeg(-45) * 0.5, 0.05, 1);
    const ReferenceValues v = referenceValues(t);
    ASSERT_EQ(v[kBranchLengthOrder1].size(), 2u);
    EXPECT_NEAR(v[kBranchLengthOrder1][0], 0.5 / 3, 1e-12);  // the twig (node order)
    EXPECT_NEAR(v[kBranchLengthOrder1][1], 0.5 / 3, 1e-12);  // the limb
    EXPECT_TRUE(v[kBranchLengthOrder2].empty());
    ASSERT_EQ(v[kBranchAngle].size(), 2u);
    EXPECT_NEAR(v[kBranchAngle][0], 45.0, 1e-9);
    EXPECT_NEAR(v[kBranchAngle][1], 45.0, 1e-9);
    // The limb is the trunk top's one lateral: ratio 0.05 / 0.15.
    ASSERT_EQ(v[kRadiusRatio].size(), 2u);
    EXPECT_NEAR(v[kRadiusRatio][0], 0.05 / 0.15, 1e-12);
    EXPECT_NEAR(v[kRadiusRatio][1], 0.02 / 0.1, 1e-12);
}

TEST(ReferenceMetrics, RootSystemIgnoredAndDegenerateTrees) {
    Tree y = yFork(0.06);
    const ReferenceValues before = referenceValues(y);
    int32_t r = addNode(y, 0, {0, -1, 0}, 0.05, 0, kRootPart);
    addNode(y, r, {0.5, -1.5, 0}, 0.02, 1, kRootPart);
    addNode(y, r, {-0.5, -1.5, 0}, 0.02, 1, kRootPart);
    const ReferenceValues after = referenceValues(y);
    for (int k = 0; k < kReferenceDistributions; ++k) EXPECT_EQ(before[k], after[k]) << k;

    for (const auto& d : referenceValues(Tree{})) EXPECT_TRUE(d.empty());
    Tree flat;  // no height: no path or length ratios
    addNode(flat, -1, {0, 0, 0});
    addNode(flat, 0, {1, 0, 0}, 0.01, 0);
    addNode(flat, 0, {-1, 0, 0}, 0.005, 1);
    const ReferenceValues f = referenceValues(flat);
    EXPECT_TRUE(f[kTipPathRatio].empty());
    EXPECT_TRUE(f[kTipHeightRatio].empty());
    EXPECT_TRUE(f[kBranchLengthOrder1].empty());
    EXPECT_EQ(f[kBranchAngle].size(), 1u);

    Tree bad = yFork(0.06);
    bad.nodes[1].parent = 3;
    EXPECT_THROW(referenceValues(bad), std::invalid_argument);
}

}  // namespace
}  // namespace sylva
