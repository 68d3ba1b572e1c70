// The run log of a dataset directory: `runs.jsonl` (`runs.shard-I-of-N.jsonl` for a shard), one
// JSON line per run of `sylva build` (and `sylva merge`) that wrote into it — what differs from
// run to run (when, where, threads, how many instances it built, how long it took) and so has
// no place in dataset.json, which describes the dataset whatever runs made it.
//
// A run's line is added when it starts (status "running") and completed when it ends; a run
// that was killed keeps "running" until the next run of the same directory marks it
// "interrupted" (with the instances it recorded). Every change rewrites the file atomically,
// under the directory's lock (output_lock.h).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace sylva {

std::string runLogName(int shardIndex, int shardCount);

class RunLog {
  public:
    explicit RunLog(std::filesystem::path file) : file_(std::move(file)) {}

    // Marks a last line still "running" (its run was killed) "interrupted", with `built` = the
    // instances recorded now minus those it found (`already_built`), then appends `line`.
    void start(const nlohmann::json& line, int64_t recordedNow);
    // Replaces the line start() added.
    void finish(const nlohmann::json& line);

    const std::filesystem::path& file() const { return file_; }

  private:
    std::filesystem::path file_;
};

// The fields every run line starts with: command, started (UTC, ISO 8601), host, pid, sylva.
nlohmann::json runLine(const std::string& command);

}  // namespace sylva
