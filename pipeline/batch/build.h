// The batch builder: instance jobs through a oneTBB flow graph
//   source → limiter → grow → write files → sequencer → record (manifest, progress)
// with a bounded number of trees in flight, files written atomically, manifest lines
// appended in job order only after an instance's files exist, and resume by skipping ids
// already in the manifest.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pipeline/batch/dataset.h"

namespace sylva {

struct BuildOptions {
    std::filesystem::path out;  // output directory
    int threads = 0;            // 0: all cores
    int shardIndex = 0;         // --shard I/N
    int shardCount = 1;
    int maxInFlight = 0;   // 0: 4 × threads
    bool progress = true;  // progress on stderr
};

struct BuildSummary {
    int64_t total = 0;    // jobs in this shard
    int64_t skipped = 0;  // already in the manifest
    int64_t built = 0;
    int64_t failed = 0;
    std::vector<std::string> failedIds;  // the first kMaxFailedIds that failed, in job order
    double wallSeconds = 0;
    // Not empty when the build stopped because a resource ran out (ENOSPC, EDQUOT, EFBIG,
    // ENOMEM): "disk full while writing <path>: N instances built, M left; free space and
    // rerun to resume". What was recorded stays; a rerun resumes.
    std::string stopped;
    static constexpr size_t kMaxFailedIds = 20;
};

// Jobs of shard i of n: a contiguous block, so shard manifests concatenate, in shard
// order, to exactly the unsharded manifest.
std::pair<size_t, size_t> shardRange(size_t jobs, int index, int count);

// ".shard-I-of-N" ("" when unsharded), the suffix of a shard's own files.
std::string shardSuffix(int index, int count);

// Manifest and dataset file names for a shard ("manifest.jsonl" when unsharded).
std::string manifestName(int index, int count);
std::string datasetJsonName(int index, int count);

// The shard a file name belongs to: "<stem>.shard-I-of-N<ext>" (ext with its dot, ".jsonl")
// with decimal I and N (leading zeros allowed, as shardSuffix pads I) and 0 ≤ I < N ≤ 2³¹ − 1;
// nullopt for every other name (a name a user or another tool put there is not a shard).
struct ShardOf {
    int index = 0, count = 1;
};
std::optional<ShardOf> parseShardFileName(std::string_view name, std::string_view stem,
                                          std::string_view ext);

// Limits of what a dataset's files may hold, for every command that reads them (a record is a
// few kB, a plot's tens of kB; a run log line a few hundred bytes, a lock file one line).
inline constexpr uint64_t kMaxManifestLineBytes = uint64_t(64) << 20;
inline constexpr uint64_t kMaxDatasetJsonBytes = uint64_t(64) << 20;
inline constexpr uint64_t kMaxRunLogBytes = uint64_t(64) << 20;

// Builds (or resumes) the shard into options.out, holding its lock (output_lock.h) throughout:
// InputError when --out cannot be used or is in use, nothing written then.
BuildSummary buildDataset(const DatasetSpec& spec, const BuildOptions& options);

// Library versions, for dataset.json.
nlohmann::json versionInfo();

}  // namespace sylva
