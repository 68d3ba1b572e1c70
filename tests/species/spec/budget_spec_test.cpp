// Budgets in species files: the [budget] table, each method's size bounds (known answers, and
// never above what a tree actually grows), the checks while a tree grows, and every shipped
// species within its budgets.
#include "species/spec/budget_spec.h"

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "pipeline/batch/dataset.h"
#include "species/geometry/tube_mesh.h"
#include "species/methods/grammar.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

const fs::path kSource = SYLVA_SOURCE_DIR;

SpeciesFile speciesFrom(const TempDir& t, const std::string& name, const std::string& text) {
    const fs::path p = t / (name + ".toml");
    std::ofstream(p) << "name = \"" << name << "\"\n" << text;
    return loadSpecies(p.string());
}

// The method of a species file as validation reads it (distributions at their centres).
std::unique_ptr<GrowthMethod> methodOf(const SpeciesFile& s) {
    DrawContext draw;
    draw.draw = false;
    return instantiateSpecies(s, draw, nullptr);
}

// The bounds of one kind, in order, as (count, key path).
std::vector<std::pair<double, std::string>> boundsOf(const GrowthMethod& m, BudgetKind kind) {
    std::vector<std::pair<double, std::string>> out;
    for (const SizeBound& b : m.sizes.bounds) {
        if (b.kind == kind) out.emplace_back(b.count, b.keyPath);
    }
    return out;
}

std::string specErrorOf(const SpeciesFile& s, const BudgetTable* dataset = nullptr) {
    try {
        validateSpecies(s, nullptr, dataset);
    } catch (const SpecError& e) {
        return e.what();
    }
    return "";
}

const char* const kCrown = R"(method = "iterated-graph"
[crown]
type = "sphere-sector"
radius = 3.0
alpha_deg = 54
)";

// Three levels of K nodes and b endpoints per graph: 1, 4 and 12 graphs.
const char* const kLevels = R"(
[[levels]]
nodes = 100
endpoints = 4
[[levels]]
nodes = 10
endpoints = 3
[[levels]]
nodes = 5
endpoints = 2
)";

TEST(BudgetEstimate, IteratedGraphCountsGraphsLevelByLevel) {
    TempDir t;
    const auto m = methodOf(speciesFrom(t, "three", std::string(kCrown) + kLevels));
    // Graph nodes and endpoints: 104; + 4 × 13; + 12 × 7.
    EXPECT_EQ(boundsOf(*m, BudgetKind::kGraphNodes),
              (std::vector<std::pair<double, std::string>>{
                  {104, "levels[0].nodes"}, {156, "levels[1].nodes"}, {240, "levels[2].nodes"}}));
    // The root and every endpoint: 1 + 4; + 12; + 24.
    EXPECT_EQ(
        boundsOf(*m, BudgetKind::kSkeletonNodes),
        (std::vector<std::pair<double, std::string>>{
            {5, "levels[0].endpoints"}, {17, "levels[1].endpoints"}, {41, "levels[2].endpoints"}}));
}

TEST(BudgetEstimate, IteratedGraphStochasticLifespanIsCertainOnlyToLevelOne) {
    TempDir t;
    const auto m = methodOf(speciesFrom(
        t, "stochastic", std::string(kCrown) + kLevels + "[lifespan]\nrule = \"stochastic\"\n"));
    EXPECT_EQ(boundsOf(*m, BudgetKind::kGraphNodes).size(), 2u);
    EXPECT_EQ(boundsOf(*m, BudgetKind::kGraphNodes).back().first, 156);
    // A lifespan of 1: level-0 endpoints get sub-graphs, theirs do not.
    const auto short1 = methodOf(
        speciesFrom(t, "short", std::string(kCrown) + kLevels + "[lifespan]\ninitial = 1\n"));
    EXPECT_EQ(boundsOf(*short1, BudgetKind::kSkeletonNodes).back().first, 17);
}

TEST(BudgetEstimate, IteratedGraphTrunkIsANodeEverySpacing) {
    TempDir t;
    const auto m = methodOf(speciesFrom(
        t, "bole",
        std::string(kCrown) + "[trunk]\nheight = 1000\n[[levels]]\nnodes = 10\nspacing = 0.5\n"
                              "endpoints = 2\n"));
    // 1000 m at 0.5 m: 2000 nodes and the root.
    EXPECT_EQ(boundsOf(*m, BudgetKind::kSkeletonNodes).front(),
              (std::pair<double, std::string>{2001, "trunk.height"}));
}

TEST(BudgetEstimate, IteratedGraphBoundsNeverExceedTheGrownTree) {
    for (const char* file : {"tests/data/tiny.toml", "species/papers/xu-mould-2012/xm-a.toml",
                             "species/papers/xu-mould-2012/xm-fig15-roots.toml"}) {
        SCOPED_TRACE(file);
        const SpeciesFile s = loadSpecies((kSource / file).string());
        const auto m = methodOf(s);
        const GrownTree g = growSpecies(s, 7, nullptr, true);
        const double graph = g.methodStats.at("graph_nodes") + g.methodStats.at("graph_endpoints");
        const auto nodes = boundsOf(*m, BudgetKind::kSkeletonNodes);
        const auto graphs = boundsOf(*m, BudgetKind::kGraphNodes);
        ASSERT_FALSE(nodes.empty());
        EXPECT_LE(nodes.back().first, static_cast<double>(g.tree.nodes.size()));
        EXPECT_LE(graphs.back().first, graph);
    }
}

TEST(BudgetEstimate, GrammarSmallestDerivation) {
    TempDir t;
    // s → a; a → a a to depth 4: 1 + 2 + 4 + 8 stems, each 1 m at 0.25 m segments.
    const std::string binary = R"(method = "grammar"
[grammar]
max_depth = 4
segment_length = 0.25
[rules]
s = [{ out = ["a"] }]
a = [{ out = ["a", "a"] }]
[geometry.a]
length = [1.0, 1.5]
[particles.a]
count = 3
)";
    const SpeciesFile s = speciesFrom(t, "binary", binary);
    const auto m = methodOf(s);
    EXPECT_EQ(
        boundsOf(*m, BudgetKind::kSkeletonNodes),
        (std::vector<std::pair<double, std::string>>{{1 + 15 * 4, "grammar.segment_length"}}));
    EXPECT_EQ(boundsOf(*m, BudgetKind::kLeaves),
              (std::vector<std::pair<double, std::string>>{{45, "particles"}}));
    const GrownTree g = growSpecies(s, 3, nullptr, false);
    EXPECT_EQ(g.methodStats.at("stems"), 15);
    EXPECT_GE(static_cast<double>(g.tree.nodes.size()), 61);
    EXPECT_EQ(g.tree.leaves.size(), 45u);

    // An alternative that stops: the smallest derivation is the one stem from s (1 m at the
    // default 0.1 m segments).
    const auto stops = methodOf(speciesFrom(
        t, "stops",
        "method = \"grammar\"\n[grammar]\nmax_depth = 4\n[rules]\ns = [{ out = [\"a\"] }]\n"
        "a = [{ out = [\"a\", \"a\"], p = 0.5 }, { out = [\"t\"], p = 0.5 }]\n"));
    EXPECT_EQ(boundsOf(*stops, BudgetKind::kSkeletonNodes).front(),
              (std::pair<double, std::string>{1 + 10, "grammar.max_depth"}));

    // Exponential and cut by max_stems: every tree has max_stems stems.
    const SpeciesFile cut =
        speciesFrom(t, "cut",
                    "method = \"grammar\"\n[grammar]\nmax_depth = 20\nmax_stems = 50\n[rules]\n"
                    "s = [{ out = [\"a\"] }]\na = [{ out = [\"a*3\"] }]\n");
    EXPECT_EQ(boundsOf(*methodOf(cut), BudgetKind::kSkeletonNodes),
              (std::vector<std::pair<double, std::string>>{{51, "grammar.max_stems"}}));
}

// max_stems cuts the derivation breadth first; the outputs queued after the first max_stems
// are counted as truncated without being held (the queue stays max_stems long).
TEST(BudgetEstimate, GrammarOutputsBeyondMaxStemsAreCountedNotQueued) {
    GrammarOptions o;
    o.start = o.state("s");
    const int a = o.state("a");
    o.stop[o.state("t")] = true;
    o.rules[o.start] = {{{a}, 1.0}};
    o.rules[a] = {{{a, a, a}, 1.0}};
    o.maxDepth = 20;
    o.maxStems = 50;
    Rng rng(5);
    GrammarStats stats;
    growGrammar(o, rng, &stats);
    EXPECT_EQ(stats.stems, 50);
    // 1 output of s, 3 of each of the 50 stems drawn: 151 queued, 101 never drawn.
    EXPECT_EQ(stats.truncated, 101);
}

TEST(BudgetEstimate, SpaceColonizationMarkersAndBole) {
    TempDir t;
    const auto m = methodOf(speciesFrom(t, "sc", R"(method = "space-colonization"
markers = 30000
internode = 0.5
trunk_length = 100
[crown]
type = "sphere"
radius = 3
position = [0, 100, 0]
)"));
    EXPECT_EQ(boundsOf(*m, BudgetKind::kGraphNodes),
              (std::vector<std::pair<double, std::string>>{{30000, "markers"}}));
    EXPECT_EQ(boundsOf(*m, BudgetKind::kSkeletonNodes),
              (std::vector<std::pair<double, std::string>>{{201, "trunk_length"}}));
}

TEST(BudgetSpec, TableReadsPlainNumbersInRange) {
    TempDir t;
    const std::string tiny =
        test::slurp(kSource / "tests" / "data" / "tiny.toml")
            .substr(test::slurp(kSource / "tests" / "data" / "tiny.toml").find("method"));
    EXPECT_NE(specErrorOf(speciesFrom(t, "a", tiny + "[budget]\nmax_leaves = 0\n"))
                  .find("budget.max_leaves: expected an integer in [1, 2000000000], got 0"),
              std::string::npos);
    EXPECT_NE(
        specErrorOf(speciesFrom(t, "b", tiny + "[budget]\nmax_leaves = { uniform = [1, 9] }\n"))
            .find("budget.max_leaves: expected a plain number (no distribution)"),
        std::string::npos);
    EXPECT_NE(specErrorOf(speciesFrom(t, "c", tiny + "[budget]\nmax_view_pixels = 10\n"))
                  .find("budget.max_view_pixels: unknown key"),
              std::string::npos);
    EXPECT_NE(specErrorOf(speciesFrom(t, "d", tiny + "[budget]\nmax_leafs = 10\n"))
                  .find("did you mean \"max_leaves\""),
              std::string::npos);
    // A budget under the estimate (61 endpoints) is a spec error at the level that makes it.
    const std::string under =
        specErrorOf(speciesFrom(t, "e", tiny + "[budget]\nmax_skeleton_nodes = 30\n"));
    EXPECT_NE(under.find("levels[2].endpoints: the levels up to this one make at least ≈ 61 "
                         "endpoints"),
              std::string::npos)
        << under;
    // The dataset's table has the last word.
    BudgetTable raised;
    raised.maxSkeletonNodes = 1000;
    EXPECT_EQ(
        specErrorOf(speciesFrom(t, "f", tiny + "[budget]\nmax_skeleton_nodes = 30\n"), &raised),
        "");
}

std::string budgetErrorOf(const SpeciesFile& s, const BudgetTable& dataset) {
    try {
        growSpecies(s, 1, nullptr, true, &dataset);
    } catch (const BudgetExceeded& e) {
        return e.what();
    }
    return "";
}

// A skeleton budget just over every bound the reader states passes validation, and the tree
// outgrows it while it grows: each method's loops stop it.
TEST(BudgetGrowth, EveryMethodStopsAtItsBudgetWhileItGrows) {
    for (const char* file :
         {"tests/data/tiny.toml", "species/papers/liu-2020/sc-broadleaf.toml",
          "species/papers/jain-2021/grammar-fir.toml", "species/papers/shesh/canopy-maple.toml"}) {
        SCOPED_TRACE(file);
        const SpeciesFile s = loadSpecies((kSource / file).string());
        double bound = 1;
        for (const auto& b : boundsOf(*methodOf(s), BudgetKind::kSkeletonNodes)) {
            bound = std::max(bound, b.first);
        }
        BudgetTable b;
        b.maxSkeletonNodes = static_cast<int64_t>(bound) + 1;
        EXPECT_EQ(specErrorOf(s, &b), "");
        const std::string err = budgetErrorOf(s, b);
        EXPECT_EQ(err.rfind("budget max_skeleton_nodes = " + std::to_string(*b.maxSkeletonNodes) +
                                " exceeded: ",
                            0),
                  0u)
            << err;
    }
    // The canopy's leaves are held before any is placed (10,000 of them).
    const SpeciesFile maple =
        loadSpecies((kSource / "species/papers/shesh/canopy-maple.toml").string());
    BudgetTable few;
    few.maxLeaves = 5000;
    EXPECT_NE(budgetErrorOf(maple, few).find("max_leaves = 5000"), std::string::npos);
}

// Budgets that are not reached change nothing: the tree is the one grown without any.
TEST(BudgetGrowth, BudgetsNotReachedLeaveTheTreeAlone) {
    const SpeciesFile s = loadSpecies((kSource / "tests" / "data" / "tiny.toml").string());
    BudgetTable tight;
    const GrownTree free = growSpecies(s, 11, nullptr, true);
    tight.maxSkeletonNodes = static_cast<int64_t>(free.tree.nodes.size());
    tight.maxLeaves = static_cast<int64_t>(free.tree.leaves.size());
    const GrownTree held = growSpecies(s, 11, nullptr, true, &tight);
    ASSERT_EQ(held.tree.nodes.size(), free.tree.nodes.size());
    for (size_t i = 0; i < free.tree.nodes.size(); ++i) {
        EXPECT_EQ(held.tree.nodes[i].position, free.tree.nodes[i].position);
        EXPECT_EQ(held.tree.nodes[i].radius, free.tree.nodes[i].radius);
    }
    EXPECT_EQ(held.tree.leaves.size(), free.tree.leaves.size());
}

// Every shipped species passes its budgets' estimates (the defaults are ten times the largest
// tree any shipped spec grows: docs/specs.md, "Budgets"), as a dataset that meshes it checks
// them; the shipped datasets (with their sweeps and outputs) are checked by `sylva validate` in
// CliValidate.EveryShippedSpecIsValid.
TEST(BudgetSpec, EveryShippedSpeciesPassesItsBudgets) {
    std::vector<fs::path> files = test::shippedSpeciesFiles();
    for (const char* dir : {"bench", "tests/data/keys"}) {
        for (const auto& e : fs::directory_iterator(kSource / dir)) {
            if (e.path().extension() != ".toml" ||
                isDatasetFile(parseTomlFile(e.path().string()))) {
                continue;
            }
            files.push_back(e.path());
        }
    }
    // In parallel (reading the crowns dominates: level sets, masks), as `sylva species list` does.
    std::vector<std::string> errors(files.size());
    tbb::parallel_for(size_t(0), files.size(), [&](size_t i) {
        try {
            validateSpecies(loadSpecies(files[i].string()), nullptr, nullptr, true);
        } catch (const std::exception& e) {
            errors[i] = e.what();
        }
    });
    for (size_t i = 0; i < files.size(); ++i) EXPECT_EQ(errors[i], "") << files[i];
    EXPECT_GE(files.size(), 70u);
}

// The tube mesh's triangles are counted exactly without making it.
TEST(BudgetGrowth, TubeTriangleCountIsTheMeshsOwn) {
    const SpeciesFile s = loadSpecies((kSource / "tests" / "data" / "tiny.toml").string());
    const GrownTree g = growSpecies(s, 2, nullptr, true);
    TubeOptions thin;
    thin.minRadius = 0.01;
    thin.dropThin = true;
    TubeOptions wide;
    wide.maxSides = 40;
    wide.edgeLength = 0.005;
    for (const TubeOptions& o : {TubeOptions{}, thin, wide}) {
        EXPECT_EQ(tubeTriangleCount(g.tree, o),
                  static_cast<int64_t>(tubeMesh(g.tree, o).triangleCount()));
    }
}

}  // namespace
}  // namespace sylva
