// `sylva merge OUT SHARD_DIR…`: joins the outputs of `sylva build --shard I/N` (run on several
// machines, e.g. a Slurm job array or a Kubernetes Indexed Job) into one directory that is the
// single-machine build: the same trees/ files, manifest.jsonl (the shard manifests' lines,
// verbatim, in instance order), contact/<species>.png regenerated from the merged instances as
// buildDataset does, dataset.json exactly as an unsharded build writes it, and runs.jsonl (the
// shards' run logs in shard order, then the merge's line). Only the per-instance `timing` of
// the manifest lines and the run log differ from another build, as between any two builds.
// OUT is locked (output_lock.h) for the whole merge, and with `move` the shard directories.
#pragma once

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/errors.h"

namespace sylva {

// Bad input to merge (a shard missing, twice, from another spec, incomplete): nothing written.
class MergeError : public InputError {
  public:
    using InputError::InputError;
};

struct MergeOptions {
    std::filesystem::path out;                  // must not exist, or be an empty directory
    std::vector<std::filesystem::path> shards;  // directories holding dataset.shard-I-of-N.json
    bool move = false;                          // rename instance directories out of the shards
                                                // instead of copying them (same file system)
};

struct MergeSummary {
    int shardCount = 0;
    int64_t instances = 0;
    int64_t sheets = 0;  // species contact sheets written
    double wallSeconds = 0;
};

// Checks every shard first (same fingerprint, versions and shard count, each shard index once,
// status complete, every instance index 0…n-1 recorded exactly once and its directory present)
// and throws MergeError with one line before anything is written. The result is assembled in a
// temporary sibling of `out` and renamed onto it at the end. Other failures (I/O) throw
// std::runtime_error.
MergeSummary mergeShards(const MergeOptions& options);

}  // namespace sylva
