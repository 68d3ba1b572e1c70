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
    const std::string path = SYLVA_SOURCE_DIR "/species/presets/xm-h.toml";
    SpeciesFile warm = loadSpecies(path);
    growSpecies(warm, 5, nullptr, false);  // fills the cache
    GrownTree cached = growSpecies(warm, 7, nullptr, false);
    GrownTree fresh = growSpecies(loadSpecies(path), 7, nullptr, false);
    expectSameTree(cached.tree, fresh.tree);
    EXPECT_TRUE(cached.sampled.empty());
}

TEST(SpeciesCache, SpeciesWithDistributionsDrawPerInstance) {
    const std::string path = SYLVA_SOURCE_DIR "/tests/data/tiny_var.toml";
    SpeciesFile s = loadSpecies(path);
    GrownTree a = growSpecies(s, 1, nullptr, false);
    GrownTree b = growSpecies(s, 2, nullptr, false);
    GrownTree a2 = growSpecies(loadSpecies(path), 1, nullptr, false);
    EXPECT_FALSE(a.sampled.empty());
    EXPECT_NE(a.sampled, b.sampled);  // drawn again for every instance, never cached
    EXPECT_EQ(a.sampled, a2.sampled);
    expectSameTree(a.tree, a2.tree);
}

}  // namespace
