// Seasons of the methods that colour their own leaves: applySeason keeps nested subsets of the
// leaves and colours them by height (known answers at the top and bottom), and a species'
// `season` / [seasons] change the leaves, never the wood; bad values are one-line errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <set>
#include <string>

#include "species/geometry/leaves.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

// A shoot from y = 0 to y = 10 with n leaves evenly up it; leaf i has size i + 1 (its name)
// and colour class 2.
Tree shootWithLeaves(int n) {
    Tree t;
    SkeletonNode a, b;
    a.position = {0, 0, 0};
    b.position = {0, 10, 0};
    b.parent = 0;
    t.nodes = {a, b};
    for (int i = 0; i < n; ++i) {
        Leaf l;
        l.position = {0, 10.0 * i / (n - 1), 0};
        l.size = i + 1;
        l.colour = 2;
        l.node = 1;
        t.leaves.push_back(l);
    }
    return t;
}

std::set<double> names(const Tree& t) {
    std::set<double> s;
    for (const Leaf& l : t.leaves) s.insert(l.size);
    return s;
}

TEST(Season, KeptLeavesAreNestedSubsetsAtTheirDensity) {
    const int n = 20000;
    const Rng rng(42);
    const std::array<SeasonPalette, 4> built = grownSeasons();
    Tree summer = shootWithLeaves(n), spring = summer, autumn = summer, winter = summer;
    applySeason(summer, built[int(Season::kSummer)], rng);
    applySeason(spring, built[int(Season::kSpring)], rng);
    applySeason(autumn, built[int(Season::kAutumn)], rng);
    applySeason(winter, built[int(Season::kWinter)], rng);
    ASSERT_EQ(summer.leaves.size(), size_t(n));  // as grown: untouched
    for (const Leaf& l : summer.leaves) EXPECT_EQ(l.colour, 2);
    EXPECT_TRUE(winter.leaves.empty());
    // Binomial spreads of 0.35 % and 0.28 %: within 2 % of the densities.
    EXPECT_NEAR(double(spring.leaves.size()) / n, 0.6, 0.02);
    EXPECT_NEAR(double(autumn.leaves.size()) / n, 0.8, 0.02);
    const std::set<double> sp = names(spring), au = names(autumn);
    EXPECT_TRUE(std::includes(au.begin(), au.end(), sp.begin(), sp.end()));
    // Another stream keeps another subset.
    Tree other = shootWithLeaves(n);
    applySeason(other, built[int(Season::kAutumn)], Rng(43));
    EXPECT_NE(names(other), au);
    // The order of the kept leaves is the grown order.
    EXPECT_TRUE(std::is_sorted(autumn.leaves.begin(), autumn.leaves.end(),
                               [](const Leaf& a, const Leaf& b) { return a.size < b.size; }));
}

TEST(Season, ClassesRunDarkLowToLightHighAsTheGrammarsDo) {
    const int n = 20000;
    Tree t = shootWithLeaves(n);
    applySeason(t, {{4, 5, 6, 7}, 1.0, false}, Rng(7));
    ASSERT_EQ(t.leaves.size(), size_t(n));
    // ⌊h·4 − 0.5 + u⌋: below h = 1/8 it is 0 or −1 (class 4), above 7/8 it is 3 or 4 (class 7);
    // at h in (1/8, 3/8) it is 0 or 1 (classes 4, 5), the share of class 5 rising with h.
    int lowMix[2] = {0, 0};
    for (const Leaf& l : t.leaves) {
        const double h = l.position.y / 10.0;
        ASSERT_GE(l.colour, 4);
        ASSERT_LE(l.colour, 7);
        if (h < 0.125) {
            EXPECT_EQ(l.colour, 4) << h;
        }
        if (h > 0.875) {
            EXPECT_EQ(l.colour, 7) << h;
        }
        if (h > 0.125 && h < 0.375) {
            EXPECT_TRUE(l.colour == 4 || l.colour == 5) << h;
            ++lowMix[l.colour - 4];
        }
    }
    // Uniform u: half of that band each way.
    EXPECT_NEAR(double(lowMix[1]) / (lowMix[0] + lowMix[1]), 0.5, 0.03);
    // As grown at half density: the colours stay.
    Tree half = shootWithLeaves(1000);
    applySeason(half, {{}, 0.5, true}, Rng(7));
    EXPECT_GT(half.leaves.size(), 400u);
    EXPECT_LT(half.leaves.size(), 600u);
    for (const Leaf& l : half.leaves) EXPECT_EQ(l.colour, 2);
}

std::string tinyWith(const std::string& topLevel, const std::string& tables = "") {
    std::string tiny = test::slurp(SYLVA_SOURCE_DIR "/tests/data/tiny.toml");
    const size_t at = tiny.find("[crown]");
    return tiny.substr(0, at) + topLevel + "\n" + tiny.substr(at) + "\n" + tables;
}

Tree grow(const test::TempDir& dir, const std::string& name, const std::string& body) {
    const auto path = dir / (name + ".toml");
    std::ofstream(path) << body;
    return growSpecies(loadSpecies(path.string()), 7, nullptr, false).tree;
}

void expectSameWood(const Tree& a, const Tree& b) {
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    for (size_t i = 0; i < a.nodes.size(); ++i) {
        EXPECT_EQ(a.nodes[i].position, b.nodes[i].position);
        EXPECT_EQ(a.nodes[i].radius, b.nodes[i].radius);
    }
}

TEST(Season, ASpeciesSeasonChangesItsLeavesNeverItsWood) {
    test::TempDir dir;
    const Tree plain = grow(dir, "plain", tinyWith(""));
    const Tree summer = grow(dir, "summer", tinyWith("season = \"summer\""));
    const Tree autumn = grow(dir, "autumn", tinyWith("season = \"autumn\""));
    const Tree winter = grow(dir, "winter", tinyWith("season = \"winter\""));
    const Tree evergreen = grow(
        dir, "evergreen",
        tinyWith("season = \"winter\"", "[seasons.winter]\nclasses = \"as-grown\"\ndensity = 1\n"));
    ASSERT_GT(plain.leaves.size(), 20u);
    for (const Tree* t : {&summer, &autumn, &winter, &evergreen}) expectSameWood(plain, *t);
    // Summer, and an evergreen's winter, are the leaves as grown, leaf for leaf.
    for (const Tree* t : {&summer, &evergreen}) {
        ASSERT_EQ(t->leaves.size(), plain.leaves.size());
        for (size_t i = 0; i < plain.leaves.size(); ++i) {
            EXPECT_EQ(t->leaves[i].position, plain.leaves[i].position);
            EXPECT_EQ(t->leaves[i].colour, plain.leaves[i].colour);
        }
    }
    EXPECT_TRUE(winter.leaves.empty());
    EXPECT_LT(autumn.leaves.size(), plain.leaves.size());
    EXPECT_GT(autumn.leaves.size(), 0u);
    for (const Leaf& l : autumn.leaves) {
        EXPECT_GE(l.colour, 4);
        EXPECT_LE(l.colour, 7);
    }
    // The canopy places its own leaves; its season applies to them the same way.
    const std::string canopy =
        "method = \"canopy\"\nseason = \"@\"\n[canopy]\nradii = [1, 1, 1]\n"
        "position = [0, 2, 0]\n[[templates]]\naxiom = \"F\"\niterations = 1\n"
        "[leaves]\ncount = 40\ncluster = 2\n";
    auto canopyIn = [&](const std::string& season) {
        std::string s = canopy;
        s.replace(s.find('@'), 1, season);
        return grow(dir, "canopy-" + season, s);
    };
    const Tree cSummer = canopyIn("summer"), cWinter = canopyIn("winter");
    EXPECT_EQ(cSummer.leaves.size(), 80u);
    EXPECT_TRUE(cWinter.leaves.empty());
    expectSameWood(cSummer, cWinter);
}

// A canopy tree's leaves are certainly meshed — unless its season drops some: the bound of its
// leaves' triangles then no longer holds, and a budget below it no longer refuses the species.
TEST(Season, ASeasonThatDropsLeavesLiftsTheirTriangleBound) {
    test::TempDir dir;
    auto validate = [&](const std::string& season) {
        const auto path = dir / ("c-" + season + ".toml");
        std::ofstream(path) << "method = \"canopy\"\nseason = \"" << season << "\"\n"
                            << "[canopy]\nradii = [1, 1, 1]\nposition = [0, 2, 0]\n"
                               "[[templates]]\naxiom = \"F\"\niterations = 1\n"
                               "[leaves]\ncount = 40\ncluster = 2\n[budget]\nmax_triangles = 100\n";
        validateSpecies(loadSpecies(path.string()), nullptr, nullptr, /*meshed=*/true);
    };
    // 80 leaves, both faces of 2 triangles each: 320 > 100.
    EXPECT_THROW(validate("summer"), SpecError);
    EXPECT_NO_THROW(validate("autumn"));  // 0.8 of them
    EXPECT_NO_THROW(validate("winter"));  // none
}

std::string errorOf(const test::TempDir& dir, const std::string& name, const std::string& body) {
    try {
        grow(dir, name, body);
    } catch (const SpecError& e) {
        return e.what();
    }
    return "no error";
}

TEST(Season, BadSeasonsAreOneLineErrorsAtTheirKey) {
    test::TempDir dir;
    const std::string path = (dir / "x.toml").string();
    EXPECT_EQ(errorOf(dir, "x", tinyWith("season = \"monsoon\"")),
              path +
                  ":7:10: season: expected one of \"spring\", \"summer\", \"autumn\", "
                  "\"winter\", got \"monsoon\"");
    EXPECT_EQ(errorOf(dir, "x", tinyWith("", "[seasons.winter]\nclasses = \"green\"\n")),
              path +
                  ":38:11: seasons.winter.classes: expected an array of colour classes or "
                  "\"as-grown\"");
    EXPECT_EQ(errorOf(dir, "x", tinyWith("", "[seasons.winter]\ndensity = 1.5\n")),
              path + ":38:11: seasons.winter.density: expected a number in [0, 1], got 1.5");
    EXPECT_EQ(errorOf(dir, "x", tinyWith("", "[seasons.monsoon]\ndensity = 1\n")),
              path +
                  ":37:1: seasons.monsoon: unknown season (expected spring, summer, autumn, "
                  "winter)");
    // The grammar colours its particles by its palettes: "as-grown" means nothing there.
    const std::string grammar =
        "method = \"grammar\"\n[grammar]\nmax_depth = 2\n"
        "[rules]\ns = [{ out = [\"b\"] }]\nb = [{ out = [\"t\"] }]\n"
        "[particles.b]\ncount = 4\n[seasons.winter]\nclasses = \"as-grown\"\n";
    EXPECT_EQ(errorOf(dir, "x", grammar),
              path +
                  ":10:11: seasons.winter.classes: expected an array of colour classes "
                  "(integers 0–255)");
}

}  // namespace
}  // namespace sylva
