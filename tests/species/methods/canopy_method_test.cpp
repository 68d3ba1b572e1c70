// The canopy method (Shesh et al. §3): L-system expansion and turtle, Murray radii, the
// envelope clipping test, area-uniform leaves on the envelope, sun orientation, support,
// template choice, determinism, leaf support (twigs to the leaves, the leaf margin) and the
// spec reader.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "species/methods/canopy.h"
#include "species/model/realism_metrics.h"
#include "species/model/tree_metrics.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

constexpr double kDeg = kPi / 180.0;

// A plain ellipsoid envelope (g0 = 1, no layers, no jitter): f ≡ 1, so the surface is the
// ellipsoid with radii k exactly.
std::shared_ptr<const CanopyEnvelope> plainEnvelope(Vec3 radii,
                                                    CanopyDomain d = CanopyDomain::kEllipsoid) {
    CanopyEnvelopeOptions o;
    o.domain = d;
    o.radii = radii;
    o.jitter = 0.0;
    Rng rng(1);
    return makeCanopyEnvelope(o, rng);
}

// A lumpy one: blobs and noise, jittered angles.
std::shared_ptr<const CanopyEnvelope> lumpyEnvelope(CanopyDomain d = CanopyDomain::kEllipsoid) {
    CanopyEnvelopeOptions o;
    o.domain = d;
    o.radii = d == CanopyDomain::kCone ? Vec3{2.0, 6.0, 2.0} : Vec3{2.5, 2.0, 2.5};
    CanopyLayer blobs;
    blobs.count = 8;
    blobs.sigma = 0.1;
    blobs.amplitude = 0.6;
    CanopyLayer noise;
    noise.kind = CanopyLayer::Kind::kNoise;
    noise.resolution = 8;
    noise.amplitude = 0.3;
    o.layers = {blobs, noise};
    Rng rng(5);
    return makeCanopyEnvelope(o, rng);
}

BranchTemplate bushTemplate(int iterations = 5) {
    BranchTemplate t;
    t.lsystem.axiom = "FX";
    t.lsystem.rules['X'] = {{"F[&&X]/////F[&&X]///////F[&X]X", 1.0}};
    t.angle = 25 * kDeg;
    t.roll = 22.5 * kDeg;
    t.lengthRatio = 0.8;
    t.iterations = iterations;
    return t;
}

CanopyOptions baseOptions(std::shared_ptr<const CanopyEnvelope> env, Vec3 position) {
    CanopyOptions o;
    o.envelope = std::move(env);
    o.position = position;
    o.templates = {bushTemplate()};
    o.leaves.count = 0;
    return o;
}

int count(const std::string& s, char c) {
    return static_cast<int>(std::count(s.begin(), s.end(), c));
}

// --- L-system ---------------------------------------------------------------------------------

TEST(CanopyLSystem, AlgaeAndKochExpandToTheKnownWords) {
    // Lindenmayer's algae: A → AB, B → A; lengths are Fibonacci numbers.
    LSystem algae;
    algae.axiom = "A";
    algae.rules['A'] = {{"AB", 1.0}};
    algae.rules['B'] = {{"A", 1.0}};
    Rng rng(1);
    const char* words[] = {"A", "AB", "ABA", "ABAAB", "ABAABABA", "ABAABABAABAAB"};
    for (int n = 0; n < 6; ++n) EXPECT_EQ(expandLSystem(algae, n, rng), words[n]) << n;
    EXPECT_EQ(expandLSystem(algae, 10, rng).size(), 144u);  // F(12)
    EXPECT_DOUBLE_EQ(lsystemSizeBound(algae, 10).length, 144.0);

    // Quadratic Koch island (ABOP Fig. 1.7b's generator): every F becomes 5 F and 4 turns.
    LSystem koch;
    koch.axiom = "F";
    koch.rules['F'] = {{"F+F-F-F+F", 1.0}};
    for (int n = 0; n <= 4; ++n) {
        const std::string w = expandLSystem(koch, n, rng);
        EXPECT_EQ(count(w, 'F'), static_cast<int>(std::pow(5, n))) << n;
        EXPECT_EQ(w.size(), static_cast<size_t>(2 * std::pow(5, n) - 1)) << n;
        EXPECT_DOUBLE_EQ(lsystemSizeBound(koch, n).segments, std::pow(5, n));
        EXPECT_DOUBLE_EQ(lsystemSizeBound(koch, n).length, 2 * std::pow(5, n) - 1);
    }
    // Whitespace is not a symbol.
    koch.rules['F'] = {{"F + F - F - F + F", 1.0}};
    EXPECT_EQ(expandLSystem(koch, 1, rng), "F+F-F-F+F");
}

TEST(CanopyLSystem, StochasticRulesFollowTheirProbabilities) {
    LSystem s;
    s.axiom = std::string(8000, 'X');
    s.rules['X'] = {{"A", 0.25}, {"BB", 0.75}};
    Rng rng(3);
    const std::string w = expandLSystem(s, 1, rng);
    const int a = count(w, 'A'), b = count(w, 'B');
    EXPECT_EQ(a + b / 2, 8000);
    // Binomial(8000, 0.25): σ ≈ 38.7; 5σ.
    EXPECT_NEAR(a, 2000, 194);
    // The bound takes, per symbol, the most of it any successor makes: 1 A and 2 B per X.
    EXPECT_DOUBLE_EQ(lsystemSizeBound(s, 1).length, 24000.0);
    // Another seed, another word; the same seed, the same word.
    Rng again(3), other(4);
    EXPECT_EQ(expandLSystem(s, 1, again), w);
    EXPECT_NE(expandLSystem(s, 1, other), w);
}

TEST(CanopyLSystem, WordCheckNamesTheBadSymbol) {
    EXPECT_EQ(checkLSystemWord("F[+F]F[-F]&^\\/|AXYZ"), "");
    EXPECT_NE(checkLSystemWord("F[+x]").find("unknown L-system symbol 'x' at position 4"),
              std::string::npos);
    EXPECT_NE(checkLSystemWord("FfF").find("'f'"), std::string::npos);
    EXPECT_NE(checkLSystemWord("F!F").find("Murray"), std::string::npos);
    EXPECT_NE(checkLSystemWord("F]F[").find("']' without"), std::string::npos);
    EXPECT_NE(checkLSystemWord("F[F").find("unclosed"), std::string::npos);
}

// --- turtle and Murray -------------------------------------------------------------------------

TEST(CanopyTurtle, TurnsPitchesRollsAndBranches) {
    BranchTemplate t;
    t.angle = 90 * kDeg;
    t.roll = 90 * kDeg;
    Rng rng(1);
    auto near = [](const Vec3& a, const Vec3& b) { return distance(a, b) < 1e-12; };
    // + turns the heading (+y) toward left (−x); − toward +x.
    Tree a = interpretTurtle("F+F", t, rng);
    ASSERT_EQ(a.nodes.size(), 3u);
    EXPECT_TRUE(near(a.nodes[1].position, {0, 1, 0}));
    EXPECT_TRUE(near(a.nodes[2].position, {-1, 1, 0}));
    EXPECT_TRUE(near(interpretTurtle("F-F", t, rng).nodes[2].position, {1, 1, 0}));
    // & pitches down: heading toward −up (−z); ^ toward +z.
    EXPECT_TRUE(near(interpretTurtle("F&F", t, rng).nodes[2].position, {0, 1, -1}));
    EXPECT_TRUE(near(interpretTurtle("F^F", t, rng).nodes[2].position, {0, 1, 1}));
    // \ rolls left toward up: after it, + turns toward the old up (+z).
    EXPECT_TRUE(near(interpretTurtle("F\\+F", t, rng).nodes[2].position, {0, 1, 1}));
    EXPECT_TRUE(near(interpretTurtle("F/+F", t, rng).nodes[2].position, {0, 1, -1}));
    EXPECT_TRUE(near(interpretTurtle("F|F", t, rng).nodes[2].position, {0, 0, 0}));
    // Brackets: the branch hangs from node 1, the main axis continues from node 1 too.
    t.step = 2.0;
    t.lengthRatio = 0.5;
    Tree b = interpretTurtle("F[+F[-F]]F", t, rng);
    ASSERT_EQ(b.nodes.size(), 5u);
    EXPECT_EQ(b.nodes[2].parent, 1);
    EXPECT_EQ(b.nodes[3].parent, 2);
    EXPECT_EQ(b.nodes[4].parent, 1);
    EXPECT_EQ(b.nodes[1].order, 0);
    EXPECT_EQ(b.nodes[2].order, 1);
    EXPECT_EQ(b.nodes[3].order, 2);
    EXPECT_EQ(b.nodes[4].order, 0);
    EXPECT_TRUE(near(b.nodes[2].position, {-1, 2, 0}));    // step 2 × 0.5
    EXPECT_TRUE(near(b.nodes[3].position, {-1, 2.5, 0}));  // step 2 × 0.25
    EXPECT_TRUE(near(b.nodes[4].position, {0, 4, 0}));
    // Variables draw nothing.
    EXPECT_EQ(interpretTurtle("AXFBFZ", t, rng).nodes.size(), 3u);
}

TEST(CanopyTurtle, MurraysRuleHoldsAtEveryTemplateFork) {
    const BranchTemplate t = bushTemplate(5);
    Rng rng(2);
    Tree tree = interpretTurtle(expandLSystem(t.lsystem, t.iterations, rng), t, rng);
    ASSERT_GT(tree.nodes.size(), 500u);
    murrayRadii(tree, 0.01, 3.0);
    const ChildIndex children(tree);
    int forks = 0;
    for (int32_t i = 0; i < static_cast<int32_t>(tree.nodes.size()); ++i) {
        if (children.count(i) == 0) {
            EXPECT_EQ(tree.nodes[i].radius, 0.01);
            continue;
        }
        double sum = 0.0;
        for (int k = children.offset[i]; k < children.offset[i + 1]; ++k) {
            sum += std::pow(tree.nodes[children.child[k]].radius, 3);
        }
        EXPECT_NEAR(std::pow(tree.nodes[i].radius, 3), sum, 1e-9 * sum) << i;
        forks += children.count(i) > 1;
    }
    EXPECT_GT(forks, 100);
    // The root carries every tip: r0³ = tips · r_tip³.
    int tips = 0;
    for (int32_t i = 0; i < static_cast<int32_t>(tree.nodes.size()); ++i)
        tips += children.count(i) == 0;
    EXPECT_NEAR(std::pow(tree.nodes[0].radius, 3), tips * 1e-6, 1e-9 * tips * 1e-6);
    // Exponent 2 (pipe model): areas add.
    murrayRadii(tree, 0.01, 2.0);
    EXPECT_NEAR(tree.nodes[0].radius * tree.nodes[0].radius, tips * 1e-4, 1e-9 * tips * 1e-4);
}

// --- clipping ---------------------------------------------------------------------------------

// Bole nodes: the chain of single children from the root up to the trunk top.
std::vector<char> boleOf(const Tree& tree, double top) {
    std::vector<char> bole(tree.nodes.size(), 0);
    const ChildIndex children(tree);
    int32_t cur = 0;
    bole[0] = 1;
    while (tree.nodes[cur].position.y < top - 1e-9 && children.count(cur) == 1) {
        cur = children.child[children.offset[cur]];
        bole[cur] = 1;
    }
    EXPECT_NEAR(tree.nodes[cur].position.y, top, 1e-9);
    return bole;
}

TEST(CanopyClip, NoNodeLeavesASphereBeyondTheThreshold) {
    const double r = 2.0;
    CanopyOptions o = baseOptions(plainEnvelope({r, r, r}), {0, 5, 0});
    o.templates[0].lsystem.axiom = "X";  // no bole in the template: a straight one is added
    for (double threshold : {0.0, 0.1, 0.3}) {
        o.branches.clipThreshold = threshold;
        Rng rng(11);
        CanopyStats st;
        const Tree tree = growCanopy(o, rng, &st);
        const double top = canopyTrunkHeight(o);
        EXPECT_DOUBLE_EQ(top, 5.0 - 0.9 * r);
        EXPECT_DOUBLE_EQ(st.trunkHeight, top);
        // The template outgrew the sphere: something was cut, and much was kept.
        EXPECT_LT(st.keptSegments, st.templateSegments);
        EXPECT_GT(st.keptSegments, 200);
        double far = 0.0;
        const std::vector<char> bole = boleOf(tree, top);
        for (size_t i = 0; i < tree.nodes.size(); ++i) {
            const SkeletonNode& n = tree.nodes[i];
            if (bole[i]) continue;
            const double d = distance(n.position, o.position);
            EXPECT_LE(d, (1 + threshold) * r * (1 + 1e-12));
            far = std::max(far, d / r);
        }
        // The threshold is used, not something stricter.
        EXPECT_GT(far, threshold > 0 ? 1.0 + 0.5 * threshold : 0.95);
        // Node 0 at the origin; the bole reaches the trunk top.
        EXPECT_EQ(tree.nodes[0].position.x, 0.0);
        EXPECT_EQ(tree.nodes[0].position.y, 0.0);
        bool reached = false;
        for (const SkeletonNode& n : tree.nodes)
            reached |= distance(n.position, {0, top, 0}) < 1e-9;
        EXPECT_TRUE(reached);
    }
}

TEST(CanopyClip, LumpyEnvelopesClipAtTheirSurface) {
    for (CanopyDomain d : {CanopyDomain::kEllipsoid, CanopyDomain::kCone}) {
        CanopyOptions o = baseOptions(lumpyEnvelope(d), {0.5, 4, -0.3});
        o.branches.clipThreshold = 0.05;
        o.branches.murrayOn = MurrayOn::kClipped;
        const CanopyEnvelope& env = *o.envelope;
        Rng rng(4);
        CanopyStats st;
        const Tree tree = growCanopy(o, rng, &st);
        EXPECT_LT(st.keptSegments, st.templateSegments);
        EXPECT_GT(st.keptSegments, 100);
        const std::vector<char> bole = boleOf(tree, canopyTrunkHeight(o));
        for (size_t i = 0; i < tree.nodes.size(); ++i) {
            const SkeletonNode& n = tree.nodes[i];
            if (bole[i]) continue;
            // The paper's test, computed here from surfacePoint alone.
            const Vec3 p = n.position - o.position;
            const Vec2 a = env.angles(p);
            const Vec3 s = env.surfacePoint(a.x, a.y);
            if (d == CanopyDomain::kEllipsoid) {
                EXPECT_LE(length(p), 1.05 * length(s) * (1 + 1e-12));
            } else {
                // Below the base and above the apex the ratio is a height over ky.
                EXPECT_GE(p.y, -0.05 * env.radii().y);
                EXPECT_LE(p.y, 1.05 * env.radii().y);
                EXPECT_LE(std::hypot(p.x, p.z), 1.05 * std::hypot(s.x, s.z) * (1 + 1e-12));
            }
        }
        // Radii from Murray's rule over the clipped tree: it holds at every fork.
        const ChildIndex children(tree);
        for (int32_t i = 0; i < static_cast<int32_t>(tree.nodes.size()); ++i) {
            if (children.count(i) == 0) continue;
            double sum = 0.0;
            for (int k = children.offset[i]; k < children.offset[i + 1]; ++k) {
                sum += std::pow(tree.nodes[children.child[k]].radius, 3);
            }
            EXPECT_NEAR(std::pow(tree.nodes[i].radius, 3), sum, 1e-9 * sum);
        }
        // Endpoints are exactly the tips.
        size_t tips = 0;
        for (int32_t i = 1; i < static_cast<int32_t>(tree.nodes.size()); ++i)
            tips += children.count(i) == 0;
        EXPECT_EQ(tree.endpoints.size(), tips);
    }
}

TEST(CanopyClip, TemplateRadiiKeepTheWholeTemplatesThickness) {
    CanopyOptions o = baseOptions(plainEnvelope({2, 2, 2}), {0, 5, 0});
    o.branches.randomYaw = false;
    o.branches.outgrow = 1.6;
    Rng a(8), b(8);
    o.branches.murrayOn = MurrayOn::kClipped;
    const Tree clipped = growCanopy(o, a);
    o.branches.murrayOn = MurrayOn::kTemplate;
    const Tree templ = growCanopy(o, b);
    ASSERT_EQ(clipped.nodes.size(), templ.nodes.size());
    int tips = 0;
    const ChildIndex ch(clipped);
    for (size_t i = 0; i < clipped.nodes.size(); ++i) tips += ch.count(int(i)) == 0;
    EXPECT_NEAR(std::pow(clipped.nodes[0].radius, 3), tips * 1e-6, 1e-15);
    // The template has more tips than survive, so its trunk is thicker.
    EXPECT_GT(templ.nodes[0].radius, clipped.nodes[0].radius * 1.05);
}

TEST(CanopyClip, OutgrowSetsTheMedianReach) {
    // A larger outgrow scales the template up, and more of it is cut.
    CanopyOptions o = baseOptions(plainEnvelope({2, 2, 2}), {0, 5, 0});
    CanopyStats small, large;
    Rng a(3), b(3);
    o.branches.outgrow = 1.05;
    growCanopy(o, a, &small);
    o.branches.outgrow = 2.0;
    growCanopy(o, b, &large);
    EXPECT_GT(large.scaleY, 1.5 * small.scaleY);
    EXPECT_LT(large.keptSegments, small.keptSegments);
    // fit = "none": the template as drawn.
    o.branches.fit = TemplateFit::kNone;
    CanopyStats none;
    Rng c(3);
    growCanopy(o, c, &none);
    EXPECT_EQ(none.scaleY, 1.0);
    EXPECT_EQ(none.scaleXZ, 1.0);
}

// --- leaves -----------------------------------------------------------------------------------

TEST(CanopyLeaves, LieOnTheEnvelopeSurfaceAndCountCountTimesCluster) {
    for (CanopyDomain d : {CanopyDomain::kEllipsoid, CanopyDomain::kCone}) {
        CanopyOptions o = baseOptions(lumpyEnvelope(d), {0, 4, 0});
        o.leaves.count = 2000;
        const CanopyEnvelope& env = *o.envelope;
        Rng rng(6);
        const Tree tree = growCanopy(o, rng);
        ASSERT_EQ(tree.leaves.size(), 2000u);
        for (const Leaf& leaf : tree.leaves) {
            const Vec3 p = leaf.position - o.position;
            const Vec2 a = env.angles(p);
            const Vec3 s = env.surfacePoint(a.x, a.y);
            if (d == CanopyDomain::kEllipsoid) {
                EXPECT_NEAR(length(p), length(s), 1e-9 * 2.5);
            } else {
                EXPECT_NEAR(std::hypot(p.x, p.z), std::hypot(s.x, s.z), 1e-9 * 6.0);
            }
            EXPECT_NEAR(length(leaf.normal), 1.0, 1e-12);
            EXPECT_NEAR(dot(leaf.normal, leaf.tangent), 0.0, 1e-12);
        }
        // Depth pulls each position inward along its ray (the cone: toward the axis).
        o.leaves.depth = 0.2;
        Rng deep(6);
        double lo = 1.0;
        for (const Leaf& leaf : growCanopy(o, deep).leaves) {
            const double r = envelopeRatio(env, leaf.position - o.position);
            EXPECT_LE(r, 1.0 + 1e-9);
            EXPECT_GE(r, 0.8 - 1e-9);
            lo = std::min(lo, r);
        }
        EXPECT_LT(lo, 0.81);
        o.leaves.cluster = 5;
        Rng again(6);
        EXPECT_EQ(growCanopy(o, again).leaves.size(), 2000u * 5);
    }
}

TEST(CanopyLeaves, AreSpreadByAreaNotByAngle) {
    // Unit sphere: the cap θ < 0.3 holds (1 − cos 0.3)/2 = 2.23 % of the area (uniform angles
    // would put 9.5 % there), the cap y > 0.5 a quarter.
    const auto sphere = plainEnvelope({1, 1, 1});
    const CanopySurfaceSampler s(*sphere);
    EXPECT_NEAR(s.area(), 4 * kPi, 4 * kPi * 1e-3);
    Rng rng(9);
    const int n = 40000;
    int pole = 0, cap = 0;
    for (int i = 0; i < n; ++i) {
        const Vec2 a = s.sample(rng);
        pole += a.y < 0.3;
        cap += std::cos(a.y) > 0.5;
    }
    const double p = (1 - std::cos(0.3)) / 2;
    EXPECT_NEAR(pole / double(n), p, 5 * std::sqrt(p * (1 - p) / n));
    EXPECT_NEAR(cap / double(n), 0.25, 5 * std::sqrt(0.25 * 0.75 / n));
    // Cone: lateral area within apex distance t grows as t², so θ < π/2 holds a quarter.
    const auto cone = plainEnvelope({1, 3, 1}, CanopyDomain::kCone);
    const CanopySurfaceSampler c(*cone);
    EXPECT_NEAR(c.area(), kPi * std::sqrt(10.0), kPi * std::sqrt(10.0) * 1e-3);  // π r ℓ
    int upper = 0;
    for (int i = 0; i < n; ++i) upper += c.sample(rng).y < kPi / 2;
    EXPECT_NEAR(upper / double(n), 0.25, 5 * std::sqrt(0.25 * 0.75 / n));
}

TEST(CanopyLeaves, SunOrientationTurnsNormalsTowardTheSun) {
    CanopyOptions o = baseOptions(plainEnvelope({2, 2, 2}), {0, 5, 0});
    o.leaves.count = 4000;
    o.leaves.sun = normalize(Vec3{1, 2, 0});
    auto meanFacing = [&](LeafOrientation orientation) {
        o.leaves.orientation = orientation;
        Rng rng(12);
        const Tree tree = growCanopy(o, rng);
        double sum = 0.0;
        for (const Leaf& leaf : tree.leaves) sum += dot(leaf.normal, o.leaves.sun);
        return sum / tree.leaves.size();
    };
    const double random = meanFacing(LeafOrientation::kRandom);
    const double sun = meanFacing(LeafOrientation::kSun);
    EXPECT_NEAR(random, 0.0, 0.05);  // σ of the mean ≈ 0.009
    EXPECT_GT(sun, 0.8);
}

TEST(CanopyLeaves, ColourClassesTakeTheirExactShares) {
    CanopyOptions o = baseOptions(plainEnvelope({2, 2, 2}), {0, 5, 0});
    o.leaves.count = 1000;
    o.leaves.cluster = 2;
    o.leaves.colourFractions = {0.6, 0.3, 0.1};
    for (double patchiness : {0.0, 1.0}) {
        o.leaves.colourPatchiness = patchiness;
        Rng rng(13);
        const Tree tree = growCanopy(o, rng);
        int n[3] = {0, 0, 0};
        for (const Leaf& leaf : tree.leaves) ++n[leaf.colour];
        EXPECT_EQ(n[0], 1200);
        EXPECT_EQ(n[1], 600);
        EXPECT_EQ(n[2], 200);
    }
    // Entries map to given classes.
    o.leaves.colourClasses = {6, 1, 5};
    Rng rng(13);
    int n[8] = {0};
    for (const Leaf& leaf : growCanopy(o, rng).leaves) ++n[leaf.colour];
    EXPECT_EQ(n[6], 1200);
    EXPECT_EQ(n[1], 600);
    EXPECT_EQ(n[5], 200);
}

TEST(CanopyLeaves, UnsupportedFractionIsReported) {
    CanopyOptions o = baseOptions(plainEnvelope({2, 2, 2}), {0, 5, 0});
    o.leaves.count = 1500;
    CanopyStats st;
    o.leaves.supportDistance = 1e6;
    Rng a(14);
    const Tree all = growCanopy(o, a, &st);
    EXPECT_EQ(st.unsupportedLeaves, 0);
    EXPECT_EQ(st.unsupportedLeafFraction, 0.0);
    // Every leaf hangs from its nearest node (brute force on a sample).
    for (size_t k = 0; k < all.leaves.size(); k += 97) {
        const Leaf& leaf = all.leaves[k];
        ASSERT_GE(leaf.node, 0);
        double best = 1e300;
        for (const SkeletonNode& n : all.nodes)
            best = std::min(best, distance(n.position, leaf.position));
        EXPECT_NEAR(distance(all.nodes[leaf.node].position, leaf.position), best, 1e-12);
    }
    o.leaves.supportDistance = 1e-6;
    Rng b(14);
    const Tree none = growCanopy(o, b, &st);
    EXPECT_EQ(st.unsupportedLeaves, 1500);
    EXPECT_EQ(st.unsupportedLeafFraction, 1.0);
    // In between: the fraction is the share of leaves without a node.
    o.leaves.supportDistance = 0.3;
    Rng c(14);
    const Tree some = growCanopy(o, c, &st);
    int without = 0;
    for (const Leaf& leaf : some.leaves) {
        if (leaf.node < 0) {
            ++without;
        } else {
            EXPECT_LE(distance(some.nodes[leaf.node].position, leaf.position), 0.3);
        }
    }
    EXPECT_EQ(st.unsupportedLeaves, without);
    EXPECT_DOUBLE_EQ(st.unsupportedLeafFraction, without / 1500.0);
    EXPECT_GT(without, 0);
    EXPECT_LT(without, 1500);
}

// --- templates, determinism ------------------------------------------------------------------

TEST(CanopyGrow, TemplateChoiceVariesWithTheSeedByWeight) {
    CanopyOptions o = baseOptions(plainEnvelope({2, 2, 2}), {0, 5, 0});
    BranchTemplate small = bushTemplate(2);
    small.weight = 3.0;
    o.templates = {bushTemplate(3), small};
    int second = 0;
    const int n = 400;
    for (int seed = 0; seed < n; ++seed) {
        Rng rng(seed);
        CanopyStats st;
        growCanopy(o, rng, &st);
        second += st.templateIndex == 1;
    }
    EXPECT_NEAR(second / double(n), 0.75, 5 * std::sqrt(0.75 * 0.25 / n));
}

TEST(CanopyGrow, SameSeedSameTreeOtherSeedOtherTree) {
    CanopyOptions o = baseOptions(lumpyEnvelope(), {0, 4, 0});
    o.leaves.count = 500;
    o.leaves.cluster = 3;
    o.leaves.colourFractions = {0.5, 0.5};
    o.templates[0].angleJitter = 5 * kDeg;
    auto grow = [&](uint64_t seed) {
        Rng rng(seed);
        return growCanopy(o, rng);
    };
    auto differ = [](const Vec3& a, const Vec3& b) {
        return !(a.x == b.x && a.y == b.y && a.z == b.z);
    };
    auto same = [&](const Tree& a, const Tree& b) {
        if (a.nodes.size() != b.nodes.size() || a.leaves.size() != b.leaves.size()) return false;
        for (size_t i = 0; i < a.nodes.size(); ++i) {
            const SkeletonNode &x = a.nodes[i], &y = b.nodes[i];
            if (differ(x.position, y.position) || x.radius != y.radius || x.parent != y.parent ||
                x.order != y.order)
                return false;
        }
        for (size_t i = 0; i < a.leaves.size(); ++i) {
            const Leaf &x = a.leaves[i], &y = b.leaves[i];
            if (differ(x.position, y.position) || differ(x.normal, y.normal) ||
                differ(x.tangent, y.tangent) || x.size != y.size || x.colour != y.colour ||
                x.node != y.node)
                return false;
        }
        return a.endpoints == b.endpoints;
    };
    const Tree a = grow(21);
    EXPECT_TRUE(same(a, grow(21)));
    EXPECT_FALSE(same(a, grow(22)));
    // A shared surface sampler gives the same tree as one built per call.
    const CanopySurfaceSampler sampler(*o.envelope);
    Rng rng(21);
    EXPECT_TRUE(same(a, growCanopy(o, rng, nullptr, &sampler)));
}

// --- leaf support -----------------------------------------------------------------------------

// A sphere of radius 1.5 m, 3 m up, with 1,500 leaves; twigs grown to them.
CanopyOptions supportedOptions(double margin = 0.2) {
    CanopyOptions o = baseOptions(plainEnvelope({1.5, 1.5, 1.5}), {0, 3, 0});
    o.templates = {bushTemplate(4)};
    o.leaves.count = 1500;
    o.leaves.sizeMin = 0.06;
    o.leaves.sizeMax = 0.1;
    o.branches.leafMargin = margin;
    o.support.mode = LeafSupport::kTwigs;
    o.support.reach = 1.2;
    o.support.step = 0.06;
    o.support.attach = 0.1;
    return o;
}

std::vector<Vec3> attachments(const Tree& t) {
    std::vector<Vec3> out;
    for (const Leaf& l : t.leaves) out.push_back(l.position - l.tangent * (0.5 * l.size));
    return out;
}

TEST(CanopySupport, EveryLeafIsCarriedWithinTheAttachDistance) {
    const CanopyOptions o = supportedOptions();
    Rng rng(31);
    CanopyStats st;
    const Tree tree = growCanopy(o, rng, &st);
    EXPECT_GT(st.twigNodes, 100);
    EXPECT_EQ(st.unsupportedLeaves, 0);
    EXPECT_EQ(static_cast<int64_t>(tree.leaves.size()) + st.droppedLeaves, 1500);
    EXPECT_LT(st.droppedLeaves, 15);  // the sphere is well inside the reach of its template
    // The carrying node is within the kill distance of the attachment, so the wood is too.
    const std::vector<Vec3> at = attachments(tree);
    const std::vector<double> wood = woodDistances(tree, at);
    double worst = 0.0;
    for (size_t k = 0; k < tree.leaves.size(); ++k) {
        const Leaf& l = tree.leaves[k];
        ASSERT_GE(l.node, 0);
        ASSERT_LT(l.node, static_cast<int32_t>(tree.nodes.size()));
        EXPECT_LE(distance(tree.nodes[l.node].position, at[k]), o.support.attach + 1e-12);
        EXPECT_LE(wood[k], o.support.attach + 1e-12);
        worst = std::max(worst, wood[k]);
    }
    EXPECT_GT(worst, 0.0);
    // Every grown twig carries a leaf at its tip (twigs that reach none are shed).
    const ChildIndex children(tree);
    std::vector<char> carries(tree.nodes.size(), 0);
    for (const Leaf& l : tree.leaves) carries[l.node] = 1;
    for (size_t i = tree.nodes.size() - static_cast<size_t>(st.twigNodes); i < tree.nodes.size();
         ++i) {
        if (children.count(static_cast<int32_t>(i)) == 0) {
            EXPECT_TRUE(carries[i]) << i;
        }
    }
    // Without support the same leaves float (the paper's rule): most are far from the wood.
    CanopyOptions off = o;
    off.support.mode = LeafSupport::kNone;
    off.branches.leafMargin = 0.0;
    Rng again(31);
    const Tree bare = growCanopy(off, again);
    const std::vector<double> far = woodDistances(bare, attachments(bare));
    EXPECT_GT(quantile(far, 0.95), 2 * o.support.attach);
}

TEST(CanopySupport, NoWoodBeyondTheEnvelopeOrInsideTheLeafMargin) {
    const double r = 1.5, margin = 0.2;
    CanopyOptions o = supportedOptions(margin);
    // The trunk top well inside (its default, 0.9 r below the centre, lies in the margin band,
    // and the first limbs leave it through the band).
    o.branches.trunkHeight = 2.0;
    Rng rng(32);
    CanopyStats st;
    const Tree tree = growCanopy(o, rng, &st);
    const size_t firstTwig = tree.nodes.size() - static_cast<size_t>(st.twigNodes);
    const std::vector<char> bole = boleOf(tree, canopyTrunkHeight(o));
    double deepest = 0.0;  // the template's closest approach to the surface
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
        const double d = distance(tree.nodes[i].position, o.position);
        if (i >= firstTwig) {
            EXPECT_LE(d, r + 1e-9) << i;  // twigs stay inside the envelope
        } else if (!bole[i]) {
            EXPECT_LE(d, r - margin + 1e-9) << i;  // the template stops below the leaf layer
            deepest = std::max(deepest, d);
        }
    }
    EXPECT_GT(deepest, r - margin - 0.2);  // the template reaches up to the margin
    // The tips' tubes too: no tip pokes out through the sphere.
    for (int32_t e : tree.endpoints) {
        const SkeletonNode& n = tree.nodes[e];
        EXPECT_LE(distance(n.position, o.position) + n.radius, r + o.branches.tipRadius);
    }
    // Without the margin the clipped template pokes beyond r − margin (the paper's rule keeps
    // nodes up to (1 + threshold) r).
    CanopyOptions paper = o;
    paper.support.mode = LeafSupport::kNone;
    paper.branches.leafMargin = 0.0;
    Rng again(32);
    double out = 0.0;
    for (const SkeletonNode& n : growCanopy(paper, again).nodes)
        out = std::max(out, distance(n.position, o.position));
    EXPECT_GT(out, r);
}

TEST(CanopySupport, TwigsHaveOrdersAndMurrayRadii) {
    for (MurrayOn radii : {MurrayOn::kClipped, MurrayOn::kTemplate}) {
        CanopyOptions o = supportedOptions();
        o.branches.murrayOn = radii;
        Rng rng(33);
        CanopyStats st;
        const Tree tree = growCanopy(o, rng, &st);
        const size_t firstTwig = tree.nodes.size() - static_cast<size_t>(st.twigNodes);
        const ChildIndex children(tree);
        for (size_t i = firstTwig; i < tree.nodes.size(); ++i) {
            const SkeletonNode& n = tree.nodes[i];
            const int32_t po = tree.nodes[n.parent].order;
            EXPECT_TRUE(n.order == po || n.order == po + 1) << i;
            EXPECT_EQ(n.level, n.order);
            EXPECT_LT(n.parent, static_cast<int32_t>(i));
        }
        // At most one child of a node continues its order.
        for (int32_t i = 0; i < static_cast<int32_t>(tree.nodes.size()); ++i) {
            int same = 0;
            for (int k = children.offset[i]; k < children.offset[i + 1]; ++k)
                same += tree.nodes[children.child[k]].order == tree.nodes[i].order;
            EXPECT_LE(same, 1) << i;
        }
        // Murray's rule: tips have the tip radius (clipped radii) and every fork carries its
        // children (equality for clipped radii; template radii add the clipped-off flow).
        for (int32_t i = 0; i < static_cast<int32_t>(tree.nodes.size()); ++i) {
            const double r = tree.nodes[i].radius;
            if (children.count(i) == 0) {
                if (radii == MurrayOn::kClipped) {
                    EXPECT_EQ(r, o.branches.tipRadius);
                }
                EXPECT_GE(r, o.branches.tipRadius * (1 - 1e-12));
                continue;
            }
            double sum = 0.0;
            for (int k = children.offset[i]; k < children.offset[i + 1]; ++k)
                sum += std::pow(tree.nodes[children.child[k]].radius, 3);
            if (radii == MurrayOn::kClipped) {
                EXPECT_NEAR(std::pow(r, 3), sum, 1e-9 * sum) << i;
            } else {
                EXPECT_GE(std::pow(r, 3), sum * (1 - 1e-9)) << i;
            }
        }
        // Endpoints are the tips.
        size_t tips = 0;
        for (int32_t i = 1; i < static_cast<int32_t>(tree.nodes.size()); ++i)
            tips += children.count(i) == 0;
        EXPECT_EQ(tree.endpoints.size(), tips);
    }
}

TEST(CanopySupport, WithoutLeavesTheRadiiAreThoseOfTheClippedTemplate) {
    // No leaves, no twigs: cutting segments into pieces changes no radius, and "template"
    // radii keep the whole template's thickness exactly.
    for (MurrayOn radii : {MurrayOn::kClipped, MurrayOn::kTemplate}) {
        CanopyOptions o = supportedOptions(0.0);
        o.leaves.count = 0;
        o.branches.murrayOn = radii;
        CanopyOptions off = o;
        off.support.mode = LeafSupport::kNone;
        Rng a(34), b(34);
        CanopyStats st;
        const Tree with = growCanopy(o, a, &st), without = growCanopy(off, b);
        EXPECT_EQ(st.twigNodes, 0);
        EXPECT_GT(with.nodes.size(), without.nodes.size());  // the crown was cut into pieces
        EXPECT_NEAR(with.nodes[0].radius, without.nodes[0].radius, 1e-12);
        EXPECT_EQ(with.endpoints.size(), without.endpoints.size());
    }
}

TEST(CanopySupport, CutAtSurfaceEndsLimbsAtTheMarginAndTheBaseCanBeOpen) {
    const double r = 1.5, margin = 0.2;
    CanopyOptions o = supportedOptions(margin);
    o.branches.trunkHeight = 2.0;
    o.leaves.count = 0;
    o.support.mode = LeafSupport::kNone;
    Rng a(35), b(35);
    CanopyStats dropped, cut;
    const Tree whole = growCanopy(o, a, &dropped);
    o.branches.cutAtSurface = true;
    const Tree shortened = growCanopy(o, b, &cut);
    // Same template, same cuts: a segment leaving the inner sphere ends on it instead of
    // vanishing, so there are more segments and the farthest tips lie on r − margin.
    EXPECT_GT(cut.keptSegments, dropped.keptSegments);
    auto farthest = [&](const Tree& t) {  // over the crown (the bole stands below the sphere)
        const std::vector<char> bole = boleOf(t, 2.0);
        double far = 0.0;
        for (size_t i = 0; i < t.nodes.size(); ++i)
            if (!bole[i]) far = std::max(far, distance(t.nodes[i].position, o.position));
        return far;
    };
    const double farWhole = farthest(whole), farCut = farthest(shortened);
    EXPECT_LE(farCut, r - margin + 1e-9);
    EXPECT_GT(farCut, r - margin - 1e-6);
    EXPECT_LT(farWhole, r - margin - 1e-3);
    // An open base: no leaf in the bottom 20 % of θ, and as many leaves as asked.
    CanopyOptions open = supportedOptions(margin);
    open.support.mode = LeafSupport::kNone;
    open.leaves.openBase = 0.2;
    Rng c(36);
    const Tree t = growCanopy(open, c);
    ASSERT_EQ(t.leaves.size(), 1500u);
    double lowest = kPi;
    for (const Leaf& l : t.leaves) {
        const Vec3 d = l.position - open.position;
        const double theta = std::acos(std::clamp(d.y / length(d), -1.0, 1.0));
        EXPECT_LE(theta, 0.8 * kPi + 1e-9);
        lowest = std::min(lowest, 0.8 * kPi - theta);
    }
    EXPECT_LT(lowest, 0.02);  // the leaves reach down to the edge
}

TEST(CanopySupport, PruneBareLeavesNoBranchWithoutLeaves) {
    // The lower half of the sphere bare: without pruning, template branches end there with no
    // leaf; with it every tip carries a leaf, and the leaves are the same.
    CanopyOptions o = supportedOptions();
    o.leaves.openBase = 0.5;
    auto bareTips = [](const Tree& t) {
        std::vector<char> carries(t.nodes.size(), 0);
        for (const Leaf& l : t.leaves) carries[l.node] = 1;
        int bare = 0;
        for (int32_t e : t.endpoints) bare += !carries[e];
        return bare;
    };
    Rng a(37), b(37);
    const Tree all = growCanopy(o, a);
    o.support.pruneBare = true;
    CanopyStats st;
    const Tree pruned = growCanopy(o, b, &st);
    EXPECT_GT(bareTips(all), 10);
    EXPECT_EQ(bareTips(pruned), 0);
    EXPECT_LT(pruned.nodes.size(), all.nodes.size());
    ASSERT_EQ(pruned.leaves.size(), all.leaves.size());
    for (size_t k = 0; k < all.leaves.size(); ++k) {
        EXPECT_EQ(pruned.leaves[k].position.x, all.leaves[k].position.x);
        const Vec3 p = pruned.nodes[pruned.leaves[k].node].position;
        const Vec3 q = all.nodes[all.leaves[k].node].position;
        EXPECT_EQ(distance(p, q), 0.0);  // the same carrying node, renumbered
    }
    // The last twigNodes nodes are still the twigs, and the tree is still rooted in order.
    for (size_t i = 1; i < pruned.nodes.size(); ++i)
        EXPECT_LT(pruned.nodes[i].parent, static_cast<int32_t>(i));
    EXPECT_LE(static_cast<size_t>(st.twigNodes), pruned.nodes.size());
}

// A hand-built trunk (0, 0, 0) → (0, 2, 0); leaves of size 0 (attachment = position).
Tree stick() {
    Tree t;
    for (int k = 0; k <= 4; ++k) {
        SkeletonNode n;
        n.position = {0, 0.5 * k, 0};
        n.parent = k - 1;
        t.nodes.push_back(n);
    }
    return t;
}

void addLeaf(Tree& t, Vec3 p) {
    Leaf l;
    l.position = p;
    l.size = 0.0;
    t.leaves.push_back(l);
}

TEST(CanopySupport, LeavesBeyondReachOrTheLongestTwigAreDropped) {
    CanopySupportOptions o;
    o.mode = LeafSupport::kTwigs;
    o.reach = 1.0;
    o.length = 1.0;
    o.step = 0.05;
    o.attach = 0.1;
    const std::vector<char> sprouts(5, 1);
    auto anywhere = [](const Vec3&) { return true; };
    Tree t = stick();
    // A ring around the top (opposite pulls cancel at the trunk: it grows toward the nearest);
    // a row out from the trunk's middle at 0.8, 1.08 (a twig of at most length = 1 m ends
    // within attach of it), 1.5 and 2.2 m (beyond length + attach); a lone leaf 3 m out; a leaf at
    // the trunk.
    for (int k = 0; k < 8; ++k) {
        const double a = 2 * kPi * k / 8;
        addLeaf(t, {0.6 * std::cos(a), 2.0, 0.6 * std::sin(a)});
    }
    for (double z : {0.8, 1.08, 1.5, 2.2}) addLeaf(t, {0, 1.0, z});
    addLeaf(t, {-3.0, 1.0, 0.0});
    addLeaf(t, {0.05, 0.5, 0.0});  // within attach of the trunk: no twig needed
    int64_t grown = 0;
    EXPECT_EQ(growSupportTwigs(t, sprouts, o, anywhere, &grown), 3);
    ASSERT_EQ(t.leaves.size(), 11u);
    EXPECT_EQ(static_cast<int64_t>(t.nodes.size()), 5 + grown);
    for (const Leaf& l : t.leaves) {
        EXPECT_NE(l.position.x, -3.0);
        EXPECT_LT(l.position.z, 1.1);
        ASSERT_GE(l.node, 0);
        EXPECT_LE(distance(t.nodes[l.node].position, l.position), o.attach + 1e-12);
    }
    EXPECT_EQ(t.leaves.back().node, 1);  // the leaf at the trunk hangs on it
    // Every new node is one step from its parent, and no twig is longer than `length`.
    std::vector<double> path(t.nodes.size(), 0.0);
    for (size_t i = 5; i < t.nodes.size(); ++i) {
        const int32_t p = t.nodes[i].parent;
        EXPECT_NEAR(distance(t.nodes[i].position, t.nodes[p].position), o.step, 1e-12);
        path[i] = path[p] + o.step;
        EXPECT_LE(path[i], o.length + 1e-9);
    }
    // Nodes that may not sprout grow nothing: a leaf beyond the kill distance drops.
    Tree u = stick();
    addLeaf(u, {0.5, 1.0, 0.0});
    addLeaf(u, {0.05, 1.0, 0.0});
    EXPECT_EQ(growSupportTwigs(u, std::vector<char>(5, 0), o, anywhere, &grown), 1);
    EXPECT_EQ(grown, 0);
    ASSERT_EQ(u.leaves.size(), 1u);
    EXPECT_EQ(u.leaves[0].node, 2);
    // Twigs never leave the region: a wall 0.15 < x < 0.25 between the trunk and a leaf at
    // x = 0.5 stops the twig at x = 0.15 and that leaf drops; the leaf at x = 0.12 hangs on the
    // first twig node to reach it (x = 0.05, 0.07 away), and the twig beyond, grown toward the
    // other leaf, is shed (it carries nothing).
    Tree v = stick();
    addLeaf(v, {0.5, 1.0, 0.0});
    addLeaf(v, {0.12, 1.0, 0.0});
    auto wall = [](const Vec3& p) { return !(p.x > 0.15 + 1e-9 && p.x < 0.25); };
    EXPECT_EQ(growSupportTwigs(v, sprouts, o, wall, &grown), 1);
    ASSERT_EQ(grown, 1);  // x = 0.05 (0.10 and 0.15 were grown and shed)
    ASSERT_EQ(v.leaves.size(), 1u);
    EXPECT_EQ(v.leaves[0].node, 5);
    EXPECT_NEAR(v.nodes[5].position.x, 0.05, 1e-12);
    for (const SkeletonNode& n : v.nodes) EXPECT_LE(n.position.x, 0.15 + 1e-9);
    // A leaf outside the region attracts no twig.
    Tree w = stick();
    addLeaf(w, {0.5, 1.0, 0.0});
    EXPECT_EQ(growSupportTwigs(
                  w, sprouts, o, [](const Vec3& p) { return p.x < 0.4; }, &grown),
              1);
    EXPECT_EQ(grown, 0);
}

TEST(CanopySupport, SameSeedSameSupportedTree) {
    CanopyOptions o = supportedOptions();
    o.envelope = lumpyEnvelope();
    o.position = {0, 4, 0};
    o.leaves.cluster = 3;
    auto grow = [&](uint64_t seed) {
        Rng rng(seed);
        return growCanopy(o, rng);
    };
    const Tree a = grow(41), b = grow(41), c = grow(42);
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    ASSERT_EQ(a.leaves.size(), b.leaves.size());
    for (size_t i = 0; i < a.nodes.size(); ++i) {
        EXPECT_EQ(a.nodes[i].position.x, b.nodes[i].position.x);
        EXPECT_EQ(a.nodes[i].position.y, b.nodes[i].position.y);
        EXPECT_EQ(a.nodes[i].radius, b.nodes[i].radius);
        EXPECT_EQ(a.nodes[i].parent, b.nodes[i].parent);
    }
    for (size_t i = 0; i < a.leaves.size(); ++i) EXPECT_EQ(a.leaves[i].node, b.leaves[i].node);
    EXPECT_NE(a.nodes.size(), c.nodes.size());
}

// --- spec reader ------------------------------------------------------------------------------

using sylva::test::TempDir;

const char* kSpec = R"(name = "c"
method = "canopy"

[canopy]
radii = [2, 1.5, 2]
position = [0, 4, 0]
jitter_deg = 0

[[templates]]
axiom = "FX"
rules = { X = "F[&X]/////[&X]///////[&X]" }
iterations = 4
)";

// Validates kSpec with `extra` appended; returns the error, or "" when valid.
std::string specError(const std::string& extra, const std::string& spec = kSpec) {
    TempDir dir;
    const fs::path file = dir / "c.toml";
    {
        std::ofstream out(file);
        out << spec << extra;
    }
    try {
        validateSpecies(loadSpecies(file.string()), nullptr);
    } catch (const SpecError& e) {
        return e.what();
    }
    return "";
}

TEST(CanopySpec, BadParametersNameFileLineAndKey) {
    struct Case {
        std::string extra, what;
    };
    const std::vector<Case> cases = {
        {"", ""},
        {"[[templates]]\naxiom = \"F\"\nrules = { F = \"F[+x]\" }\niterations = 2\n",
         "c.toml:15:15: templates[1].rules.F: unknown L-system symbol 'x'"},
        {"[[templates]]\naxiom = \"F[\"\niterations = 2\n", "templates[1].axiom: unclosed '['"},
        {"[[templates]]\naxiom = \"F\"\nrules = { f = \"FF\" }\niterations = 2\n",
         "templates[1].rules.f: a rule rewrites one letter A-Z"},
        {"[[templates]]\naxiom = \"F\"\nrules = { F = \"FFFFFFFFFF\" }\niterations = 6\n",
         "c.toml:16:14: templates[1].iterations: after 6 iterations the template has up to 1e+06 "
         "segments"},
        {"[[templates]]\naxiom = \"X\"\niterations = 2\n", "the template draws nothing"},
        {"[[templates]]\naxiom = \"F\"\nrules = { F = [ { to = \"F\", p = 0.5 }, { to = \"FF\", "
         "p = 0.4 } ] }\niterations = 2\n",
         "templates[1].rules.F: the probabilities p sum to 0.9, expected 1"},
        {"[leaves]\ncount = -5\n", "c.toml:14:9: leaves.count: expected an integer in [0,"},
        {"[leaves]\ncolours = [0.5, 0.6]\n", "leaves.colours: the fractions sum to 1.1"},
        {"[leaves]\ncolours = [0.5, 0.5]\ncolour_classes = [1]\n",
         "leaves.colour_classes: expected one class"},
        {"[leaves]\ncolours = [0.5, 0.5]\ncolour_classes = [1, 6]\n", ""},
        {"[leaves]\nper_tip = 4\n", "leaves.per_tip: unknown key"},
        {"[branches]\ntrunk_height = 1.0\n", "branches.trunk_height: the trunk top"},
        {"[branches]\nfit = \"squash\"\n", "branches.fit: expected one of"},
        {"[branches]\nleaf_margin = -0.1\n", "branches.leaf_margin: expected a number"},
        {"[support]\nmode = \"twigs\"\nreach = 1.2\nstep = 0.1\nattach = 0.15\n", ""},
        {"[support]\nmode = \"grow\"\n", "support.mode: expected one of"},
        {"[support]\nmode = \"twigs\"\nstep = 0.2\n",
         "c.toml:15:8: support.step: attach (0.12 m) must be at least step (0.2 m)"},
        {"[support]\nmode = \"twigs\"\nattach = 0.05\n", "support.attach: attach (0.05 m)"},
        {"[support]\nreach = 0.1\nattach = 0.11\n",
         "support.attach: attach (0.11 m) must not exceed reach (0.1 m)"},
    };
    for (const Case& c : cases) {
        const std::string e = specError(c.extra);
        if (c.what.empty()) {
            EXPECT_EQ(e, "") << c.extra;
        } else {
            EXPECT_NE(e.find(c.what), std::string::npos) << c.extra << "\n -> " << e;
        }
    }
    // The canopy needs its position; the envelope's keys are checked by its own reader.
    std::string noPosition = kSpec;
    noPosition.replace(noPosition.find("position = [0, 4, 0]\n"), 21, "");
    EXPECT_NE(specError("", noPosition).find("canopy.position: required key missing"),
              std::string::npos);
    std::string onGround = kSpec;
    onGround.replace(onGround.find("position = [0, 4, 0]"), 20, "position = [0, 1, 0]");
    EXPECT_NE(specError("", onGround).find("raise canopy.position"), std::string::npos);
}

TEST(CanopySpec, PresetsGrowRootedTreesWithLeaves) {
    for (const char* name : {"canopy-maple", "canopy-pine"}) {
        const SpeciesFile species =
            loadSpecies(std::string(SYLVA_SOURCE_DIR) + "/species/papers/shesh/" + name + ".toml");
        EXPECT_EQ(species.method, "canopy");
        const GrownTree g = growSpecies(species, 1, nullptr, false);
        const Tree& t = g.tree;
        ASSERT_GT(t.nodes.size(), 500u) << name;
        EXPECT_EQ(t.nodes[0].parent, -1);
        for (size_t i = 1; i < t.nodes.size(); ++i) EXPECT_LT(t.nodes[i].parent, int32_t(i));
        EXPECT_GE(t.leaves.size(), 8000u) << name;
        EXPECT_EQ(g.methodStats.count("unsupported_leaf_fraction"), 1u);
        EXPECT_LT(g.methodStats.at("unsupported_leaf_fraction"), 0.9) << name;
        // Two colour classes in both.
        std::set<int> classes;
        for (const Leaf& leaf : t.leaves) classes.insert(leaf.colour);
        EXPECT_EQ(classes.size(), 2u) << name;
    }
}

}  // namespace
}  // namespace sylva
