// OutputLock in-process: which scopes exclude each other, the holder recorded, stale and
// foreign locks, removal; checkOutputDir on paths that cannot be a dataset directory. (Two
// real processes: tests/cli/build_safety_test.cpp.)
#include "pipeline/batch/output_lock.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;
using test::slurp;
using test::TempDir;

void spit(const fs::path& p, const std::string& s) { std::ofstream(p, std::ios::binary) << s; }

std::string lockError(const fs::path& dir, int index = 0, int count = 1) {
    try {
        OutputLock lock(dir, "probe", index, count);
    } catch (const LockError& e) {
        return e.what();
    }
    return "";
}

TEST(OutputLock, RecordsItsHolderAndIsRemovedAtTheEnd) {
    TempDir t;
    {
        OutputLock lock(t.path(), "sylva build");
        EXPECT_EQ(lock.file(), t / ".sylva.lock");
        auto j = nlohmann::json::parse(slurp(lock.file()));
        EXPECT_EQ(j["pid"], ::getpid());
        EXPECT_EQ(j["host"], currentHolder("").host);
        EXPECT_EQ(j["command"], "sylva build");
        EXPECT_GT(j["pid_start"].get<int64_t>(), 0);
        EXPECT_EQ(j["started"].get<std::string>().size(), 20u);  // 2030-01-02T03:04:05Z
        // Held: this process' own second attempt is refused, naming it.
        const std::string e = lockError(t.path());
        EXPECT_EQ(e.rfind(t.path().string() + " is in use by sylva build (pid " +
                              std::to_string(::getpid()) + " on host ",
                          0),
                  0u)
            << e;
    }
    EXPECT_TRUE(fs::is_empty(t.path()));
    EXPECT_EQ(lockError(t.path()), "");
}

TEST(OutputLock, ShardsOfOneCountCoexistEverythingElseConflicts) {
    TempDir t;
    OutputLock s0(t.path(), "a", 0, 3);
    EXPECT_EQ(s0.file().filename(), ".sylva.shard-0-of-3.lock");
    OutputLock s1(t.path(), "b", 1, 3);        // another shard of the same build: fine
    EXPECT_NE(lockError(t.path(), 0, 3), "");  // the same shard
    EXPECT_NE(lockError(t.path(), 2, 4), "");  // shards of another count overlap
    EXPECT_NE(lockError(t.path()), "");        // the whole directory
    EXPECT_EQ(lockError(t.path(), 2, 3), "");
    EXPECT_TRUE(OutputLock::isLockFile(".sylva.lock"));
    EXPECT_TRUE(OutputLock::isLockFile(".sylva.shard-12-of-100.lock"));
    EXPECT_FALSE(OutputLock::isLockFile("manifest.jsonl"));
    EXPECT_FALSE(OutputLock::isLockFile(".sylva.lock.new.host.12"));
}

TEST(OutputLock, TakesOverADeadProcessesLockButNotAnotherHosts) {
    TempDir t;
    const pid_t dead = ::fork();
    if (dead == 0) ::_exit(0);
    ASSERT_GT(dead, 0);
    ::waitpid(dead, nullptr, 0);
    LockHolder h = currentHolder("sylva build");
    nlohmann::json j = {{"pid", dead},    {"host", h.host},       {"boot_id", h.bootId},
                        {"pid_start", 1}, {"started", h.started}, {"command", h.command}};
    spit(t / ".sylva.lock", j.dump());
    // (and the temp file of a lock it was creating when it died)
    const fs::path half = t / (".sylva.lock.new." + h.host + "." + std::to_string(dead));
    spit(half, "{");
    EXPECT_EQ(lockError(t.path()), "");  // taken over (and released)
    EXPECT_FALSE(fs::exists(t / ".sylva.lock"));
    EXPECT_FALSE(fs::exists(half));

    // Alive but its pid now names another process (start time differs): stale too.
    j["pid"] = ::getpid();
    j["pid_start"] = 1;
    spit(t / ".sylva.lock", j.dump());
    EXPECT_EQ(lockError(t.path()), "");

    // A boot ago.
    j["pid_start"] = h.pidStart;
    j["boot_id"] = "not-this-boot";
    spit(t / ".sylva.lock", j.dump());
    if (!h.bootId.empty()) {
        EXPECT_EQ(lockError(t.path()), "");
    }

    // Another host: never taken over, whatever its pid.
    j["host"] = "elsewhere.invalid";
    j["pid"] = dead;
    spit(t / ".sylva.lock", j.dump());
    const std::string e = lockError(t.path());
    EXPECT_NE(e.find("on host elsewhere.invalid"), std::string::npos) << e;
    EXPECT_NE(e.find("if that process no longer runs, delete " + (t / ".sylva.lock").string()),
              std::string::npos)
        << e;
    EXPECT_TRUE(fs::exists(t / ".sylva.lock"));

    // Unreadable: not guessed at.
    spit(t / ".sylva.lock", "");
    EXPECT_NE(lockError(t.path()).find("holder unreadable"), std::string::npos);
}

TEST(OutputLock, AHolderOfTheWrongShapeIsUnreadableNotACrash) {
    // Fields of the wrong JSON type, a lock file over 64 KiB, a FIFO (which blocked the reader
    // forever) and a directory in its place: each the one-line "holder unreadable" LockError.
    TempDir t;
    const fs::path lock = t / ".sylva.lock";
    for (const char* bad : {R"({"pid": "12", "host": "h"})", R"({"pid": 12, "host": 7})",
                            R"({"pid": 12.5})", R"({"pid": 12, "command": ["sylva"]})"}) {
        spit(lock, bad);
        EXPECT_NE(lockError(t.path()).find("holder unreadable"), std::string::npos) << bad;
    }
    spit(lock, R"({"pid": 12, "host": ")" + std::string(70000, 'x') + R"("})");
    EXPECT_NE(lockError(t.path()).find("holder unreadable"), std::string::npos);
    fs::remove(lock);
    ASSERT_EQ(::mkfifo(lock.c_str(), 0600), 0);
    EXPECT_NE(lockError(t.path()).find("holder unreadable"), std::string::npos);
    fs::remove(lock);
    fs::create_directory(lock);
    EXPECT_NE(lockError(t.path()).find("holder unreadable"), std::string::npos);
}

TEST(OutputLock, NamesThatAreNoLocksOfOursAreLeftAlone) {
    // A shard number too long for an int and a dead creator's pid of 20 digits (std::stoi and
    // std::stoll threw on them: the build exited 1 with "stoi"): neither is a lock.
    TempDir t;
    spit(t / ".sylva.shard-99999999999-of-2.lock", "{}");
    const std::string host = currentHolder("").host;
    spit(t / (".sylva.lock.new." + host + ".99999999999999999999"), "{");
    EXPECT_EQ(lockError(t.path()), "");
    EXPECT_EQ(lockError(t.path(), 1, 2), "");
    EXPECT_TRUE(fs::exists(t / ".sylva.shard-99999999999-of-2.lock"));
}

TEST(OutputLock, FollowsItsDirectoryWhenRenamed) {
    TempDir t;
    fs::create_directories(t / "a");
    {
        OutputLock lock(t / "a", "sylva merge");
        fs::rename(t / "a", t / "b");
        lock.movedTo(t / "b");
        EXPECT_EQ(lock.file(), t / "b" / ".sylva.lock");
    }
    EXPECT_TRUE(fs::is_empty(t / "b"));
}

TEST(CheckOutputDir, RejectsWhatCannotBeADatasetDirectory) {
    TempDir t;
    spit(t / "file", "x");
    auto message = [](const fs::path& p) -> std::string {
        try {
            checkOutputDir(p, "--out");
        } catch (const InputError& e) {
            return e.what();
        }
        return "";
    };
    EXPECT_EQ(message(""), "--out: expected a directory, got an empty path");
    EXPECT_EQ(message(t / "file"),
              "--out " + (t / "file").string() + ": exists and is not a directory");
    EXPECT_EQ(message(t / "file" / "a" / "b"), "--out " + (t / "file" / "a" / "b").string() +
                                                   ": cannot be created (" + (t / "file").string() +
                                                   " is not a directory)");
    EXPECT_EQ(message(t.path()), "");
    EXPECT_EQ(message(t / "new" / "deeper"), "");
    EXPECT_FALSE(fs::exists(t / "new"));  // checking creates nothing
}

}  // namespace
}  // namespace sylva
