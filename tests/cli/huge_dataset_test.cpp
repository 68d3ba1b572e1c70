// Huge datasets through the real binary (issue 15, item 2): `validate` of a 10⁹-instance and of
// the largest dataset, the last shard of 10⁹ building its one tree, shards of a huge dataset
// concatenating to a coarser shard, and a huge shard resumed after a kill — each within a fixed
// peak resident size over the binary's own start-up (getrusage of the child), under an
// address-space limit and a watchdog so a binary that lists every instance fails fast instead
// of taking the machine.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "pipeline/batch/dataset.h"
#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kTiny = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data" / "tiny.toml";

// What one run may use beyond `sylva --help` (≈ 130 MiB here, nearly all of it the 260 shared
// libraries OpenImageIO and OpenVDB bring, loaded before main): a build of one tiny tree adds
// ≈ 8 MiB; a list of 10⁹ jobs would add ≈ 100 GB. And the limits that stop a binary sized by
// the count (before issue 15: 8 GB and 20 s+ for 10⁹ instances) from running away.
constexpr long kMaxRssOverStartKiB = 64 * 1024;
constexpr rlim_t kAddressSpace = rlim_t{4} << 30;
constexpr auto kWatchdog = std::chrono::seconds(60);

using RunResult = sylva::test::CliResult;  // maxRssKiB: the run's peak resident size

struct Command {
    Command(std::vector<std::string> a, std::vector<std::string> e = {})
        : args(std::move(a)), env(std::move(e)) {}
    std::vector<std::string> args;
    std::vector<std::string> env;  // "NAME=value", added to the test's (without the abort hook)
};

// Runs the commands at the same time (start-up dominates these runs) in `dir`, each under the
// address-space limit, and waits for all (killing what outlives the watchdog).
std::vector<RunResult> runAll(const std::vector<Command>& commands, const fs::path& dir) {
    std::vector<sylva::test::CliChild> children;
    for (const Command& c : commands) {
        sylva::test::CliOptions o;
        o.env = c.env;
        o.addressSpace = kAddressSpace;
        o.watchdog = kWatchdog;
        children.push_back(sylva::test::spawnSylva(c.args, dir, o));
    }
    std::vector<RunResult> results;
    for (const auto& c : children) {
        results.push_back(sylva::test::finishSylva(c));
        if (results.back().hung) ADD_FAILURE() << "killed after " << kWatchdog.count() << " s";
    }
    return results;
}

RunResult run(const std::vector<std::string>& args, const fs::path& dir,
              const std::vector<std::string>& env = {}) {
    return runAll({{args, env}}, dir).front();
}

// Peak resident size allowed: `sylva --help`'s (run beside the command) plus the margin.
long bound(const RunResult& help) {
    EXPECT_EQ(help.code, 0);
    return help.maxRssKiB + kMaxRssOverStartKiB;
}

std::string describe(const RunResult& r) {
    return "exit " + std::to_string(r.code) + ", peak RSS " + std::to_string(r.maxRssKiB / 1024) +
           " MiB\n--- stdout:\n" + r.out + "--- stderr:\n" + r.err;
}

void spit(const fs::path& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary);
    out << bytes;
}

std::vector<nlohmann::json> records(const fs::path& manifest) {
    std::vector<nlohmann::json> out;
    std::ifstream in(manifest, std::ios::binary);
    for (std::string line; std::getline(in, line);) {
        auto j = nlohmann::json::parse(line);
        j.erase("timing");  // the only field that differs between identical builds
        out.push_back(j);
    }
    return out;
}

// tiny.toml 10⁹ times, skeletons only: one instance is a few milliseconds.
std::string billion(const std::string& name = "billion") {
    return "name = \"" + name + "\"\nseed = 15\n[[species]]\nfile = '" + kTiny.string() +
           "'\ncount = 1000000000\n[outputs]\nskeleton = [\"ply\"]\n";
}

TEST(CliHugeDataset, ValidateAnswersForABillionAndForTheLargestDataset) {
    TempDir t;
    spit(t / "billion.toml", billion());
    // Exactly the largest dataset: 9 × 10¹⁵ = 10¹⁵ + 4 × 2 × 10¹⁵ over two species entries (one
    // more is an error: tests/data/bad/dataset_instances_over_limit.toml).
    spit(t / "largest.toml",
         "name = \"largest\"\n[[species]]\nfile = '" + kTiny.string() +
             "'\ncount = 1000000000000000\n[[species]]\nfile = '" +
             (kTiny.parent_path() / "tiny_var.toml").string() +
             "'\ncount = 2000000000000000\n[[sweep]]\npath = \"levels[1].endpoints\"\n"
             "values = [2, 3, 4, 5]\nspecies = [\"tiny-var\"]\n");
    const auto r = runAll(
        {{{"--help"}}, {{"validate", "billion.toml"}}, {{"validate", "largest.toml"}}}, t.path());
    EXPECT_EQ(r[1].out, "billion.toml: ok — dataset \"billion\", 1 species, 1000000000 instances\n")
        << describe(r[1]);
    EXPECT_EQ(r[2].out,
              "largest.toml: ok — dataset \"largest\", 2 species, 9000000000000000 instances\n")
        << describe(r[2]);
    for (size_t i = 1; i < r.size(); ++i) {
        EXPECT_EQ(r[i].code, 0) << describe(r[i]);
        EXPECT_LT(r[i].maxRssKiB, bound(r[0])) << describe(r[i]);
    }
}

TEST(CliHugeDataset, LastShardOfABillionBuildsItsOneTreeInBoundedMemory) {
    TempDir t;
    spit(t / "billion.toml", billion());
    const auto runs = runAll({{{"--help"}},
                              {{"build", "billion.toml", "--out", "out", "--shard",
                                "999999999/1000000000", "--threads", "2"}}},
                             t.path());
    const RunResult& r = runs[1];
    ASSERT_EQ(r.code, 0) << describe(r);
    EXPECT_LT(r.maxRssKiB, bound(runs[0])) << describe(r);
    const auto lines = records(t / "out" / "manifest.shard-0999999999-of-1000000000.jsonl");
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_EQ(lines[0]["id"], "tiny-999999999");
    EXPECT_EQ(lines[0]["index"], 999999999);
    char seed[20];
    std::snprintf(seed, sizeof seed, "%016llx",
                  static_cast<unsigned long long>(sylva::instanceSeed(15, "tiny", "", 999999999)));
    EXPECT_EQ(lines[0]["seed"], seed);
    EXPECT_TRUE(
        fs::is_regular_file(t / "out" / "trees" / "tiny" / "tiny-999999999" / "skeleton.ply"));
    const auto ds =
        nlohmann::json::parse(slurp(t / "out" / "dataset.shard-0999999999-of-1000000000.json"));
    EXPECT_EQ(ds["status"], "complete");
    EXPECT_EQ(ds["counts"]["instances_in_dataset"], 1000000000);
    EXPECT_EQ(ds["counts"]["instances_in_shard"], 1);
    EXPECT_EQ(ds["counts"]["built"], 1);
}

// Shards 99999998 and 99999999 of 10⁸ (10 instances each), built at once into one directory,
// are, concatenated, shard 49999999 of 5 × 10⁷ ([10⁹ − 20, 10⁹)): contiguous blocks in the one
// order, at any N.
TEST(CliHugeDataset, FineShardsConcatenateToACoarseShard) {
    TempDir t;
    spit(t / "billion.toml", billion());
    const std::vector<std::string> fine = {"099999998", "099999999"};
    std::vector<Command> commands = {
        {{"--help"}},
        {{"build", "billion.toml", "--out", "coarse", "--shard", "49999999/50000000"}}};
    for (const std::string& i : fine) {
        commands.push_back(
            {{"build", "billion.toml", "--out", "fine", "--shard", i.substr(1) + "/100000000"}});
    }
    const auto r = runAll(commands, t.path());
    for (size_t i = 1; i < r.size(); ++i) {
        ASSERT_EQ(r[i].code, 0) << describe(r[i]);
        EXPECT_LT(r[i].maxRssKiB, bound(r[0])) << describe(r[i]);
    }
    const auto want = records(t / "coarse" / "manifest.shard-49999999-of-50000000.jsonl");
    ASSERT_EQ(want.size(), 20u);
    EXPECT_EQ(want.front()["id"], "tiny-999999980");
    EXPECT_EQ(want.back()["id"], "tiny-999999999");
    std::vector<nlohmann::json> got;
    for (const std::string& i : fine) {
        const auto part = records(t / "fine" / ("manifest.shard-" + i + "-of-100000000.jsonl"));
        EXPECT_EQ(part.size(), 10u) << i;
        got.insert(got.end(), part.begin(), part.end());
    }
    ASSERT_EQ(got.size(), want.size());
    for (size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i], want[i]) << i;
    for (const auto& j : want) {
        const fs::path f = fs::path("trees") / "tiny" / j["id"].get<std::string>() / "skeleton.ply";
        EXPECT_EQ(slurp(t / "fine" / f), slurp(t / "coarse" / f)) << f;
    }
}

// A huge shard killed after 4 of its 10 trees (and a torn line) resumes to the uninterrupted
// shard; the rerun reads the manifest into runs of positions, not a set of every id.
TEST(CliHugeDataset, HugeShardResumesAfterAKill) {
    TempDir t;
    spit(t / "billion.toml", billion());
    auto build = [](const std::string& out) {
        return std::vector<std::string>{"build", "billion.toml", "--out",
                                        out,     "--shard",      "99999999/100000000"};
    };
    const auto first = runAll(
        {{{"--help"}}, {build("ref")}, {build("out"), {"SYLVA_TEST_ABORT_AFTER=4"}}}, t.path());
    ASSERT_EQ(first[1].code, 0) << describe(first[1]);
    ASSERT_EQ(first[2].code, 137) << describe(first[2]);
    const fs::path manifest = "manifest.shard-099999999-of-100000000.jsonl";
    ASSERT_EQ(records(t / "out" / manifest).size(), 4u);
    {
        std::ofstream torn(t / "out" / manifest, std::ios::binary | std::ios::app);
        torn << "{\"id\":\"tiny-9999999";
    }
    const RunResult rerun = run(build("out"), t.path());
    ASSERT_EQ(rerun.code, 0) << describe(rerun);
    EXPECT_NE(rerun.err.find("6 built, 4 already there, 0 failed of 10"), std::string::npos)
        << rerun.err;
    EXPECT_LT(rerun.maxRssKiB, bound(first[0])) << describe(rerun);
    const auto got = records(t / "out" / manifest), want = records(t / "ref" / manifest);
    ASSERT_EQ(got.size(), 10u);
    for (size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i], want[i]) << i;
    for (const auto& j : want) {
        const fs::path f = fs::path("trees") / "tiny" / j["id"].get<std::string>() / "skeleton.ply";
        EXPECT_EQ(slurp(t / "out" / f), slurp(t / "ref" / f)) << f;
    }
}

// `sylva merge`, `stats` and `report` of 10⁷ records in bounded memory: a packed dataset built as
// two shards (synthetic: two species of 5 × 10⁶ records each, one tar shard per build shard) with a
// uniform metric (a low-discrepancy sequence on [0, 1)) and a constant. Merged a line at a time,
// then summarised into sketches: each run's peak RSS stays within `sylva --help`'s plus the
// margin (and under 512 MiB) whatever the count, and the quantiles land within the sketch's
// error of the known ones.
TEST(CliHugeDataset, MergeStatsAndReportOfTenMillionRecordsInBoundedMemory) {
    TempDir t;
    const fs::path dir = t / "sharded";
    fs::create_directories(dir / "shards");
    constexpr int64_t kPerSpecies = 5'000'000;
    for (int shard = 0; shard < 2; ++shard) {
        const char species = shard ? 'b' : 'a';
        nlohmann::json d = {
            {"name", "huge"},
            {"fingerprint", "f"},
            {"status", "complete"},
            {"versions", {{"sylva", "test"}}},
            {"shard", {{"index", shard}, {"count", 2}}},
            {"counts",
             {{"instances_in_dataset", 2 * kPerSpecies},
              {"instances_in_shard", kPerSpecies},
              {"built", kPerSpecies},
              {"missing", 0}}},
            {"spec", {{"outputs", {{"pack", "tar"}, {"pack_instances", kPerSpecies}}}}},
            {"species",
             {{{"name", "a"}, {"count", kPerSpecies}, {"sweep_points", 1}},
              {{"name", "b"}, {"count", kPerSpecies}, {"sweep_points", 1}}}}};
        spit(dir / ("dataset.shard-" + std::to_string(shard) + "-of-2.json"), d.dump());
        spit(dir / "shards" / ("00000" + std::to_string(shard) + ".tar"), std::string(10240, '\0'));
        std::ofstream out(dir / ("manifest.shard-" + std::to_string(shard) + "-of-2.jsonl"),
                          std::ios::binary);
        std::string buf;
        char line[200];
        for (int64_t i = 0; i < kPerSpecies; ++i) {
            const double u = std::fmod(static_cast<double>(i) * 0.6180339887498949, 1.0);
            const int n = std::snprintf(
                line, sizeof line,
                "{\"id\":\"%c-%05lld\",\"index\":%lld,\"species\":\"%c\",\"pack\":"
                "\"shards/00000%d.tar\",\"stats\":{\"u\":%.9f,\"k\":3}}\n",
                species, static_cast<long long>(i), static_cast<long long>(i), species, shard, u);
            buf.append(line, static_cast<size_t>(n));
            if (buf.size() > (8u << 20)) {
                out << buf;
                buf.clear();
            }
        }
        out << buf;
    }
    sylva::test::CliOptions o;
    o.addressSpace = kAddressSpace;
    o.watchdog = std::chrono::seconds(900);
    const RunResult help = sylva::test::runSylva({"--help"}, t.path(), o);
    const fs::path merged = t / "merged";
    const RunResult m =
        sylva::test::runSylva({"merge", merged.string(), dir.string(), "--move"}, t.path(), o);
    ASSERT_EQ(m.code, 0) << describe(m);
    EXPECT_LT(m.maxRssKiB, bound(help)) << describe(m);
    EXPECT_LT(m.maxRssKiB, 512 * 1024) << describe(m);
    EXPECT_TRUE(fs::is_regular_file(merged / "shards" / "000001.tar"));
    EXPECT_EQ(fs::file_size(merged / "manifest.jsonl"),
              fs::file_size(dir / "manifest.shard-0-of-2.jsonl") +
                  fs::file_size(dir / "manifest.shard-1-of-2.jsonl"));

    const RunResult r = sylva::test::runSylva({"stats", merged.string()}, t.path(), o);
    ASSERT_EQ(r.code, 0) << describe(r);
    EXPECT_LT(r.maxRssKiB, bound(help)) << describe(r);
    EXPECT_LT(r.maxRssKiB, 512 * 1024) << describe(r);
    EXPECT_NE(r.out.find("2 species, 10000000 instances"), std::string::npos) << r.out;
    // species,metric,count,mean,sd,cv,q05,q25,q50,q75,q95
    std::ifstream csv(merged / "stats" / "species.csv");
    int rows = 0;
    for (std::string line; std::getline(csv, line);) {
        if (line.rfind("a,u,", 0) != 0 && line.rfind("b,u,", 0) != 0) continue;
        ++rows;
        std::vector<double> v;
        std::stringstream s(line.substr(4));
        for (std::string f; std::getline(s, f, ',');) v.push_back(std::stod(f));
        ASSERT_EQ(v.size(), 9u) << line;
        EXPECT_EQ(v[0], 5e6) << line;
        EXPECT_NEAR(v[1], 0.5, 1e-4) << line;                  // mean, exact
        EXPECT_NEAR(v[2], std::sqrt(1.0 / 12), 1e-4) << line;  // sd, exact
        const double q[] = {0.05, 0.25, 0.5, 0.75, 0.95};
        for (int k = 0; k < 5; ++k) EXPECT_NEAR(v[4 + k], q[k], 0.01) << line << " q" << q[k];
    }
    EXPECT_EQ(rows, 2);
    const std::string compare = slurp(merged / "stats" / "compare.csv");
    EXPECT_NE(compare.find("a,b,u,5000000,5000000,"), std::string::npos) << compare;

    // The report: its box plots from the same streams, its strips at most 300 dots a species.
    const RunResult rep = sylva::test::runSylva({"report", merged.string()}, t.path(), o);
    ASSERT_EQ(rep.code, 0) << describe(rep);
    EXPECT_LT(rep.maxRssKiB, bound(help)) << describe(rep);
    EXPECT_LT(rep.maxRssKiB, 512 * 1024) << describe(rep);
    const std::string html = slurp(merged / "report" / "index.html");
    EXPECT_NE(html.find("a: n 5000000, mean 0.5,"), std::string::npos);
    EXPECT_LT(html.size(), size_t{1} << 20);
}

}  // namespace
