// End-to-end tests of the `sylva` command line: determinism across thread counts, shards,
// resume after a (simulated and real) kill, one-line errors for bad specs, --help, grow and
// validate. Every test runs the real binary (SYLVA_EXE) in its own temp directory, on tiny
// fixture trees from tests/data/ so the whole file takes a few seconds.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::slurp;

const fs::path kSource = SYLVA_SOURCE_DIR;
const fs::path kData = kSource / "tests" / "data";
const fs::path kDataset = kData / "tiny_dataset.toml";
const fs::path kTiny = kData / "tiny.toml";
constexpr int kDatasetInstances = 24;  // tiny_dataset.toml: 2 species × 2 sweep points × 6

void spit(const fs::path& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary);
    out << bytes;
}

std::vector<std::string> readLines(const fs::path& p) {
    std::vector<std::string> lines;
    std::ifstream in(p, std::ios::binary);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
}

// Fresh per-test scratch directory (unique per process, test and instance), removed afterwards.
using sylva::test::TempDir;

// --- running the CLI -------------------------------------------------------------------------

using RunResult = sylva::test::CliResult;
using Child = sylva::test::CliChild;
using sylva::test::describeRun;

// Starts `sylva args…` in `dir` with `env` ("NAME=value") added (tests/cli/cli_support.h).
Child spawn(const std::vector<std::string>& args, const fs::path& dir,
            const std::vector<std::string>& env = {}) {
    sylva::test::CliOptions o;
    o.env = env;
    return sylva::test::spawnSylva(args, dir, o);
}

RunResult finish(const Child& c) { return sylva::test::finishSylva(c); }

RunResult run(const std::vector<std::string>& args, const fs::path& dir,
              const std::vector<std::string>& env = {}) {
    return finish(spawn(args, dir, env));
}

std::vector<RunResult> runAll(const std::vector<std::vector<std::string>>& runs,
                              const fs::path& dir) {
    return sylva::test::runAllSylva(runs, dir);
}

// `sylva build SPEC --out DIR extra…`, expected to succeed.
void buildOk(const fs::path& spec, const fs::path& out, const fs::path& cwd,
             const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args = {"build", spec.string(), "--out", out.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    RunResult r = run(args, cwd);
    ASSERT_EQ(r.code, 0) << describeRun(r);
}

// --- comparing outputs -----------------------------------------------------------------------

// Manifest lines with the "timing" object removed (the only field that may differ between
// identical builds), in file order. Every line must parse and carry a "timing" object.
std::vector<std::string> strippedManifest(const fs::path& file) {
    std::vector<std::string> out;
    EXPECT_TRUE(fs::is_regular_file(file)) << file;
    for (const std::string& line : readLines(file)) {
        auto j = nlohmann::json::parse(line, nullptr, false);
        EXPECT_FALSE(j.is_discarded()) << "unparsable manifest line in " << file << ": " << line;
        if (j.is_discarded()) continue;
        EXPECT_TRUE(j.contains("timing") && j["timing"].is_object()) << line;
        j.erase("timing");
        out.push_back(j.dump());
    }
    return out;
}

// Every regular file under dir (relative path -> bytes).
std::map<std::string, std::string> filesUnder(const fs::path& dir) {
    std::map<std::string, std::string> files;
    if (!fs::exists(dir)) return files;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (e.is_regular_file()) {
            files[fs::relative(e.path(), dir).generic_string()] = slurp(e.path());
        }
    }
    return files;
}

// Files under a/<sub> and b/<sub> (trees/, or plots/): the same names and byte-identical
// contents.
void expectSameTrees(const fs::path& a, const fs::path& b, const std::string& sub = "trees") {
    auto fa = filesUnder(a / sub);
    auto fb = filesUnder(b / sub);
    EXPECT_FALSE(fa.empty()) << "no files under " << a / sub;
    int reported = 0;
    for (const auto& [name, bytes] : fa) {
        auto it = fb.find(name);
        if (it == fb.end()) {
            if (reported++ < 5) ADD_FAILURE() << "only in " << a << ": " << sub << "/" << name;
        } else if (it->second != bytes) {
            if (reported++ < 5) ADD_FAILURE() << sub << "/" << name << " differs";
        }
    }
    for (const auto& [name, bytes] : fb) {
        if (!fa.count(name) && reported++ < 5) {
            ADD_FAILURE() << "only in " << b << ": " << sub << "/" << name;
        }
    }
    EXPECT_EQ(reported, 0) << sub << " files differ between " << a << " and " << b;
}

// Manifests (timing stripped) equal line by line; a mismatch is reported as the JSON patch
// between the two records, e.g. [{"op":"replace","path":"/stats/nodes","value":12}].
void expectSameLines(const std::vector<std::string>& got, const std::vector<std::string>& want) {
    ASSERT_EQ(got.size(), want.size()) << "manifest line count";
    int reported = 0;
    for (size_t i = 0; i < got.size(); ++i) {
        if (got[i] == want[i]) continue;
        if (reported++ >= 3) continue;
        auto g = nlohmann::json::parse(got[i]), w = nlohmann::json::parse(want[i]);
        ADD_FAILURE() << "manifest line " << i + 1 << " (" << w.value("id", "?")
                      << ") differs; patch from expected to actual: "
                      << nlohmann::json::diff(w, g).dump();
    }
    EXPECT_EQ(reported, 0) << "manifest lines differ";
}

std::vector<fs::path> tempFilesUnder(const fs::path& dir) {
    std::vector<fs::path> tmp;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (e.path().filename().string().find(".tmp.") != std::string::npos) {
            tmp.push_back(e.path());
        }
    }
    return tmp;
}

size_t countLines(const fs::path& file) {
    std::string s = slurp(file);
    return static_cast<size_t>(std::count(s.begin(), s.end(), '\n'));
}

// --- 1. determinism --------------------------------------------------------------------------

TEST(CliBuild, SameOutputWithOneAndTwoThreads) {
    TempDir t;
    buildOk(kDataset, t / "t1", t.path(), {"--threads", "1"});
    buildOk(kDataset, t / "t2", t.path(), {"--threads", "2"});

    auto m1 = strippedManifest(t / "t1" / "manifest.jsonl");
    auto m2 = strippedManifest(t / "t2" / "manifest.jsonl");
    ASSERT_EQ(m1.size(), static_cast<size_t>(kDatasetInstances));
    expectSameLines(m2, m1);
    expectSameTrees(t / "t1", t / "t2");

    // Job order: species in file order, then sweep point, then index; ids unique.
    std::vector<std::string> ids;
    for (const auto& line : m1) ids.push_back(nlohmann::json::parse(line)["id"]);
    EXPECT_EQ(ids.front(), "tiny-p000-00000");
    EXPECT_EQ(ids.back(), "tiny-var-p001-00005");
    EXPECT_EQ(std::set<std::string>(ids.begin(), ids.end()).size(), ids.size());
    // Each record's files exist; drawn parameters are recorded for the variant species.
    for (const auto& line : m1) {
        auto j = nlohmann::json::parse(line);
        for (const auto& [k, v] : j["files"].items()) {
            const fs::path f = t / "t1" / v.get<std::string>();
            EXPECT_TRUE(k == "views" ? fs::is_directory(f) : fs::is_regular_file(f)) << k << v;
        }
        // skeleton ply + swc; mesh and watertight in ply, glb, obj with its mtl; the views
        // directory, transforms.json, points.ply and contact.png.
        EXPECT_EQ(j["files"].size(), 14u) << j["files"].dump();
        for (const std::string stem : {"mesh", "watertight"}) {
            ASSERT_TRUE(j["files"].contains(stem + "_mtl")) << j["files"].dump();
            EXPECT_NE(slurp(t / "t1" / j["files"][stem + "_obj"].get<std::string>())
                          .find("\nmtllib " + stem + ".mtl\n"),
                      std::string::npos);
        }
        if (j["species"] == "tiny-var") {
            EXPECT_TRUE(j["params"].contains("levels[0].endpoints"));
        }
    }
    auto ds = nlohmann::json::parse(slurp(t / "t1" / "dataset.json"));
    EXPECT_EQ(ds["status"], "complete");
    EXPECT_TRUE(tempFilesUnder(t.path()).empty());
}

// --- 2. shards -------------------------------------------------------------------------------

TEST(CliBuild, ShardManifestsConcatenateToTheWhole) {
    TempDir t;
    buildOk(kDataset, t / "whole", t.path());
    const auto whole = strippedManifest(t / "whole" / "manifest.jsonl");
    ASSERT_EQ(whole.size(), static_cast<size_t>(kDatasetInstances));

    // Two shards running at the same time into one directory.
    const fs::path two = t / "two";
    Child a =
        spawn({"build", kDataset.string(), "--out", two.string(), "--shard", "0/2"}, t.path());
    Child b =
        spawn({"build", kDataset.string(), "--out", two.string(), "--shard", "1/2"}, t.path());
    RunResult ra = finish(a), rb = finish(b);
    ASSERT_EQ(ra.code, 0) << describeRun(ra);
    ASSERT_EQ(rb.code, 0) << describeRun(rb);
    EXPECT_FALSE(fs::exists(two / "manifest.jsonl"));
    auto s0 = strippedManifest(two / "manifest.shard-0-of-2.jsonl");
    auto s1 = strippedManifest(two / "manifest.shard-1-of-2.jsonl");
    EXPECT_EQ(s0.size(), 12u);
    std::vector<std::string> cat = s0;
    cat.insert(cat.end(), s1.begin(), s1.end());
    expectSameLines(cat, whole);
    expectSameTrees(t / "whole", two);

    // An uneven split (24 jobs over 5 shards), all at once into one directory.
    const fs::path five = t / "five";
    std::vector<std::vector<std::string>> runs;
    for (int i = 0; i < 5; ++i) {
        runs.push_back({"build", kDataset.string(), "--out", five.string(), "--shard",
                        std::to_string(i) + "/5"});
    }
    for (const RunResult& r : runAll(runs, t.path())) ASSERT_EQ(r.code, 0) << describeRun(r);
    cat.clear();
    for (int i = 0; i < 5; ++i) {
        auto s = strippedManifest(five / ("manifest.shard-" + std::to_string(i) + "-of-5.jsonl"));
        EXPECT_EQ(s.size(), i == 0 ? 4u : 5u) << "shard " << i;  // jobs [24i/5, 24(i+1)/5)
        cat.insert(cat.end(), s.begin(), s.end());
    }
    expectSameLines(cat, whole);
    expectSameTrees(t / "whole", five);
}

// --- 2b. plots: threads, shards, merge, resume ------------------------------------------------

const fs::path kPlotDataset = kData / "plot" / "build_plot.toml";  // 3 trees, then 3 plots

// A dataset of single trees and plots: the same bytes with 1 and 2 threads, as two shards
// merged, and after a kill and a rerun; plots come after the trees in the manifest; stats
// group the plots' statistics under their names.
TEST(CliPlots, ThreadsShardsMergeAndResumeGiveTheSameBytes) {
    TempDir t;
    buildOk(kPlotDataset, t / "t1", t.path(), {"--threads", "1"});
    buildOk(kPlotDataset, t / "t2", t.path(), {"--threads", "2"});
    const auto whole = strippedManifest(t / "t1" / "manifest.jsonl");
    ASSERT_EQ(whole.size(), 6u);
    expectSameLines(strippedManifest(t / "t2" / "manifest.jsonl"), whole);
    expectSameTrees(t / "t1", t / "t2");
    expectSameTrees(t / "t1", t / "t2", "plots");
    std::vector<std::string> ids;
    for (const auto& line : whole) ids.push_back(nlohmann::json::parse(line)["id"]);
    EXPECT_EQ(
        ids, (std::vector<std::string>{"tiny-00000", "tiny-00001", "tiny-00002", "tiny-slope-00000",
                                       "tiny-slope-00001", "tiny-round-00000"}));
    const auto plot = nlohmann::json::parse(whole[3]);
    EXPECT_EQ(plot["kind"], "plot");
    EXPECT_EQ(plot["plot"], "tiny-slope");
    EXPECT_EQ(plot["stats"]["trees"], 6);
    for (const auto& [k, v] : plot["files"].items()) {
        EXPECT_TRUE(fs::exists(t / "t1" / v.get<std::string>())) << k << v;
    }
    auto ds = nlohmann::json::parse(slurp(t / "t1" / "dataset.json"));
    ASSERT_EQ(ds["plots"].size(), 2u);
    EXPECT_EQ(ds["plots"][0]["name"], "tiny-slope");

    // Two shards (the split falls inside the trees: 3 + 3) merged.
    const fs::path two = t / "two";
    for (const char* shard : {"0/2", "1/2"}) {
        buildOk(kPlotDataset, two, t.path(), {"--shard", shard});
    }
    RunResult merged = run({"merge", (t / "merged").string(), two.string()}, t.path());
    ASSERT_EQ(merged.code, 0) << describeRun(merged);
    expectSameLines(strippedManifest(t / "merged" / "manifest.jsonl"), whole);
    expectSameTrees(t / "t1", t / "merged", "plots");

    // Killed after the first plot (4 records), then rerun.
    const fs::path out = t / "resumed";
    RunResult killed = run({"build", kPlotDataset.string(), "--out", out.string()}, t.path(),
                           {"SYLVA_TEST_ABORT_AFTER=4"});
    EXPECT_EQ(killed.code, 137) << describeRun(killed);
    ASSERT_EQ(readLines(out / "manifest.jsonl").size(), 4u);
    buildOk(kPlotDataset, out, t.path());
    expectSameLines(strippedManifest(out / "manifest.jsonl"), whole);
    expectSameTrees(t / "t1", out, "plots");

    // stats: the plots' statistics under their names.
    RunResult stats = run({"stats", (t / "t1").string()}, t.path());
    ASSERT_EQ(stats.code, 0) << describeRun(stats);
    const std::string table = slurp(t / "t1" / "stats" / "species.csv");
    EXPECT_NE(table.find("tiny-slope,"), std::string::npos) << table.substr(0, 400);
    EXPECT_NE(table.find("stems_per_ha"), std::string::npos) << table.substr(0, 400);
    // report: the plots are groups of the report too (6 records: 3 trees, 3 plots).
    RunResult report = run({"report", (t / "t1").string()}, t.path());
    ASSERT_EQ(report.code, 0) << describeRun(report);
    EXPECT_NE((report.out + report.err).find("6 instances, 3 species"), std::string::npos)
        << report.out << report.err;
}

// --- 3. resume after a kill ------------------------------------------------------------------

TEST(CliResume, SimulatedKillThenRerunEqualsUninterrupted) {
    TempDir t;
    buildOk(kDataset, t / "ref", t.path());
    const fs::path out = t / "out";
    RunResult killed = run({"build", kDataset.string(), "--out", out.string()}, t.path(),
                           {"SYLVA_TEST_ABORT_AFTER=5"});
    EXPECT_NE(killed.code, 0) << describeRun(killed);
    EXPECT_EQ(killed.code, 137) << describeRun(killed);
    ASSERT_EQ(readLines(out / "manifest.jsonl").size(), 5u);

    RunResult rerun = run({"build", kDataset.string(), "--out", out.string()}, t.path());
    ASSERT_EQ(rerun.code, 0) << describeRun(rerun);
    EXPECT_NE(rerun.err.find("5 already there"), std::string::npos) << rerun.err;
    expectSameLines(strippedManifest(out / "manifest.jsonl"),
                    strippedManifest(t / "ref" / "manifest.jsonl"));
    expectSameTrees(t / "ref", out);
    EXPECT_EQ(nlohmann::json::parse(slurp(out / "dataset.json"))["status"], "complete");

    // A third run finds everything done and changes nothing.
    const std::string before = slurp(out / "manifest.jsonl");
    RunResult again = run({"build", kDataset.string(), "--out", out.string()}, t.path());
    ASSERT_EQ(again.code, 0) << describeRun(again);
    EXPECT_NE(again.err.find("0 built, 24 already there"), std::string::npos) << again.err;
    EXPECT_EQ(slurp(out / "manifest.jsonl"), before);
}

// A kill while a file is being written leaves its temp sibling ("<file>.tmp.<pid>.…") behind;
// the rerun must not leave it in the dataset. Planted deterministically here (the real-kill
// test below only hits a write now and then).
TEST(CliResume, RerunRemovesTempFilesLeftByAKill) {
    TempDir t;
    const fs::path out = t / "out";
    RunResult killed = run({"build", kDataset.string(), "--out", out.string()}, t.path(),
                           {"SYLVA_TEST_ABORT_AFTER=5"});
    ASSERT_EQ(killed.code, 137) << describeRun(killed);
    // The last instance of the dataset: not built yet, it was "being written" by the dead process.
    const fs::path dir = out / "trees" / "tiny-var" / "tiny-var-p001-00005";
    fs::create_directories(dir);
    const fs::path stale = dir / "skeleton.ply.tmp.4194303.123.7";
    spit(stale, "ply\nformat binary_little_endian 1.0\n");  // torn: no end_header
    fs::create_directories(dir / "views");  // image writers leave theirs one level down
    spit(dir / "views" / "002.png.tmp.4194303.123.8.png", "\x89PNG");

    RunResult rerun = run({"build", kDataset.string(), "--out", out.string()}, t.path());
    ASSERT_EQ(rerun.code, 0) << describeRun(rerun);
    EXPECT_EQ(countLines(out / "manifest.jsonl"), static_cast<size_t>(kDatasetInstances));
    for (const fs::path& p : tempFilesUnder(out)) ADD_FAILURE() << "left over: " << p;
}

TEST(CliResume, RealKillAndTornLineThenRerunEqualsUninterrupted) {
    TempDir t;
    // A bigger dataset of the same tiny trees, so a build runs for about a second.
    const fs::path spec = t / "bigger.toml";
    spit(spec,
         "name = \"bigger\"\nseed = 11\n"
         "[[species]]\nfile = '" +
             kTiny.string() +
             "'\ncount = 100\n"
             "[[species]]\nfile = '" +
             (kData / "tiny_var.toml").string() +
             "'\ncount = 100\n"
             "[[sweep]]\npath = \"levels[1].endpoints\"\nvalues = [2, 3]\n"
             "[outputs]\nskeleton = [\"ply\", \"swc\"]\n");
    const size_t total = 400;
    buildOk(spec, t / "ref", t.path());
    ASSERT_EQ(countLines(t / "ref" / "manifest.jsonl"), total);

    const fs::path out = t / "out";
    const fs::path manifest = out / "manifest.jsonl";
    // Held after its third record (SYLVA_TEST_PAUSE_AT, never released): the kill lands
    // before the end however slow the machine is, while the trees in flight are being written.
    Child c = spawn({"build", spec.string(), "--out", out.string()}, t.path(),
                    {"SYLVA_TEST_PAUSE_AT=3:" + (t / "never").string()});
    ASSERT_GT(c.pid, 0);
    bool exited = false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!(fs::exists(manifest) && countLines(manifest) >= 3)) {
        int status = 0;
        if (::waitpid(c.pid, &status, WNOHANG) == c.pid) {
            exited = true;
            break;
        }
        ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "no manifest lines after 60 s";
        std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    ASSERT_FALSE(exited) << "the build ended before it could be killed";
    ASSERT_EQ(::kill(c.pid, SIGKILL), 0);
    RunResult killed = finish(c);
    EXPECT_EQ(killed.code, 128 + SIGKILL);
    const size_t recorded = countLines(manifest);
    ASSERT_GE(recorded, 3u);
    ASSERT_LT(recorded, total) << "the build finished before the kill landed";

    // A torn write of the next record.
    {
        std::ofstream app(manifest, std::ios::binary | std::ios::app);
        app << "{\"id\":\"trunc";
    }
    RunResult rerun = run({"build", spec.string(), "--out", out.string()}, t.path());
    ASSERT_EQ(rerun.code, 0) << describeRun(rerun);
    EXPECT_EQ(slurp(manifest).find("trunc"), std::string::npos);
    expectSameLines(strippedManifest(manifest), strippedManifest(t / "ref" / "manifest.jsonl"));
    expectSameTrees(t / "ref", out);
    for (const fs::path& p : tempFilesUnder(out)) ADD_FAILURE() << "left over: " << p;
}

// --- 4. bad specs ----------------------------------------------------------------------------

// A fixture in tests/data/bad/ declares what its error must say in leading comments:
//   # expect: <substring>      (one or more: key path, message fragments)
//   # line: <n>                (the line the error must point at)
struct BadFixture {
    fs::path path;
    std::vector<std::string> expect;
    int line = 0;
    bool dataset = false;
};

BadFixture readBadFixture(const fs::path& p) {
    BadFixture f;
    f.path = p;
    for (const std::string& l : readLines(p)) {
        if (l.rfind("# expect: ", 0) == 0) f.expect.push_back(l.substr(10));
        if (l.rfind("# line: ", 0) == 0) f.line = std::stoi(l.substr(8));
        if (l.rfind("[[species]]", 0) == 0) f.dataset = true;
    }
    return f;
}

std::vector<std::string> badFixtureNames() {
    std::vector<std::string> names;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(kData / "bad", ec)) {
        if (e.path().extension() == ".toml") names.push_back(e.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

// Exit 2 and exactly one line on stderr.
void expectOneLineError(const RunResult& r) {
    EXPECT_EQ(r.code, 2) << describeRun(r);
    ASSERT_FALSE(r.err.empty()) << describeRun(r);
    EXPECT_EQ(r.err.back(), '\n') << describeRun(r);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << describeRun(r);
}

void expectFixtureError(const RunResult& r, const BadFixture& f) {
    expectOneLineError(r);
    const std::string at = f.path.filename().string() + ":" + std::to_string(f.line) + ":";
    EXPECT_NE(r.err.find(at), std::string::npos) << "expected \"" << at << "\" in: " << r.err;
    for (const std::string& e : f.expect) {
        EXPECT_NE(r.err.find(e), std::string::npos) << "expected \"" << e << "\" in: " << r.err;
    }
}

class CliBadSpec : public ::testing::TestWithParam<std::string> {};

TEST_P(CliBadSpec, OneLineErrorExitTwoAndNothingWritten) {
    const BadFixture f = readBadFixture(kData / "bad" / GetParam());
    ASSERT_FALSE(f.expect.empty()) << f.path << " has no '# expect:' line";
    ASSERT_GT(f.line, 0) << f.path << " has no '# line:' line";
    TempDir t;

    // build: a dataset fixture directly; a species fixture through a dataset that uses it.
    fs::path spec = f.path;
    if (!f.dataset) {
        spec = t / "uses_bad_species.toml";
        spit(spec,
             "name = \"uses-bad\"\n[[species]]\nfile = '" + f.path.string() + "'\ncount = 2\n");
    }
    const fs::path buildOut = t / "build_out";
    const std::vector<std::vector<std::string>> runs = {
        {"validate", f.path.string()}, {"build", spec.string(), "--out", buildOut.string()}};
    const std::vector<RunResult> r = runAll(runs, t.path());
    for (size_t i = 0; i < r.size(); ++i) {
        SCOPED_TRACE(runs[i][0]);
        expectFixtureError(r[i], f);
    }
    EXPECT_FALSE(fs::exists(buildOut)) << "build of a bad spec created " << buildOut;
    // Nothing at all in the working directory (no default out/ either).
    for (const auto& e : fs::directory_iterator(t.path())) {
        if (e.path() != spec) ADD_FAILURE() << "unexpected " << e.path();
    }
}

INSTANTIATE_TEST_SUITE_P(Cli, CliBadSpec, ::testing::ValuesIn(badFixtureNames()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                             return sylva::test::identifier(fs::path(info.param).stem().string());
                         });

TEST(CliBadSpecs, FixturesCoverEveryKindOfError) {
    const std::vector<std::string> names = badFixtureNames();
    for (const char* want :
         {"misspelt_key.toml", "wrong_type.toml", "alpha_out_of_range.toml", "nodes_zero.toml",
          "endpoints_negative.toml", "spacing_nan.toml", "uniform_bad_bounds.toml",
          "unknown_distribution.toml", "unknown_method.toml", "unknown_volume_type.toml",
          "dataset_missing_species_file.toml", "missing_levels.toml", "dataset_sweep_bad_path.toml",
          "dataset_sweep_bad_species.toml", "toml_syntax.toml", "nodes_do_not_fit.toml"}) {
        EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
    }
}

TEST(CliBadSpecs, NonexistentSpecFile) {
    TempDir t;
    const std::string missing = (t / "no_such_spec.toml").string();
    const fs::path out = t / "out";
    const std::vector<std::vector<std::string>> runs = {{"validate", missing},
                                                        {"build", missing, "--out", out.string()},
                                                        {"grow", missing, "--out", out.string()}};
    const std::vector<RunResult> r = runAll(runs, t.path());
    for (size_t i = 0; i < r.size(); ++i) {
        SCOPED_TRACE(runs[i][0]);
        expectOneLineError(r[i]);
        EXPECT_NE(r[i].err.find("no_such_spec.toml"), std::string::npos) << r[i].err;
        EXPECT_NE(r[i].err.find("not found"), std::string::npos) << r[i].err;
    }
    EXPECT_FALSE(fs::exists(out));
}

// --- 5. arguments ----------------------------------------------------------------------------

TEST(CliArgs, HelpForEverySubcommand) {
    TempDir t;
    const std::vector<std::pair<std::vector<std::string>, std::vector<std::string>>> cases = {
        {{"--help"}, {"build", "grow", "validate"}},
        {{"build", "--help"}, {"SPEC", "--out", "--threads", "--shard"}},
        {{"grow", "--help"}, {"SPECIES", "--seed", "--out", "--threads"}},
        {{"validate", "--help"}, {"SPEC"}},
    };
    std::vector<std::vector<std::string>> runs;
    for (const auto& c : cases) runs.push_back(c.first);
    const std::vector<RunResult> r = runAll(runs, t.path());
    for (size_t i = 0; i < r.size(); ++i) {
        SCOPED_TRACE("sylva " + runs[i][0] + (runs[i].size() > 1 ? " --help" : ""));
        EXPECT_EQ(r[i].code, 0) << describeRun(r[i]);
        for (const auto& w : cases[i].second) {
            EXPECT_NE(r[i].out.find(w), std::string::npos) << "no \"" << w << "\" in " << r[i].out;
        }
    }
}

TEST(CliArgs, BadArgumentsExitTwoAndWriteNothing) {
    TempDir t;
    const fs::path out = t / "out";
    const std::string spec = kDataset.string(), o = out.string();
    const std::vector<std::vector<std::string>> runs = {
        {"build", spec, "--out", o, "--shard", "2/2"},
        {"build", spec, "--out", o, "--shard", "x"},
        {"build", spec, "--out", o, "--shard", "-1/2"},
        {"build", spec, "--out", o, "--shard", "0/0"},
        {"build", spec, "--out", o, "--threads", "-1"},
        {"frobnicate"},
        {}};
    const std::vector<RunResult> r = runAll(runs, t.path());
    for (size_t i = 0; i < r.size(); ++i) {
        std::string cmd = "sylva";
        for (const auto& a : runs[i]) cmd += " " + a;
        SCOPED_TRACE(cmd);
        EXPECT_EQ(r[i].code, 2) << describeRun(r[i]);
        EXPECT_FALSE(r[i].err.empty());
    }
    EXPECT_FALSE(fs::exists(out));
}

// --- 6. grow ---------------------------------------------------------------------------------

TEST(CliGrow, WritesFilesAndIsDeterministicPerSeed) {
    TempDir t;
    const std::string spec = kTiny.string();
    for (const RunResult& r : runAll({{"grow", spec, "--seed", "5", "--out", (t / "a").string()},
                                      {"grow", spec, "--seed", "5", "--out", (t / "b").string()},
                                      {"grow", spec, "--seed", "6", "--out", (t / "c").string()}},
                                     t.path())) {
        EXPECT_EQ(r.code, 0) << describeRun(r);
    }
    for (const char* f :
         {"skeleton.ply", "skeleton.swc", "preview.png", "preview_wood.png", "stats.json"}) {
        EXPECT_TRUE(fs::is_regular_file(t / "a" / f)) << f;
        EXPECT_GT(fs::file_size(t / "a" / f), 0u) << f;
    }
    EXPECT_EQ(slurp(t / "a" / "preview.png").substr(0, 4), "\x89PNG");
    EXPECT_EQ(slurp(t / "a" / "skeleton.ply").substr(0, 4), "ply\n");
    auto stats = nlohmann::json::parse(slurp(t / "a" / "stats.json"));
    EXPECT_EQ(stats["species"], "tiny");
    EXPECT_EQ(stats["seed"], 5);
    EXPECT_GT(stats["stats"]["nodes"].get<int>(), 1);

    EXPECT_EQ(slurp(t / "a" / "skeleton.ply"), slurp(t / "b" / "skeleton.ply"));
    EXPECT_EQ(slurp(t / "a" / "skeleton.swc"), slurp(t / "b" / "skeleton.swc"));
    EXPECT_NE(slurp(t / "a" / "skeleton.ply"), slurp(t / "c" / "skeleton.ply"));
    EXPECT_TRUE(tempFilesUnder(t.path()).empty());
}

// `grow` and `volume` check --out as `build` does: a path that is a file, or lies under one,
// is bad input (exit 2, one line naming --out), found before anything is grown or written.
TEST(CliGrow, AnOutThatIsAFileExitsTwoWithOneLineAndWritesNothing) {
    TempDir t;
    const fs::path file = t / "file";
    std::ofstream(file) << "keep";
    const std::string spec = kTiny.string();
    const std::vector<std::vector<std::string>> runs = {
        {"grow", spec, "--out", file.string()},
        {"grow", spec, "--out", (file / "sub").string()},
        {"volume", spec, "--out", file.string()},
        {"volume", spec, "--out", (file / "sub").string()}};
    const std::vector<RunResult> r = runAll(runs, t.path());
    for (size_t i = 0; i < r.size(); ++i) {
        SCOPED_TRACE(runs[i][0] + " --out " + runs[i][3]);
        EXPECT_EQ(r[i].code, 2) << describeRun(r[i]);
        EXPECT_EQ(std::count(r[i].err.begin(), r[i].err.end(), '\n'), 1) << r[i].err;
        EXPECT_NE(r[i].err.find("--out " + runs[i][3]), std::string::npos) << r[i].err;
        EXPECT_EQ(r[i].err.find("filesystem error"), std::string::npos) << r[i].err;
    }
    EXPECT_EQ(slurp(file), "keep");
    EXPECT_TRUE(tempFilesUnder(t.path()).empty());
}

// `sylva gates DIR`: the realism gates table of a built dataset on stdout; no dataset: exit 2.
TEST(CliGates, PrintsOneRowPerSpeciesAndRejectsADirectoryWithoutManifest) {
    TempDir t;
    buildOk(kDataset, t / "d", t.path());
    const RunResult ok = run({"gates", (t / "d").string()}, t.path());
    EXPECT_EQ(ok.code, 0) << describeRun(ok);
    EXPECT_EQ(ok.out.rfind("| species | habit | n | ground |", 0), 0u) << ok.out;
    EXPECT_NE(ok.out.find("| `tiny` | tree | "), std::string::npos) << ok.out;
    const RunResult bad = run({"gates", t.path().string()}, t.path());
    EXPECT_EQ(bad.code, 2);
    EXPECT_NE(bad.err.find("sylva: gates: "), std::string::npos) << bad.err;
    EXPECT_NE(bad.err.find("no manifest.jsonl"), std::string::npos) << bad.err;
    const RunResult none = run({"gates", (t / "nothing").string()}, t.path());
    EXPECT_EQ(none.code, 2);
    EXPECT_NE(none.err.find("not a directory"), std::string::npos) << none.err;
}

// --- 7. validate -----------------------------------------------------------------------------

TEST(CliValidate, EveryShippedSpecIsValid) {
    TempDir t;
    std::vector<std::vector<std::string>> runs;
    for (const fs::path& f : sylva::test::shippedSpeciesFiles()) {
        runs.push_back({"validate", f.string()});
    }
    for (const fs::path& dir : {kSource / "datasets", kData, kData / "keys"}) {
        for (const auto& e : fs::directory_iterator(dir)) {
            if (e.path().extension() == ".toml") runs.push_back({"validate", e.path().string()});
        }
    }
    std::sort(runs.begin(), runs.end());
    ASSERT_GE(runs.size(), 48u + 5u + 4u);  // every preset, the datasets, the fixtures
    const std::vector<RunResult> r = runAll(runs, t.path());
    for (size_t i = 0; i < r.size(); ++i) {
        SCOPED_TRACE(runs[i][1]);
        EXPECT_EQ(r[i].code, 0) << describeRun(r[i]);
        EXPECT_NE(r[i].out.find(": ok"), std::string::npos) << describeRun(r[i]);
        if (fs::path(runs[i][1]) == kDataset) {
            EXPECT_NE(r[i].out.find(std::to_string(kDatasetInstances) + " instances"),
                      std::string::npos)
                << r[i].out;
        }
    }
}

// --- 8. stats and report ----------------------------------------------------------------------

// What is not a dataset (or a dataset without a record) is bad input: one line, exit 2.
TEST(CliStatsReport, BadDirectoriesExitTwoWithOneLine) {
    TempDir t;
    auto expectBadInput = [&](const std::vector<std::string>& args, const std::string& message) {
        const RunResult r = run(args, t.path());
        EXPECT_EQ(r.code, 2) << describeRun(r);
        EXPECT_NE(r.err.find(message), std::string::npos) << describeRun(r);
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << describeRun(r);
    };
    expectBadInput({"stats", (t / "nope").string()}, "sylva: stats: ");
    expectBadInput({"stats", (t / "nope").string()}, "not a directory");
    expectBadInput({"stats", t.path().string()}, "no manifest.jsonl");
    expectBadInput({"report", (t / "nowhere").string()}, "sylva: report: ");
    expectBadInput({"report", (t / "nowhere").string()}, "not a directory");
    expectBadInput({"report", t.path().string()}, "no dataset.json");

    buildOk(kDataset, t / "ds", t.path());
    RunResult ok = run({"report", (t / "ds").string()}, t.path());
    EXPECT_EQ(ok.code, 0) << describeRun(ok);
    EXPECT_TRUE(fs::is_regular_file(t / "ds" / "report" / "index.html"));
    spit(t / "ds" / "manifest.jsonl", "");
    fs::remove_all(t / "ds" / "report");
    expectBadInput({"report", (t / "ds").string()}, "the manifest has no record");
    EXPECT_FALSE(fs::exists(t / "ds" / "report" / "index.html"));
}

// stats, gates and report read a dataset through one checked reader: a manifest or description
// of the wrong shape, a record nested too deep for a recursive walk, a path leading out of the
// dataset, or a FIFO or device as a reference is one line and exit 2 from each of them, and
// nothing is written (neither stats/ nor report/). Each of these was accepted, crashed (stats on
// deep nesting), hung (a FIFO) or exited 1 with a raw library message before.
TEST(CliDatasetReader, EveryCommandRefusesAMalformedDatasetWithOneLine) {
    TempDir t;
    buildOk(kDataset, t / "good", t.path());
    const std::vector<std::string> lines = readLines(t / "good" / "manifest.jsonl");
    ASSERT_GE(lines.size(), 3u);
    auto variant = [&](const std::string& name, const std::function<void(const fs::path&)>& edit) {
        const fs::path d = t / name;
        fs::copy(t / "good", d, fs::copy_options::recursive);
        edit(d);
        return d;
    };
    auto manifestWith = [&](size_t line, const std::function<void(nlohmann::json&)>& edit) {
        return [&, line, edit](const fs::path& d) {
            std::string text;
            for (size_t i = 0; i < lines.size(); ++i) {
                nlohmann::json j = nlohmann::json::parse(lines[i]);
                if (i == line) edit(j);
                text += j.dump() + "\n";
            }
            spit(d / "manifest.jsonl", text);
        };
    };
    struct Case {
        fs::path dir;
        std::string expect;
    };
    std::string noise(4000, '\0');
    for (size_t i = 0; i < noise.size(); ++i) noise[i] = static_cast<char>((i * 2654435761u) >> 13);
    const std::vector<Case> cases = {
        {variant("noise", [&](const fs::path& d) { spit(d / "manifest.jsonl", noise + "\n"); }),
         "manifest.jsonl:1: not a manifest record"},
        {variant("species-number", manifestWith(1, [](nlohmann::json& j) { j["species"] = 5; })),
         "manifest.jsonl:2: species: expected a string"},
        {variant("stats-array", manifestWith(0,
                                             [](nlohmann::json& j) {
                                                 j["stats"] = {1, 2};
                                             })),
         "manifest.jsonl:1: stats: expected an object"},
        {variant("deep",
                 [&](const fs::path& d) {
                     std::string line = lines[0];
                     const size_t at = line.find("\"stats\":{") + 9;
                     line.insert(at, "\"deep\":" + std::string(200000, '[') +
                                         std::string(200000, ']') + ",");
                     spit(d / "manifest.jsonl", line + "\n" + lines[1] + "\n");
                 }),
         "manifest.jsonl:1: nested more than 32 deep"},
        {variant("outside",
                 manifestWith(
                     2, [](nlohmann::json& j) { j["files"]["skeleton_ply"] = "/etc/passwd"; })),
         "manifest.jsonl:3: files.skeleton_ply: expected a relative path inside the dataset"},
        {variant("dataset-noise", [&](const fs::path& d) { spit(d / "dataset.json", noise); }),
         "dataset.json: not JSON"},
        {variant("dataset-array", [&](const fs::path& d) { spit(d / "dataset.json", "[]"); }),
         "dataset.json: expected a JSON object"},
        {variant("dataset-none", [&](const fs::path& d) { fs::remove(d / "dataset.json"); }),
         "no dataset.json (not a dataset directory)"},
    };
    // One command over every case at a time (stats and report lock the directory they read).
    std::vector<std::vector<std::string>> runs;
    std::vector<RunResult> r;
    for (const char* command : {"stats", "gates", "report"}) {
        std::vector<std::vector<std::string>> these;
        for (const Case& c : cases) these.push_back({command, c.dir.string()});
        for (RunResult& one : runAll(these, t.path())) r.push_back(std::move(one));
        runs.insert(runs.end(), these.begin(), these.end());
    }
    for (size_t i = 0; i < r.size(); ++i) {
        const Case& c = cases[i % cases.size()];
        SCOPED_TRACE(runs[i][0] + " " + runs[i][1]);
        EXPECT_EQ(r[i].code, 2) << describeRun(r[i]);
        EXPECT_EQ(std::count(r[i].err.begin(), r[i].err.end(), '\n'), 1) << describeRun(r[i]);
        EXPECT_NE(r[i].err.find("sylva: " + runs[i][0] + ": "), std::string::npos) << r[i].err;
        EXPECT_NE(r[i].err.find(c.expect), std::string::npos) << r[i].err;
        EXPECT_FALSE(fs::exists(c.dir / "stats"));
        EXPECT_FALSE(fs::exists(c.dir / "report"));
    }

    // A reference that is a FIFO (it would block forever) or a device (it would never end).
    const fs::path fifo = t / "fifo";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    sylva::test::CliOptions bounded;
    bounded.watchdog = std::chrono::seconds(120);
    for (const std::string& reference : {fifo.string(), std::string("/dev/zero")}) {
        const RunResult ref = sylva::test::runSylva(
            {"stats", (t / "good").string(), "--reference", reference}, t.path(), bounded);
        EXPECT_FALSE(ref.hung) << reference;
        EXPECT_EQ(ref.code, 2) << describeRun(ref);
        EXPECT_NE(ref.err.find(reference + ": not a regular file"), std::string::npos) << ref.err;
        EXPECT_FALSE(fs::exists(t / "good" / "stats"));
    }
}

// `sylva stats DIR --reference FILE`: reference.csv/json with a D for every species and
// distribution of the shipped reference; a missing or malformed reference file is one line,
// exit 2, and nothing is written.
TEST(CliStatsReference, TinyDatasetAgainstTheShippedReference) {
    TempDir t;
    buildOk(kDataset, t / "ds", t.path());
    const std::string ref = (kSource / "species" / "reference" / "treeqsm-broadleaf.json").string();
    RunResult r = run({"stats", (t / "ds").string(), "--no-timing", "--reference", ref}, t.path());
    ASSERT_EQ(r.code, 0) << describeRun(r);
    EXPECT_NE(r.out.find("reference treeqsm-broadleaf: "), std::string::npos) << r.out;
    const std::vector<std::string> lines = readLines(t / "ds" / "stats" / "reference.csv");
    ASSERT_EQ(lines.size(), 1u + 2 * 8) << slurp(t / "ds" / "stats" / "reference.csv");  // 8 tables
    EXPECT_EQ(lines[0],
              "species,habit,distribution,instances,n,d,median,reference_n,reference_median");
    for (size_t i = 1; i < lines.size(); ++i) {
        // Every tiny tree forks: each species has values and a D in [0, 1] for each.
        std::vector<std::string> f;
        std::stringstream ss(lines[i]);
        for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
        ASSERT_EQ(f.size(), 9u) << lines[i];
        EXPECT_EQ(f[3], "12") << lines[i];  // instances: 2 sweep points × 6
        EXPECT_GT(std::stoi(f[4]), 0) << lines[i];
        const double d = std::stod(f[5]);
        EXPECT_TRUE(d >= 0 && d <= 1) << lines[i];
    }
    auto j = nlohmann::json::parse(slurp(t / "ds" / "stats" / "reference.json"));
    EXPECT_EQ(j["reference"]["name"], "treeqsm-broadleaf");
    EXPECT_EQ(j["species"]["tiny"]["habit"], "tree");
    EXPECT_EQ(j["species"]["tiny"]["distributions"].size(), 8u);

    fs::remove_all(t / "ds" / "stats");
    spit(t / "bad.json", R"({"distributions": {"radius_ratio": {"p": [0, 1], "q": [1, 0]}}})");
    for (const auto& [file, message] : std::vector<std::pair<std::string, std::string>>{
             {(t / "missing.json").string(),
              "missing.json: cannot read (No such file or directory)"},
             {(t / "bad.json").string(),
              "bad.json: distributions.radius_ratio.q: expected non-decreasing quantiles"}}) {
        RunResult bad = run({"stats", (t / "ds").string(), "--reference", file}, t.path());
        EXPECT_EQ(bad.code, 2) << describeRun(bad);
        EXPECT_EQ(bad.err.rfind("sylva: stats: ", 0), 0u) << describeRun(bad);
        EXPECT_NE(bad.err.find(message), std::string::npos) << describeRun(bad);
        EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << describeRun(bad);
        EXPECT_FALSE(fs::exists(t / "ds" / "stats"));
    }
}

}  // namespace
