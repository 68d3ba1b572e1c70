// The form stage (species/model/form.h) on hand-built skeletons with known answers: pipe-model
// radii (one exponent or one per fork), the clear bole, turned and bent branches, scale and
// width, asymmetry, lean and the ground plane, leaves following their twigs; and its reader's
// ranges.
#include "species/model/form.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "species/model/reference_metrics.h"
#include "species/model/tree_metrics.h"
#include "species/spec/form_spec.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

// Root → trunk top (0, 1, 0) → two tips; radii 0.5 everywhere (the method's, to be replaced).
Tree yFork() {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.5);
    addNode(t, 0, {0, 1, 0}, 0.5);
    addNode(t, 1, {-0.5, 2, 0}, 0.5, 1);
    addNode(t, 1, {0.5, 2, 0}, 0.5, 0);
    return t;
}

Leaf leafAt(int32_t node, Vec3 p) {
    Leaf l;
    l.node = node;
    l.position = p;
    return l;
}

TEST(Form, PipeModelRadiiFromTheTips) {
    Tree t = yFork();
    pipeModelRadii(t, 2.0, 0.01, 0.0, 0.0);
    EXPECT_DOUBLE_EQ(t.nodes[2].radius, 0.01);
    EXPECT_DOUBLE_EQ(t.nodes[3].radius, 0.01);
    EXPECT_NEAR(t.nodes[1].radius, 0.01 * std::sqrt(2.0), 1e-15);  // r² = Σ r_child²
    EXPECT_NEAR(t.nodes[0].radius, t.nodes[1].radius, 1e-15);      // no taper: constant
    // The fork's measured exponent is the model's.
    EXPECT_NEAR(radiusExponent(t.nodes[1].radius, {0.01, 0.01}), 2.0, 1e-9);

    Tree u = yFork();
    pipeModelRadii(u, 2.5, 0.01, 0.1, 0.0);  // taper 0.1 per metre over the 1-m trunk
    const double fork = std::pow(2.0 * std::pow(0.01, 2.5), 1 / 2.5);
    EXPECT_NEAR(u.nodes[1].radius, fork, 1e-15);
    EXPECT_NEAR(u.nodes[0].radius, fork * 1.1, 1e-15);

    Tree v = yFork();
    pipeModelRadii(v, 2.0, 0.01, 0.0, 0.2);  // rescaled to a 0.2-m base
    EXPECT_NEAR(v.nodes[0].radius, 0.2, 1e-15);
    EXPECT_NEAR(v.nodes[2].radius, 0.2 / std::sqrt(2.0), 1e-15);
}

TEST(Form, PipeModelLeavesTheRootSystemAlone) {
    Tree t = yFork();
    const int32_t root = addNode(t, 0, {0, -1, 0}, 0.3, 0, kRootPart);
    pipeModelRadii(t, 2.0, 0.01, 0.0, 0.0);
    EXPECT_DOUBLE_EQ(t.nodes[root].radius, 0.3);
    EXPECT_NEAR(t.nodes[0].radius, 0.01 * std::sqrt(2.0), 1e-15);  // from the shoot only
}

TEST(Form, ClearBoleRemovesLowLateralsWithTheirLeaves) {
    Tree t;
    addNode(t, -1, {0, 0, 0});
    addNode(t, 0, {0, 1, 0});                                 // 1
    addNode(t, 1, {0, 2, 0});                                 // 2
    addNode(t, 2, {0, 3, 0});                                 // 3
    const int32_t low = addNode(t, 1, {1, 1.5, 0}, 0.01, 1);  // leaves the trunk at 1 m
    addNode(t, low, {2, 2, 0}, 0.01, 2);
    const int32_t high = addNode(t, 2, {1, 2.5, 0}, 0.01, 1);  // at 2 m
    t.leaves = {leafAt(low + 1, {2, 2.1, 0}), leafAt(high, {1, 2.6, 0})};
    t.endpoints = {3, low + 1, high};
    FormOptions o;
    o.clearBole = 1.5;
    applyForm(t, o, Rng(1));
    ASSERT_EQ(t.nodes.size(), 5u);  // 4 trunk nodes + the high lateral
    EXPECT_EQ(t.nodes[4].position, (Vec3{1, 2.5, 0}));
    EXPECT_EQ(t.nodes[4].parent, 2);
    ASSERT_EQ(t.leaves.size(), 1u);
    EXPECT_EQ(t.leaves[0].node, 4);
    EXPECT_EQ(t.endpoints, (std::vector<int32_t>{3, 4}));
}

TEST(Form, ScaleKeepsLeavesOnTheirTwigsAtTheirSize) {
    Tree t = yFork();
    t.leaves = {leafAt(2, {-0.5, 2.1, 0}), leafAt(-1, {0, 3, 0})};
    t.leaves[0].size = 0.1;
    FormOptions o;
    o.scale = 2.0;
    applyForm(t, o, Rng(1));
    EXPECT_EQ(t.nodes[2].position, (Vec3{-1, 4, 0}));
    EXPECT_DOUBLE_EQ(t.nodes[2].radius, 1.0);
    EXPECT_NEAR(distance(t.leaves[0].position, Vec3{-1, 4.1, 0}), 0, 1e-12);  // offset kept
    EXPECT_DOUBLE_EQ(t.leaves[0].size, 0.1);
    EXPECT_EQ(t.leaves[1].position, (Vec3{0, 6, 0}));  // a free leaf moves as a point
}

TEST(Form, LeanTiltsTheShootAboutTheBase) {
    Tree t;
    addNode(t, -1, {0, 0, 0});
    addNode(t, 0, {0, 5, 0});
    const int32_t root = addNode(t, 0, {0, -1, 0}, 0.01, 0, kRootPart);
    t.leaves = {leafAt(1, {0, 5.2, 0})};
    FormOptions o;
    o.leanRad = 10.0 * kPi / 180.0;
    applyForm(t, o, Rng(7));
    const Vec3 top = t.nodes[1].position;
    EXPECT_NEAR(length(top), 5.0, 1e-12);
    EXPECT_NEAR(angleBetween(top, Vec3{0, 1, 0}) * 180 / kPi, 10.0, 1e-9);
    EXPECT_EQ(t.nodes[0].position, (Vec3{0, 0, 0}));
    EXPECT_EQ(t.nodes[root].position, (Vec3{0, -1, 0}));  // the root system stays
    // The leaf turned with its twig: still 0.2 m beyond the top, along the stem.
    EXPECT_NEAR(distance(t.leaves[0].position, top * (5.2 / 5.0)), 0, 1e-12);
    EXPECT_NEAR(angleBetween(t.leaves[0].normal, Vec3{0, 1, 0}) * 180 / kPi, 10.0, 1e-9);
    // Another seed leans another way; the same seed the same way.
    Tree s1;
    addNode(s1, -1, {0, 0, 0});
    addNode(s1, 0, {0, 5, 0});
    Tree s2 = s1, s3 = s1;
    applyForm(s1, o, Rng(7));
    applyForm(s2, o, Rng(7));
    applyForm(s3, o, Rng(8));
    EXPECT_EQ(s1.nodes[1].position, s2.nodes[1].position);
    EXPECT_GT(distance(s1.nodes[1].position, s3.nodes[1].position), 0.01);
}

TEST(Form, PropRootsFollowTheirLimbAndStayOnTheGround) {
    Tree t;
    addNode(t, -1, {0, 0, 0});
    const int32_t top = addNode(t, 0, {0, 4, 0});
    const int32_t limb = addNode(t, top, {3, 4, 0}, 0.05, 1);
    const int32_t r1 = addNode(t, limb, {3, 2, 0}, 0.05, 2, kRootPart);
    const int32_t r2 = addNode(t, r1, {3, 0, 0}, 0.05, 2, kRootPart);
    FormOptions o;
    o.leanRad = 8.0 * kPi / 180.0;
    o.scale = 1.5;
    applyForm(t, o, Rng(11));
    const Vec3 a = t.nodes[limb].position;
    EXPECT_NEAR(length(a), 1.5 * 5.0, 1e-12);  // the limb tip moved with the lean
    for (int32_t r : {r1, r2}) {               // still straight under it
        EXPECT_NEAR(t.nodes[r].position.x, a.x, 1e-12);
        EXPECT_NEAR(t.nodes[r].position.z, a.z, 1e-12);
    }
    EXPECT_NEAR(t.nodes[r1].position.y, a.y / 2, 1e-12);  // halfway down, as before
    EXPECT_EQ(t.nodes[r2].position.y, 0.0);               // and still on the ground
}

TEST(Form, AsymmetryStretchesTheCrownAlongOneDirection) {
    Tree t;
    addNode(t, -1, {0, 0, 0});
    const int kRing = 360;
    for (int k = 0; k < kRing; ++k) {
        const double a = 2 * kPi * k / kRing;
        addNode(t, 0, {std::cos(a), 3, std::sin(a)}, 0.01, 1);
    }
    FormOptions o;
    o.asymmetry = 0.2;
    applyForm(t, o, Rng(3));
    double rMin = 1e9, rMax = 0;
    for (size_t i = 1; i < t.nodes.size(); ++i) {
        const Vec3 p = t.nodes[i].position;
        EXPECT_DOUBLE_EQ(p.y, 3.0);
        const double r = std::hypot(p.x, p.z);
        rMin = std::min(rMin, r);
        rMax = std::max(rMax, r);
    }
    EXPECT_NEAR(rMax, 1.2, 1e-3);
    EXPECT_NEAR(rMin, 0.8, 1e-3);
}

TEST(Form, GroundCutsBranchesAtTheGroundAndLiftsTheTrunk) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.2);
    const int32_t trunk = addNode(t, 0, {0.1, -0.01, 0}, 0.2);  // the trunk dips: lifted
    const int32_t top = addNode(t, trunk, {0, 2, 0}, 0.2);
    const int32_t droop = addNode(t, top, {2, -2, 0}, 0.1, 1);      // crosses the ground at x = 1
    const int32_t below = addNode(t, droop, {3, -1, 0}, 0.05, 1);   // beyond the cut: removed
    const int32_t upAgain = addNode(t, below, {4, 1, 0}, 0.05, 2);  // above, but beyond: removed
    addNode(t, 0, {0, -1, 0}, 0.1, 0, kRootPart);                   // roots stay
    t.leaves = {leafAt(upAgain, {4, 1.1, 0}), leafAt(top, {0, 2.1, 0}), leafAt(top, {0, -0.1, 0}),
                leafAt(-1, {1, -0.5, 0})};
    FormOptions o;
    o.ground = GroundRule::kPrune;
    applyForm(t, o, Rng(1));
    ASSERT_EQ(t.nodes.size(), 5u);
    EXPECT_EQ(t.nodes[1].position, (Vec3{0.1, 0, 0}));
    EXPECT_NEAR(distance(t.nodes[3].position, Vec3{1, 0, 0}), 0, 1e-12);  // the cut
    EXPECT_NEAR(t.nodes[3].radius, 0.15, 1e-12);                          // halfway from 0.2 to 0.1
    EXPECT_EQ(t.nodes[4].part, kRootPart);
    EXPECT_EQ(t.nodes[4].position, (Vec3{0, -1, 0}));
    ASSERT_EQ(t.leaves.size(), 1u);  // the leaf above on the top; the others went
    EXPECT_EQ(t.leaves[0].node, 2);
    for (const SkeletonNode& n : t.nodes) {
        if (n.part == kShootPart) {
            EXPECT_GE(n.position.y, 0.0);
        }
    }
}

// A trunk of `forks` 0.1-m segments, each node carrying a 45° lateral of `segments` 0.5-m
// segments (order 1) heading along +x.
Tree comb(int forks, int segments) {
    Tree t;
    addNode(t, -1, {0, 0, 0});
    int32_t stem = 0;
    for (int k = 1; k <= forks; ++k) {
        stem = addNode(t, stem, {0, 0.1 * k, 0});
        int32_t at = stem;
        for (int s = 1; s <= segments; ++s) {
            const double d = 0.5 * s / std::sqrt(2.0);
            at = addNode(t, at, {d, 0.1 * k + d, 0}, 0.01, 1);
        }
    }
    return t;
}

std::vector<double> sortedForkExponents(const Tree& t) {
    const ChildIndex kids(t);
    std::vector<double> e;
    for (size_t i = 0; i < t.nodes.size(); ++i) {
        if (kids.count(static_cast<int>(i)) < 2) continue;
        std::vector<double> rc;
        for (int32_t k = kids.offset[i]; k < kids.offset[i + 1]; ++k) {
            rc.push_back(t.nodes[kids.child[k]].radius);
        }
        e.push_back(radiusExponent(t.nodes[i].radius, rc));
    }
    std::sort(e.begin(), e.end());
    return e;
}

TEST(Form, PipeExponentSpreadDrawsOneExponentPerFork) {
    Tree fixed = comb(400, 1);
    pipeModelRadii(fixed, 2.5, 0.01, 0.0, 0.0);
    Tree spread = comb(400, 1);
    const Rng rng(7);
    pipeModelRadii(spread, 2.5, 0.01, 0.0, 0.0, 0.6, &rng);
    const std::vector<double> e = sortedForkExponents(spread);
    ASSERT_EQ(e.size(), 399u);  // the top node carries only its lateral
    // Each fork has the drawn exponent, within [1.2, 6]; N(2.5, 0.6): median 2.5, IQR 0.81.
    EXPECT_GE(e.front(), kMinForkExponent - 1e-9);
    EXPECT_LE(e.back(), kMaxForkExponent + 1e-9);
    const double median = e[e.size() / 2];
    const double iqr = e[e.size() * 3 / 4] - e[e.size() / 4];
    EXPECT_NEAR(median, 2.5, 0.1);
    EXPECT_NEAR(iqr, 1.349 * 0.6, 0.15);
    // The fixed exponent has no spread; the base keeps the mean exponent's radius.
    const std::vector<double> f = sortedForkExponents(fixed);
    EXPECT_NEAR(f.front(), 2.5, 1e-6);
    EXPECT_NEAR(f.back(), 2.5, 1e-6);
    EXPECT_NEAR(spread.nodes[0].radius, fixed.nodes[0].radius, 1e-12);
    // Keyed by the fork: the same stream gives the same radii, another stream others.
    Tree again = comb(400, 1);
    pipeModelRadii(again, 2.5, 0.01, 0.0, 0.0, 0.6, &rng);
    for (size_t i = 0; i < again.nodes.size(); ++i) {
        ASSERT_EQ(again.nodes[i].radius, spread.nodes[i].radius);
    }
    Tree other = comb(400, 1);
    const Rng rng2(8);
    pipeModelRadii(other, 2.5, 0.01, 0.0, 0.0, 0.6, &rng2);
    EXPECT_NE(sortedForkExponents(other)[200], e[200]);
}

// A full binary tree of `depth` levels of forks (2^depth − 1 of them) above a trunk segment:
// every fork's children carry equal numbers of tips, so its exponent is well conditioned
// (r_child / r_parent stays above 0.25 for n ≥ 0.5).
Tree binaryTree(int depth) {
    Tree t;
    addNode(t, -1, {0, 0, 0});
    std::vector<int32_t> level = {addNode(t, 0, {0, 1, 0})};
    for (int d = 0; d < depth; ++d) {
        std::vector<int32_t> next;
        for (int32_t p : level) {
            const Vec3 at = t.nodes[p].position;
            for (double side : {-1.0, 1.0}) {
                next.push_back(addNode(t, p, at + Vec3{side * 0.1, 0.2, 0}, 0.01, d + 1));
            }
        }
        level = next;
    }
    return t;
}

// The log-normal spread: n = 2.3 · e^(0.7z) held to [0.5, 6], so the median fork keeps 2.3,
// the quartiles are 2.3 · e^(±0.472) = 1.44 and 3.69, 8.5 % of the forks sit at 6 (z > 1.370)
// and 1.5 % at 0.5 (z < −2.18); the base keeps the median exponent's radius. 2,047 forks: the
// quartiles' sampling error is about 0.03 (lower) and 0.08 (upper), the counts' 13 and 5.
TEST(Form, LogNormalExponentSpreadIsSkewedAndHeldAtTheReferenceBounds) {
    Tree fixed = binaryTree(11);
    pipeModelRadii(fixed, 2.3, 0.01, 0.0, 0.0);
    Tree spread = binaryTree(11);
    const Rng rng(11);
    pipeModelRadii(spread, 2.3, 0.01, 0.0, 0.0, 0.7, &rng, ForkSpread::kLogNormal);
    const std::vector<double> e = sortedForkExponents(spread);
    ASSERT_EQ(e.size(), 2047u);
    EXPECT_NEAR(e.front(), kMinLogForkExponent, 1e-6);
    EXPECT_NEAR(e.back(), kMaxForkExponent, 1e-6);
    EXPECT_NEAR(e[e.size() / 2], 2.3, 0.12);
    EXPECT_NEAR(e[e.size() / 4], 1.44, 0.1);
    EXPECT_NEAR(e[e.size() * 3 / 4], 3.69, 0.25);
    const auto atTop = std::count_if(e.begin(), e.end(), [](double x) { return x > 6 - 1e-6; });
    const auto atFloor = std::count_if(e.begin(), e.end(), [](double x) { return x < 0.5 + 1e-6; });
    EXPECT_GE(atTop, 135);  // 175 expected
    EXPECT_LE(atTop, 215);
    EXPECT_GE(atFloor, 13);  // 30 expected
    EXPECT_LE(atFloor, 47);
    EXPECT_NEAR(spread.nodes[0].radius, fixed.nodes[0].radius, 1e-12);

    // About a median of its own (2.8 · e^(±0.5 · 0.674): quartiles 2.00 and 3.92), while the
    // base keeps the radius n = 2.3 gives it.
    Tree own = binaryTree(11);
    pipeModelRadii(own, 2.3, 0.01, 0.0, 0.0, 0.5, &rng, ForkSpread::kLogNormal, 2.8);
    const std::vector<double> m = sortedForkExponents(own);
    EXPECT_NEAR(m[m.size() / 2], 2.8, 0.12);
    EXPECT_NEAR(m[m.size() / 4], 2.0, 0.1);
    EXPECT_NEAR(m[m.size() * 3 / 4], 3.92, 0.25);
    EXPECT_NEAR(own.nodes[0].radius, fixed.nodes[0].radius, 1e-12);
}

// The bound on a fork's thickest child (half the fork's radius here). Each fork's first draw is
// its stream's first normal, n = 2.3 · e^(0.7z) held to [0.5, 6]: a fork whose first draw keeps
// its thickest child at half its radius or more has exactly that exponent; the others drew again
// and keep the bound.
TEST(Form, ThickestChildBoundRedrawsOnlyTheForksThatBreakIt) {
    Tree t = binaryTree(11);
    const Rng rng(11);
    pipeModelRadii(t, 2.3, 0.01, 0.0, 0.0, 0.7, &rng, ForkSpread::kLogNormal, 0.0, 0.5);
    const ChildIndex kids(t);
    int redrawn = 0, forks = 0;
    for (int32_t i = 0; i < static_cast<int32_t>(t.nodes.size()); ++i) {
        if (kids.offset[i + 1] - kids.offset[i] != 2) continue;
        ++forks;
        std::vector<double> rc;
        double thickest = 0.0;
        for (int32_t k = kids.offset[i]; k < kids.offset[i + 1]; ++k) {
            rc.push_back(t.nodes[kids.child[k]].radius);
            thickest = std::max(thickest, rc.back());
        }
        EXPECT_GE(thickest, 0.5 * t.nodes[i].radius * (1 - 1e-12)) << "fork " << i;
        Rng draw = rng.derive(static_cast<uint64_t>(i));
        const double first = std::clamp(2.3 * std::exp(0.7 * draw.normal(0.0, 1.0)), 0.5, 6.0);
        const double firstRadius =
            std::pow(std::pow(rc[0], first) + std::pow(rc[1], first), 1 / first);
        if (firstRadius <= thickest / 0.5) {
            EXPECT_NEAR(radiusExponent(t.nodes[i].radius, rc), first, 1e-9) << "fork " << i;
        } else {
            ++redrawn;
        }
    }
    ASSERT_EQ(forks, 2047);
    EXPECT_GE(redrawn, 20);  // the bound is exercised (n < 1 at near-equal children: ~10 %)

    // A fork no draw can satisfy is held to the bound: four equal tips under n ≈ 0.6 would make
    // it 4^(1/0.6) = 10.1 × as thick as each; held at 2 ×.
    Tree star;
    addNode(star, -1, {0, 0, 0});
    addNode(star, 0, {0, 1, 0});
    for (double x : {-0.3, -0.1, 0.1, 0.3}) addNode(star, 1, {x, 1.5, 0}, 0.01, 1);
    Tree loose = star;
    pipeModelRadii(loose, 2.3, 0.01, 0.0, 0.0, 0.01, &rng, ForkSpread::kLogNormal, 0.6);
    EXPECT_NEAR(loose.nodes[1].radius / loose.nodes[2].radius, std::pow(4.0, 1 / 0.6), 0.5);
    pipeModelRadii(star, 2.3, 0.01, 0.0, 0.0, 0.01, &rng, ForkSpread::kLogNormal, 0.6, 0.5);
    EXPECT_NEAR(star.nodes[1].radius / star.nodes[2].radius, 2.0, 1e-12);
}

double elevationDeg(const Vec3& a, const Vec3& b) {
    const Vec3 d = b - a;
    return std::asin(d.y / length(d)) * 180 / kPi;
}

TEST(Form, BendTurnsEachSegmentByTheRateTimesTheLengthBefore) {
    Tree t = comb(1, 6);  // one lateral of six 0.5-m segments at 45° elevation
    t.leaves = {leafAt(7, t.nodes[7].position + Vec3{0, 0.05, 0})};
    const Tree before = t;
    FormOptions o;
    o.bendRadPerM = 10 * kPi / 180;  // 10° per metre toward the ground: 5° per segment
    turnBranches(t, o, Rng(3));
    EXPECT_EQ(t.nodes[1].position, before.nodes[1].position);  // the trunk stays
    for (int s = 1; s <= 6; ++s) {
        const int32_t i = 1 + s, p = t.nodes[i].parent;
        EXPECT_NEAR(elevationDeg(t.nodes[p].position, t.nodes[i].position), 45.0 - 5.0 * s, 1e-9);
        EXPECT_NEAR(distance(t.nodes[p].position, t.nodes[i].position), 0.5, 1e-12);
    }
    // The leaf went with its node, its offset turned with the last segment (30° of turn).
    const Vec3 offset = t.leaves[0].position - t.nodes[7].position;
    EXPECT_NEAR(length(offset), 0.05, 1e-12);
    EXPECT_NEAR(std::acos(offset.y / 0.05) * 180 / kPi, 30.0, 1e-9);

    Tree steep = comb(1, 6);
    o.bendRadPerM = 90 * kPi / 180;  // would pass the vertical: held 80° below the horizontal
    turnBranches(steep, o, Rng(3));
    EXPECT_NEAR(elevationDeg(steep.nodes[6].position, steep.nodes[7].position), -80.0, 1e-9);
    Tree rising = comb(1, 6);
    o.bendRadPerM = -10 * kPi / 180;  // negative: upturned
    turnBranches(rising, o, Rng(3));
    EXPECT_NEAR(elevationDeg(rising.nodes[6].position, rising.nodes[7].position), 75.0, 1e-9);
}

TEST(Form, InsertionAnglesSpreadPerBranchAndBranchesTurnWhole) {
    Tree t = comb(600, 3);
    const Tree before = t;
    FormOptions o;
    o.angleSdRad = 15 * kPi / 180;
    turnBranches(t, o, Rng(11));
    std::vector<double> angles;
    for (size_t i = 1; i < t.nodes.size(); ++i) {
        const SkeletonNode& n = t.nodes[i];
        const SkeletonNode& p = t.nodes[n.parent];
        if (n.order == 0) {
            EXPECT_EQ(n.position, before.nodes[i].position);
            continue;
        }
        // Rigid: every segment keeps its length, and the branch stays straight.
        EXPECT_NEAR(distance(n.position, p.position), 0.5, 1e-9);
        if (p.order == 0) {
            const Vec3 stem = p.position - t.nodes[p.parent].position;
            angles.push_back(angleBetween(stem, n.position - p.position) * 180 / kPi);
        } else {
            const Vec3 a = p.position - t.nodes[p.parent].position, b = n.position - p.position;
            EXPECT_NEAR(angleBetween(a, b), 0.0, 1e-6);
        }
    }
    ASSERT_EQ(angles.size(), 600u);
    double mean = 0, ss = 0;
    for (double a : angles) mean += a / angles.size();
    for (double a : angles) ss += (a - mean) * (a - mean);
    EXPECT_NEAR(mean, 45.0, 1.5);
    EXPECT_NEAR(std::sqrt(ss / (angles.size() - 1)), 15.0, 1.5);
    EXPECT_GE(*std::min_element(angles.begin(), angles.end()), 5.0 - 1e-9);
}

// The mean shift opens (or closes) every first-order branch by the same angle, weighted like
// the spread: 45° + 20° = 65° for the comb's 1.5-m laterals at full weight, and 45° + 20° × w
// with w = spread_reach · H / 1.5 m when the laterals reach farther than that.
TEST(Form, AngleShiftOpensEveryFirstOrderBranchByItsWeight) {
    auto insertions = [](double shiftDeg, double spreadReach) {
        Tree t = comb(200, 3);
        // The stem goes on above its last lateral (else that lateral would continue it).
        addNode(t, 1 + 199 * 4, {0, 20.1, 0});
        FormOptions o;
        o.angleShiftRad = shiftDeg * kPi / 180;
        o.spreadReach = spreadReach;
        turnBranches(t, o, Rng(5));
        std::vector<double> angles;
        for (size_t i = 1; i < t.nodes.size(); ++i) {
            const SkeletonNode& n = t.nodes[i];
            const SkeletonNode& p = t.nodes[n.parent];
            if (n.order != 1 || p.order != 0) continue;
            const Vec3 stem = p.position - t.nodes[p.parent].position;
            angles.push_back(angleBetween(stem, n.position - p.position) * 180 / kPi);
        }
        return angles;
    };
    const std::vector<double> open = insertions(20, 0.2), close = insertions(-20, 0.2);
    ASSERT_EQ(open.size(), 200u);
    for (size_t k = 0; k < open.size(); ++k) {
        ASSERT_NEAR(open[k], 65.0, 1e-6);
        ASSERT_NEAR(close[k], 25.0, 1e-6);
    }
    // Height 20 m + the top lateral's 1.5 / √2 m rise; spread_reach 0.025 gives a free reach of
    // 0.527 m, so w = 0.351 and the shift 7.03°.
    const double height = 20.0 + 1.5 / std::sqrt(2.0);
    const double w = 0.025 * height / 1.5;
    for (double a : insertions(20, 0.025)) ASSERT_NEAR(a, 45.0 + 20.0 * w, 1e-6);
}

TEST(Form, LengthFactorsScaleEachBranchAsAWhole) {
    Tree t = comb(800, 3);
    t.leaves = {leafAt(4, t.nodes[4].position + Vec3{0, 0.05, 0})};
    FormOptions o;
    o.lengthSd = 0.5;
    turnBranches(t, o, Rng(13));
    std::vector<double> logs;
    for (size_t i = 1; i < t.nodes.size(); ++i) {
        const SkeletonNode& n = t.nodes[i];
        const SkeletonNode& p = t.nodes[n.parent];
        if (n.order == 0) continue;
        const double len = distance(n.position, p.position);
        if (p.order == 0) {
            logs.push_back(std::log(len / 0.5));
            // Only scaled: the direction is the method's (45° from the stem).
            EXPECT_NEAR(angleBetween(n.position - p.position, {1, 1, 0}), 0.0, 1e-6);
        } else {  // the rest of the branch has its first segment's factor
            EXPECT_NEAR(len, distance(p.position, t.nodes[p.parent].position), 1e-9);
        }
    }
    ASSERT_EQ(logs.size(), 800u);
    double mean = 0, ss = 0;
    for (double l : logs) mean += l / logs.size();
    for (double l : logs) ss += (l - mean) * (l - mean);
    // ln factor = σ(0.674 − |z|): mean σ(0.674 − √(2/π)) = −0.062, sd σ√(1 − 2/π) = 0.301,
    // median 0, never above 0.674σ = 0.337.
    EXPECT_NEAR(mean, -0.062, 0.03);
    EXPECT_NEAR(std::sqrt(ss / (logs.size() - 1)), 0.301, 0.03);
    std::vector<double> sorted = logs;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_NEAR(sorted[sorted.size() / 2], 0.0, 0.03);
    EXPECT_LE(sorted.back(), 0.5 * 0.6744897501960817 + 1e-12);
    EXPECT_GE(*std::min_element(logs.begin(), logs.end()), std::log(0.25) - 1e-12);
    // A leaf keeps its offset and size.
    EXPECT_NEAR(distance(t.leaves[0].position, t.nodes[4].position), 0.05, 1e-12);
}

TEST(Form, OnlyBranchesLeavingTheStemChangeTheirInsertion) {
    Tree t;  // a trunk, a lateral (order 1) and a lateral of the lateral (order 2)
    addNode(t, -1, {0, 0, 0});
    addNode(t, 0, {0, 1, 0});
    addNode(t, 1, {0.5, 1.5, 0}, 0.01, 1);
    addNode(t, 2, {1.0, 2.0, 0}, 0.01, 1);
    addNode(t, 3, {1.0, 2.5, 0}, 0.01, 2);
    addNode(t, 1, {0, 2, 0});  // the stem goes on (else the lateral would continue it)
    const Tree before = t;
    FormOptions o;
    o.angleSdRad = 30 * kPi / 180;
    turnBranches(t, o, Rng(2));
    const Vec3 lateral = t.nodes[2].position - t.nodes[1].position;
    EXPECT_GT(std::abs(angleBetween(lateral, {0, 1, 0}) - kPi / 4), 1e-6);  // turned
    // The order-2 branch keeps its angle to its parent branch (turned with it, not apart).
    const Vec3 parent = t.nodes[3].position - t.nodes[2].position;
    const Vec3 child = t.nodes[4].position - t.nodes[3].position;
    EXPECT_NEAR(angleBetween(parent, child), kPi / 4, 1e-9);
    EXPECT_EQ(t.nodes[1].position, before.nodes[1].position);
}

TEST(Form, AStemThatChangesOrderGoesOnUnturnedAndItsBranchesTurn) {
    // A grammar stem changes its order field where its rule changes the state: a 1-m order-0
    // trunk whose top carries only order-1 children, a 2-m leader straight up with a 0.5-m
    // order-2 twig at 45° and a 0.5-m limb at 45°. The leader continues the stem: it is not
    // turned, while the limb and the twig, both leaving the stem, open by the shift.
    Tree t;
    addNode(t, -1, {0, 0, 0});
    const int32_t top = addNode(t, 0, {0, 1, 0});
    const int32_t mid = addNode(t, top, {0, 2, 0}, 0.01, 1);
    const int32_t tip = addNode(t, mid, {0, 3, 0}, 0.01, 1);
    const double h = 0.5 / std::sqrt(2.0);  // each leg of a 0.5-m segment at 45°
    const int32_t twig = addNode(t, mid, Vec3{h, 2 + h, 0}, 0.01, 2);
    const int32_t limb = addNode(t, top, Vec3{-h, 1 + h, 0}, 0.01, 1);
    const Tree before = t;
    FormOptions o;
    o.angleShiftRad = 20 * kPi / 180;
    o.spreadReach = 10.0;  // weight 1 everywhere
    turnBranches(t, o, Rng(3));
    EXPECT_EQ(t.nodes[mid].position, before.nodes[mid].position);
    EXPECT_EQ(t.nodes[tip].position, before.nodes[tip].position);
    const Vec3 up{0, 1, 0};
    EXPECT_NEAR(angleBetween(t.nodes[limb].position - t.nodes[top].position, up) * 180 / kPi, 65.0,
                1e-9);
    EXPECT_NEAR(angleBetween(t.nodes[twig].position - t.nodes[mid].position, up) * 180 / kPi, 65.0,
                1e-9);
}

TEST(Form, WhereScaffoldsChangeOrderTheThickestContinuesTheStem) {
    // Four 2-m scaffolds of order 1 from the top of an order-0 trunk (45° out, a quarter turn
    // apart; radii 3, 5, 4 and 2 cm), each with a 0.3-m order-2 twig pointing up from its
    // middle. The thickest continues the stem: it stays where it was grown, the other three
    // and every twig open by the shift, and whatever length factors the branches draw, the stem
    // the reference distributions find in the result is that scaffold — every first-order
    // angle they measure is the shifted one.
    const double radii[4] = {0.03, 0.05, 0.04, 0.02};
    for (uint64_t seed = 1; seed <= 20; ++seed) {
        Tree t;
        addNode(t, -1, {0, 0, 0}, 0.1);
        const int32_t top = addNode(t, 0, {0, 1, 0}, 0.1);
        std::vector<int32_t> first;
        for (int k = 0; k < 4; ++k) {
            const double az = k * kPi / 2;
            const Vec3 u{std::cos(az) / std::sqrt(2.0), 1 / std::sqrt(2.0),
                         std::sin(az) / std::sqrt(2.0)};
            const int32_t a = addNode(t, top, Vec3{0, 1, 0} + u, radii[k], 1);
            addNode(t, a, Vec3{0, 1, 0} + u * 2.0, 0.01, 1);
            addNode(t, a, Vec3{0, 1, 0} + u + Vec3{0, 0.3, 0}, 0.005, 2);
            first.push_back(a);
        }
        const Tree before = t;
        FormOptions o;
        o.angleShiftRad = 30 * kPi / 180;
        o.lengthSd = 0.8;
        o.spreadReach = 10.0;
        turnBranches(t, o, Rng(seed));
        for (int k = 0; k < 4; ++k) {
            const Vec3 was = before.nodes[first[k]].position - before.nodes[top].position;
            const Vec3 now = t.nodes[first[k]].position - t.nodes[top].position;
            if (k == 1) {
                EXPECT_NEAR(angleBetween(was, now), 0.0, 1e-9) << seed;
            } else {
                EXPECT_NEAR(angleBetween(now, {0, 1, 0}) * 180 / kPi, 75.0, 1e-9) << seed;
            }
        }
        const ReferenceValues v = referenceValues(t);
        ASSERT_EQ(v[kBranchAngle].size(), 4u) << seed;  // three scaffolds and the stem's twig
        for (double a : v[kBranchAngle]) EXPECT_NEAR(a, 75.0, 1e-6) << seed;
    }
}

TEST(Form, BigLimbsTurnLessThanSmallShoots) {
    // A 10-m trunk with one 6-m limb: the limb reaches 6 m, 3 × 0.2 × height.
    auto tree = [] {
        Tree t;
        addNode(t, -1, {0, 0, 0});
        addNode(t, 0, {0, 5, 0});
        addNode(t, 1, {0, 10, 0});
        int32_t at = 1;
        for (int s = 1; s <= 6; ++s)
            at = addNode(t, at, {s / std::sqrt(2.0), 5 + s / std::sqrt(2.0), 0}, 0.01, 1);
        return t;
    };
    auto turned = [&](double reach) {
        Tree t = tree();
        FormOptions o;
        o.angleSdRad = 20 * kPi / 180;
        o.spreadReach = reach;
        turnBranches(t, o, Rng(4));
        return angleBetween(t.nodes[3].position - t.nodes[1].position, {0, 1, 0}) - kPi / 4;
    };
    const double free = turned(10.0), limb = turned(0.2);  // weight 1, and 2 m / 6 m
    ASSERT_GT(std::abs(free), 1e-3);
    EXPECT_NEAR(limb, free * (0.2 * 10.0) / 6.0, 1e-9);
}

TEST(Form, FreeLeavesMoveWithTheNearestShootNode) {
    Tree t = comb(1, 2);
    Leaf free = leafAt(-1, t.nodes[3].position + Vec3{0, 0.1, 0});
    Leaf far = leafAt(-1, {5, 5, 5});
    t.leaves = {free, far};
    FormOptions o;
    o.angleSdRad = 20 * kPi / 180;
    turnBranches(t, o, Rng(5));
    EXPECT_NEAR(distance(t.leaves[0].position, t.nodes[3].position), 0.1, 1e-12);
    EXPECT_EQ(t.leaves[1].position, far.position);  // nothing within 1 m: stays
}

TEST(Form, WidthScalesTheShootHorizontallyAboutTheBase) {
    Tree t = yFork();
    FormOptions o;
    o.width = 1.5;
    applyForm(t, o, Rng(1));
    EXPECT_NEAR(t.nodes[2].position.x, -0.75, 1e-12);
    EXPECT_NEAR(t.nodes[2].position.y, 2.0, 1e-12);
    EXPECT_NEAR(t.nodes[3].radius, 0.5, 1e-12);  // radii are not widened
}

TEST(Form, InactiveOptionsLeaveTheTreeAsGrown) {
    Tree t = yFork();
    t.leaves = {leafAt(2, {-0.5, 2.1, 0})};
    const Tree before = t;
    applyForm(t, FormOptions{}, Rng(1));
    ASSERT_EQ(t.nodes.size(), before.nodes.size());
    for (size_t i = 0; i < t.nodes.size(); ++i) {
        EXPECT_EQ(t.nodes[i].position, before.nodes[i].position);
        EXPECT_EQ(t.nodes[i].radius, before.nodes[i].radius);
    }
    EXPECT_EQ(t.leaves[0].position, before.leaves[0].position);
}

// A stem with two laterals at 1 m: one under a crown of 25 tips, one out beside it. Voxels of
// 1 m, a = 0.1, b = 2, depth 6: the crown's tips, one to a voxel in a 5 × 5 layer at 6.5 m, see
// full light, and shade the voxel five layers below them by 25 · 0.1 / 2⁵ = 0.078 (the pyramid
// reaches ±5 voxels there), so the lateral under them has its tip at 1 − 0.078 = 0.92 (its own
// share given back); the lateral 8 m out is 6 voxels from the nearest and sees full light.
// The shade options these known answers are worked out with: 1-m voxels, a = 0.1, b = 2,
// depth 6, and branches shed under `shed` of full light.
FormOptions shadeInMetreVoxels(double shed) {
    FormOptions o;
    o.shadeVoxel = 1.0;
    o.shadeStrength = 0.1;
    o.shadeDecay = 2.0;
    o.shadeDepth = 6;
    o.shadeShed = shed;
    return o;
}

// The crown above: a stem node at 6.2 m over `stem` carrying 25 first-order tips, one to a
// voxel in a 5 × 5 layer at 6.5 m.
void addCrownOfTips(Tree& t, int32_t stem) {
    const int32_t top = addNode(t, stem, {0.5, 6.2, 0.5});
    for (int i = 0; i < 5; ++i) {
        for (int k = 0; k < 5; ++k) addNode(t, top, {i - 1.5, 6.5, k - 1.5}, 0.01, 1);
    }
}

Tree shadedAndOpen(int32_t& under, int32_t& beside) {
    Tree t;
    addNode(t, -1, {0.5, 0, 0.5});
    const int32_t low = addNode(t, 0, {0.5, 1.0, 0.5});
    addCrownOfTips(t, low);
    under = addNode(t, low, {0.6, 1.2, 0.5}, 0.01, 1);
    addNode(t, under, {0.7, 1.4, 0.5}, 0.01, 1);
    beside = addNode(t, low, {8.5, 1.2, 0.5}, 0.01, 1);
    addNode(t, beside, {8.6, 1.4, 0.5}, 0.01, 1);
    return t;
}

TEST(Form, ShadeShedsTheBranchUnderTheCrownAndKeepsTheOneInTheLight) {
    FormOptions o = shadeInMetreVoxels(0.93);
    int32_t under = 0, beside = 0;
    {
        // Under 0.92 of full light: the shaded lateral (two nodes) goes, the open one stays.
        Tree t = shadedAndOpen(under, beside);
        t.leaves = {leafAt(under + 1, {0.7, 1.45, 0.5}), leafAt(beside + 1, {8.6, 1.45, 0.5})};
        t.endpoints = {under + 1, beside + 1};
        const size_t before = t.nodes.size();
        const ShadeShedResult r = shedShadedBranches(t, o);
        EXPECT_EQ(r.branches, 1);
        EXPECT_EQ(r.nodes, 2);
        ASSERT_EQ(t.nodes.size(), before - 2);
        // The open lateral, its leaf and its endpoint are kept (indices moved down by two).
        EXPECT_EQ(t.nodes[beside - 2].position, (Vec3{8.5, 1.2, 0.5}));
        ASSERT_EQ(t.leaves.size(), 1u);
        EXPECT_EQ(t.leaves[0].node, beside - 1);
        EXPECT_EQ(t.endpoints, (std::vector<int32_t>{beside - 1}));
    }
    {
        // Just below its exposure nothing goes; and the top tips, in full light, never do.
        Tree t = shadedAndOpen(under, beside);
        o.shadeShed = 0.91;
        EXPECT_EQ(shedShadedBranches(t, o).branches, 0);
        o.shadeShed = 0.0;
        EXPECT_EQ(shedShadedBranches(t, o).nodes, 0);
    }
    {
        // Twice the decay: the shade five layers down is 25 · 0.1 / 4⁵ = 0.0024 and the lateral
        // stays at 0.93.
        Tree t = shadedAndOpen(under, beside);
        o.shadeShed = 0.93;
        o.shadeDecay = 4.0;
        EXPECT_EQ(shedShadedBranches(t, o).branches, 0);
        // A pyramid only four layers deep does not reach it either.
        o.shadeDecay = 2.0;
        o.shadeDepth = 4;
        EXPECT_EQ(shedShadedBranches(t, o).branches, 0);
    }
}

TEST(Form, ShadeNeverShedsTheStemAndLeavesABareStemTipAnEndpoint) {
    // The stem's side shoot at 1 m carries the only tip below a dense top: shed, the stem
    // stays, and a stem node left without children becomes an endpoint.
    Tree t;
    addNode(t, -1, {0.5, 0, 0.5});
    const int32_t stub = addNode(t, 0, {0.5, 1.0, 0.5});
    addNode(t, stub, {0.6, 1.3, 0.5}, 0.01, 1);
    // The stem's own tips, 40 in one voxel: shaded to nothing by each other, and kept.
    const int32_t top = addNode(t, 0, {0.5, 3.2, 0.5});
    for (int k = 0; k < 40; ++k) addNode(t, top, {0.5, 3.5, 0.5});
    // The side shoot two layers below: 1 − 40 · 0.1 / 2² < 0.
    const ShadeShedResult r = shedShadedBranches(t, shadeInMetreVoxels(0.5));
    EXPECT_EQ(r.branches, 1);
    ASSERT_EQ(t.nodes.size(), 43u);
    EXPECT_EQ(t.nodes[stub].order, 0);
    EXPECT_EQ(t.endpoints, (std::vector<int32_t>{stub}));
}

TEST(Form, ShadeMinOrderKeepsTheLimbsAndShedsTheirShadedShoots) {
    // Under the crown of shadedAndOpen, a first-order limb carrying a second-order shoot.
    int32_t under = 0, beside = 0;
    Tree t = shadedAndOpen(under, beside);
    addNode(t, under + 1, {0.8, 1.45, 0.5}, 0.01, 2);
    FormOptions o = shadeInMetreVoxels(0.93);
    o.shadeMinOrder = 2;  // the limb (order 1) stays; its shoot (order 2) is shed
    const size_t before = t.nodes.size();
    const ShadeShedResult r = shedShadedBranches(t, o);
    EXPECT_EQ(r.branches, 1);
    EXPECT_EQ(r.nodes, 1);
    ASSERT_EQ(t.nodes.size(), before - 1);
    EXPECT_EQ(t.nodes[under].order, 1);
    EXPECT_EQ(t.nodes[under + 1].position, (Vec3{0.7, 1.4, 0.5}));
    // The default, 1: the limb goes with its shoot.
    Tree u = shadedAndOpen(under, beside);
    addNode(u, under + 1, {0.8, 1.45, 0.5}, 0.01, 2);
    o.shadeMinOrder = 1;
    EXPECT_EQ(shedShadedBranches(u, o).nodes, 3);
}

TEST(Form, ShadeSheddingThroughApplyFormIsDeterministicAndOffByDefault) {
    int32_t under = 0, beside = 0;
    Tree a = shadedAndOpen(under, beside), b = a, c = a;
    FormOptions o = shadeInMetreVoxels(0.0);
    EXPECT_FALSE(o.active());
    o.shadeShed = 0.93;
    EXPECT_TRUE(o.active());
    applyForm(a, o, Rng(1));
    applyForm(b, o, Rng(2));  // no randomness in it
    EXPECT_EQ(a.nodes.size(), c.nodes.size() - 2);
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    for (size_t i = 0; i < a.nodes.size(); ++i) EXPECT_EQ(a.nodes[i].position, b.nodes[i].position);
}

TEST(Form, ShadeSheddingBoundsAForkThatLostItsThickChildAsThePipeModelDoes) {
    // A limb under a dense top carries two shoots: 30 tips crowded in one voxel (exposure 0,
    // shed) and one tip out in the open (kept). With pipe radii (n = 2, tips 0.01 m) the limb is
    // √31 · 0.01 thick; left with the open shoot (0.01) it is held to 0.01 / 0.5 under a child
    // ratio of 0.5, and keeps √31 · 0.01 without one.
    auto build = [] {
        Tree t;
        addNode(t, -1, {0.5, 0, 0.5});
        const int32_t n1 = addNode(t, 0, {0.5, 1.0, 0.5});
        addCrownOfTips(t, n1);
        const int32_t limb = addNode(t, n1, {0.6, 1.1, 0.5}, 0.01, 1);
        const int32_t crowded = addNode(t, limb, {0.6, 1.2, 0.5}, 0.01, 2);
        for (int k = 0; k < 30; ++k) addNode(t, crowded, {0.6 + 0.01 * k, 1.4, 0.5}, 0.01, 2);
        const int32_t open = addNode(t, limb, {8.5, 1.2, 0.5}, 0.01, 2);
        addNode(t, open, {8.6, 1.4, 0.5}, 0.01, 2);
        return std::make_pair(t, limb);
    };
    FormOptions o = shadeInMetreVoxels(0.5);
    o.pipeExponent = 2.0;
    o.tipRadius = 0.01;
    o.shadeMinOrder = 2;
    {
        auto [t, limb] = build();
        applyForm(t, o, Rng(1));
        EXPECT_NEAR(t.nodes[limb].radius, std::sqrt(31.0) * 0.01, 1e-12);  // disused pipes
        EXPECT_NEAR(t.nodes[1].radius, std::sqrt(56.0) * 0.01, 1e-12);
    }
    {
        auto [t, limb] = build();
        o.pipeExponentLogSd = 1e-9;  // the bound needs drawn forks; these draw n = 2
        o.pipeMinChildRatio = 0.5;
        const size_t before = t.nodes.size();
        applyForm(t, o, Rng(1));
        ASSERT_EQ(t.nodes.size(), before - 31);
        EXPECT_NEAR(t.nodes[limb].radius, 0.02, 1e-9);
        // And no node is left thicker than twice its thickest child.
        std::vector<double> thickest(t.nodes.size(), 0.0);
        for (size_t i = 1; i < t.nodes.size(); ++i) {
            thickest[t.nodes[i].parent] = std::max(thickest[t.nodes[i].parent], t.nodes[i].radius);
        }
        for (size_t i = 0; i < t.nodes.size(); ++i) {
            if (thickest[i] > 0) {
                EXPECT_LE(t.nodes[i].radius, 2 * thickest[i] * (1 + 1e-12)) << i;
            }
        }
    }
}

TEST(Form, ShadeSheddingKeepsTheShedShootsPipesInWhatCarriedThem) {
    // After the pipe model: the stem below the shed lateral keeps the radius its pipes gave it
    // (Shinozaki's disused pipes), and so does the base.
    int32_t under = 0, beside = 0;
    const Tree grown = shadedAndOpen(under, beside);
    FormOptions o = shadeInMetreVoxels(0.0);
    o.pipeExponent = 2.0;
    o.tipRadius = 0.01;
    Tree kept = grown, shed = grown;
    applyForm(kept, o, Rng(1));
    o.shadeShed = 0.93;
    applyForm(shed, o, Rng(1));
    ASSERT_EQ(shed.nodes.size(), kept.nodes.size() - 2);
    // Root and the stem node at 1 m, where the lateral left: 27 tips' pipes, √27 · 0.01.
    EXPECT_NEAR(kept.nodes[1].radius, std::sqrt(27.0) * 0.01, 1e-12);
    EXPECT_EQ(shed.nodes[0].radius, kept.nodes[0].radius);
    EXPECT_EQ(shed.nodes[1].radius, kept.nodes[1].radius);
}

TEST(FormSpec, ReadsKeysAndRejectsBadValues) {
    const toml::table good = toml::parse(
        "[form]\nclear_bole = 2\npipe_exponent = 2.3\nlean_deg = 4\nground = \"prune\"\n"
        "pipe_exponent_sd = 0.5\nangle_sd_deg = 12\nbend_deg_per_m = -3\nbend_sd_deg_per_m = 2\n"
        "width = 1.1\nlength_sd = 0.3\nangle_shift_deg = -7\nshade_shed = 0.4\n"
        "shade_voxel = 0.3\nshade_strength = 0.2\nshade_decay = 1.5\nshade_depth = 8\n"
        "shade_min_order = 2\n");
    const toml::table logNormal =
        toml::parse("[form]\npipe_exponent = 2.3\npipe_exponent_log_sd = 0.7\n");
    DrawContext draw;
    Params p(good, "s.toml", "", &draw);
    const FormOptions o = readForm(p);
    EXPECT_EQ(o.clearBole, 2.0);
    EXPECT_EQ(o.pipeExponent, 2.3);
    EXPECT_NEAR(o.leanRad, 4 * kPi / 180, 1e-15);
    EXPECT_EQ(o.ground, GroundRule::kPrune);
    EXPECT_EQ(o.pipeExponentSd, 0.5);
    EXPECT_NEAR(o.angleSdRad, 12 * kPi / 180, 1e-15);
    EXPECT_NEAR(o.bendRadPerM, -3 * kPi / 180, 1e-15);
    EXPECT_NEAR(o.bendSdRadPerM, 2 * kPi / 180, 1e-15);
    EXPECT_EQ(o.width, 1.1);
    EXPECT_EQ(o.lengthSd, 0.3);
    EXPECT_NEAR(o.angleShiftRad, -7 * kPi / 180, 1e-15);
    EXPECT_EQ(o.shadeShed, 0.4);
    EXPECT_EQ(o.shadeVoxel, 0.3);
    EXPECT_EQ(o.shadeStrength, 0.2);
    EXPECT_EQ(o.shadeDecay, 1.5);
    EXPECT_EQ(o.shadeDepth, 8);
    EXPECT_EQ(o.shadeMinOrder, 2);
    EXPECT_TRUE(o.active());
    EXPECT_EQ(o.pipeExponentLogSd, 0.0);
    {
        DrawContext d;
        Params q(logNormal, "s.toml", "", &d);
        EXPECT_EQ(readForm(q).pipeExponentLogSd, 0.7);
    }

    auto errorOf = [](const char* text) -> std::string {
        const toml::table t = toml::parse(text);
        DrawContext d;
        Params q(t, "s.toml", "", &d);
        try {
            readForm(q);
        } catch (const SpecError& e) {
            return e.what();
        }
        return "";
    };
    EXPECT_EQ(errorOf("[form]\npipe_exponent = 0.5\n"),
              "s.toml:2:17: form.pipe_exponent: expected 0 (off) or a value in [1, 4]");
    EXPECT_EQ(errorOf("[form]\nground = \"flat\"\n"),
              "s.toml:2:10: form.ground: expected one of \"none\", \"prune\", got \"flat\"");
    EXPECT_EQ(
        errorOf("[form]\npipe_exponent_sd = 0.4\n"),
        "s.toml:2:20: form.pipe_exponent_sd: needs pipe_exponent (the mean it spreads about)");
    EXPECT_EQ(errorOf("[form]\npipe_exponent_log_sd = 0.4\n"),
              "s.toml:2:24: form.pipe_exponent_log_sd: needs pipe_exponent (the median it spreads "
              "about)");
    EXPECT_EQ(
        errorOf("[form]\npipe_exponent = 2\npipe_exponent_sd = 1\npipe_exponent_log_sd = 0.4\n"),
        "s.toml:4:24: form.pipe_exponent_log_sd: set either pipe_exponent_sd or "
        "pipe_exponent_log_sd");
    EXPECT_EQ(errorOf("[form]\npipe_exponent = 2\npipe_exponent_log_sd = 2\n"),
              "s.toml:3:24: form.pipe_exponent_log_sd: expected a number in [0, 1.5], got 2");
    EXPECT_EQ(errorOf("[form]\nshade_voxel = 0.3\n"),
              "s.toml:2:15: form.shade_voxel: needs shade_shed (the light under which branches "
              "go)");
    EXPECT_EQ(errorOf("[form]\nshade_shed = 0.4\nshade_decay = 1\n"),
              "s.toml:3:15: form.shade_decay: expected a number in (1, 100], got 1");
    EXPECT_EQ(errorOf("[form]\nangle_sd_deg = 50\n"),
              "s.toml:2:16: form.angle_sd_deg: expected a number in [0, 45], got 50");
    EXPECT_EQ(errorOf("[form]\npipe_exponent = 2\npipe_exponent_log_median = 2.8\n"),
              "s.toml:3:28: form.pipe_exponent_log_median: needs pipe_exponent_log_sd (the spread "
              "about it)");
    EXPECT_EQ(
        errorOf("[form]\npipe_exponent = 2\npipe_exponent_log_sd = 0.5\n"
                "pipe_exponent_log_median = 0.5\n"),
        "s.toml:4:28: form.pipe_exponent_log_median: expected 0 (pipe_exponent) or a value in "
        "[1, 4]");
    EXPECT_EQ(errorOf("[form]\npipe_exponent = 2\npipe_min_child_ratio = 0.5\n"),
              "s.toml:3:24: form.pipe_min_child_ratio: needs pipe_exponent_log_sd (the forks it "
              "bounds)");
    EXPECT_EQ(errorOf("[form]\npipe_exponent = 2\npipe_exponent_log_sd = 0.5\n"
                      "pipe_min_child_ratio = 1\n"),
              "s.toml:4:24: form.pipe_min_child_ratio: expected a number in [0, 0.9], got 1");
    EXPECT_EQ(errorOf("[form]\nangle_shift_deg = 60\n"),
              "s.toml:2:19: form.angle_shift_deg: expected a number in [-45, 45], got 60");
    EXPECT_EQ(errorOf("[form]\nscael = 1.1\n"),
              "s.toml:2:9: form.scael: unknown key; did you mean \"scale\"?");
}

}  // namespace
}  // namespace sylva
