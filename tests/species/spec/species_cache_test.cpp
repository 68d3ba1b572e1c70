// A species without distributions is parsed once per sweep point and shared by its instances;
// a tree must not depend on whether its method came from that cache.
#include <gtest/gtest.h>

#include "species/spec/species.h"

using namespace sylva;

namespace {

void expectSameTree(const Tree& a, const Tree& b) {
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    for (size_t i = 0; i < a.nodes.size(); ++i) {
        ASSERT_EQ(a.nodes[i].position, b.nodes[i].position) << i;
        ASSERT_EQ(a.nodes[i].radius, b.nodes[i].radius) << i;
        ASSERT_EQ(a.nodes[i].parent, b.nodes[i].parent) << i;
    }
    ASSERT_EQ(a.leaves.size(), b.leaves.size());
}

TEST(SpeciesCache, CachedMethodGrowsTheSameTreeAsAFreshParse) {
    // xm-h's crown is an OpenVDB level set: the expensive part the cache saves.
    const std::string path = SYLVA_SOURCE_DIR "/species/papers/xu-mould-2012/xm-h.toml";
    SpeciesFile warm = loadSpecies(path);
    growSpecies(warm, 5, nullptr, false);  // fills the cache
    EXPECT_EQ(speciesCacheCounts(warm).misses, 1);
    EXPECT_EQ(speciesCacheCounts(warm).hits, 0);
    GrownTree cached = growSpecies(warm, 7, nullptr, false);
    growSpecies(warm, 8, nullptr, false);
    EXPECT_EQ(speciesCacheCounts(warm).misses, 1);  // parsed once ...
    EXPECT_EQ(speciesCacheCounts(warm).hits, 2);    // ... and reused by the next two trees
    const SpeciesFile cold = loadSpecies(path);
    GrownTree fresh = growSpecies(cold, 7, nullptr, false);
    EXPECT_EQ(speciesCacheCounts(cold).misses, 1);
    expectSameTree(cached.tree, fresh.tree);
    EXPECT_TRUE(cached.sampled.empty());
}

TEST(SpeciesCache, EachSweepPointIsCachedOnItsOwn) {
    const SpeciesFile s = loadSpecies(SYLVA_SOURCE_DIR "/tests/data/tiny.toml");
    auto point = [](double shrink) {
        Overrides o;
        o["graph.shrink"].holder.insert("v", shrink);
        return o;
    };
    const Overrides a = point(0.6), b = point(0.8);
    const GrownTree a1 = growSpecies(s, 1, &a, false);
    const GrownTree b1 = growSpecies(s, 1, &b, false);
    growSpecies(s, 2, &a, false);
    growSpecies(s, 2, &b, false);
    growSpecies(s, 3, nullptr, false);
    EXPECT_EQ(speciesCacheCounts(s).misses, 3);  // one parse per sweep point (and none)
    EXPECT_EQ(speciesCacheCounts(s).hits, 2);
    // The points differ (the cache did not hand one point's method to the other).
    EXPECT_FALSE(a1.tree.nodes.back().position == b1.tree.nodes.back().position);
    expectSameTree(a1.tree, growSpecies(loadSpecies(s.path), 1, &a, false).tree);
}

TEST(SpeciesCache, SpeciesWithDistributionsDrawPerInstance) {
    const std::string path = SYLVA_SOURCE_DIR "/tests/data/tiny_var.toml";
    SpeciesFile s = loadSpecies(path);
    GrownTree a = growSpecies(s, 1, nullptr, false);
    GrownTree b = growSpecies(s, 2, nullptr, false);
    growSpecies(s, 1, nullptr, false);
    EXPECT_EQ(speciesCacheCounts(s).hits, 0);  // never cached: parsed for every tree
    EXPECT_EQ(speciesCacheCounts(s).misses, 3);
    GrownTree a2 = growSpecies(loadSpecies(path), 1, nullptr, false);
    EXPECT_FALSE(a.sampled.empty());
    EXPECT_NE(a.sampled, b.sampled);  // drawn again for every instance, never cached
    EXPECT_EQ(a.sampled, a2.sampled);
    expectSameTree(a.tree, a2.tree);
}

}  // namespace
