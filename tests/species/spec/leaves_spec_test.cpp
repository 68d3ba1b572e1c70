// The leaves' `shape` key: read by the shared leaf-card reader (the species' [leaves] and the
// canopy's [leaves]) and by the grammar's [particles.<state>], default "card", an unknown word
// an error naming its place; and grown trees carry the shape on their leaves (fruit stays a
// card).
#include "species/spec/leaves_spec.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "species/model/leaf_shape.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

TEST(LeavesSpec, ShapeIsReadWithCardAsTheDefault) {
    const toml::table absent = toml::parse("[leaves]\nper_tip = 2\n");
    Params a(absent, "s.toml", "", nullptr);
    EXPECT_EQ(readLeaves(a).shape, LeafShape::kCard);
    for (const auto& [word, shape] : leafShapeWords()) {
        const toml::table t = toml::parse("[leaves]\nshape = \"" + word + "\"\n");
        Params p(t, "s.toml", "", nullptr);
        const LeafOptions o = readLeaves(p);
        EXPECT_TRUE(o.enabled);
        EXPECT_EQ(o.shape, shape) << word;
    }
}

TEST(LeavesSpec, AnUnknownShapeIsAnErrorWithItsPlace) {
    const toml::table t = toml::parse("[leaves]\nper_tip = 2\nshape = \"pinnate\"\n");
    Params p(t, "s.toml", "", nullptr);
    try {
        readLeaves(p);
        FAIL() << "expected a SpecError";
    } catch (const SpecError& e) {
        EXPECT_EQ(std::string(e.what()),
                  "s.toml:3:9: leaves.shape: expected one of \"card\", \"simple\", \"lobed\", "
                  "\"palmate\", \"compound\", \"needles\", \"frond\", got \"pinnate\"");
    }
}

// Grows a species written to a scratch file.
Tree grow(const test::TempDir& dir, const std::string& name, const std::string& body) {
    const auto path = dir / (name + ".toml");
    std::ofstream(path) << body;
    return growSpecies(loadSpecies(path.string()), 7, nullptr, false).tree;
}

TEST(LeavesSpec, GrownLeavesCarryTheirShapeInEveryMethod) {
    test::TempDir dir;
    // The species' [leaves] (iterated-graph), through readLeafCards.
    std::string tiny = test::slurp(SYLVA_SOURCE_DIR "/tests/data/tiny.toml");
    const Tree ig = grow(dir, "ig", tiny + "shape = \"lobed\"\n");
    ASSERT_FALSE(ig.leaves.empty());
    for (const Leaf& l : ig.leaves) EXPECT_EQ(l.shape, LeafShape::kLobed);
    // The canopy's own [leaves], through the same reader.
    const Tree canopy = grow(dir, "canopy",
                             "method = \"canopy\"\n[canopy]\nradii = [1, 1, 1]\n"
                             "position = [0, 2, 0]\n[[templates]]\naxiom = \"F\"\niterations = 1\n"
                             "[leaves]\ncount = 40\ncluster = 2\nshape = \"palmate\"\n");
    ASSERT_EQ(canopy.leaves.size(), 80u);
    for (const Leaf& l : canopy.leaves) EXPECT_EQ(l.shape, LeafShape::kPalmate);
    // The grammar's particles; its fruit cards stay cards.
    const Tree grammar = grow(dir, "grammar",
                              "method = \"grammar\"\n[grammar]\nmax_depth = 3\n"
                              "[rules]\ns = [{ out = [\"a\"] }]\na = [{ out = [\"b\", \"b\"] }]\n"
                              "b = [{ out = [\"t\"] }]\n"
                              "[particles.b]\ncount = 4\nshape = \"compound\"\n"
                              "[fruit.b]\ncount = 1\n");
    size_t leaves = 0, fruit = 0;
    for (const Leaf& l : grammar.leaves) {
        if (l.colour == 8) {
            ++fruit;
            EXPECT_EQ(l.shape, LeafShape::kCard);
        } else {
            ++leaves;
            EXPECT_EQ(l.shape, LeafShape::kCompound);
        }
    }
    EXPECT_GT(leaves, 0u);
    EXPECT_GT(fruit, 0u);
}

}  // namespace
}  // namespace sylva
