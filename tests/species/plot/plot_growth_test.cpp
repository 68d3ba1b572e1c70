// growPlot: trees grown together (shared markers, crown clips, tropism), placed on the
// terrain, scaled to their heights and to the LAI; the crown statistics.
#include "species/plot/plot_growth.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "core/errors.h"
#include "pipeline/batch/dataset.h"
#include "species/plot/inventory.h"
#include "species/plot/layout.h"
#include "species/spec/species.h"

namespace sylva {
namespace {

const std::string kData = std::string(SYLVA_SOURCE_DIR) + "/tests/data/plot/";

PlotSpecies plotSpecies(const std::string& file, int index) {
    PlotSpecies s;
    const std::string preset = std::string(SYLVA_SOURCE_DIR) + "/species/presets/" + file;
    s.species = loadSpecies(file.rfind("small-", 0) == 0 ? kData + file : preset);
    s.keyPath = "plot[0].species[" + std::to_string(index) + "]";
    s.where = SourcePos{"plot.toml", 3 + index, 1};
    return s;
}

PlotSpec makeSpec(const std::vector<std::string>& files, double width = 30, double depth = 12) {
    PlotSpec spec;
    spec.name = "test";
    spec.keyPath = "plot[0]";
    spec.where = SourcePos{"plot.toml", 1, 1};
    spec.area.width = width;
    spec.area.depth = depth;
    for (size_t i = 0; i < files.size(); ++i) {
        spec.species.push_back(plotSpecies(files[i], static_cast<int>(i)));
    }
    return spec;
}

// Heights y = slope·x over [−20, 20] × [−10, 10].
Terrain makeTerrain(double slope = 0.0) {
    const int nx = 41, nz = 21;
    std::vector<float> h(size_t(nx) * nz);
    for (int j = 0; j < nz; ++j) {
        for (int i = 0; i < nx; ++i) h[size_t(j) * nx + i] = static_cast<float>(slope * (i - 20));
    }
    return Terrain(-20, -10, 1.0, nx, nz, std::move(h));
}

// `count` stems in a row along x, `spacing` apart, centred on x = 0, all of species `species`
// (or alternating 0, 1 when species < 0).
PlotLayout row(int count, double spacing, int species = 0, double slope = 0.0,
               double targetHeight = 0.0) {
    PlotLayout layout;
    layout.terrain = makeTerrain(slope);
    for (int k = 0; k < count; ++k) {
        PlotStem s;
        s.id = k + 1;
        s.species = species < 0 ? k % 2 : species;
        const double x = (k - (count - 1) / 2.0) * spacing;
        s.base = {x, layout.terrain.height(x, 0.0), 0.0};
        s.targetHeight = targetHeight;
        s.seed = 1000 + 17 * k;
        layout.stems.push_back(s);
    }
    return layout;
}

// `count` pairs of stems, `within` apart along x, the pairs `between` apart along z (so every
// tree has one close neighbour).
PlotLayout pairs(int count, double within, double between) {
    PlotLayout layout;
    layout.terrain = makeTerrain();
    for (int k = 0; k < 2 * count; ++k) {
        PlotStem s;
        s.id = k + 1;
        const double x = (k % 2 ? 0.5 : -0.5) * within;
        const double z = (k / 2 - (count - 1) / 2.0) * between;
        s.base = {x, 0.0, z};
        s.seed = 5000 + 31 * k;
        layout.stems.push_back(s);
    }
    return layout;
}

// Every byte of every tree's nodes and leaves.
std::string serialize(const GrownPlot& plot) {
    std::string out;
    auto put = [&](const void* p, size_t n) { out.append(static_cast<const char*>(p), n); };
    for (const PlotTree& t : plot.trees) {
        for (const SkeletonNode& n : t.grown.tree.nodes) {
            put(&n.position, sizeof n.position);
            put(&n.radius, sizeof n.radius);
            put(&n.parent, sizeof n.parent);
            put(&n.order, sizeof n.order);
        }
        for (const Leaf& l : t.grown.tree.leaves) {
            put(&l.position, sizeof l.position);
            put(&l.normal, sizeof l.normal);
            put(&l.size, sizeof l.size);
        }
        put(&t.leafScale, sizeof t.leafScale);
    }
    put(&plot.lai, sizeof plot.lai);
    return out;
}

// The plot's own budget: past the dataset's max_plot_seconds the plot stops with
// BudgetExceeded naming it (a plot of 10⁵ stems could otherwise run for hours, each tree
// within its own max_growth_seconds). Progress is reported per tree: every tree's growth, and
// its finishing once, the counts reaching the plot's trees.
TEST(PlotGrowth, APlotHasItsOwnTimeBudgetAndReportsItsTrees) {
    const PlotSpec spec = makeSpec({"small-graph.toml", "small-colonizer.toml"});
    const PlotLayout layout = row(4, 3.0, -1);
    BudgetTable none;
    none.maxPlotSeconds = 1e-9;
    try {
        (void)growPlot(spec, layout, &none, false);
        FAIL() << "a plot grew past max_plot_seconds";
    } catch (const BudgetExceeded& e) {
        EXPECT_EQ(std::string(e.what()).rfind("budget max_plot_seconds = 1e-09 exceeded", 0), 0u)
            << e.what();
    }
    std::mutex mutex;
    std::map<std::string, std::vector<int64_t>> seen;
    const PlotProgress progress = [&](const char* phase, int64_t done, int64_t total) {
        std::lock_guard<std::mutex> lock(mutex);
        EXPECT_EQ(total, 4);
        seen[phase].push_back(done);
    };
    BudgetTable ample;
    ample.maxPlotSeconds = 1e6;
    const GrownPlot plot = growPlot(spec, layout, &ample, true, progress);
    EXPECT_EQ(plot.trees.size(), 4u);
    ASSERT_EQ(seen["finishing"].size(), 4u);
    std::sort(seen["finishing"].begin(), seen["finishing"].end());
    EXPECT_EQ(seen["finishing"], (std::vector<int64_t>{1, 2, 3, 4}));
    EXPECT_GE(seen["growing"].size(), 4u);  // trees regrown among neighbours count again
    // The same trees with and without a report.
    EXPECT_EQ(serialize(plot), serialize(growPlot(spec, layout, nullptr, false)));
}

TEST(PlotGrowth, LoneColonizerGrowsAsGrowSpecies) {
    const PlotSpec spec = makeSpec({"small-colonizer.toml"});
    PlotLayout layout = row(1, 0.0);
    const GrownPlot plot = growPlot(spec, layout, nullptr, false);
    const GrownTree alone =
        growSpecies(spec.species[0].species, layout.stems[0].seed, nullptr, false);
    ASSERT_EQ(plot.trees.size(), 1u);
    const Tree& a = plot.trees[0].grown.tree;
    ASSERT_EQ(a.nodes.size(), alone.tree.nodes.size());
    for (size_t i = 0; i < a.nodes.size(); ++i) {
        EXPECT_EQ(a.nodes[i].position.x, alone.tree.nodes[i].position.x);
        EXPECT_EQ(a.nodes[i].position.y, alone.tree.nodes[i].position.y);
        EXPECT_EQ(a.nodes[i].position.z, alone.tree.nodes[i].position.z);
        EXPECT_EQ(a.nodes[i].radius, alone.tree.nodes[i].radius);
    }
    EXPECT_EQ(a.leaves.size(), alone.tree.leaves.size());
}

TEST(PlotGrowth, ColonizersGrowAwayFromCloseNeighbours) {
    PlotSpec spec = makeSpec({"small-colonizer.toml"}, 30, 60);
    const PlotLayout layout = pairs(6, 2.4, 8.0);
    const GrownPlot together = growPlot(spec, layout, nullptr, false);
    const auto a = crownAsymmetry(together);
    const double cosTogether = crownNeighbourCosine(a);
    spec.neighbours = false;
    const GrownPlot alone = growPlot(spec, layout, nullptr, false);
    const double cosAlone = crownNeighbourCosine(crownAsymmetry(alone));
    EXPECT_GT(cosTogether, 0.6);
    EXPECT_LT(cosAlone, 0.3);
    // Every tree's crown centre lies on its far side from its partner.
    for (size_t k = 0; k < a.size(); ++k) {
        EXPECT_GT(a[k].offset.x * (k % 2 ? 1 : -1), 0.05) << "tree " << k + 1;
    }
    // Shared space: less overlap than the trees grown alone.
    EXPECT_LT(maxCrownOverlap(crownOverlaps(together)), maxCrownOverlap(crownOverlaps(alone)));
}

TEST(PlotGrowth, GrammarCrownsTurnAwayFromCloseNeighbours) {
    PlotSpec spec = makeSpec({"lemon.toml"}, 30, 60);  // a preset: grammar trees are fast
    const PlotLayout layout = pairs(5, 2.0, 10.0);
    const double together =
        crownNeighbourCosine(crownAsymmetry(growPlot(spec, layout, nullptr, false)));
    spec.neighbours = false;
    const double alone =
        crownNeighbourCosine(crownAsymmetry(growPlot(spec, layout, nullptr, false)));
    EXPECT_GT(together, 0.6);
    EXPECT_LT(alone, together - 0.4);
}

// The gap between two neighbouring crowns along the line between their bases: the distance
// minus each crown's reach toward the other (leaf centres and shoot nodes above 1 m).
double gapBetween(const PlotTree& a, const PlotTree& b) {
    const double dx = b.stem.base.x - a.stem.base.x, dz = b.stem.base.z - a.stem.base.z;
    const double d = std::hypot(dx, dz);
    const Vec3 u{dx / d, 0, dz / d};
    auto reach = [&](const PlotTree& t, const Vec3& dir) {
        double r = 0;
        for (const Leaf& l : t.grown.tree.leaves)
            r = std::max(r, dot(l.position - t.stem.base, dir));
        for (const SkeletonNode& n : t.grown.tree.nodes) {
            if (n.part == kShootPart && n.position.y > t.stem.base.y + 1.0) {
                r = std::max(r, dot(n.position - t.stem.base, dir));
            }
        }
        return r;
    };
    return d - reach(a, u) - reach(b, u * -1.0);
}

// The gap held between equal crowns of radius `radius` (predicted, at the trees' scale) in a
// row `spacing` apart: crown_shyness × each crown's radius toward the other, the smaller of
// its radius and its half of the spacing.
double expectedGap(double shyness, double radius, double spacing) {
    return shyness * std::min(radius, 0.5 * spacing);
}

void expectShyness(const std::string& file, double spacing) {
    PlotSpec spec = makeSpec({file});
    spec.species[0].crownShyness = 0.2;
    const PlotLayout layout = row(4, spacing);
    const GrownPlot plot = growPlot(spec, layout, nullptr, false);
    // The crown volume's radius (every test species: 2 m).
    const double gap = expectedGap(0.2, 2.0, spacing);
    ASSERT_GT(gap, 0.2);
    for (size_t k = 0; k + 1 < plot.trees.size(); ++k) {
        EXPECT_GE(gapBetween(plot.trees[k], plot.trees[k + 1]), gap * 0.95)
            << file << " trees " << k + 1 << "–" << k + 2;
    }
    EXPECT_LE(maxCrownOverlap(crownOverlaps(plot)), spec.species[0].maxOverlap) << file;
    // Grown alone they overlap (the test would prove nothing otherwise).
    spec.neighbours = false;
    const GrownPlot alone = growPlot(spec, layout, nullptr, false);
    EXPECT_GT(maxCrownOverlap(crownOverlaps(alone)), 0.1) << file;
}

TEST(PlotGrowth, CanopyCrownsKeepTheShynessGap) { expectShyness("small-canopy.toml", 3.0); }
TEST(PlotGrowth, IteratedGraphCrownsKeepTheShynessGap) { expectShyness("small-graph.toml", 2.6); }
// Shared markers: each colonizer's buds perceive only the markers on its side of the planes.
TEST(PlotGrowth, ColonizerCrownsKeepTheShynessGap) { expectShyness("small-colonizer.toml", 2.6); }

// Grammar crowns (the lemon preset, about 2 m wide alone) 2 m apart: their branches stop at
// (or, rising, grow up along) the planes, so the gap holds and the crowns share no space.
TEST(PlotGrowth, GrammarCrownsKeepTheShynessGap) {
    PlotSpec spec = makeSpec({"lemon.toml"}, 30, 60);
    spec.species[0].crownShyness = 0.2;
    const PlotLayout layout = row(4, 2.0);
    spec.neighbours = false;
    const GrownPlot alone = growPlot(spec, layout, nullptr, false);
    spec.neighbours = true;
    const GrownPlot plot = growPlot(spec, layout, nullptr, false);
    double smallest = 1e300;  // the crowns' predicted radii: each grown alone
    for (const PlotTree& t : alone.trees) {
        smallest = std::min(smallest, crownShape(t).radius);
    }
    const double gap = expectedGap(0.2, smallest, 2.0);
    ASSERT_GT(gap, 0.15);
    for (size_t k = 0; k + 1 < plot.trees.size(); ++k) {
        EXPECT_LT(gapBetween(alone.trees[k], alone.trees[k + 1]), 0.0) << "alone " << k + 1;
        EXPECT_GE(gapBetween(plot.trees[k], plot.trees[k + 1]), gap * 0.95)
            << "trees " << k + 1 << "–" << k + 2;
    }
    EXPECT_LE(maxCrownOverlap(crownOverlaps(plot)), spec.species[0].maxOverlap);
    EXPECT_GT(maxCrownOverlap(crownOverlaps(alone)), 0.1);
}

// Colonizers between canopy trees: each side keeps its half of the gap (the colonizer's
// markers and perception end at its planes; the canopy trees' volumes are clipped at theirs).
TEST(PlotGrowth, MixedMethodsKeepTheShynessGap) {
    PlotSpec spec = makeSpec({"small-colonizer.toml", "small-canopy.toml"});
    const PlotLayout layout = row(4, 3.0, -1);
    const GrownPlot plot = growPlot(spec, layout, nullptr, false);
    for (size_t k = 0; k + 1 < plot.trees.size(); ++k) {
        EXPECT_GE(gapBetween(plot.trees[k], plot.trees[k + 1]), expectedGap(0.1, 2.0, 3.0) * 0.95)
            << "trees " << k + 1 << "–" << k + 2;
    }
    EXPECT_LE(maxCrownOverlap(crownOverlaps(plot)), 0.05);
}

// The planes hold up to the lower crown's top (and kShyAbove of the shorter tree's height
// over it): a tall colonizer 3 m from a short one keeps to its side below that height and
// spreads over the short tree above it.
TEST(PlotGrowth, TallerCrownsSpreadOverShorterOnesOnlyAboveThem) {
    PlotSpec spec = makeSpec({"small-colonizer.toml"});
    PlotLayout layout = row(2, 3.0, 0, 0.0, 9.0);
    layout.stems[1].targetHeight = 4.0;
    const GrownPlot plot = growPlot(spec, layout, nullptr, false);
    const PlotTree& tall = plot.trees[0];
    const PlotTree& shortTree = plot.trees[1];
    const double limit = 4.0 * (1 + kShyAbove);  // the short tree's top (flat ground: y = 0)
    const Vec3 u{1, 0, 0};                       // from the tall tree toward the short one
    double reachBelow = -1e300, reachAbove = -1e300;
    auto note = [&](const Vec3& p) {
        const double r = dot(p - tall.stem.base, u);
        (p.y <= limit ? reachBelow : reachAbove) =
            std::max(p.y <= limit ? reachBelow : reachAbove, r);
    };
    for (const Leaf& l : tall.grown.tree.leaves) note(l.position);
    for (const SkeletonNode& n : tall.grown.tree.nodes) note(n.position);
    double shortReach = -1e300;
    for (const Leaf& l : shortTree.grown.tree.leaves) {
        shortReach = std::max(shortReach, dot(l.position - shortTree.stem.base, u * -1.0));
    }
    // Below: the tall crown keeps short of the short one's (with the gap between them).
    EXPECT_LT(reachBelow + shortReach, 3.0);
    // Above: it spreads over the short tree's stem.
    EXPECT_GT(reachAbove, 3.0);
}

// The tropical preset's second plot: 101 grammar trees of eight species on rolling ground
// (alone, their crowns run through each other: a pair's shared layer wholly). Among
// neighbours no pair shares space in the layer both occupy — which needs the planes to hold
// up to the crowns' tops as grown: some grow taller among neighbours than alone, and without
// growing their neighbours again (kShyRegrowths = 0) a sal and a gulmohar overlap 0.32.
TEST(PlotGrowth, TropicalPresetCrownsShareNoSpace) {
    const DatasetSpec d =
        loadDataset(std::string(SYLVA_SOURCE_DIR) + "/datasets/plot-tropical-mixed.toml");
    const PlotSpec& p = d.plots[0];
    const GrownPlot among = growPlot(p, layoutPlot(p, plotSeed(d.seed, p, 1)), &d.budget, true);
    EXPECT_LE(maxCrownOverlap(crownOverlaps(among, 0.1)), 0.05);  // 0.1 m cells, as plot.json
}

TEST(PlotGrowth, TreesStandVerticalOnTheTerrainAtTheirHeight) {
    const PlotSpec spec = makeSpec({"small-colonizer.toml", "small-canopy.toml"});
    const PlotLayout layout = row(4, 6.0, -1, 0.3, 5.0);  // a 0.3 slope (17°)
    const GrownPlot plot = growPlot(spec, layout, nullptr, false);
    for (const PlotTree& t : plot.trees) {
        const Tree& tree = t.grown.tree;
        const double ground = layout.terrain.height(t.stem.base.x, t.stem.base.z);
        EXPECT_NEAR(tree.nodes[0].position.y, ground, 1e-9);
        EXPECT_EQ(tree.nodes[0].position.x, t.stem.base.x);
        EXPECT_EQ(tree.nodes[0].position.z, t.stem.base.z);
        // The lowest shoot node is at the ground: the bole starts on it.
        double lowest = 1e300, top = -1e300;
        for (const SkeletonNode& n : tree.nodes) {
            if (n.part != kShootPart) continue;
            lowest = std::min(lowest, n.position.y);
            top = std::max(top, n.position.y);
        }
        EXPECT_NEAR(lowest, ground, 1e-9);
        EXPECT_NEAR(top - ground, 5.0, 1e-9);  // scaled to its target height
        // Vertical: the bole's first node straight above the base.
        const SkeletonNode& up = tree.nodes[1];
        EXPECT_NEAR(up.position.x, t.stem.base.x, 1e-6);
        EXPECT_NEAR(up.position.z, t.stem.base.z, 1e-6);
        EXPECT_GT(up.position.y, ground);
    }
}

// slenderness: each stem's radii scaled so height / DBH is the drawn value, exactly (radii
// only: the height stays); without it the trees keep their grown proportions.
TEST(PlotGrowth, SlendernessSetsHeightOverDbh) {
    const PlotSpec spec = makeSpec({"small-colonizer.toml"});
    PlotLayout layout = row(3, 6.0, 0, 0.0, 6.0);
    const GrownPlot alone = growPlot(spec, layout, nullptr, false);
    for (size_t k = 0; k < layout.stems.size(); ++k) layout.stems[k].slenderness = 120.0 + 40 * k;
    const GrownPlot slender = growPlot(spec, layout, nullptr, false);
    for (size_t k = 0; k < slender.trees.size(); ++k) {
        const TreeRecord a = measureTree(alone.trees[k].grown.tree, alone.trees[k].stem.base);
        const TreeRecord m = measureTree(slender.trees[k].grown.tree, slender.trees[k].stem.base);
        ASSERT_GT(m.dbh, 0.0);
        EXPECT_NEAR(m.height / m.dbh, 120.0 + 40 * k, 1e-6 * (120.0 + 40 * k)) << k;
        EXPECT_NEAR(m.height, a.height, 1e-9);
        EXPECT_GT(std::abs(a.height / a.dbh - m.height / m.dbh), 1.0) << "unchanged: " << k;
    }
}

TEST(PlotGrowth, LeafAreaIndexIsReached) {
    PlotSpec spec = makeSpec({"small-colonizer.toml", "small-canopy.toml"}, 12, 6);
    const PlotLayout layout = row(4, 3.0, -1);
    spec.lai = 1.5;
    const GrownPlot plot = growPlot(spec, layout, nullptr, false);
    EXPECT_NEAR(plot.lai, 1.5, 0.05 * 1.5);
    EXPECT_NEAR(plotLai(plot), plot.lai, 1e-12);
    EXPECT_NE(plot.trees[0].leafScale, 1.0);
    // Per species: each to its own share.
    spec.lai = -1;
    spec.species[0].lai = 0.5;
    spec.species[1].lai = 1.0;
    const GrownPlot shares = growPlot(spec, layout, nullptr, false);
    double a0 = 0, a1 = 0;
    for (const PlotTree& t : shares.trees) {
        (t.stem.species == 0 ? a0 : a1) += treeLeafArea(t.grown.tree);
    }
    EXPECT_NEAR(a0 / spec.area.area(), 0.5, 0.025);
    EXPECT_NEAR(a1 / spec.area.area(), 1.0, 0.05);
    EXPECT_NEAR(shares.lai, 1.5, 0.075);
}

// Mean height of a tree's leaves in its own leaf layer (0 lowest, 1 highest), over `leaves`.
double meanLayerHeight(const std::vector<Leaf>& leaves, double lo, double hi) {
    double sum = 0;
    for (const Leaf& l : leaves) sum += (l.position.y - lo) / (hi - lo);
    return leaves.empty() ? 0.0 : sum / static_cast<double>(leaves.size());
}

// A target far below the grown leaf area (beyond what shrinking within kMinLeafScale could
// reach: refused before thinning) is reached within 5 % by dropping leaves, the lower ones
// first, and scaling the kept ones by a factor near 1; the same draws every time.
TEST(PlotGrowth, LeafAreaIndexIsReachedByThinning) {
    PlotSpec spec = makeSpec({"small-colonizer.toml"}, 12, 6);
    const PlotLayout layout = row(3, 3.0);
    const GrownPlot grown = growPlot(spec, layout, nullptr, false);
    const double ratio = 0.05;  // needs ×0.22 leaf sizes by shrinking alone (< 0.25)
    ASSERT_LT(std::sqrt(ratio), kMinLeafScale);
    spec.lai = ratio * grown.lai;
    const GrownPlot plot = growPlot(spec, layout, nullptr, false);
    EXPECT_NEAR(plot.lai, spec.lai, 0.05 * spec.lai);
    EXPECT_NEAR(plotLai(plot), plot.lai, 1e-12);
    for (size_t k = 0; k < plot.trees.size(); ++k) {
        const PlotTree& t = plot.trees[k];
        const std::vector<Leaf>& all = grown.trees[k].grown.tree.leaves;
        const std::vector<Leaf>& kept = t.grown.tree.leaves;
        EXPECT_EQ(t.leavesGrown, static_cast<int64_t>(all.size()));
        EXPECT_GT(kept.size(), 0u);
        EXPECT_LT(kept.size(), all.size() / 10) << "tree " << k + 1;
        EXPECT_GT(t.leafScale, 0.8);
        EXPECT_LT(t.leafScale, 1.25);
        // The kept leaves stand higher in the crown than the grown ones on average.
        double lo = 1e300, hi = -1e300;
        for (const Leaf& l : all) {
            lo = std::min(lo, l.position.y);
            hi = std::max(hi, l.position.y);
        }
        EXPECT_GT(meanLayerHeight(kept, lo, hi), meanLayerHeight(all, lo, hi) + 0.1)
            << "tree " << k + 1;
    }
    EXPECT_TRUE(serialize(plot) == serialize(growPlot(spec, layout, nullptr, false)));
}

TEST(PlotGrowth, UnreachableLeafAreaIndexIsRefusedAtItsKey) {
    PlotSpec spec = makeSpec({"small-colonizer.toml"}, 12, 6);
    const PlotLayout layout = row(2, 3.0);
    spec.lai = 60;
    try {
        growPlot(spec, layout, nullptr, false);
        FAIL() << "no error";
    } catch (const SpecError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("plot.toml:1:1: plot[0].lai: expected"), std::string::npos) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
    spec.lai = -1;
    spec.species[0].lai = 0.001;
    try {
        growPlot(spec, layout, nullptr, false);
        FAIL() << "no error";
    } catch (const SpecError& e) {
        EXPECT_NE(std::string(e.what()).find("plot[0].species[0].lai"), std::string::npos);
    }
}

TEST(PlotGrowth, OneAndTwoThreadsGrowTheSamePlot) {
    PlotSpec spec = makeSpec({"small-colonizer.toml", "small-canopy.toml"});
    // A row of both species (one shared marker set), and pairs of colonizers (three
    // independent marker sets, grown in parallel), the leaves thinned to an LAI target.
    spec.lai = 0.1 * growPlot(spec, row(6, 2.5, -1), nullptr, false).lai;
    for (const PlotLayout& layout : {row(6, 2.5, -1), pairs(3, 2.4, 8.0)}) {
        std::string one, two;
        tbb::task_arena(1).execute([&] { one = serialize(growPlot(spec, layout, nullptr, true)); });
        tbb::task_arena(2).execute([&] { two = serialize(growPlot(spec, layout, nullptr, true)); });
        const std::string serial = serialize(growPlot(spec, layout, nullptr, false));
        EXPECT_FALSE(one.empty());
        EXPECT_TRUE(one == two);
        EXPECT_TRUE(one == serial);
    }
    // Grammar trees among colonizers: stopped branches, slid trunks and the regrowth passes.
    const PlotSpec mixed = makeSpec({"lemon.toml", "small-colonizer.toml"}, 30, 60);
    const PlotLayout layout = row(6, 2.0, -1);
    std::string one, two;
    tbb::task_arena(1).execute([&] { one = serialize(growPlot(mixed, layout, nullptr, true)); });
    tbb::task_arena(2).execute([&] { two = serialize(growPlot(mixed, layout, nullptr, true)); });
    EXPECT_FALSE(one.empty());
    EXPECT_TRUE(one == two);
    EXPECT_TRUE(one == serialize(growPlot(mixed, layout, nullptr, false)));
}

TEST(PlotGrowth, CrownStatisticsHaveKnownAnswers) {
    // Two trees made by hand: leaves on a disc of radius 1 round (0, 0) and (1, 0).
    PlotSpec spec = makeSpec({"small-colonizer.toml"});
    GrownPlot plot;
    plot.spec = &spec;
    for (int k = 0; k < 2; ++k) {
        PlotTree t;
        t.stem.id = k + 1;
        t.stem.base = {double(k), 0, 0};
        t.grown.tree.nodes.push_back(SkeletonNode{});
        t.grown.tree.nodes[0].position = t.stem.base;
        for (int a = 0; a < 360; a += 2) {
            Leaf l;
            const double th = a * kPi / 180;
            l.position = {k + std::cos(th), 2.0, std::sin(th)};
            t.grown.tree.leaves.push_back(l);
        }
        plot.trees.push_back(t);
    }
    const auto overlaps = crownOverlaps(plot, 0.01);
    ASSERT_EQ(overlaps.size(), 1u);
    // Two unit discs 1 apart share 2π/3 − √3/2 of their π.
    EXPECT_NEAR(overlaps[0].fraction, (2 * kPi / 3 - std::sqrt(3.0) / 2) / kPi, 0.01);
    EXPECT_NEAR(overlaps[0].projected, overlaps[0].fraction, 1e-12);  // one layer: y = 2
    EXPECT_FALSE(overlaps[0].overtopped);
    // Tree 2's crown lifted above tree 1's: the projections still meet, the crowns share no
    // layer (tree 1 is overtopped, not overlapped).
    for (Leaf& l : plot.trees[1].grown.tree.leaves) l.position.y += 3.0;
    const auto lifted = crownOverlaps(plot, 0.01);
    ASSERT_EQ(lifted.size(), 1u);
    EXPECT_EQ(lifted[0].fraction, 0.0);
    EXPECT_TRUE(lifted[0].overtopped);
    EXPECT_NEAR(lifted[0].projected, overlaps[0].projected, 1e-12);
    EXPECT_EQ(maxCrownOverlap(lifted), 0.0);
    // Tree 2 a deep crown (discs at y = 2 … 5): the layer both share is y = 2, where the
    // overlap is the discs' again.
    for (Leaf& l : plot.trees[1].grown.tree.leaves) l.position.y -= 3.0;
    for (int y = 3; y <= 5; ++y) {
        for (int a = 0; a < 360; a += 2) {
            Leaf l;
            const double th = a * kPi / 180;
            l.position = {1 + 0.5 * std::cos(th), double(y), 0.5 * std::sin(th)};
            plot.trees[1].grown.tree.leaves.push_back(l);
        }
    }
    const auto deep = crownOverlaps(plot, 0.01);
    ASSERT_EQ(deep.size(), 1u);
    EXPECT_NEAR(deep[0].fraction, (2 * kPi / 3 - std::sqrt(3.0) / 2) / kPi, 0.01);
    for (int k = 0; k < 3 * 180; ++k) plot.trees[1].grown.tree.leaves.pop_back();
    const auto asym = crownAsymmetry(plot);
    EXPECT_NEAR(asym[0].neighbours.x, -1.0, 1e-12);  // from tree 2 (at +x) toward tree 1
    EXPECT_NEAR(asym[1].neighbours.x, 1.0, 1e-12);
    EXPECT_NEAR(asym[0].offset.x, 0.0, 1e-9);
    // Shift tree 1's leaves toward −x: offset (−0.5, 0) against neighbours (−1, 0): cosine 1;
    // tree 2 still centred: not counted.
    for (Leaf& l : plot.trees[0].grown.tree.leaves) l.position.x -= 0.5;
    EXPECT_NEAR(crownNeighbourCosine(crownAsymmetry(plot)), 1.0, 1e-12);
}

}  // namespace
}  // namespace sylva
