// The grammar method (Jain et al. 2021 §3): rule probabilities, depth bound, nested growth
// stages, the reduce-length/angle/width laws on generated stems, particle leaves and seasons,
// determinism, and spec errors with their file:line.
#include "species/methods/grammar.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <tuple>

#include "pipeline/batch/dataset.h"
#include "species/spec/species.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = kPi / 180.0;

// s → (a); a → (a a) on straight stems of fixed geometry.
GrammarOptions binaryTree(int depth) {
    GrammarOptions o;
    o.start = o.state("s");
    const int a = o.state("a");
    o.rules[o.start] = {{{a}, 1.0}};
    o.rules[a] = {{{a, a}, 1.0}};
    o.maxDepth = depth;
    o.fallback.lengthLo = o.fallback.lengthHi = 1.0;
    return o;
}

// A Fir-like grammar (Table 1) with every random element switched on.
GrammarOptions firLike(int depth) {
    GrammarOptions o;
    o.start = o.state("s");
    const int a = o.state("a"), b1 = o.state("b1"), b2 = o.state("b2");
    const int c1 = o.state("c1"), c2 = o.state("c2"), t = o.state("t");
    o.stop[t] = true;
    o.rules[o.start] = {{{a}, 1.0}};
    o.rules[a] = {{{a, b1, b1, b2, b2}, 0.5}, {{a, b1, b1, b2}, 0.3}, {{a, b1, b1}, 0.2}};
    o.rules[b1] = {{{t}, 1.0}};
    o.rules[b2] = {{{c1, c2}, 1.0}};
    o.rules[c1] = {{{t}, 1.0}};
    o.rules[c2] = {{{t}, 1.0}};
    o.maxDepth = depth;
    o.trunkWidthLo = 0.2;
    o.trunkWidthHi = 0.3;
    GrammarGeometry g;
    g.lengthLo = 0.8;
    g.lengthHi = 1.2;
    g.reduceLength = 0.9;
    g.tiltLo = 60 * kDeg;
    g.tiltHi = 80 * kDeg;
    g.curveLo = 0.05;
    g.curveHi = 0.1;
    g.tropism = 20 * kDeg;
    g.positionLo = 0.5;
    g.positionHi = 1.0;
    o.fallback = g;
    GrammarGeometry leader = g;
    leader.tiltLo = 0;
    leader.tiltHi = 5 * kDeg;
    leader.tropism = 0;
    leader.positionLo = leader.positionHi = 1.0;
    o.transition[{o.start, a}] = leader;
    o.transition[{a, a}] = leader;
    GrammarGeometry even = g;
    even.evenSpread = true;
    even.azimuthLo = -10 * kDeg;
    even.azimuthHi = 10 * kDeg;
    o.transition[{a, b1}] = even;
    o.transition[{a, b2}] = even;
    o.particles[b1].enabled = true;
    o.particles[b1].count = 10;
    return o;
}

TEST(Grammar, RuleProbabilitiesAreHonoured) {
    // 4000 independent a-stems each choose x (0.2), y (0.5) or z (0.3): counts within
    // 4.5 binomial standard deviations.
    GrammarOptions o;
    o.start = o.state("s");
    const int a = o.state("a"), x = o.state("x"), y = o.state("y"), z = o.state("z");
    o.rules[o.start] = {{std::vector<int>(4000, a), 1.0}};
    o.rules[a] = {{{x}, 0.2}, {{y}, 0.5}, {{z}, 0.3}};
    o.maxDepth = 2;
    o.segmentLength = 10.0;
    const int n = 4000;
    for (uint64_t seed : {1u, 2u, 3u}) {
        Rng rng(seed);
        std::vector<GrammarStem> stems;
        growGrammar(o, rng, nullptr, &stems);
        int count[3] = {0, 0, 0};
        for (const GrammarStem& s : stems) {
            if (s.state == x) ++count[0];
            if (s.state == y) ++count[1];
            if (s.state == z) ++count[2];
        }
        EXPECT_EQ(count[0] + count[1] + count[2], n);
        const double p[3] = {0.2, 0.5, 0.3};
        for (int k = 0; k < 3; ++k) {
            const double sd = std::sqrt(n * p[k] * (1 - p[k]));
            EXPECT_NEAR(count[k], n * p[k], 4.5 * sd) << "alternative " << k << " seed " << seed;
        }
    }
}

TEST(Grammar, DepthBoundsTheBranchingLevel) {
    for (int d = 1; d <= 7; ++d) {
        GrammarOptions o = binaryTree(d);
        Rng rng(5);
        GrammarStats stats;
        std::vector<GrammarStem> stems;
        Tree t = growGrammar(o, rng, &stats, &stems);
        EXPECT_EQ(stats.stems, (int64_t{1} << d) - 1) << "D = " << d;  // 1 + 2 + … + 2^(D−1)
        EXPECT_EQ(stats.depthReached, d);
        EXPECT_EQ(stats.truncated, int64_t{1} << (d - 1));  // the leaves of the derivation
        int maxLevel = 0;
        for (const SkeletonNode& n : t.nodes) maxLevel = std::max(maxLevel, n.level);
        EXPECT_EQ(maxLevel, d - 1);
        for (const GrammarStem& s : stems) EXPECT_LT(s.level, d);
        EXPECT_EQ(t.endpoints.size(), stems.size());
    }
}

TEST(Grammar, UnboundedDepthStopsAtStopStates) {
    GrammarOptions o;
    o.start = o.state("s");
    const int a = o.state("a"), t = o.state("t");
    o.stop[t] = true;
    o.rules[o.start] = {{{a}, 1.0}};
    o.rules[a] = {{{a, t}, 0.5}, {{t}, 0.5}};  // geometric chain, ends with probability 1
    GrammarStats stats;
    Rng rng(11);
    growGrammar(o, rng, &stats);
    EXPECT_EQ(stats.truncated, 0);
    EXPECT_EQ(stats.stopStates, stats.stems);  // every a emits exactly one t
    EXPECT_EQ(stats.depthReached, stats.stems);
}

// Growth stages (Jain Fig. 4): the tree at D is a subtree of the tree at D + 1.
TEST(Grammar, GrowthStagesAreNested) {
    for (uint64_t seed : {3u, 4u}) {
        Tree prev;
        for (int d = 1; d <= 9; ++d) {
            Rng rng(seed);
            Tree t = growGrammar(firLike(d), rng);
            std::set<std::tuple<double, double, double, double>> here;
            for (const SkeletonNode& n : t.nodes) {
                here.insert({n.position.x, n.position.y, n.position.z, n.radius});
            }
            EXPECT_GE(t.nodes.size(), prev.nodes.size());
            for (const SkeletonNode& n : prev.nodes) {
                ASSERT_TRUE(here.count({n.position.x, n.position.y, n.position.z, n.radius}))
                    << "node of D = " << d - 1 << " missing at D = " << d << ", seed " << seed;
            }
            if (d > 1) {
                EXPECT_GT(t.nodes.size(), prev.nodes.size());
            }
            prev = std::move(t);
        }
    }
}

TEST(Grammar, ReduceLengthAndAngleLawsHoldOnGeneratedStems) {
    // Straight stems: chord = b_l · r_l^c; angle to the parent's axis = b_a · r_a^c.
    GrammarOptions o = binaryTree(6);
    o.fallback.lengthLo = o.fallback.lengthHi = 2.0;
    o.fallback.reduceLength = 0.8;
    o.fallback.tiltLo = o.fallback.tiltHi = 40 * kDeg;
    o.fallback.reduceAngle = {1.0, 0.7, 1.0};
    GrammarGeometry trunk = o.fallback;
    trunk.tiltLo = trunk.tiltHi = 0;
    o.transition[{o.start, 1}] = trunk;
    o.segmentLength = 0.07;
    Rng rng(9);
    std::vector<GrammarStem> stems;
    Tree t = growGrammar(o, rng, nullptr, &stems);
    ASSERT_EQ(stems.size(), 63u);
    auto chord = [&](const GrammarStem& s) {
        return t.nodes[s.nodes.back()].position - t.nodes[s.baseNode].position;
    };
    for (const GrammarStem& s : stems) {
        EXPECT_NEAR(length(chord(s)), 2.0 * std::pow(0.8, s.level), 1e-9);
        const Vec3 parentAxis = s.parent < 0 ? Vec3{0, 1, 0} : chord(stems[s.parent]);
        const double expected = s.parent < 0 ? 0.0 : 40 * kDeg * std::pow(0.7, s.level);
        EXPECT_NEAR(angleBetween(chord(s), parentAxis), expected, 1e-7) << "level " << s.level;
    }
}

TEST(Grammar, WidthsFollowReduceWidthBeginAndEnd) {
    GrammarOptions o = binaryTree(5);
    o.trunkWidthLo = o.trunkWidthHi = 0.4;
    o.fallback.reduceWidthBegin = 0.8;
    o.fallback.reduceWidthEnd = 0.5;
    o.fallback.positionLo = 0.3;  // attachments along the parent, not only at its end
    o.fallback.positionHi = 1.0;
    o.fallback.tiltLo = o.fallback.tiltHi = 30 * kDeg;
    o.segmentLength = 0.1;
    Rng rng(2);
    std::vector<GrammarStem> stems;
    Tree t = growGrammar(o, rng, nullptr, &stems);
    EXPECT_DOUBLE_EQ(t.nodes[0].radius, 0.2);
    int midAttachments = 0;
    for (const GrammarStem& s : stems) {
        const double w = 2 * t.nodes[s.baseNode].radius;  // parent's width at the attachment
        const size_t n = s.nodes.size();
        for (size_t i = 0; i < n; ++i) {
            const double expected = 0.5 * w * (0.8 + (0.5 - 0.8) * double(i + 1) / double(n));
            EXPECT_NEAR(t.nodes[s.nodes[i]].radius, expected, 1e-12);
        }
        if (s.parent >= 0 && s.baseNode != stems[s.parent].nodes.back()) ++midAttachments;
    }
    EXPECT_GT(midAttachments, 10);
}

TEST(Grammar, EvenPhyllotaxisSpreadsSiblingsEvenly) {
    GrammarOptions o;
    o.start = o.state("s");
    const int a = o.state("a"), b = o.state("b");
    o.rules[o.start] = {{{a}, 1.0}};
    o.rules[a] = {{std::vector<int>(7, b), 1.0}};
    o.maxDepth = 2;
    GrammarGeometry g;
    g.tiltLo = g.tiltHi = 90 * kDeg;
    g.evenSpread = true;
    g.azimuthLo = g.azimuthHi = 0;
    o.transition[{a, b}] = g;
    for (uint64_t seed : {1u, 2u}) {
        Rng rng(seed);
        std::vector<GrammarStem> stems;
        growGrammar(o, rng, nullptr, &stems);
        std::vector<double> az;
        for (const GrammarStem& s : stems) {
            if (s.state != b) continue;
            EXPECT_NEAR(s.direction.y, 0.0, 1e-12);
            az.push_back(std::atan2(s.direction.z, s.direction.x));
        }
        ASSERT_EQ(az.size(), 7u);
        std::sort(az.begin(), az.end());
        for (size_t i = 0; i < az.size(); ++i) {
            const double next = i + 1 < az.size() ? az[i + 1] : az[0] + 2 * kPi;
            EXPECT_NEAR(next - az[i], 2 * kPi / 7, 1e-9);
        }
    }
}

TEST(Grammar, OrderCountsLateralsAndLevelCountsDerivationDepth) {
    Rng rng(1);
    std::vector<GrammarStem> stems;
    GrammarOptions o = firLike(6);
    Tree t = growGrammar(o, rng, nullptr, &stems);
    for (const GrammarStem& s : stems) {
        const std::string& name = o.states[s.state];
        const int expected = name == "a" ? 0 : (name[0] == 'b' ? 1 : 2);
        EXPECT_EQ(s.order, expected) << name;
        for (int32_t n : s.nodes) {
            EXPECT_EQ(t.nodes[n].order, expected);
            EXPECT_EQ(t.nodes[n].level, s.level);
            EXPECT_LT(t.nodes[n].parent, n);  // rooted: parents first
        }
    }
}

TEST(Grammar, LeafCountSizeAndColourFollowHeight) {
    GrammarOptions o = binaryTree(6);
    o.fallback.tiltLo = 20 * kDeg;
    o.fallback.tiltHi = 40 * kDeg;
    o.trunkWidthLo = o.trunkWidthHi = 0.01;  // leaves sit on the axis: heights compare
    GrammarParticles& p = o.particles[1];
    p.enabled = true;
    p.count = 25;
    p.sizeLo = 0.04;
    p.sizeHi = 0.12;
    p.randomness = 0.0;
    Rng rng(4);
    GrammarStats stats;
    Tree t = growGrammar(o, rng, &stats);
    ASSERT_EQ(t.leaves.size(), 25u * 63u);
    EXPECT_EQ(stats.leaves, 25 * 63);
    double yLo = 1e300, yHi = -1e300;
    for (const SkeletonNode& n : t.nodes) {
        yLo = std::min(yLo, n.position.y);
        yHi = std::max(yHi, n.position.y);
    }
    const std::vector<uint8_t>& palette = o.seasons[int(Season::kSummer)].classes;
    const int k = static_cast<int>(palette.size());
    double lowColour = 0, highColour = 0;
    int low = 0, high = 0;
    for (const Leaf& leaf : t.leaves) {
        // Height of the leaf's attachment point: its base on the stem (centre − half a card
        // along the tangent, − half the stem width sideways: well below 1 cm here).
        const Vec3 base = leaf.position - leaf.tangent * (0.5 * leaf.size);
        const double h = (base.y - yLo) / (yHi - yLo);
        EXPECT_NEAR(leaf.size, 0.12 - 0.08 * h, 0.08 * 0.02) << "larger low, smaller high";
        const int ci = static_cast<int>(std::find(palette.begin(), palette.end(), leaf.colour) -
                                        palette.begin());
        ASSERT_LT(ci, k);
        const int lo = std::clamp(static_cast<int>(std::floor(h * k - 0.5)) - 1, 0, k - 1);
        const int hi = std::clamp(static_cast<int>(std::floor(h * k - 0.5)) + 2, 0, k - 1);
        EXPECT_GE(ci, lo);
        EXPECT_LE(ci, hi);
        if (h < 0.3) lowColour += ci, ++low;
        if (h > 0.7) highColour += ci, ++high;
        EXPECT_NEAR(length(leaf.normal), 1.0, 1e-9);
        EXPECT_NEAR(dot(leaf.normal, leaf.tangent), 0.0, 1e-9);
    }
    ASSERT_GT(low, 20);
    ASSERT_GT(high, 20);
    EXPECT_LT(lowColour / low + 1.5, highColour / high) << "lighter classes higher up";
}

TEST(Grammar, SeasonsChooseDensityAndPalette) {
    auto grow = [](Season s) {
        GrammarOptions o = firLike(7);
        o.season = s;
        Rng rng(8);
        return growGrammar(o, rng);
    };
    const Tree summer = grow(Season::kSummer), autumn = grow(Season::kAutumn);
    const Tree winter = grow(Season::kWinter), spring = grow(Season::kSpring);
    EXPECT_TRUE(winter.leaves.empty()) << "winter is bare";
    ASSERT_FALSE(summer.leaves.empty());
    // Density 0.8 and 0.6: binomial thinning of the summer leaves, which are a superset.
    const double n = static_cast<double>(summer.leaves.size());
    EXPECT_NEAR(autumn.leaves.size(), 0.8 * n, 4.5 * std::sqrt(n * 0.16));
    EXPECT_NEAR(spring.leaves.size(), 0.6 * n, 4.5 * std::sqrt(n * 0.24));
    std::set<std::tuple<double, double, double>> all;
    for (const Leaf& l : summer.leaves) all.insert({l.position.x, l.position.y, l.position.z});
    for (const Leaf& l : autumn.leaves) {
        EXPECT_TRUE(all.count({l.position.x, l.position.y, l.position.z}));
        EXPECT_GE(l.colour, 4);
        EXPECT_LE(l.colour, 7);
    }
    for (const Leaf& l : summer.leaves) EXPECT_LE(l.colour, 3);
    for (const Leaf& l : spring.leaves) EXPECT_GE(l.colour, 1);
    // Branches do not depend on the season.
    ASSERT_EQ(summer.nodes.size(), winter.nodes.size());
    for (size_t i = 0; i < summer.nodes.size(); ++i) {
        EXPECT_EQ(summer.nodes[i].position, winter.nodes[i].position);
    }
}

TEST(Grammar, FruitHangsFromItsStemsInItsSeasons) {
    GrammarOptions o = binaryTree(4);
    GrammarFruit& f = o.fruit[1];
    f.enabled = true;
    f.count = 3;
    f.colour = 8;
    f.minLevel = 2;
    f.seasons = {false, true, false, false};
    Rng rng(1);
    GrammarStats stats;
    Tree t = growGrammar(o, rng, &stats);
    EXPECT_EQ(stats.fruit, 3 * (4 + 8));  // stems at levels 2 and 3
    ASSERT_EQ(t.leaves.size(), 36u);
    for (const Leaf& l : t.leaves) {
        EXPECT_EQ(l.colour, 8);
        EXPECT_EQ(l.tangent, Vec3(0, -1, 0));
        EXPECT_GE(t.nodes[l.node].level, 2);
        EXPECT_LT(l.position.y, t.nodes[l.node].position.y + 0.1);
    }
    o.season = Season::kAutumn;
    Rng rng2(1);
    EXPECT_TRUE(growGrammar(o, rng2).leaves.empty());
}

TEST(Grammar, DeterministicForASeed) {
    auto bytes = [](uint64_t seed) {
        Rng rng(seed);
        Tree t = growGrammar(firLike(8), rng);
        std::string b;
        for (const SkeletonNode& n : t.nodes) {
            b.append(reinterpret_cast<const char*>(&n.position), sizeof n.position);
            b.append(reinterpret_cast<const char*>(&n.radius), sizeof n.radius);
            b.append(reinterpret_cast<const char*>(&n.parent), sizeof n.parent);
        }
        for (const Leaf& l : t.leaves) {
            b.append(reinterpret_cast<const char*>(&l.position), sizeof l.position);
            b.append(reinterpret_cast<const char*>(&l.normal), sizeof l.normal);
            b.push_back(static_cast<char>(l.colour));
        }
        return b;
    };
    EXPECT_EQ(bytes(12), bytes(12));
    EXPECT_NE(bytes(12), bytes(13));
}

TEST(Grammar, ValueNoiseIsSmoothAndBounded) {
    double maxStep = 0, lo = 1, hi = -1;
    for (int i = 0; i < 2000; ++i) {
        const Vec3 p{0.01 * i, 0.3, 7.2};
        const double v = valueNoise3(p, 42);
        lo = std::min(lo, v);
        hi = std::max(hi, v);
        maxStep = std::max(maxStep, std::abs(valueNoise3(p + Vec3{0.01, 0, 0}, 42) - v));
        EXPECT_EQ(v, valueNoise3(p, 42));
    }
    EXPECT_GE(lo, -1.0);
    EXPECT_LE(hi, 1.0);
    EXPECT_GT(hi - lo, 0.5);   // it varies
    EXPECT_LT(maxStep, 0.05);  // continuously (slope ≤ 1.5 × 2 per unit)
    EXPECT_EQ(valueNoise3({2, 3, 4}, 1), valueNoise3({2, 3, 4}, 1));
}

// --- our extensions (issue 13): roots, ground clearance, straight leader, leaf density --------

// s → (a); a → (h); h → (r × 6): a 5 m vertical trunk, a horizontal 6 m limb, six roots hanging
// from it. Root lengths alternate by draw between 3 m (hang free) and 7 m (reach the ground).
GrammarOptions propRoots(RootForm form) {
    GrammarOptions o;
    o.start = o.state("s");
    const int a = o.state("a"), h = o.state("h"), r = o.state("r"), t = o.state("t");
    o.stop[t] = true;
    o.rules[o.start] = {{{a}, 1.0}};
    o.rules[a] = {{{h}, 1.0}};
    o.rules[h] = {{std::vector<int>(6, r), 1.0}};
    o.rules[r] = {{{t}, 1.0}};
    o.trunkWidthLo = o.trunkWidthHi = 0.6;
    o.segmentLength = 0.25;
    GrammarGeometry trunk;
    trunk.lengthLo = trunk.lengthHi = 5.0;
    o.transition[{o.start, a}] = trunk;
    GrammarGeometry limb;
    limb.lengthLo = limb.lengthHi = 6.0;
    limb.tiltLo = limb.tiltHi = 90 * kDeg;
    limb.curveLo = limb.curveHi = 0.05;
    o.transition[{a, h}] = limb;
    GrammarGeometry root;
    root.lengthLo = 3.0;
    root.lengthHi = 7.0;  // ≥ 5.3 m reaches the ground from a limb at ≈ 5 m
    root.positionLo = 0.2;
    root.positionHi = 1.0;
    root.tiltLo = root.tiltHi = 120 * kDeg;  // arching: out and down from the limb
    root.tropism = 90 * kDeg;
    root.curveLo = root.curveHi = 0.05;  // ignored by vertical roots
    root.reduceWidthBegin = 0.3;
    root.reduceWidthEnd = 0.2;
    o.transition[{h, r}] = root;
    o.roots[r].enabled = true;
    o.roots[r].form = form;
    o.roots[r].pillarWidthLo = o.roots[r].pillarWidthHi = 0.25;
    return o;
}

TEST(Grammar, VerticalPropRootsReachTheGroundStraightAndThicken) {
    int rootedSeen = 0, hangingSeen = 0;
    for (uint64_t seed = 1; seed <= 6; ++seed) {
        const GrammarOptions o = propRoots(RootForm::kVertical);
        Rng rng(seed);
        GrammarStats stats;
        std::vector<GrammarStem> stems;
        const Tree t = growGrammar(o, rng, &stats, &stems);
        EXPECT_EQ(stats.roots, 6);
        int rooted = 0;
        for (const GrammarStem& st : stems) {
            const bool isRoot = o.states[st.state] == "r";
            EXPECT_EQ(st.root, isRoot);
            for (int32_t n : st.nodes) {
                EXPECT_EQ(t.nodes[n].part, isRoot ? kRootPart : kShootPart);
            }
            if (!isRoot) continue;
            const Vec3 top = t.nodes[st.baseNode].position;
            const Vec3 end = t.nodes[st.nodes.back()].position;
            ASSERT_GT(top.y, 4.0);
            // Vertical: every node straight under the attachment (well within a degree).
            for (int32_t n : st.nodes) {
                const Vec3 d = t.nodes[n].position - top;
                EXPECT_LT(angleBetween(d, Vec3{0, -1, 0}), 1e-9) << "seed " << seed;
                EXPECT_GE(t.nodes[n].position.y, 0.0);
            }
            if (st.length >= top.y) {
                // Rooted: ends exactly on the ground, a pillar of the key's width throughout.
                EXPECT_TRUE(st.rooted);
                EXPECT_EQ(end.y, 0.0);
                for (int32_t n : st.nodes) EXPECT_DOUBLE_EQ(t.nodes[n].radius, 0.125);
                ++rooted;
            } else {
                // Hanging free: its drawn length, the transition's thin widths.
                EXPECT_FALSE(st.rooted);
                EXPECT_NEAR(top.y - end.y, st.length, 1e-9);
                EXPECT_NEAR(t.nodes[st.nodes.back()].radius,
                            0.5 * 0.2 * 2 * t.nodes[st.baseNode].radius, 1e-12);
                ++hangingSeen;
            }
        }
        EXPECT_EQ(stats.rooted, rooted);
        rootedSeen += rooted;
    }
    EXPECT_GT(rootedSeen, 5);
    EXPECT_GT(hangingSeen, 5);
}

TEST(Grammar, ArchingStiltRootsFollowTheirGeometryAndStopAtTheGround) {
    int rooted = 0;
    for (uint64_t seed = 1; seed <= 12; ++seed) {
        const GrammarOptions o = propRoots(RootForm::kArching);
        Rng rng(seed);
        std::vector<GrammarStem> stems;
        const Tree t = growGrammar(o, rng, nullptr, &stems);
        for (const GrammarStem& st : stems) {
            if (!st.root) continue;
            const Vec3 top = t.nodes[st.baseNode].position;
            const Vec3 first = t.nodes[st.nodes.front()].position;
            // It leaves the limb along its Euler angles (outward, not straight down) ...
            EXPECT_GT(angleBetween(first - top, Vec3{0, -1, 0}), 10 * kDeg);
            // ... and never goes below the ground; a rooted one ends on it.
            for (int32_t n : st.nodes) EXPECT_GE(t.nodes[n].position.y, 0.0);
            if (st.rooted) {
                EXPECT_EQ(t.nodes[st.nodes.back()].position.y, 0.0);
                for (size_t k = 0; k + 1 < st.nodes.size(); ++k) {
                    EXPECT_GT(t.nodes[st.nodes[k]].position.y, 0.0);
                }
                ++rooted;
            }
        }
    }
    EXPECT_GT(rooted, 10);
}

// A trunk of 2 m and three limbs tilted 130° from it, turning further down: straight lines
// that would dive into the ground.
GrammarOptions drooping() {
    GrammarOptions o;
    o.start = o.state("s");
    const int a = o.state("a"), b = o.state("b"), t = o.state("t");
    o.stop[t] = true;
    o.rules[o.start] = {{{a}, 1.0}};
    o.rules[a] = {{{b, b, b}, 1.0}};
    o.rules[b] = {{{t}, 1.0}};
    o.segmentLength = 0.05;
    GrammarGeometry trunk;
    trunk.lengthLo = trunk.lengthHi = 2.0;
    o.transition[{o.start, a}] = trunk;
    GrammarGeometry limb;
    limb.lengthLo = 4.0;
    limb.lengthHi = 6.0;
    limb.tiltLo = limb.tiltHi = 130 * kDeg;
    o.transition[{a, b}] = limb;
    return o;
}

TEST(Grammar, GroundClearanceBendsDescendingStemsAboveTheGround) {
    const double h = 0.5;
    for (uint64_t seed : {1u, 2u, 3u}) {
        GrammarOptions o = drooping();
        Rng r0(seed);
        const Tree free = growGrammar(o, r0);
        o.groundClearance = h;
        Rng r1(seed);
        const Tree held = growGrammar(o, r1);
        ASSERT_EQ(free.nodes.size(), held.nodes.size());
        double lowest = 1e300;
        for (const SkeletonNode& n : free.nodes) lowest = std::min(lowest, n.position.y);
        EXPECT_LT(lowest, -0.5) << "without clearance the limbs go into the ground";
        // The trunk rises: unchanged. Straight limbs descending from above h: heights above h
        // unchanged, below it y = h·exp((y₀ − h)/h) (the integral of dy' = dy·y/h); x and z
        // unchanged.
        for (size_t i = 0; i < free.nodes.size(); ++i) {
            const Vec3 p0 = free.nodes[i].position, p = held.nodes[i].position;
            const bool limb = free.nodes[i].order > 0;
            const double expected = !limb || p0.y >= h ? p0.y : h * std::exp((p0.y - h) / h);
            EXPECT_NEAR(p.y, expected, 1e-9) << "node " << i;
            EXPECT_EQ(p.x, p0.x);
            EXPECT_EQ(p.z, p0.z);
            if (i > 0) {
                EXPECT_GT(p.y, 0.0);
            }
        }
    }
}

// s → a (a 2 m trunk); a → four straight branches spread evenly about it at `tilt` from the
// vertical, 2 m long, each with a leaf particle every 10 cm.
GrammarOptions fan(double tiltDeg) {
    GrammarOptions o;
    o.start = o.state("s");
    const int a = o.state("a"), b = o.state("b");
    o.rules[o.start] = {{{a}, 1.0}};
    o.rules[a] = {{{b, b, b, b}, 1.0}};
    o.maxDepth = 2;
    GrammarGeometry trunk;
    trunk.lengthLo = trunk.lengthHi = 2.0;
    o.transition[{o.start, a}] = trunk;
    GrammarGeometry branch;
    branch.lengthLo = branch.lengthHi = 2.0;
    branch.tiltLo = branch.tiltHi = tiltDeg * kDeg;
    branch.evenSpread = true;
    branch.azimuthLo = branch.azimuthHi = 0.0;
    o.transition[{a, b}] = branch;
    o.particles[b].enabled = true;
    o.particles[b].perMetre = 10;
    return o;
}

// Crown shyness (GrammarOptions::shyBounds): every branch point and leaf below the layer's top
// keeps the bound; a branch heading out (30° above the horizontal) stops at it, one rising
// steeply (20° from the vertical) is moved onto the plane and keeps its heights; the trunk is
// never touched; above the layer branches are free.
TEST(Grammar, ShyBoundsStopOrTurnBranchesAtTheNeighboursPlane) {
    ShyBound bound;
    bound.plane = {{1, 0, 0}, 0.5};  // x ≤ 0.5
    bound.low = -1e300;
    bound.high = 10.0;
    bool stoppedOne = false, slidOne = false;
    for (double tilt : {60.0, 20.0}) {
        GrammarOptions o = fan(tilt);
        Rng r0(7);
        GrammarStats freeStats;
        std::vector<GrammarStem> freeStems;
        const Tree free = growGrammar(o, r0, &freeStats, &freeStems);
        o.shyBounds = {bound};
        Rng r1(7);
        GrammarStats stats;
        std::vector<GrammarStem> stems;
        const Tree held = growGrammar(o, r1, &stats, &stems);
        ASSERT_EQ(stems.size(), freeStems.size());
        EXPECT_EQ(freeStats.shyStopped, 0);
        double freeReach = -1e300;
        for (const SkeletonNode& n : free.nodes) freeReach = std::max(freeReach, n.position.x);
        ASSERT_GT(freeReach, 0.6) << "some branch must cross the plane when free";
        for (const SkeletonNode& n : held.nodes) EXPECT_TRUE(bound.holds(n.position)) << tilt;
        for (const Leaf& l : held.leaves) EXPECT_TRUE(bound.holds(l.position)) << tilt;
        // The trunk (stem 0) is the same.
        ASSERT_EQ(stems[0].nodes.size(), freeStems[0].nodes.size());
        for (size_t k = 0; k < stems[0].nodes.size(); ++k) {
            EXPECT_EQ(held.nodes[stems[0].nodes[k]].position.y,
                      free.nodes[freeStems[0].nodes[k]].position.y);
        }
        for (size_t si = 1; si < stems.size(); ++si) {
            const Vec3 freeTip = free.nodes[freeStems[si].nodes.back()].position;
            const Vec3 tip = held.nodes[stems[si].nodes.back()].position;
            if (freeTip.x <= 0.5) {  // never reached the plane: unchanged
                EXPECT_EQ(stems[si].nodes.size(), freeStems[si].nodes.size());
                continue;
            }
            if (tilt == 60.0) {  // heading out: stopped short, at its last point inside
                EXPECT_LT(stems[si].nodes.size(), freeStems[si].nodes.size());
                EXPECT_GT(tip.x, 0.5 - 0.2);  // within a segment or two of the plane
                stoppedOne = true;
            } else {  // rising: along the plane, its top at the free stem's height
                EXPECT_EQ(stems[si].nodes.size(), freeStems[si].nodes.size());
                EXPECT_NEAR(tip.x, 0.5, 1e-6);
                EXPECT_EQ(tip.y, freeTip.y);
                slidOne = true;
            }
        }
        EXPECT_EQ(stats.shyStopped > 0, tilt == 60.0);
        // Above the layer a branch is free: with the layer's top under the branches, the tree
        // grows as it does alone.
        o.shyBounds[0].high = 1.0;
        Rng r2(7);
        const Tree above = growGrammar(o, r2);
        EXPECT_EQ(above.nodes.size(), free.nodes.size());
        EXPECT_EQ(above.leaves.size(), free.leaves.size());
    }
    EXPECT_TRUE(stoppedOne);
    EXPECT_TRUE(slidOne);
}

// A branch never begins on the part of its parent that a bound stopped: a fir's laterals
// drawn beyond a stopped branch's end are not drawn, and the slack moves each stem's stop by
// its own draw (tips spread, not on one line).
TEST(Grammar, ShyBoundsDropLateralsBeyondAStoppedParentAndRaggedTheEdge) {
    GrammarOptions o = firLike(5);
    Rng r0(11);
    std::vector<GrammarStem> freeStems;
    growGrammar(o, r0, nullptr, &freeStems);
    ShyBound bound;
    bound.plane = {{0, 0, 1}, 0.4};  // z ≤ 0.4
    bound.low = -1e300;
    bound.high = 1e300;
    bound.slack = 0.3;
    o.shyBounds = {bound};
    Rng r1(11);
    std::vector<GrammarStem> stems;
    GrammarStats stats;
    const Tree held = growGrammar(o, r1, &stats, &stems);
    EXPECT_LT(stems.size(), freeStems.size());  // laterals of stopped parents not drawn
    std::vector<double> tips;
    for (const GrammarStem& st : stems) {
        if (st.order == 0) continue;
        const Vec3 tip = held.nodes[st.nodes.back()].position;
        EXPECT_LE(tip.z, 0.4 + 1e-9);
        if (tip.z > 0.4 - 0.3 - 0.15) tips.push_back(tip.z);  // stopped near the plane
    }
    ASSERT_GE(tips.size(), 4u);
    const auto [lo, hi] = std::minmax_element(tips.begin(), tips.end());
    EXPECT_GT(*hi - *lo, 0.1);  // spread over the slack
}

TEST(Grammar, StraightLeaderIsAVerticalLine) {
    for (uint64_t seed : {1u, 2u, 3u}) {
        GrammarOptions o = firLike(9);  // leader tilts 0–5°, curve noise 0.05–0.1
        Rng r0(seed);
        const Tree bent = growGrammar(o, r0);
        o.straightLeader = true;
        Rng r1(seed);
        std::vector<GrammarStem> stems;
        const Tree t = growGrammar(o, r1, nullptr, &stems);
        double bentOff = 0.0;
        for (const SkeletonNode& n : bent.nodes) {
            if (n.order == 0) bentOff = std::max(bentOff, std::hypot(n.position.x, n.position.z));
        }
        EXPECT_GT(bentOff, 0.05) << "the test grammar's leader drifts without the key";
        int leaderNodes = 0;
        double top = 0.0;
        for (const SkeletonNode& n : t.nodes) {
            if (n.order != 0) continue;
            EXPECT_EQ(n.position.x, 0.0);
            EXPECT_EQ(n.position.z, 0.0);
            top = std::max(top, n.position.y);
            ++leaderNodes;
        }
        EXPECT_GT(leaderNodes, 20);
        // Its height is the sum of the leader stems' lengths (no curve shortens it).
        double sum = 0.0;
        for (const GrammarStem& st : stems) sum += st.order == 0 ? st.length : 0.0;
        EXPECT_NEAR(top, sum, 1e-9);
        // The laterals still follow their geometry (they are not straightened).
        int laterals = 0;
        for (const GrammarStem& st : stems) {
            if (st.order == 1) {
                EXPECT_GT(angleBetween(st.direction, Vec3{0, 1, 0}), 55 * kDeg);
                ++laterals;
            }
        }
        EXPECT_GT(laterals, 10);
    }
}

TEST(Grammar, LeavesPerMetreGiveTheExpectedCountSpreadEvenly) {
    // One straight 3 m stem; leaves on its stretch [0.2, 1]: 5 + round(10/m × 3 m × 0.8) = 29.
    GrammarOptions o;
    o.start = o.state("s");
    const int a = o.state("a"), t = o.state("t");
    o.stop[t] = true;
    o.rules[o.start] = {{{a}, 1.0}};
    o.rules[a] = {{{t}, 1.0}};
    o.fallback.lengthLo = o.fallback.lengthHi = 3.0;
    o.trunkWidthLo = o.trunkWidthHi = 0.02;
    GrammarParticles& p = o.particles[a];
    p.enabled = true;
    p.count = 5;
    p.perMetre = 10.0;
    p.alongLo = 0.2;
    p.alongHi = 1.0;
    for (uint64_t seed : {1u, 2u}) {
        Rng rng(seed);
        GrammarStats stats;
        const Tree tree = growGrammar(o, rng, &stats);
        ASSERT_EQ(tree.leaves.size(), 29u);
        EXPECT_EQ(stats.leaves, 29);
        // Stratified: exactly one leaf base in each of the 29 equal sub-intervals of [0.6, 3] m.
        std::vector<int> per(29, 0);
        for (const Leaf& l : tree.leaves) {
            const double s = l.position.y - l.tangent.y * 0.5 * l.size;  // height on the stem
            const int k = static_cast<int>(std::floor((s - 0.6) / (2.4 / 29)));
            ASSERT_GE(k, 0);
            ASSERT_LT(k, 29);
            ++per[k];
        }
        for (int k = 0; k < 29; ++k) EXPECT_EQ(per[k], 1) << "interval " << k;
    }
}

TEST(Grammar, LengthScaleScalesEveryStem) {
    GrammarOptions o = binaryTree(5);
    o.fallback.tiltLo = 20 * kDeg;
    o.fallback.tiltHi = 50 * kDeg;
    o.segmentLength = 100.0;  // one segment per stem: positions scale exactly
    Rng r0(3);
    const Tree a = growGrammar(o, r0);
    o.lengthScale = 1.3;
    Rng r1(3);
    const Tree b = growGrammar(o, r1);
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    for (size_t i = 0; i < a.nodes.size(); ++i) {
        EXPECT_NEAR(distance(b.nodes[i].position, a.nodes[i].position * 1.3), 0.0, 1e-12);
        EXPECT_EQ(b.nodes[i].radius, a.nodes[i].radius);  // widths are not lengths
    }
}

TEST(Grammar, RootsClearanceAndLeaderAreDeterministic) {
    auto bytes = [](uint64_t seed) {
        GrammarOptions o = propRoots(RootForm::kArching);
        o.groundClearance = 0.4;
        o.straightLeader = true;
        Rng rng(seed);
        const Tree t = growGrammar(o, rng);
        std::string b;
        for (const SkeletonNode& n : t.nodes) {
            b.append(reinterpret_cast<const char*>(&n.position), sizeof n.position);
            b.append(reinterpret_cast<const char*>(&n.radius), sizeof n.radius);
            b.push_back(static_cast<char>(n.part));
        }
        return b;
    };
    EXPECT_EQ(bytes(4), bytes(4));
    EXPECT_NE(bytes(4), bytes(5));
}

// --- species files -------------------------------------------------------------------------

const char* kHeader = "name = \"g\"\nmethod = \"grammar\"\n";

std::string specError(const std::string& body) {
    const fs::path dir =
        fs::temp_directory_path() / ("sylva-grammar-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const fs::path file = dir / "g.toml";
    {
        std::ofstream out(file);
        out << kHeader << body;
    }
    std::string e;
    try {
        validateSpecies(loadSpecies(file.string()), nullptr);
    } catch (const SpecError& err) {
        e = err.what();
    }
    fs::remove_all(dir);
    return e;
}

TEST(GrammarSpec, BadGrammarsNameFileLineAndKey) {
    struct Case {
        std::string body, where, what;
    };
    const std::string ok = "[grammar]\nmax_depth = 4\n";
    const std::vector<Case> cases = {
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"a\", \"q\"] }]\n",
         "g.toml:7:", "unknown state \"q\""},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"a\"], p = 0.5 },\n"
              "     { out = [\"t\"], p = 0.4 }]\n",
         "g.toml:7:", "rules.a: the alternatives' probabilities sum to 0.9"},
        {ok + "[rules]\na = [{ out = [\"a\"] }]\n", "g.toml:5:", "no rule for the start state"},
        {"[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"a\", \"a\"] }]\n",
         "g.toml:5:", "rules.a: no path from \"a\" to a stop state"},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n[geometry.a]\n"
              "length = [2, 1]\n",
         "g.toml:9:", "length: expected lo ≤ hi"},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n[geometry.\"a->a\"]\n"
              "length = [1, 2]\n",
         "g.toml:8:", "no rule turns \"a\" into \"a\""},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n[leaves]\nper_tip = 3\n",
         "g.toml:8:", "use [particles.<state>]"},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n[particles.b]\n"
              "count = 3\n",
         "g.toml:8:", "unknown state \"b\""},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }, { out = [\"a\"] }]\n",
         "g.toml:7:", "missing \"p\""},
        {ok + "[rules]\ns = [{ out = [\"a*0\"] }]\na = [{ out = [\"t\"] }]\n",
         "g.toml:6:", "state*N"},
        {ok +
             "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\nt = [{ out = [\"a\"] }]\n",
         "g.toml:8:", "stop states have no rule"},
        {ok + "season = \"monsoon\"\n[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n",
         "g.toml:5:", "season: expected one of"},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n[geometry.a]\n"
              "tilt_dg = [1, 2]\n",
         "g.toml:9:", "did you mean \"tilt_deg\""},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n[particles.a]\n"
              "size = [0.1, 0.2]\n",
         "g.toml:8:", "missing \"count\" (leaves per stem) or \"per_metre\""},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n[roots.a]\n"
              "form = \"hanging\"\n",
         "g.toml:9:", "roots.a.form: expected one of"},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n[roots.a]\n"
              "pillar_width = [0.4, 0.2]\n",
         "g.toml:9:", "pillar_width: expected lo ≤ hi"},
        {ok + "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n[roots.t]\n",
         "g.toml:8:", "\"t\" is a stop state"},
        {ok + "ground_clearance = -1\n[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"t\"] }]\n",
         "g.toml:5:", "grammar.ground_clearance"},
    };
    for (const Case& c : cases) {
        const std::string e = specError(c.body);
        EXPECT_NE(e.find(c.where), std::string::npos) << "got: " << e << "\nfor:\n" << c.body;
        EXPECT_NE(e.find(c.what), std::string::npos) << "got: " << e << "\nfor:\n" << c.body;
    }
    // Unbounded depth with a path to a stop state is fine.
    EXPECT_EQ(specError("[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"a\", \"t\"], p = 0.5 }, "
                        "{ out = [\"t\"], p = 0.5 }]\n"),
              "");
}

TEST(GrammarSpec, GeometryMergesTransitionStateAndDefault) {
    const fs::path dir =
        fs::temp_directory_path() / ("sylva-grammar-m-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const fs::path file = dir / "g.toml";
    {
        std::ofstream out(file);
        out << kHeader
            << "[grammar]\nmax_depth = 3\ntrunk_width = [0.5, 0.5]\n"
               "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"a\", \"b\"] }]\nb = [{ out = "
               "[\"t\"] }]\n"
               "[geometry.default]\nlength = [3, 3]\nreduce_length = 0.5\n"
               "[geometry.b]\nlength = [2, 2]\ntilt_deg = [90, 90]\n"
               "[geometry.\"s->a\"]\nlength = [4, 4]\n";
    }
    const GrownTree g = growSpecies(loadSpecies(file.string()), 1, nullptr, false);
    fs::remove_all(dir);
    // s→a: 4 m; a→a: 3 · 0.5 = 1.5 m; a→b at levels 1 and 2: 2 · 0.5 = 1, 2 · 0.25 = 0.5.
    EXPECT_EQ(g.methodStats.at("stems"), 5.0);
    EXPECT_EQ(g.methodStats.at("depth_reached"), 3.0);
    EXPECT_EQ(g.methodStats.at("stop_states"), 1.0);  // b at level 1 → t
    EXPECT_EQ(g.methodStats.at("truncated"), 2.0);
    double top = 0;
    for (const SkeletonNode& n : g.tree.nodes) top = std::max(top, n.position.y);
    EXPECT_NEAR(top, 4 + 1.5 + 0.75, 1e-9);
    EXPECT_DOUBLE_EQ(g.tree.nodes[0].radius, 0.25);
}

TEST(GrammarSpec, PresetsBuildDeterministicallyAndFast) {
    const fs::path presets = fs::path(SYLVA_SOURCE_DIR) / "species/papers/jain-2021";
    int found = 0;
    for (const char* name : {"grammar-fir", "grammar-guava", "grammar-palm", "grammar-bamboo"}) {
        const fs::path file = presets / (std::string(name) + ".toml");
        ASSERT_TRUE(fs::exists(file)) << file;
        ++found;
        const SpeciesFile sp = loadSpecies(file.string());
        const GrownTree a = growSpecies(sp, 7, nullptr, false);
        const GrownTree b = growSpecies(sp, 7, nullptr, true);
        ASSERT_EQ(a.tree.nodes.size(), b.tree.nodes.size()) << name;
        for (size_t i = 0; i < a.tree.nodes.size(); ++i) {
            ASSERT_EQ(a.tree.nodes[i].position, b.tree.nodes[i].position) << name;
        }
        ASSERT_EQ(a.tree.leaves.size(), b.tree.leaves.size());
        EXPECT_GT(a.methodStats.at("stems"), 3.0) << name;
        EXPECT_GT(a.methodStats.at("leaves"), 100.0) << name;
        for (size_t i = 1; i < a.tree.nodes.size(); ++i) {
            EXPECT_LT(a.tree.nodes[i].parent, static_cast<int32_t>(i));
            EXPECT_GE(a.tree.nodes[i].position.y, -0.05) << name << " node below ground";
        }
    }
    EXPECT_GE(found, 1);
}

// The library's grammar species (species/presets/): the same tree threaded or not, no shoot
// node below the ground (their ground_clearance, before the form stage's prune), and the
// banyan's prop roots, labelled as roots, hanging straight down and ending on the ground.
TEST(GrammarSpec, LibrarySpeciesGrowAboveTheGround) {
    const fs::path presets = fs::path(SYLVA_SOURCE_DIR) / "species/presets";
    int grammar = 0, rootedProps = 0;
    for (const auto& e : fs::directory_iterator(presets)) {
        if (e.path().extension() != ".toml") continue;
        const SpeciesFile sp = loadSpecies(e.path().string());
        if (sp.method != "grammar") continue;
        SCOPED_TRACE(sp.name);
        ++grammar;
        const GrownTree a = growSpecies(sp, 7, nullptr, false);
        const GrownTree b = growSpecies(sp, 7, nullptr, true);
        ASSERT_EQ(a.tree.nodes.size(), b.tree.nodes.size());
        for (size_t i = 0; i < a.tree.nodes.size(); ++i) {
            ASSERT_EQ(a.tree.nodes[i].position, b.tree.nodes[i].position);
        }
        const ChildIndex children(a.tree);
        for (size_t i = 1; i < a.tree.nodes.size(); ++i) {
            const SkeletonNode& n = a.tree.nodes[i];
            if (n.part == kShootPart) {
                EXPECT_GE(n.position.y, 0.0) << "shoot node " << i;
                continue;
            }
            // A prop root: straight under its parent, above the ground, ending on it if rooted.
            const Vec3 step = n.position - a.tree.nodes[n.parent].position;
            EXPECT_LT(angleBetween(step, Vec3{0, -1, 0}), 1.0 * kDeg) << "root node " << i;
            EXPECT_GE(n.position.y, 0.0);
            if (children.count(static_cast<int>(i)) == 0 && n.position.y == 0.0) ++rootedProps;
        }
    }
    EXPECT_GE(grammar, 17);
    EXPECT_GT(rootedProps, 0) << "the banyan's prop roots reach the ground";
}

// A dataset sweep over grammar.max_depth with same_seed = true is a growth series: one seed
// per instance across the points, and each point's tree contains the previous one.
TEST(GrammarSpec, SameSeedDepthSweepGivesNestedGrowthStages) {
    const DatasetSpec spec =
        loadDataset((fs::path(SYLVA_SOURCE_DIR) / "datasets/grammar-growth-stages.toml").string());
    const std::vector<InstanceJob> jobs = expandJobs(spec);
    std::map<std::pair<std::string, int64_t>, std::vector<const InstanceJob*>> series;
    for (const InstanceJob& j : jobs) series[{j.entry->species.name, j.index}].push_back(&j);
    ASSERT_EQ(series.size(), 8u);
    for (const auto& [id, points] : series) {
        ASSERT_GE(points.size(), 5u);
        Tree prev;
        for (const InstanceJob* j : points) {
            EXPECT_EQ(j->seed, points[0]->seed) << id.first;
            const Tree t =
                growSpecies(j->entry->species, j->seed, j->point->overrides.get(), false).tree;
            std::set<std::tuple<double, double, double>> here;
            for (const SkeletonNode& n : t.nodes) {
                here.insert({n.position.x, n.position.y, n.position.z});
            }
            EXPECT_GT(t.nodes.size(), prev.nodes.size());
            for (const SkeletonNode& n : prev.nodes) {
                ASSERT_TRUE(here.count({n.position.x, n.position.y, n.position.z})) << id.first;
            }
            prev = t;
        }
    }
    // Without same_seed the points draw different trees (the default, unchanged).
    EXPECT_NE(instanceSeed(1, "a", "grammar.max_depth=3", 0),
              instanceSeed(1, "a", "grammar.max_depth=4", 0));
}

}  // namespace
}  // namespace sylva
