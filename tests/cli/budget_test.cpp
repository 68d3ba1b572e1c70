// Per-tree budgets (issue 15, item 3), end to end: the resource bombs of the issue and one per
// growth method and output stage end as one-line spec errors (exit 2) before anything grows or
// is written, and a tree that outgrows a budget while it grows fails alone (named in the
// summary, left out of the manifest) while the others are built. Every `sylva` run here is
// killed if it has not ended after kHang seconds: main's binary ran each bomb for minutes, so
// against it these tests fail instead of hanging (a guard against runaway runs, not a timing).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <ostream>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kSource = SYLVA_SOURCE_DIR;
const fs::path kData = kSource / "tests" / "data";
constexpr int kHang = 60;  // seconds: a run still going then has no working budget

using RunResult = sylva::test::CliResult;  // hung: killed by the watchdog (no budget stopped it)

using sylva::test::describeRun;

// Runs SYLVA_EXE with `args` in `dir`, killing it after kHang seconds (result.hung).
RunResult run(const std::vector<std::string>& args, const fs::path& dir) {
    sylva::test::CliOptions o;
    o.watchdog = std::chrono::seconds(kHang);
    return sylva::test::runSylva(args, dir, o);
}

void spit(const fs::path& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary);
    out << bytes;
}

size_t lineCount(const std::string& s) { return std::count(s.begin(), s.end(), '\n'); }

// Nothing in `dir` but the files the test put there.
void expectNothingWritten(const fs::path& dir, const std::set<fs::path>& mine) {
    for (const auto& e : fs::directory_iterator(dir)) {
        if (!mine.count(e.path())) ADD_FAILURE() << "written: " << e.path();
    }
}

struct Bomb {
    const char* name;  // a fixture in tests/data/bad/, or "canopy-triangles" (made here)
    bool dataset;      // validate and build only (a species: grow too, and build through a dataset)
    const char* want;  // "file:line:col: key" of the error
    const char* budget;
};

// One per size the issue found unbounded, and one per method and output stage.
const Bomb kBombs[] = {
    {"budget_ig_endpoints.toml", false, "budget_ig_endpoints.toml:25:13: levels[0].endpoints",
     "max_skeleton_nodes = 1000000"},
    {"budget_ig_nodes.toml", false, "budget_ig_nodes.toml:24:9: levels[0].nodes",
     "max_graph_nodes = 4000000"},
    {"budget_ig_levels.toml", false, "budget_ig_levels.toml:83:9: levels[15].nodes",
     "max_graph_nodes = 4000000"},
    {"budget_sc_markers.toml", false, "budget_sc_markers.toml:10:11: markers",
     "max_graph_nodes = 4000000"},
    {"budget_grammar_stems.toml", false, "budget_grammar_stems.toml:12:13: grammar.max_stems",
     "max_skeleton_nodes = 1000000"},
    // A dataset that meshes a canopy of 10⁶ frond leaves (leaves × shape points).
    {"canopy-triangles", true, "canopy-fronds.toml:19:9: leaves.count", "max_triangles = 40000000"},
    {"budget_dataset_view_pixels.toml", true,
     "budget_dataset_view_pixels.toml:14:14: views.resolution", "max_view_pixels = 100000000"},
};

// Test names print the bomb's name.
void PrintTo(const Bomb& b, std::ostream* os) { *os << b.name; }

class CliBudgetBomb : public ::testing::TestWithParam<Bomb> {};

TEST_P(CliBudgetBomb, IsAOneLineSpecErrorBeforeAnythingGrows) {
    const Bomb& b = GetParam();
    TempDir t;
    fs::path spec = kData / "bad" / b.name;
    if (std::string(b.name) == "canopy-triangles") {
        spec = t / "canopy-triangles.toml";
        spit(spec, "name = \"canopy-triangles\"\n[[species]]\nfile = '" +
                       (kData / "budget" / "canopy-fronds.toml").string() +
                       "'\ncount = 2\n[outputs]\nmesh = [\"ply\"]\n");
    }
    fs::path dataset = spec;
    if (!b.dataset) {
        dataset = t / "uses-bomb.toml";
        spit(dataset,
             "name = \"uses-bomb\"\n[[species]]\nfile = '" + spec.string() + "'\ncount = 2\n");
    }
    const fs::path out = t / "out";
    std::vector<std::vector<std::string>> runs = {
        {"validate", spec.string()}, {"build", dataset.string(), "--out", out.string()}};
    if (!b.dataset) runs.push_back({"grow", spec.string(), "--out", out.string()});
    for (const auto& args : runs) {
        SCOPED_TRACE(args[0]);
        const RunResult r = run(args, t.path());
        EXPECT_EQ(r.code, 2) << describeRun(r);
        EXPECT_EQ(lineCount(r.err), 1u) << describeRun(r);
        EXPECT_NE(r.err.find(b.want), std::string::npos) << describeRun(r);
        EXPECT_NE(r.err.find(std::string("over the budget ") + b.budget), std::string::npos)
            << describeRun(r);
        EXPECT_NE(r.err.find("raise [budget]"), std::string::npos) << describeRun(r);
    }
    expectNothingWritten(t.path(), {spec, dataset});
}

INSTANTIATE_TEST_SUITE_P(Cli, CliBudgetBomb, ::testing::ValuesIn(kBombs),
                         [](const ::testing::TestParamInfo<Bomb>& info) {
                             return sylva::test::identifier(
                                 fs::path(info.param.name).stem().string());
                         });

// A species raises the budget it was over: the estimate then meets the next one (its level-1
// graphs), and with both raised as far as its trees need it is valid.
TEST(CliBudget, ASpeciesRaisesItsBudgets) {
    TempDir t;
    const std::string bomb = slurp(kData / "bad" / "budget_ig_endpoints.toml");
    const fs::path one = t / "one.toml", both = t / "both.toml";
    spit(one, bomb + "\n[budget]\nmax_skeleton_nodes = 2000000\n");
    spit(both, bomb + "\n[budget]\nmax_skeleton_nodes = 20000000\nmax_graph_nodes = 1000000000\n");
    const RunResult r1 = run({"validate", one.string()}, t.path());
    EXPECT_EQ(r1.code, 2) << describeRun(r1);
    EXPECT_NE(r1.err.find("one.toml:28:9: levels[1].nodes: the levels up to this one make at "
                          "least ≈ 4.4e7 graph nodes and endpoints (1.0e6 graphs at this level"),
              std::string::npos)
        << describeRun(r1);
    EXPECT_NE(r1.err.find("over the budget max_graph_nodes = 4000000"), std::string::npos);
    const RunResult r2 = run({"validate", both.string()}, t.path());
    EXPECT_EQ(r2.code, 0) << describeRun(r2);
}

// tiny.toml whose [budget] lets it pass the estimate (61 endpoints at least) but not grow
// (its trees have about 180 nodes).
std::string tinyWithBudget(const std::string& name, const std::string& budget) {
    std::string s = slurp(kData / "tiny.toml");
    const std::string from = "name = \"tiny\"";
    s.replace(s.find(from), from.size(), "name = \"" + name + "\"");
    return s + "\n[budget]\n" + budget + "\n";
}

std::vector<std::string> manifestIds(const fs::path& file) {
    std::vector<std::string> ids;
    std::ifstream in(file);
    for (std::string line; std::getline(in, line);) {
        ids.push_back(nlohmann::json::parse(line).at("id").get<std::string>());
    }
    return ids;
}

TEST(CliBudget, ATreeOverItsBudgetFailsAloneAndIsLeftOutOfTheManifest) {
    TempDir t;
    spit(t / "limited.toml", tinyWithBudget("limited", "max_skeleton_nodes = 100"));
    const fs::path spec = t / "mixed.toml";
    spit(spec,
         "name = \"mixed\"\n[[species]]\nfile = 'limited.toml'\ncount = 2\n"
         "[[species]]\nfile = '" +
             (kData / "tiny.toml").string() + "'\ncount = 2\n");
    const fs::path out = t / "out";
    const RunResult r = run({"build", spec.string(), "--out", out.string()}, t.path());
    EXPECT_EQ(r.code, 1) << describeRun(r);
    for (const char* id : {"limited-00000", "limited-00001"}) {
        EXPECT_NE(r.err.find(std::string("sylva: ") + id +
                             ": budget max_skeleton_nodes = 100 exceeded: "),
                  std::string::npos)
            << describeRun(r);
    }
    EXPECT_NE(r.err.find("sylva: mixed: failed: limited-00000, limited-00001\n"), std::string::npos)
        << describeRun(r);
    EXPECT_NE(r.err.find("2 built, 0 already there, 2 failed of 4"), std::string::npos)
        << describeRun(r);
    EXPECT_EQ(manifestIds(out / "manifest.jsonl"),
              (std::vector<std::string>{"tiny-00000", "tiny-00001"}));
    EXPECT_FALSE(fs::exists(out / "trees" / "limited"));
    const auto d = nlohmann::json::parse(slurp(out / "dataset.json"));
    EXPECT_EQ(d["status"], "incomplete");
    EXPECT_EQ(d["counts"]["missing"], 2);  // failed: not recorded (runs.jsonl has the run's count)

    // The dataset's [budget] has the last word: raised there, every tree is built.
    const fs::path raised = t / "raised.toml";
    spit(raised, slurp(spec) + "[budget]\nmax_skeleton_nodes = 1000000\n");
    const RunResult ok = run({"build", raised.string(), "--out", (t / "out2").string()}, t.path());
    EXPECT_EQ(ok.code, 0) << describeRun(ok);
    EXPECT_EQ(manifestIds(t / "out2" / "manifest.jsonl").size(), 4u);
}

TEST(CliBudget, GrowOverItsTimeBudgetExitsOneAndWritesNothing) {
    TempDir t;
    const fs::path spec = t / "slow.toml";
    spit(spec, tinyWithBudget("slow", "max_growth_seconds = 1e-9"));
    const fs::path out = t / "grown";
    const RunResult r = run({"grow", spec.string(), "--out", out.string()}, t.path());
    EXPECT_EQ(r.code, 1) << describeRun(r);
    EXPECT_EQ(lineCount(r.err), 1u) << describeRun(r);
    EXPECT_NE(
        r.err.find(
            "sylva: grow: slow seed 1: budget max_growth_seconds = 1e-09 exceeded: still growing"),
        std::string::npos)
        << describeRun(r);
    EXPECT_TRUE(r.out.empty()) << describeRun(r);
    EXPECT_FALSE(fs::exists(out));
}

}  // namespace
