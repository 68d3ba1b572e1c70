// The parameter reader (core/params.h) with known answers: typed reads and ranges, required
// and default keys, distributions and their draws, sweep overrides, unknown keys, and the
// promise that adding a parameter never changes another's draw.
#include "core/params.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace sylva {
namespace {

// The message of the SpecError `read` throws ("" when it throws nothing).
template <class F>
std::string errorOf(F read) {
    try {
        read();
    } catch (const SpecError& e) {
        return e.what();
    }
    return "";
}

DrawContext drawing(uint64_t seed) {
    DrawContext d;
    d.seed = seed;
    return d;
}

TEST(Params, NumbersAndIntegersWithRanges) {
    const toml::table t = toml::parse("a = 2.5\nb = 7\nc = -1\nd = 0\n");
    DrawContext draw = drawing(1);
    Params p(t, "s.toml", "", &draw);
    EXPECT_EQ(p.number("a", Range::positive()), 2.5);
    EXPECT_EQ(p.integer("b", Range::closed(1, 10)), 7);
    EXPECT_EQ(p.number("b", Range::any()), 7.0);  // an integer is a number
    // Required keys that are missing, defaults for optional ones.
    EXPECT_EQ(p.number("missing", 4.0, Range::positive()), 4.0);
    EXPECT_EQ(p.integer("missing_int", 3, Range::closed(0, 5)), 3);
    EXPECT_EQ(errorOf([&] { p.number("absent", Range::positive()); }),
              "s.toml:1:1: absent: required key missing (expected a number > 0)");
    // Out of range: the message names file:line:col, the key and the valid range.
    EXPECT_EQ(errorOf([&] { p.number("c", Range::nonNegative()); }),
              "s.toml:3:5: c: expected a number ≥ 0, got -1");
    EXPECT_EQ(errorOf([&] { p.number("d", Range::positive()); }),
              "s.toml:4:5: d: expected a number > 0, got 0");
    EXPECT_EQ(errorOf([&] { p.integer("b", Range::leftOpen(7, 9)); }),
              "s.toml:2:5: b: expected an integer in (7, 9], got 7");
    EXPECT_EQ(errorOf([&] { p.integer("a", Range::any()); }),
              "s.toml:1:5: a: expected an integer, got 2.5");
}

TEST(Params, WrongTypesAndChoices) {
    const toml::table t = toml::parse("s = \"x\"\nb = 1\nw = \"yao\"\nv = [1, 2]\n");
    Params p(t, "s.toml", "graph", nullptr);
    EXPECT_EQ(errorOf([&] { p.number("s", Range::any()); }),
              "s.toml:1:5: graph.s: expected a finite number, got a string");
    EXPECT_EQ(errorOf([&] { p.boolean("b", false); }),
              "s.toml:2:5: graph.b: expected true or false");
    EXPECT_EQ(p.choice("w", "distance", {"distance", "yao"}), "yao");
    EXPECT_EQ(errorOf([&] {
                  p.choice("s", "a", {"a", "xy"});
              }),
              "s.toml:1:5: graph.s: expected one of \"a\", \"xy\", got \"x\"; did you mean \"a\"?");
    EXPECT_EQ(errorOf([&] {
                  p.vec3("v", {0, 0, 0});
              }),
              "s.toml:4:5: graph.v: expected an array [x, y, z]");
    EXPECT_EQ(p.interval("v", {0, 0}, Range::any()), std::make_pair(1.0, 2.0));
}

enum class Shape { kSector, kCone };

TEST(Params, EnumChoicesAndDegrees) {
    const toml::table t = toml::parse("shape = \"cone\"\nalpha_deg = 90\nrot_deg = [30, 60]\n");
    Params p(t, "s.toml", "", nullptr);
    EXPECT_EQ(
        p.choice("shape", Shape::kSector, {{"sector", Shape::kSector}, {"cone", Shape::kCone}}),
        Shape::kCone);
    EXPECT_EQ(p.choice("other", Shape::kCone, {{"sector", Shape::kSector}, {"cone", Shape::kCone}}),
              Shape::kCone);
    EXPECT_DOUBLE_EQ(p.degrees("alpha_deg", 0.0, Range::closed(0, 180)), kPi / 2);
    // Absent: the fallback in radians, bit for bit.
    const double fallback = 54.0 * (kPi / 180.0);
    EXPECT_EQ(p.degrees("beta_deg", fallback, Range::closed(0, 180)), fallback);
    const auto [lo, hi] = p.degreeInterval("rot_deg", {0, 0}, Range::closed(0, 180));
    EXPECT_DOUBLE_EQ(lo, kPi / 6);
    EXPECT_DOUBLE_EQ(hi, kPi / 3);
    EXPECT_EQ(p.degreeInterval("none_deg", {0.25, 0.5}, Range::any()), std::make_pair(0.25, 0.5));
    EXPECT_EQ(errorOf([&] { p.degrees("alpha_deg", 0.0, Range::closed(0, 45)); }),
              "s.toml:2:13: alpha_deg: expected a number in [0, 45], got 90");
}

TEST(Params, UnknownKeysSuggestTheClosestAskedKey) {
    const toml::table t = toml::parse("linking = \"yao\"\nlinkng_factor = 2\n");
    Params p(t, "s.toml", "graph", nullptr);
    p.string("linking", "distance");
    p.number("link_factor", 1.8, Range::any());
    EXPECT_EQ(errorOf([&] { p.finish(); }),
              "s.toml:2:17: graph.linkng_factor: unknown key; did you mean \"link_factor\"?");
    EXPECT_EQ(closestWord("brancing", {"branching", "linking"}), "branching");
    EXPECT_FALSE(closestWord("zzzzzz", {"branching", "linking"}).has_value());
}

TEST(Params, UniformDrawsLieInTheirBoundsAndIntegersAreRounded) {
    const toml::table t = toml::parse("x = { uniform = [2.0, 3.0] }\nn = { uniform = [8, 14] }\n");
    double lo = 1e9, hi = -1e9;
    for (uint64_t seed = 1; seed <= 200; ++seed) {
        DrawContext draw = drawing(seed);
        Params p(t, "s.toml", "", &draw);
        const double x = p.number("x", Range::positive());
        const int64_t n = p.integer("n", Range::closed(0, 100));
        EXPECT_GE(x, 2.0);
        EXPECT_LE(x, 3.0);
        EXPECT_GE(n, 8);
        EXPECT_LE(n, 14);
        lo = std::min(lo, x);
        hi = std::max(hi, x);
        EXPECT_EQ(draw.sampled.at("x"), x);  // recorded for the manifest
        EXPECT_EQ(draw.sampled.at("n"), static_cast<double>(n));
    }
    EXPECT_LT(lo, 2.1);  // 200 draws spread over the interval
    EXPECT_GT(hi, 2.9);
}

TEST(Params, NormalDrawsAreClampedIntoTheValidRange) {
    const toml::table t = toml::parse("r = { normal = [0.1, 5.0] }\n");
    int clamped = 0;
    for (uint64_t seed = 1; seed <= 200; ++seed) {
        DrawContext draw = drawing(seed);
        Params p(t, "s.toml", "", &draw);
        const double r = p.number("r", Range::closed(0, 1));
        EXPECT_GE(r, 0.0);
        EXPECT_LE(r, 1.0);
        if (r == 0.0 || r == 1.0) ++clamped;
    }
    EXPECT_GT(clamped, 150);  // σ = 5 around 0.1: most draws fall outside [0, 1]
    // An open bound is never reached.
    const toml::table u = toml::parse("r = { normal = [0.5, 50.0] }\n");
    for (uint64_t seed = 1; seed <= 50; ++seed) {
        DrawContext draw = drawing(seed);
        Params p(u, "s.toml", "", &draw);
        const double r = p.number("r", Range::leftOpen(0, 1));
        EXPECT_GT(r, 0.0);
        EXPECT_LE(r, 1.0);
    }
}

TEST(Params, ValidationUsesTheCentreAndChecksTheBounds) {
    const toml::table t = toml::parse(
        "a = { uniform = [2, 4] }\nb = { normal = [5, 1] }\nc = { uniform = [-1, 1] }\n");
    DrawContext draw;
    draw.draw = false;
    Params p(t, "s.toml", "", &draw);
    EXPECT_EQ(p.number("a", Range::any()), 3.0);
    EXPECT_EQ(p.number("b", Range::any()), 5.0);
    EXPECT_TRUE(draw.sampled.empty());
    EXPECT_EQ(errorOf([&] { p.number("c", Range::positive()); }),
              "s.toml:3:5: c: uniform bounds must lie in the valid range: expected a number > 0");
    const toml::table bad = toml::parse("d = { uniform = [3, 2] }\ne = { unifrom = [1, 2] }\n");
    Params q(bad, "s.toml", "", &draw);
    EXPECT_EQ(errorOf([&] { q.number("d", Range::any()); }),
              "s.toml:1:5: d: uniform [a, b] needs a ≤ b");
    EXPECT_NE(errorOf([&] { q.number("e", Range::any()); }).find("did you mean"),
              std::string::npos);
}

TEST(Params, AddingOrReorderingParametersChangesNoOtherDraw) {
    const toml::table two = toml::parse(
        "a = { uniform = [0, 1] }\nb = { normal = [5, 2] }\n[t]\nc = { uniform = [0, 9] }\n");
    const toml::table more = toml::parse(
        "z = { uniform = [0, 1] }\nb = { normal = [5, 2] }\nnew = { normal = [0, 1] }\n"
        "a = { uniform = [0, 1] }\n[t]\nd = { uniform = [0, 1] }\nc = { uniform = [0, 9] }\n");
    for (uint64_t seed : {1u, 7u, 12345u}) {
        DrawContext d1 = drawing(seed), d2 = drawing(seed);
        Params p1(two, "s.toml", "", &d1), p2(more, "s.toml", "", &d2);
        p2.number("z", Range::any());
        p2.number("new", Range::any());
        EXPECT_EQ(p1.number("a", Range::any()), p2.number("a", Range::any()));
        EXPECT_EQ(p1.number("b", Range::any()), p2.number("b", Range::any()));
        Params t1 = p1.table("t"), t2 = p2.table("t");
        t2.number("d", Range::any());
        EXPECT_EQ(t1.number("c", Range::any()), t2.number("c", Range::any()));
        // Each draw depends on its own path: a and z (same distribution) differ.
        EXPECT_NE(d2.sampled.at("a"), d2.sampled.at("z"));
        EXPECT_EQ(d1.sampled.at("t.c"), d2.sampled.at("t.c"));
    }
}

TEST(Params, OverridesReplaceValuesAndReportTheirOwnPlace) {
    const toml::table t = toml::parse("[graph]\nshrink = 0.7\n");
    Overrides ov;
    auto add = [&](const std::string& path, double v, int line) {
        Override o;
        o.holder.insert("v", v);
        o.where = SourcePos{"d.toml", line, 3};
        ov[path] = std::move(o);
    };
    add("graph.shrink", 0.5, 11);
    add("light.spread", 0.25, 12);  // inside a table the species does not have
    add("graph.link_factor", -1.0, 13);
    Params p(t, "s.toml", "", nullptr, &ov);
    Params g = p.table("graph");
    EXPECT_EQ(g.number("shrink", 0.7, Range::positive()), 0.5);
    EXPECT_TRUE(ov.at("graph.shrink").used);
    EXPECT_EQ(errorOf([&] { g.number("link_factor", 1.8, Range::closed(1, 10)); }),
              "d.toml:13:3: graph.link_factor: expected a number in [1, 10], got -1");
    std::optional<Params> light = p.optionalTable("light");
    ASSERT_TRUE(light.has_value());  // absent, but an override reaches into it
    EXPECT_EQ(light->number("spread", 0.5, Range::closed(0, 1)), 0.25);
    EXPECT_TRUE(ov.at("light.spread").used);
    EXPECT_FALSE(p.optionalTable("roots").has_value());
}

TEST(Params, FormatNumberAndSourcePositions) {
    EXPECT_EQ(formatNumber(0.1 + 0.2, 6), "0.3");
    EXPECT_EQ(formatNumber(1e6, 12), "1000000");
    EXPECT_EQ((SourcePos{"a.toml", 3, 7}.str()), "a.toml:3:7");
    EXPECT_EQ((SourcePos{"a.toml", 0, 0}.str()), "a.toml");
    EXPECT_EQ((SourcePos{"", 2, 1}.str()), "<spec>:2:1");
    EXPECT_EQ(SpecError(SourcePos{"a.toml", 3, 7}, "k.x", "bad").what(),
              std::string("a.toml:3:7: k.x: bad"));
}

// Issue 15: `count = 1e9` (a TOML float) was read as the integer 10⁹.
TEST(Params, IntegerKeysTakeTomlIntegersOnly) {
    const toml::table t = toml::parse(
        "whole = 300.0\nexponent = 1e9\nfraction = 2.5\nn = 7\nnan = nan\n"
        "d = { uniform = [2, 4] }\n");
    DrawContext draw = drawing(1);
    Params p(t, "s.toml", "", &draw);
    EXPECT_EQ(errorOf([&] { p.integer("whole", Range::atLeast(1)); }),
              "s.toml:1:9: whole: expected an integer, got the float 300.0 (write integers "
              "without a decimal point or exponent)");
    EXPECT_EQ(errorOf([&] { p.integer("exponent", 0, Range::closed(0, 1e9)); }),
              "s.toml:2:12: exponent: expected an integer, got the float 1000000000.0 (write "
              "integers without a decimal point or exponent)");
    EXPECT_EQ(errorOf([&] { p.integer("fraction", Range::any()); }),
              "s.toml:3:12: fraction: expected an integer, got 2.5");
    EXPECT_EQ(errorOf([&] { p.integer("nan", Range::any()); }),
              "s.toml:5:7: nan: expected an integer, got nan");
    EXPECT_EQ(p.integer("n", Range::closed(1, 10)), 7);
    EXPECT_EQ(p.number("whole", Range::positive()), 300.0);      // a float is a number
    const int64_t drawn = p.integer("d", Range::closed(0, 10));  // distributions still draw
    EXPECT_GE(drawn, 2);
    EXPECT_LE(drawn, 4);
}

// Issue 15: integers went through a double, so seed = 2⁵³ + 1 became 2⁵³.
TEST(Params, IntegersAreExactBeyondTwoToThe53) {
    const toml::table t = toml::parse("seed = 9007199254740993\nbig = 9223372036854775807\n");
    Params p(t, "s.toml", "", nullptr);
    EXPECT_EQ(p.integer("seed", Range::closed(0, 9.2e18)), 9007199254740993LL);
    EXPECT_EQ(errorOf([&] { p.integer("big", Range::closed(1, 5e6)); }),
              "s.toml:2:7: big: expected an integer in [1, 5000000], got 9223372036854775807");
}

// Issue 15: 1e299 passed every range without an upper bound and ended in a runtime failure
// (exit 1: "poissonSample: minDistance is not finite").
TEST(Params, NumbersWithoutABoundOfTheirOwnAreAtMostOneBillion) {
    const toml::table t = toml::parse(
        "huge = 1e299\nneg = -2e9\nok = 1e9\nten = 1e10\nv = [0, 1e300, 0]\n"
        "u = { uniform = [1, 1e308] }\nn = { normal = [3, 1e300] }\npairs = [[0, 0], [1e10, 1]]\n");
    DrawContext draw = drawing(1);
    Params p(t, "s.toml", "", &draw);
    EXPECT_EQ(errorOf([&] { p.number("huge", Range::positive()); }),
              "s.toml:1:8: huge: expected a number > 0 of magnitude at most 1e9 (the largest a "
              "spec number may be), got 1e+299");
    EXPECT_NE(errorOf([&] { p.number("neg", Range::any()); }).find("magnitude at most 1e9"),
              std::string::npos);
    EXPECT_EQ(p.number("ok", Range::positive()), 1e9);
    EXPECT_EQ(p.number("ten", Range::closed(0, 1e12)), 1e10);  // a range of its own allows more
    EXPECT_NE(errorOf([&] {
                  p.vec3("v", {0, 0, 0});
              })
                  .find("v[1]: expected a finite number of "
                        "magnitude at most 1e9"),
              std::string::npos);
    EXPECT_NE(errorOf([&] {
                  p.number("u", Range::positive());
              }).find("distribution parameters must have magnitude at most 1e9, got 1e+308"),
              std::string::npos);
    EXPECT_NE(errorOf([&] { p.number("n", Range::positive()); }).find("magnitude at most 1e9"),
              std::string::npos);
    EXPECT_NE(errorOf([&] { p.pairArray("pairs"); }).find("magnitude at most 1e9"),
              std::string::npos);
    EXPECT_FALSE(Range::positive().contains(1.5e9));
    EXPECT_TRUE(Range::closed(0, 9.2e18).contains(9e18));
}

TEST(Params, SpecErrorsKeepTheirPlace) {
    const SpecError e(SourcePos{"a.toml", 3, 7}, "k.x", "bad");
    EXPECT_EQ(e.where().file, "a.toml");
    EXPECT_EQ(e.where().line, 3);
    EXPECT_EQ(e.where().column, 7);
}

}  // namespace
}  // namespace sylva
