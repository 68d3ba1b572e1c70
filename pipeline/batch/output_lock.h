// One process at a time per dataset directory (or per shard of one): the lock that `sylva
// build`, `merge`, `stats` and `report` hold while they write into a dataset, and the checks
// of an output directory named on the command line before anything is created.
//
// The lock is a file in the directory — `.sylva.lock` for the whole directory, or
// `.sylva.shard-I-of-N.lock` for shard I of N, so the shards of one build may share a
// directory — created atomically (link(2) of a complete temporary file, O_EXCL where the file
// system has no hard links), holding its holder as JSON (pid, host, boot id, start time,
// command), and kept flock(2)ed by its holder while it runs. It conflicts with any lock of the
// whole directory and with the shards of another count N (their instances overlap); it is
// removed when its holder ends, by exit, exception or SIGINT/SIGTERM/SIGHUP. A lock whose
// holder is gone — same host and boot, process dead or its pid reused, flock free — is taken
// over; a lock from another host is never taken over (the message says which file to delete).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "core/errors.h"

namespace sylva {

// The directory is in use by another process (or its lock cannot be taken): one line naming
// the holder; the command exits 2 and writes nothing.
class LockError : public InputError {
  public:
    using InputError::InputError;
};

struct LockHolder {
    int64_t pid = 0;
    std::string host;
    std::string bootId;    // /proc/sys/kernel/random/boot_id ("" where there is none)
    int64_t pidStart = 0;  // the process' start time, clock ticks after boot (pid reuse)
    std::string started;   // UTC, ISO 8601
    std::string command;   // e.g. "sylva build --shard 1/4"
};

class OutputLock {
  public:
    // Locks `dir` (which must exist) for `command`, whole (shardCount 1) or shard
    // `shardIndex` of `shardCount`. Throws LockError naming the holder when a conflicting lock
    // is held, and when the lock file cannot be created.
    OutputLock(const std::filesystem::path& dir, const std::string& command, int shardIndex = 0,
               int shardCount = 1);
    ~OutputLock();  // removes the lock file (if it is still this one)
    OutputLock(const OutputLock&) = delete;
    OutputLock& operator=(const OutputLock&) = delete;

    const std::filesystem::path& file() const { return file_; }
    // The directory holding the lock was renamed to `dir` (merge's final rename): follow it.
    void movedTo(const std::filesystem::path& dir);

    // The lock file's name in its directory, and whether a file name is a lock's.
    static std::string fileName(int shardIndex, int shardCount);
    static bool isLockFile(const std::string& name);

  private:
    std::filesystem::path file_;
    int fd_ = -1;  // open and flock()ed while held
};

// Files unlinked, like the locks, should the process be ended by SIGINT, SIGTERM or SIGHUP
// (at most a few at a time), and taken off that list again.
void unlinkOnSignal(const std::filesystem::path& file);
void keepOnSignal(const std::filesystem::path& file);

// This process as a lock holder.
LockHolder currentHolder(const std::string& command);

// Before anything is written: `dir`, given as command-line option `option` (e.g. "--out"),
// must be a non-empty path that is a writable directory or can be created (every existing
// ancestor a directory, the nearest one writable). Throws InputError naming the option.
void checkOutputDir(const std::filesystem::path& dir, const std::string& option);
// Creates `dir` (after every other check passed); InputError naming the option on failure.
void createOutputDir(const std::filesystem::path& dir, const std::string& option);

}  // namespace sylva
