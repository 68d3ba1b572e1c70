// `sylva stats DATASET_DIR`: per-species summaries of every numeric per-instance metric, the
// two-sample Kolmogorov–Smirnov test and the 1-D Wasserstein distance between every pair of
// species, and each metric per swept value. Reads the manifest(s) only (never modifies them), so
// it works on a finished dataset, one still building or killed (a torn last line is ignored) and
// on shards written into one directory.
#pragma once

#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/errors.h"

namespace sylva {

// Bad input for `sylva stats` (missing directory, no manifest, no complete record, a malformed
// line that is not the last): the CLI prints the message and exits 2.
struct DatasetStatsInputError : InputError {
    using InputError::InputError;
};

// Quantile of ascending `sorted` at probability q in [0,1]: linear interpolation between order
// statistics, Hyndman & Fan type 7 (R's default, numpy's "linear"): h = (n−1)q,
// x[⌊h⌋] + (h−⌊h⌋)(x[⌊h⌋+1] − x[⌊h⌋]). `sorted` must not be empty.
double quantileType7(const std::vector<double>& sorted, double q);

struct KsResult {
    double d = 0;  // sup |F1 − F2|
    double p = 1;  // P(D ≥ d) under H0 (same distribution)
};

// Two-sample Kolmogorov–Smirnov test of ascending samples `a`, `b` (both non-empty). The
// p-value is exact (Hodges' lattice-path recursion, as R's psmirnov, assuming no ties) when
// n_a·n_b ≤ 10000, else the asymptotic Kolmogorov distribution Q(λ) = 2 Σ (−1)^(j−1) e^(−2j²λ²)
// at λ = (√nₑ + 0.12 + 0.11/√nₑ)·D, nₑ = n_a n_b/(n_a+n_b) (Stephens 1970 correction, as in
// Numerical Recipes §14.3).
KsResult ksTwoSample(const std::vector<double>& a, const std::vector<double>& b);

// 1-D Wasserstein-1 distance ∫|F_a − F_b| dx between the empirical distributions of ascending
// samples `a`, `b` (both non-empty).
double wasserstein1(const std::vector<double>& a, const std::vector<double>& b);

// A summary of one metric's values.
struct MetricSummary {
    size_t count = 0;
    double mean = 0;
    std::optional<double> sd;  // sample (n−1); none when count < 2
    std::optional<double> cv;  // sd / |mean|; none when sd is none or mean is 0
    double q05 = 0, q25 = 0, q50 = 0, q75 = 0, q95 = 0;
};
MetricSummary summarize(std::vector<double> values);

struct DatasetStatsOptions {
    // Include the timing.* metrics (machine-dependent, so off for reproducible stats files).
    bool timing = true;
    // Pairs listed in the printed summary use this many top-ranked metrics.
    int topMetrics = 3;
    // The printed summary lists at most this many pairs (compare.csv has them all).
    size_t maxPairsListed = 20;
};

struct DatasetStatsResult {
    std::filesystem::path outDir;          // DIR/stats
    std::vector<std::string> species;      // in order of first instance
    std::map<std::string, size_t> counts;  // instances per species
    size_t instances = 0;
    size_t metrics = 0;  // distinct metric names
    size_t ignoredPartialLines = 0;
    std::vector<std::string> manifests;  // files read (names relative to DIR)
    std::string summary;                 // the short text the CLI prints
};

// Reads DIR/manifest.jsonl and every DIR/manifest.shard-*.jsonl (records deduplicated by id,
// first file wins, ordered by instance index), writes DIR/stats/species.csv, species.json,
// compare.csv and sweep.csv atomically. Throws DatasetStatsInputError on bad input (before
// writing anything) and std::runtime_error on I/O failure.
DatasetStatsResult computeDatasetStats(const std::filesystem::path& dir,
                                       const DatasetStatsOptions& options = {});

}  // namespace sylva
