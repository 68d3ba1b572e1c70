// `sylva merge`: shards built separately and merged give the single-machine build, file for
// file (only the documented timing fields differ), and a bad set of shards (one missing, one
// twice, another spec's, an incomplete manifest) exits 2 and writes nothing. Runs the real
// binary (SYLVA_EXE) on tests/data/merge_dataset.toml (12 tiny trees).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kDataset = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data" / "merge_dataset.toml";

using CliRun = sylva::test::CliResult;

// Runs `sylva args…` in `scratch` (paths are absolute), its output files there meanwhile.
CliRun sylva(const std::vector<std::string>& args, const fs::path& scratch) {
    return sylva::test::runSylva(args, scratch);
}

// Every regular file under `dir`, by relative path.
std::map<std::string, fs::path> filesUnder(const fs::path& dir) {
    std::map<std::string, fs::path> files;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (e.is_regular_file()) files[e.path().lexically_relative(dir).string()] = e.path();
    }
    return files;
}

// The documented differences between two builds of one spec: the manifest lines' `timing`,
// and the run log runs.jsonl (which runs made the dataset: checked on its own). dataset.json
// is byte-identical.
std::string withoutTiming(const std::string& rel, const std::string& bytes) {
    if (rel == "manifest.jsonl") {
        std::istringstream in(bytes);
        std::string out;
        for (std::string line; std::getline(in, line);) {
            auto j = nlohmann::json::parse(line);
            j.erase("timing");
            out += j.dump() + "\n";
        }
        return out;
    }
    if (rel == "runs.jsonl") return "";
    return bytes;
}

void expectSameDataset(const fs::path& merged, const fs::path& single) {
    auto a = filesUnder(merged), b = filesUnder(single);
    ASSERT_EQ(a.size(), b.size());
    for (const auto& [rel, path] : b) {
        ASSERT_TRUE(a.count(rel)) << rel << " missing from the merged dataset";
        EXPECT_EQ(withoutTiming(rel, slurp(a[rel])), withoutTiming(rel, slurp(path))) << rel;
    }
}

// Builds once for the whole suite: the unsharded dataset and shards 0, 1, 2 of 3.
class MergeTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        root_ = new TempDir();
        for (int i = 0; i < 3; ++i) {
            CliRun r = sylva({"build", kDataset.string(), "--out", shard(i).string(), "--shard",
                              std::to_string(i) + "/3", "--threads", "1"},
                             root_->path());
            ASSERT_EQ(r.code, 0) << r.err;
        }
    }
    static void TearDownTestSuite() {
        delete root_;
        root_ = nullptr;
    }
    static fs::path shard(int i) { return *root_ / ("shard-" + std::to_string(i)); }
    // The unsharded build, made on first use (ctest runs each test in its own process).
    static fs::path single() {
        const fs::path dir = *root_ / "single";
        if (!fs::exists(dir / "manifest.jsonl")) {
            CliRun r = sylva({"build", kDataset.string(), "--out", dir.string(), "--threads", "2"},
                             root_->path());
            EXPECT_EQ(r.code, 0) << r.err;
        }
        return dir;
    }

    // A copy of shard i in this test's scratch directory (which tests may modify).
    fs::path copyOfShard(int i, const std::string& name) {
        fs::path to = scratch_ / name;
        fs::copy(shard(i), to, fs::copy_options::recursive);
        return to;
    }
    // Runs a merge expected to fail: exit 2, one line naming `expect`, nothing written.
    void expectRefused(const std::vector<std::string>& dirs, const std::string& expect) {
        const fs::path out = scratch_ / "merged";
        std::vector<std::string> args = {"merge", out.string()};
        args.insert(args.end(), dirs.begin(), dirs.end());
        const auto before = filesUnder(scratch_.path());
        CliRun r = sylva(args, root_->path());
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find(expect), std::string::npos) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
        EXPECT_FALSE(fs::exists(out));
        EXPECT_EQ(filesUnder(scratch_.path()).size(), before.size());  // no stage left either
        for (const auto& e : fs::directory_iterator(scratch_.path())) {
            EXPECT_EQ(e.path().filename().string().find(".merge."), std::string::npos);
        }
    }

    static TempDir* root_;
    TempDir scratch_;
};
TempDir* MergeTest::root_ = nullptr;

TEST_F(MergeTest, ThreeShardsMergeIntoTheSingleMachineBuild) {
    const fs::path out = scratch_ / "merged";
    CliRun r =
        sylva({"merge", out.string(), shard(0).string(), shard(1).string(), shard(2).string()},
              scratch_.path());
    ASSERT_EQ(r.code, 0) << r.err;
    expectSameDataset(out, single());
    // The merged manifest is the shard manifests verbatim, concatenated in shard order.
    std::string cat;
    for (int i = 0; i < 3; ++i)
        cat += slurp(shard(i) / ("manifest.shard-" + std::to_string(i) + "-of-3.jsonl"));
    EXPECT_EQ(slurp(out / "manifest.jsonl"), cat);
    auto d = nlohmann::json::parse(slurp(out / "dataset.json"));
    EXPECT_EQ(d["counts"]["instances_in_shard"], 12);
    EXPECT_EQ(d["counts"]["built"], 12);
    EXPECT_EQ(d["shard"]["count"], 1);
    EXPECT_TRUE(fs::exists(out / "contact" / "tiny.png"));
    EXPECT_TRUE(fs::exists(out / "contact" / "tiny-var.png"));
    // runs.jsonl: each shard's run, in shard order, then the merge.
    std::vector<nlohmann::json> runs;
    std::istringstream lines(slurp(out / "runs.jsonl"));
    for (std::string line; std::getline(lines, line);) runs.push_back(nlohmann::json::parse(line));
    ASSERT_EQ(runs.size(), 4u);
    for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(runs[i]["command"], "build");
        EXPECT_EQ(runs[i]["shard"]["index"], i);
        EXPECT_EQ(runs[i]["built"], 4);
        EXPECT_EQ(runs[i]["status"], "complete");
    }
    EXPECT_EQ(runs[3]["command"], "merge");
    EXPECT_EQ(runs[3]["shards"], 3);
    EXPECT_EQ(runs[3]["instances"], 12);
    // The shards are untouched (copied, not moved).
    EXPECT_EQ(filesUnder(shard(0) / "trees").size(), filesUnder(out / "trees").size() * 4 / 12);
}

TEST_F(MergeTest, ShardsSharingOneDirectoryAndMoveGiveTheSameDataset) {
    // All three shards in one --out (the pre-merge README layout), merged with --move.
    const fs::path shared = scratch_ / "shared";
    for (int i = 0; i < 3; ++i) {
        fs::copy(shard(i), shared, fs::copy_options::recursive | fs::copy_options::skip_existing);
    }
    const fs::path out = scratch_ / "merged";
    CliRun r = sylva({"merge", "--move", out.string(), shared.string()}, scratch_.path());
    ASSERT_EQ(r.code, 0) << r.err;
    expectSameDataset(out, single());
    // Moved: no instance directory is left in the shard directory.
    size_t left = 0;
    for (const auto& e : fs::recursive_directory_iterator(shared / "trees"))
        left += e.is_regular_file();
    EXPECT_EQ(left, 0u);
}

TEST_F(MergeTest, MissingShardIsRefused) {
    expectRefused({shard(0).string(), shard(2).string()}, "shard 1 of 3 missing");
}

TEST_F(MergeTest, ShardGivenTwiceIsRefused) {
    fs::path again = copyOfShard(1, "again");
    expectRefused({shard(0).string(), shard(1).string(), again.string(), shard(2).string()},
                  "shard 1 of 3 given twice");
}

TEST_F(MergeTest, ShardOfAnotherSpecIsRefused) {
    fs::path other = copyOfShard(2, "other");
    const fs::path json = other / "dataset.shard-2-of-3.json";
    auto d = nlohmann::json::parse(slurp(json));
    d["fingerprint"] = "0123456789abcdef";
    std::ofstream(json) << d.dump(2) << "\n";
    expectRefused({shard(0).string(), shard(1).string(), other.string()},
                  "dataset fingerprint 0123456789abcdef");
}

TEST_F(MergeTest, ShardWithAnUnrecordedInstanceIsRefused) {
    // A failed tree: its manifest line is absent though the shard says "complete".
    fs::path partial = copyOfShard(1, "partial");
    const fs::path m = partial / "manifest.shard-1-of-3.jsonl";
    std::string bytes = slurp(m);
    bytes.erase(bytes.rfind('\n', bytes.size() - 2) + 1);
    std::ofstream(m, std::ios::binary) << bytes;
    expectRefused({shard(0).string(), partial.string(), shard(2).string()},
                  "3 of the shard's 4 instances recorded");
}

// A shard's run log that is not a regular file (a FIFO blocked the merge forever) or holds a
// line over 64 MiB: one line naming it, nothing written.
TEST_F(MergeTest, ShardRunLogThatIsNotARegularFileIsRefused) {
    fs::path odd = copyOfShard(1, "odd");
    const fs::path log = odd / "runs.shard-1-of-3.jsonl";
    fs::remove(log);
    ASSERT_EQ(::mkfifo(log.c_str(), 0600), 0);
    expectRefused({shard(0).string(), odd.string(), shard(2).string()},
                  log.string() + ": not a regular file");
    fs::remove(log);
    std::ofstream(log, std::ios::binary) << std::string((size_t(64) << 20) + 1, 'x') << "\n";
    expectRefused({shard(0).string(), odd.string(), shard(2).string()},
                  log.string() + ":1: a line of more than");
}

// A file named like a shard's description with a shard number too long for an int (merge exited 1
// with "stoi") is not a shard: the three real shards merge.
TEST_F(MergeTest, AFileNamedLikeAnImpossibleShardIsNotAShard) {
    fs::path odd = copyOfShard(1, "odd");
    std::ofstream(odd / "dataset.shard-99999999999-of-3.json") << "{}";
    const fs::path out = scratch_ / "merged";
    CliRun r = sylva({"merge", out.string(), shard(0).string(), odd.string(), shard(2).string()},
                     root_->path());
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(out / "manifest.jsonl"));
}

// OUT in use by another process (here this test, holding OUT's lock as a live process on this
// host), or with --move a shard directory in use: one line naming the holder, nothing written.
TEST_F(MergeTest, LockedOutputOrShardIsRefused) {
    char host[256] = {};
    ::gethostname(host, sizeof host - 1);
    const nlohmann::json holder = {{"pid", ::getpid()},
                                   {"host", host},
                                   {"boot_id", ""},
                                   {"pid_start", 0},
                                   {"started", "2030-01-02T03:04:05Z"},
                                   {"command", "sylva build"}};
    const fs::path out = scratch_ / "merged";
    fs::create_directories(out);
    std::ofstream(out / ".sylva.lock") << holder.dump();
    CliRun r =
        sylva({"merge", out.string(), shard(0).string(), shard(1).string(), shard(2).string()},
              scratch_.path());
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(r.err, "sylva: merge: " + out.string() + " is in use by sylva build (pid " +
                         std::to_string(::getpid()) + " on host " + host +
                         ", since 2030-01-02T03:04:05Z); wait for it to finish or use another "
                         "directory\n");
    EXPECT_EQ(filesUnder(out).size(), 1u);
    fs::remove_all(out);

    const fs::path moving = copyOfShard(1, "moving");
    std::ofstream(moving / ".sylva.shard-1-of-3.lock") << holder.dump();
    const auto before = filesUnder(moving);
    r = sylva(
        {"merge", "--move", out.string(), shard(0).string(), moving.string(), shard(2).string()},
        scratch_.path());
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find(moving.string() + " is in use by sylva build (pid "), std::string::npos)
        << r.err;
    EXPECT_EQ(filesUnder(moving), before);
    EXPECT_FALSE(fs::exists(out));
}

TEST_F(MergeTest, NonEmptyOutputIsRefused) {
    const fs::path out = scratch_ / "merged";
    fs::create_directories(out);
    std::ofstream(out / "keep.txt") << "x";
    CliRun r =
        sylva({"merge", out.string(), shard(0).string(), shard(1).string(), shard(2).string()},
              scratch_.path());
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("not an empty directory"), std::string::npos) << r.err;
    EXPECT_EQ(filesUnder(out).size(), 1u);
}

}  // namespace
