// `sylva build --estimate`: sizes a build before it runs. The first few instances of every
// species entry and every [[plot]] (in the dataset's own instance order, so with the seeds the
// build gives them) are grown with the spec's full per-instance outputs into a scratch
// directory, one at a time on one worker thread, and removed afterwards; per instance the
// process CPU time, the wall time and the bytes and files of its directory (by kind) are
// measured, and scaled by each species' instance count to the whole dataset, a shard of it and
// this machine's cores (docs/outputs.md, "sylva build --estimate: sizing a build").
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pipeline/batch/dataset.h"

namespace sylva {

struct EstimateOptions {
    int samples = 2;     // instances measured per species entry and per plot (≥ 1)
    int threads = 0;     // cores the build would use, for the wall-time estimate (0: all cores)
    int shardIndex = 0;  // --shard I/N: the shard whose share is reported (N = 1: none)
    int shardCount = 1;
    std::filesystem::path out;      // the build's --out: never written, only its free space read
    std::filesystem::path scratch;  // where the scratch directory goes (default: $TMPDIR or /tmp)
};

// One measured instance.
struct EstimateSample {
    std::string id;
    double cpuSeconds = 0;       // process CPU time (user + system), the instance alone on 1 thread
    double wallSeconds = 0;      // its wall time
    uint64_t bytes = 0;          // sum of the sizes of the files of its directory
    uint64_t files = 0;          // regular files in its directory
    uint64_t manifestBytes = 0;  // its manifest line without the `timing` block
    std::map<std::string, uint64_t> byKind;  // bytes per kind (estimateFileKind)
    std::string error;                       // not empty: it failed (as the build would)
};

// A species entry (all its sweep points) or a [[plot]] of the spec.
struct EstimateRow {
    std::string name;
    bool plot = false;
    int64_t count = 0;    // its instances in the dataset
    int64_t inShard = 0;  // of them, in the chosen shard (= count unsharded)
    size_t sweepPoints = 1;
    std::vector<EstimateSample> samples;
    // Means over the samples that succeeded (0 when none did).
    int ok = 0;
    double cpuSeconds = 0, wallSeconds = 0, bytes = 0, files = 0, manifestBytes = 0;
    std::map<std::string, double> byKind;
};

struct EstimateResult {
    std::string dataset, spec;
    int samples = 0;  // asked for per row
    int cores = 1;    // the wall-time estimate's cores
    int shardIndex = 0, shardCount = 1;
    std::vector<EstimateRow> rows;  // species entries in spec order, then plots
    // Over every shard (shardCount > 1 and at most kMaxShardsScanned): the one with the most CPU.
    int heaviestShard = -1;
    double heaviestShardCpuSeconds = 0;
    std::filesystem::path out;       // the build's --out, and the free space of its file system
    int64_t outFreeBytes = -1;       // (-1: unknown)
    double measuredSeconds = 0;      // the estimate's own wall time
    long peakRssKiB = 0;             // the process's peak resident size while measuring
    std::vector<std::string> notes;  // what the numbers leave out or could not measure
    static constexpr int kMaxShardsScanned = 1000000;
};

// The kind of an instance file, from its path relative to the instance directory: "mesh",
// "watertight", "skeleton", "views" (silhouettes, transforms.json), "depth", "labels", "ids",
// "colour", "points", "previews", "scan", "qsm", "stats" or "other".
std::string estimateFileKind(const std::filesystem::path& relative);

// Measures the samples (InputError when options are unusable; the scratch directory is removed
// whatever happens).
EstimateResult estimateDataset(const DatasetSpec& spec, const EstimateOptions& options);

// The table printed by `sylva build --estimate`, and the same numbers as JSON.
std::string estimateTable(const EstimateResult& r);
nlohmann::json estimateJson(const EstimateResult& r);

}  // namespace sylva
