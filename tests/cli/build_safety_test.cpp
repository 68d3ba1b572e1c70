// A dataset directory under stress, with the real binary (SYLVA_EXE): two builds at once (one
// gets the lock, the other one line naming it and exit 2), locks left by a kill, by a live
// process and by another host, a manifest damaged by an old concurrent run, a full disk (the
// file size limit, EFBIG, in a child process: the same errno → stop path as ENOSPC, and it
// needs no root), a kill -9 then a rerun (dataset.json byte-identical, the runs in runs.jsonl)
// and --out values that cannot be used.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
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

const fs::path kData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data";

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

size_t countLines(const fs::path& file) {
    const std::string s = slurp(file);
    return static_cast<size_t>(std::count(s.begin(), s.end(), '\n'));
}

// A dataset of `count` × 2 species × 2 sweep points of tiny trees, skeleton files only: about
// 2 ms a tree, so a build of a few hundred runs long enough to be caught running.
fs::path writeSpec(const fs::path& dir, int count, const std::string& extraOutputs = "") {
    const fs::path spec = dir / "spec.toml";
    spit(spec, "name = \"safety\"\nseed = 5\n[[species]]\nfile = '" +
                   (kData / "tiny.toml").string() + "'\ncount = " + std::to_string(count) +
                   "\n[[species]]\nfile = '" + (kData / "tiny_var.toml").string() +
                   "'\ncount = " + std::to_string(count) +
                   "\n[[sweep]]\npath = \"levels[1].endpoints\"\nvalues = [2, 3]\n"
                   "[outputs]\nskeleton = [\"ply\", \"swc\"]\n" +
                   extraOutputs);
    return spec;
}

// --- running the CLI -------------------------------------------------------------------------

using RunResult = sylva::test::CliResult;
using Child = sylva::test::CliChild;

// Starts `sylva args…` in `dir`; fileSizeLimit > 0 sets RLIMIT_FSIZE (bytes) in the child
// first, as `ulimit -f` would (SIGXFSZ keeps its default action: sylva must handle it). With a
// gate (a pipe) the child waits until the parent closes the pipe's write end, so that several
// children start at the same moment.
Child spawn(const std::vector<std::string>& args, const fs::path& dir, rlim_t fileSizeLimit = 0,
            const int* gate = nullptr) {
    sylva::test::CliOptions o;
    o.fileSizeLimit = fileSizeLimit;
    o.gate = gate;
    return sylva::test::spawnSylva(args, dir, o);
}

RunResult finish(const Child& c) { return sylva::test::finishSylva(c); }

RunResult run(const std::vector<std::string>& args, const fs::path& dir, rlim_t fileSizeLimit = 0) {
    return finish(spawn(args, dir, fileSizeLimit));
}

using sylva::test::describeRun;

RunResult build(const fs::path& spec, const fs::path& out, const fs::path& cwd,
                const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args = {"build", spec.string(), "--out", out.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return run(args, cwd);
}

void expectOneLine(const RunResult& r, int code) {
    EXPECT_EQ(r.code, code) << describeRun(r);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << describeRun(r);
}

// --- comparing datasets ----------------------------------------------------------------------

// Manifest lines without their per-instance "timing" (what differs between any two builds).
std::vector<std::string> strippedManifest(const fs::path& file) {
    std::vector<std::string> out;
    for (const std::string& line : readLines(file)) {
        auto j = nlohmann::json::parse(line, nullptr, false);
        EXPECT_FALSE(j.is_discarded()) << file << ": " << line;
        if (j.is_discarded()) continue;
        j.erase("timing");
        out.push_back(j.dump());
    }
    return out;
}

std::map<std::string, std::string> filesUnder(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (e.is_regular_file())
            files[fs::relative(e.path(), dir).generic_string()] = slurp(e.path());
    }
    return files;
}

// `got` is the dataset `want` is: the same files with the same bytes (the manifest up to its
// lines' timing; runs.jsonl is the run log, different by nature), no lock or temp file.
void expectSameDataset(const fs::path& got, const fs::path& want) {
    auto a = filesUnder(got), b = filesUnder(want);
    for (auto* m : {&a, &b}) m->erase("runs.jsonl");
    for (const auto& [rel, bytes] : a) {
        EXPECT_EQ(rel.find(".tmp."), std::string::npos) << "temp file left: " << rel;
        EXPECT_EQ(rel.find(".sylva"), std::string::npos) << "lock file left: " << rel;
        if (!b.count(rel)) ADD_FAILURE() << "only in " << got << ": " << rel;
    }
    for (const auto& [rel, bytes] : b) {
        if (!a.count(rel)) {
            ADD_FAILURE() << "missing from " << got << ": " << rel;
        } else if (rel == "manifest.jsonl") {
            EXPECT_EQ(strippedManifest(got / rel), strippedManifest(want / rel));
        } else {
            EXPECT_TRUE(a[rel] == bytes) << rel << " differs";
        }
    }
}

std::vector<nlohmann::json> runsOf(const fs::path& dir) {
    std::vector<nlohmann::json> runs;
    for (const std::string& l : readLines(dir / "runs.jsonl"))
        runs.push_back(nlohmann::json::parse(l));
    return runs;
}

// Waits until `file` exists with at least `lines` lines, or the child ends (false).
bool waitForLines(const Child& c, const fs::path& file, size_t lines) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!(fs::exists(file) && countLines(file) >= lines)) {
        int status = 0;
        if (::waitpid(c.pid, &status, WNOHANG) == c.pid) return false;
        if (std::chrono::steady_clock::now() > deadline) return false;
        std::this_thread::sleep_for(std::chrono::microseconds(300));
    }
    return true;
}

std::string hostName() {
    char buf[256] = {};
    ::gethostname(buf, sizeof buf - 1);
    return buf;
}

// --- 1. the lock -----------------------------------------------------------------------------

// Options for a build held by SYLVA_TEST_PAUSE_AT once it has recorded `at` instances (0: right
// after taking its lock) until `release` exists: the test acts while that build certainly runs,
// however busy the machine is.
sylva::test::CliOptions heldAt(int64_t at, const fs::path& release, const int* gate = nullptr) {
    sylva::test::CliOptions o;
    o.env = {"SYLVA_TEST_PAUSE_AT=" + std::to_string(at) + ":" + release.string()};
    o.gate = gate;
    o.watchdog = std::chrono::seconds(900);
    return o;
}

// The first of `children` to end (its index), or -1 when none ends within a minute.
int firstToEnd(const std::vector<Child>& children) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < deadline) {
        for (size_t i = 0; i < children.size(); ++i) {
            siginfo_t info{};
            if (::waitid(P_PID, static_cast<id_t>(children[i].pid), &info,
                         WEXITED | WNOHANG | WNOWAIT) == 0 &&
                info.si_pid == children[i].pid) {
                return static_cast<int>(i);
            }
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return -1;
}

// Two builds into one --out started together: one builds, the other prints one line naming the
// holder and exits 2 without writing; the dataset is a single build's. Each build, once it holds
// the lock, waits for the test's word, so the two certainly overlap.
TEST(CliLock, TwoBuildsAtOnceOneWinsAndTheDatasetIsASingleBuilds) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 25);  // 100 trees
    ASSERT_EQ(build(spec, t / "ref", t.path()).code, 0);

    const fs::path out = t / "out", release = t / "release";
    const std::vector<std::string> args = {"build", spec.string(), "--out", out.string()};
    int gate[2];
    ASSERT_EQ(::pipe(gate), 0);
    const std::vector<Child> children = {
        sylva::test::spawnSylva(args, t.path(), heldAt(0, release, gate)),
        sylva::test::spawnSylva(args, t.path(), heldAt(0, release, gate))};
    ::close(gate[0]);
    ::close(gate[1]);  // both go
    const int first = firstToEnd(children);
    spit(release, "");  // the holder goes on
    RunResult ra = finish(children[0]), rb = finish(children[1]);
    ASSERT_GE(first, 0) << "neither build ended while the other held the lock";
    const RunResult& loser = first == 0 ? ra : rb;
    const RunResult& winner = first == 0 ? rb : ra;
    ASSERT_EQ(winner.code, 0) << describeRun(winner);
    expectOneLine(loser, 2);
    EXPECT_EQ(
        loser.err.rfind("sylva: build: " + out.string() + " is in use by sylva build (pid ", 0), 0u)
        << loser.err;
    EXPECT_NE(loser.err.find(" on host " + hostName() + ", since 20"), std::string::npos)
        << loser.err;
    expectSameDataset(out, t / "ref");
    EXPECT_EQ(runsOf(out).size(), 1u) << "the loser wrote a run line";
    EXPECT_EQ(countLines(out / "manifest.jsonl"), 100u);
}

// Started one after the other, the second while the first is writing: it neither deletes the
// first one's temp files nor appends a line; a third run afterwards finds everything done.
TEST(CliLock, ASecondBuildWhileTheFirstRunsWritesNothing) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 40);  // 160 trees
    ASSERT_EQ(build(spec, t / "ref", t.path()).code, 0);
    const fs::path out = t / "out", release = t / "release";
    // Held after its second record, with more trees in flight.
    Child first = sylva::test::spawnSylva({"build", spec.string(), "--out", out.string()}, t.path(),
                                          heldAt(2, release));
    ASSERT_TRUE(waitForLines(first, out / "manifest.jsonl", 2)) << "the first build ended early";
    ASSERT_TRUE(fs::exists(out / ".sylva.lock"));
    const auto holder = nlohmann::json::parse(slurp(out / ".sylva.lock"));
    EXPECT_EQ(holder["pid"], first.pid);
    EXPECT_EQ(holder["host"], hostName());
    // Stopped as well, so that its trees in flight write nothing while the second one runs.
    ASSERT_EQ(::kill(first.pid, SIGSTOP), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(first.pid, &status, WUNTRACED), first.pid);
    ASSERT_TRUE(WIFSTOPPED(status));
    const auto files = filesUnder(out);
    RunResult second = build(spec, out, t.path());
    const auto after = filesUnder(out);
    EXPECT_TRUE(after == files) << "the second build wrote or removed something";
    for (const auto& [rel, bytes] : files) {
        if (!after.count(rel)) ADD_FAILURE() << "removed: " << rel;
    }
    for (const auto& [rel, bytes] : after) {
        if (!files.count(rel)) ADD_FAILURE() << "added: " << rel;
    }
    spit(release, "");
    ASSERT_EQ(::kill(first.pid, SIGCONT), 0);
    expectOneLine(second, 2);
    EXPECT_NE(second.err.find("(pid " + std::to_string(first.pid) + " on host "), std::string::npos)
        << second.err;
    RunResult ra = finish(first);
    ASSERT_EQ(ra.code, 0) << describeRun(ra);
    expectSameDataset(out, t / "ref");
    RunResult third = build(spec, out, t.path());
    ASSERT_EQ(third.code, 0) << describeRun(third);
    EXPECT_NE(third.err.find("0 built, 160 already there"), std::string::npos) << third.err;
    expectSameDataset(out, t / "ref");
}

// Ended by SIGTERM (a scheduler's cancel, Ctrl-C's cousin): the lock and the space reserve go
// with the process; kill -9 cannot clean up, and the next run takes that lock over (CliRunLog).
TEST(CliLock, TerminatedBuildLeavesNoLockBehind) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 40);
    const fs::path out = t / "out";
    // Held after its first record (never released): it is certainly running when the signal
    // comes.
    Child c = sylva::test::spawnSylva({"build", spec.string(), "--out", out.string()}, t.path(),
                                      heldAt(1, t / "never"));
    ASSERT_TRUE(waitForLines(c, out / "manifest.jsonl", 1)) << "the build ended early";
    ASSERT_EQ(::kill(c.pid, SIGTERM), 0);
    EXPECT_EQ(finish(c).code, 128 + SIGTERM);
    for (const auto& e : fs::directory_iterator(out)) {
        EXPECT_NE(e.path().filename().string().rfind(".sylva", 0), 0u) << e.path();
    }
}

// The files a rerun reads back and appends to — the manifest, dataset.json, the run log — must be
// regular files: a FIFO in place of one blocked the build forever (it opened the FIFO to read
// and waited for a writer). Now one line naming the file, exit 2, nothing written beside it.
TEST(CliShards, AFifoInPlaceOfABuildsOwnFileIsRefusedNotWaitedOn) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 1);
    for (const char* name : {"manifest.jsonl", "dataset.json", "runs.jsonl"}) {
        SCOPED_TRACE(name);
        const fs::path out = t / (std::string("out-") + name);
        fs::create_directories(out);
        ASSERT_EQ(::mkfifo((out / name).c_str(), 0600), 0);
        sylva::test::CliOptions o;
        o.watchdog = std::chrono::seconds(120);
        const RunResult r =
            sylva::test::runSylva({"build", spec.string(), "--out", out.string()}, t.path(), o);
        ASSERT_FALSE(r.hung) << "the build waited on the FIFO";
        expectOneLine(r, 2);
        EXPECT_NE(r.err.find("--out " + out.string() + ": " + name + " is not a regular file"),
                  std::string::npos)
            << r.err;
        std::vector<std::string> left;
        for (const auto& e : fs::directory_iterator(out)) {
            left.push_back(e.path().filename().string());
        }
        EXPECT_EQ(left, std::vector<std::string>{name});
    }
}

// A directory holds one sharding: a shard built beside the unsharded build (it would grow its
// trees again under its own files), shards of another count, or the unsharded build beside
// shards is refused with one line naming the other build's file, and nothing there changes.
TEST(CliShards, AShardBesideAnotherShardingIsRefusedAndChangesNothing) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 4);
    const fs::path whole = t / "whole", shards = t / "shards";
    ASSERT_EQ(build(spec, whole, t.path()).code, 0);
    ASSERT_EQ(build(spec, shards, t.path(), {"--shard", "0/2"}).code, 0);
    auto withoutLocks = [&](const fs::path& dir) {
        auto files = filesUnder(dir);
        for (auto it = files.begin(); it != files.end();) {
            it = it->first.find(".lock") != std::string::npos ? files.erase(it) : std::next(it);
        }
        return files;
    };
    const auto wholeBefore = withoutLocks(whole), shardsBefore = withoutLocks(shards);
    struct Case {
        fs::path out;
        std::vector<std::string> extra;
        std::string expect;
    };
    for (const Case& c : std::vector<Case>{
             {whole, {"--shard", "0/2"}, "holds the unsharded build (dataset.json)"},
             {whole, {"--shard", "1/2"}, "holds the unsharded build (dataset.json)"},
             {shards, {"--shard", "1/3"}, "holds shards of 2 (dataset.shard-0-of-2.json)"},
             {shards, {}, "holds shards of 2 (dataset.shard-0-of-2.json)"}}) {
        const RunResult r = build(spec, c.out, t.path(), c.extra);
        expectOneLine(r, 2);
        EXPECT_NE(r.err.find("--out " + c.out.string() + ": " + c.expect), std::string::npos)
            << r.err;
        EXPECT_NE(r.err.find("into another directory"), std::string::npos) << r.err;
    }
    EXPECT_EQ(withoutLocks(whole), wholeBefore);
    EXPECT_EQ(withoutLocks(shards), shardsBefore);
    // The other shard of the same count is welcome.
    const RunResult other = build(spec, shards, t.path(), {"--shard", "1/2"});
    EXPECT_EQ(other.code, 0) << describeRun(other);
}

// Shards of one build may share a directory (each locks its own shard); an unsharded build or
// shards of another count there at the same time may not.
TEST(CliLock, ShardsShareADirectoryButNotWithOtherCounts) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 1);
    const fs::path out = t / "out";
    fs::create_directories(out);
    // A live holder of shard 0 of 2: this test process, flock()ed like sylva's own.
    const nlohmann::json me = {{"pid", ::getpid()},
                               {"host", hostName()},
                               {"boot_id", ""},
                               {"pid_start", 0},
                               {"started", "2030-01-02T03:04:05Z"},
                               {"command", "sylva build --shard 0/2"}};
    spit(out / ".sylva.shard-0-of-2.lock", me.dump());
    int fd = ::open((out / ".sylva.shard-0-of-2.lock").c_str(), O_RDWR);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::flock(fd, LOCK_EX), 0);

    RunResult other = build(spec, out, t.path(), {"--shard", "1/2"});
    EXPECT_EQ(other.code, 0) << describeRun(other);  // the other shard of the same count
    for (const std::vector<std::string>& extra :
         {std::vector<std::string>{}, {"--shard", "0/2"}, {"--shard", "1/3"}}) {
        RunResult r = build(spec, out, t.path(), extra);
        expectOneLine(r, 2);
        EXPECT_NE(r.err.find("is in use by sylva build --shard 0/2 (pid " +
                             std::to_string(::getpid()) + " on host " + hostName() +
                             ", since 2030-01-02T03:04:05Z); wait for it to finish"),
                  std::string::npos)
            << r.err;
    }
    // stats and report write into the dataset too.
    for (const char* cmd : {"stats", "report"}) {
        RunResult r = run({cmd, out.string()}, t.path());
        expectOneLine(r, 2);
        EXPECT_NE(r.err.find("sylva: " + std::string(cmd) + ": " + out.string() + " is in use by"),
                  std::string::npos)
            << r.err;
    }
    EXPECT_FALSE(fs::exists(out / "manifest.jsonl"));
    EXPECT_FALSE(fs::exists(out / "manifest.shard-0-of-2.jsonl"));
    EXPECT_FALSE(fs::exists(out / "manifest.shard-1-of-3.jsonl"));
    ::close(fd);
}

// A lock left by a process that is gone (kill -9) is taken over; one of another host is not
// (the line says which file to delete), and nothing is written.
TEST(CliLock, StaleLockIsTakenOverForeignOneIsNot) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 1);
    const fs::path out = t / "out";
    fs::create_directories(out);
    pid_t dead = ::fork();
    if (dead == 0) ::_exit(0);
    ASSERT_GT(dead, 0);
    ::waitpid(dead, nullptr, 0);
    nlohmann::json holder = {{"pid", dead},
                             {"host", hostName()},
                             {"boot_id", ""},
                             {"pid_start", 0},
                             {"started", "2030-01-02T03:04:05Z"},
                             {"command", "sylva build"}};
    spit(out / ".sylva.lock", holder.dump());
    RunResult r = build(spec, out, t.path());
    ASSERT_EQ(r.code, 0) << describeRun(r);
    EXPECT_EQ(countLines(out / "manifest.jsonl"), 4u);
    EXPECT_FALSE(fs::exists(out / ".sylva.lock"));

    holder["host"] = "elsewhere.invalid";
    holder["pid"] = 1;
    spit(out / ".sylva.lock", holder.dump());
    const auto before = filesUnder(out);
    RunResult foreign = build(spec, out, t.path());
    expectOneLine(foreign, 2);
    EXPECT_NE(foreign.err.find("is in use by sylva build (pid 1 on host elsewhere.invalid, since "
                               "2030-01-02T03:04:05Z); if that process no longer runs, delete " +
                               (out / ".sylva.lock").string()),
              std::string::npos)
        << foreign.err;
    EXPECT_EQ(filesUnder(out), before);
}

// A manifest damaged by two builds that once ran at the same time — duplicate records (the
// later copies differing in timing), records out of job order, a torn line in the middle and
// a torn last line, some instances missing — is repaired by the next run: the first complete
// record of each id, in job order, and the missing ones built.
TEST(CliResume, DamagedManifestIsRepairedOnTheNextRun) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 5);  // 20 trees
    ASSERT_EQ(build(spec, t / "ref", t.path()).code, 0);
    const fs::path out = t / "out";
    ASSERT_EQ(build(spec, out, t.path()).code, 0);
    const std::vector<std::string> good = readLines(out / "manifest.jsonl");
    ASSERT_EQ(good.size(), 20u);

    std::string damaged;
    for (int i = 0; i < 8; ++i) damaged += good[i] + "\n";
    for (int i = 12; i < 16; ++i) damaged += good[i] + "\n";  // ahead of 8–11
    damaged += "{\"id\":\"tiny-p00";                          // torn, then another append
    for (int i = 8; i < 12; ++i) damaged += good[i] + "\n";
    for (int i = 0; i < 12; ++i) {  // the second build's copies
        auto j = nlohmann::json::parse(good[i]);
        j["timing"]["grow_ms"] = 12345.0;
        damaged += j.dump() + "\n";
    }
    damaged += good[17] + "\n";  // 16, 18, 19 missing
    damaged += "{\"id\":\"tiny-var-p001-000";
    spit(out / "manifest.jsonl", damaged);

    RunResult r = build(spec, out, t.path());
    ASSERT_EQ(r.code, 0) << describeRun(r);
    EXPECT_NE(r.err.find("3 built, 17 already there"), std::string::npos) << r.err;
    const std::vector<std::string> repaired = readLines(out / "manifest.jsonl");
    ASSERT_EQ(repaired.size(), 20u);
    for (int i : {0, 5, 9, 11, 12, 15, 17}) EXPECT_EQ(repaired[i], good[i]) << "line " << i + 1;
    // The torn line swallowed the next append (good[8]): the first complete record of that id
    // is the second build's copy.
    EXPECT_EQ(nlohmann::json::parse(repaired[8])["timing"]["grow_ms"], 12345.0);
    expectSameDataset(out, t / "ref");
}

// --- 2. a full disk --------------------------------------------------------------------------

// The file size limit (EFBIG, what a full disk gives as ENOSPC) reached by the manifest after a
// few records: one line, exit 1, the manifest a prefix of complete records in job order, no
// temp file; a rerun with room completes the dataset as an uninterrupted build. Then a limit
// below an instance's first file: nothing recorded, one line.
TEST(CliDiskFull, StopsWithOneLineAndAResumeCompletes) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 20);  // 80 trees, manifest ≈ 150 KB
    ASSERT_EQ(build(spec, t / "ref", t.path()).code, 0);
    const std::vector<std::string> ref = strippedManifest(t / "ref" / "manifest.jsonl");
    ASSERT_EQ(ref.size(), 80u);
    size_t biggest = 0;
    for (const auto& [rel, bytes] : filesUnder(t / "ref" / "trees")) {
        biggest = std::max(biggest, bytes.size());
    }
    const rlim_t limit = 24 * 1024;
    ASSERT_LT(biggest, limit) << "an instance file would reach the limit before the manifest";

    const fs::path out = t / "out";
    RunResult full =
        run({"build", spec.string(), "--out", out.string(), "--threads", "2"}, t.path(), limit);
    expectOneLine(full, 1);
    const std::vector<std::string> got = strippedManifest(out / "manifest.jsonl");
    ASSERT_GT(got.size(), 0u);
    ASSERT_LT(got.size(), 80u);
    EXPECT_EQ(slurp(out / "manifest.jsonl").back(), '\n');
    EXPECT_TRUE(std::equal(got.begin(), got.end(), ref.begin())) << "not a prefix of the job order";
    EXPECT_EQ(full.err, "sylva: build: file size limit reached while writing " +
                            (out / "manifest.jsonl").string() + ": " + std::to_string(got.size()) +
                            " instances built, " + std::to_string(80 - got.size()) +
                            " left; raise the file size limit (ulimit -f) and rerun to resume\n");
    for (const auto& [rel, bytes] : filesUnder(out)) {
        EXPECT_EQ(rel.find(".tmp."), std::string::npos) << rel;
        EXPECT_EQ(rel.find(".sylva"), std::string::npos) << rel;
    }
    auto runs = runsOf(out);
    ASSERT_EQ(runs.size(), 1u);
    EXPECT_EQ(runs[0]["status"], "stopped");
    EXPECT_EQ(runs[0]["built"], got.size());

    RunResult rerun = build(spec, out, t.path());
    ASSERT_EQ(rerun.code, 0) << describeRun(rerun);
    expectSameDataset(out, t / "ref");

    // The limit below a skeleton file: the first instance cannot be written.
    const fs::path none = t / "none";
    RunResult early = run({"build", spec.string(), "--out", none.string()}, t.path(), 1024);
    expectOneLine(early, 1);
    EXPECT_EQ(early.err.rfind(
                  "sylva: build: file size limit reached while writing " + none.string() + "/", 0),
              0u)
        << early.err;
    EXPECT_NE(early.err.find(": 0 instances built, 80 left; "), std::string::npos) << early.err;
    EXPECT_EQ(countLines(none / "manifest.jsonl"), 0u);
    for (const auto& [rel, bytes] : filesUnder(none)) {
        EXPECT_EQ(rel.find(".tmp."), std::string::npos) << rel;
    }
}

// --- 3. dataset.json describes the dataset, runs.jsonl the runs -------------------------------

TEST(CliRunLog, KilledAndResumedBuildHasTheDatasetJsonOfAnUninterruptedOne) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 40);  // 160 trees
    RunResult ref = build(spec, t / "ref", t.path(), {"--threads", "2"});
    ASSERT_EQ(ref.code, 0) << describeRun(ref);
    const auto refRuns = runsOf(t / "ref");
    ASSERT_EQ(refRuns.size(), 1u);
    EXPECT_EQ(refRuns[0]["status"], "complete");
    EXPECT_EQ(refRuns[0]["built"], 160);
    EXPECT_EQ(refRuns[0]["threads"], 2);
    const auto info = nlohmann::json::parse(slurp(t / "ref" / "dataset.json"));
    EXPECT_EQ(info["counts"]["built"], 160);
    EXPECT_EQ(info["counts"]["missing"], 0);
    for (const char* perRun : {"threads", "wall_seconds", "trees_per_second"}) {
        EXPECT_FALSE(info.contains(perRun)) << perRun;
    }

    const fs::path out = t / "out";
    // Held after its third record (never released), so the kill lands before the end however
    // slow the machine is.
    Child c =
        sylva::test::spawnSylva({"build", spec.string(), "--out", out.string(), "--threads", "1"},
                                t.path(), heldAt(3, t / "never"));
    ASSERT_TRUE(waitForLines(c, out / "manifest.jsonl", 3)) << "the build ended before the kill";
    ASSERT_EQ(::kill(c.pid, SIGKILL), 0);
    EXPECT_EQ(finish(c).code, 128 + SIGKILL);
    const size_t recorded = countLines(out / "manifest.jsonl");
    ASSERT_LT(recorded, 160u) << "the build finished before the kill landed";
    EXPECT_TRUE(fs::exists(out / ".sylva.lock")) << "kill -9 leaves the lock";

    RunResult rerun = build(spec, out, t.path(), {"--threads", "2"});
    ASSERT_EQ(rerun.code, 0) << describeRun(rerun);
    EXPECT_EQ(slurp(out / "dataset.json"), slurp(t / "ref" / "dataset.json"));
    expectSameDataset(out, t / "ref");
    const auto runs = runsOf(out);
    ASSERT_EQ(runs.size(), 2u);
    EXPECT_EQ(runs[0]["status"], "interrupted");
    EXPECT_EQ(runs[0]["already_built"], 0);
    EXPECT_EQ(runs[0]["threads"], 1);
    EXPECT_GE(runs[0]["built"].get<size_t>(), recorded);  // (a line may land after the count)
    EXPECT_EQ(runs[1]["status"], "complete");
    EXPECT_EQ(runs[1]["already_built"].get<size_t>() + runs[1]["built"].get<size_t>(), 160u);
    EXPECT_EQ(runs[0]["built"].get<size_t>(), runs[1]["already_built"].get<size_t>());
    for (const auto& r : runs) {
        EXPECT_EQ(r["command"], "build");
        EXPECT_EQ(r["host"], hostName());
        EXPECT_TRUE(r.contains("started") && r.contains("pid")) << r.dump();
    }
}

// --- 4. --out --------------------------------------------------------------------------------

// An --out that cannot be a dataset directory: one line naming --out, exit 2, nothing created.
TEST(CliOut, UnusableOutIsOneLineAndCreatesNothing) {
    TempDir t;
    const fs::path spec = writeSpec(t.path(), 1);
    spit(t / "a-file", "x");
    const std::vector<std::string> outs = {(t / "a-file").string(), (t / "a-file" / "sub").string(),
                                           "/proc/sylva-no-such-dir/out", ""};
    const auto before = filesUnder(t.path());
    for (const std::string& o : outs) {
        SCOPED_TRACE("--out '" + o + "'");
        RunResult r = run({"build", spec.string(), "--out", o}, t.path());
        expectOneLine(r, 2);
        EXPECT_EQ(r.err.rfind("sylva: build: --out", 0), 0u) << r.err;
        EXPECT_EQ(filesUnder(t.path()), before);
        EXPECT_FALSE(fs::exists(t / "out"));
    }
    EXPECT_FALSE(fs::exists("/proc/sylva-no-such-dir"));
}

}  // namespace
