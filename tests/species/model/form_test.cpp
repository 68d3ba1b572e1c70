// The form stage (species/model/form.h) on hand-built skeletons with known answers: pipe-model
// radii, the clear bole, scale, asymmetry, lean and the ground plane, leaves following their
// twigs; and its reader's ranges.
#include "species/model/form.h"

#include <gtest/gtest.h>

#include <cmath>

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

TEST(FormSpec, ReadsKeysAndRejectsBadValues) {
    const toml::table good = toml::parse(
        "[form]\nclear_bole = 2\npipe_exponent = 2.3\nlean_deg = 4\nground = \"prune\"\n");
    DrawContext draw;
    Params p(good, "s.toml", "", &draw);
    const FormOptions o = readForm(p);
    EXPECT_EQ(o.clearBole, 2.0);
    EXPECT_EQ(o.pipeExponent, 2.3);
    EXPECT_NEAR(o.leanRad, 4 * kPi / 180, 1e-15);
    EXPECT_EQ(o.ground, GroundRule::kPrune);
    EXPECT_TRUE(o.active());

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
    EXPECT_EQ(errorOf("[form]\nscael = 1.1\n"),
              "s.toml:2:9: form.scael: unknown key; did you mean \"scale\"?");
}

}  // namespace
}  // namespace sylva
