// `sylva stats DATASET_DIR`: per-species summaries of every numeric per-instance metric, the
// two-sample Kolmogorov–Smirnov test and the 1-D Wasserstein distance between every pair of
// species, and each metric per swept value. Reads the manifest(s) only (never modifies them), so
// it works on a finished dataset, one still building or killed (a torn last line is ignored) and
// on shards written into one directory. With a reference file (`--reference FILE`, e.g.
// species/reference/treeqsm-broadleaf.json) it also reads every instance's skeleton.ply and
// gives the KS distance of each species' architecture distributions (reference_metrics.h) to the
// measured trees' quantile tables.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/errors.h"
#include "species/model/reference_metrics.h"

namespace sylva {

// The largest reference file (a quantile table is a few kB) and skeleton (a few MB for the
// largest library trees) stats reads.
inline constexpr uint64_t kMaxReferenceBytes = uint64_t(64) << 20;
inline constexpr uint64_t kMaxSkeletonBytes = uint64_t(1) << 30;

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
// The asymptotic p-value of D for samples of na and nb values (Kolmogorov's distribution with
// Stephens' correction), as ksTwoSample gives it above 10,000 pairs.
double ksAsymptoticP(double d, double na, double nb);

// 1-D Wasserstein-1 distance ∫|F_a − F_b| dx between the empirical distributions of ascending
// samples `a`, `b` (both non-empty).
double wasserstein1(const std::vector<double>& a, const std::vector<double>& b);

// A distribution as a quantile table: probabilities p (p[0] = 0 < … < p.back() = 1) and their
// quantiles q (non-decreasing), so q[0] is the minimum and q.back() the maximum.
struct QuantileTable {
    std::vector<double> p, q;
};

// The CDF of a quantile table: piecewise linear through the points (q_k, p_k), 0 below q[0] and 1
// from q.back(); where q repeats (a point mass) it jumps, right-continuous. `left` gives the
// limit from the left, F(x−).
double quantileTableCdf(const QuantileTable& t, double x, bool left = false);

// The quantile q(p) of a table, linear in p between its points.
double quantileTableQuantile(const QuantileTable& t, double p);

// The table of an ascending, non-empty sample: p_i = i/(n−1), q_i = x₍ᵢ₎, i.e. the CDF whose
// quantile function is type 7 (quantileType7); one value is a jump from 0 to 1 at it. It differs
// from the empirical step CDF by at most 1/(n−1).
QuantileTable sampleTable(const std::vector<double>& sorted);

// Kolmogorov–Smirnov distance sup_x |F_a(x) − F_b(x)| between the CDFs of two tables, exactly:
// the difference is linear between the union of their knots, so the sup is reached at a knot,
// from the left or from the right.
double ksDistance(const QuantileTable& a, const QuantileTable& b);

// A reference file: quantile tables of the distributions in kReferenceDistributionNames.
struct Reference {
    std::string name;  // the file's "name", else its file name
    size_t trees = 0;  // the file's "trees" (trees measured); 0 when absent
    struct Distribution {
        QuantileTable table;
        size_t n = 0;      // values the table was made from ("n"; 0 when absent)
        size_t trees = 0;  // trees they came from ("trees"; 0 when absent)
    };
    std::map<std::string, Distribution> distributions;
};

// Reads a reference JSON file: {"name": …, "distributions": {NAME: {"p": [...], "q": [...],
// "n": …, "trees": …}, …}} with NAME among kReferenceDistributionNames (docs/metrics.md).
// Throws DatasetStatsInputError "FILE: what is wrong" when the file is missing, not a regular file,
// larger than kMaxReferenceBytes, not JSON, names an
// unknown distribution or holds a table that is not one (p from 0 to 1 strictly increasing, q
// non-decreasing, as many of each, at least two, every number finite).
Reference readReference(const std::filesystem::path& file);

// The reference distributions (reference_metrics.h) of the skeleton in a binary skeleton.ply.
// Throws DatasetStatsInputError "PATH: …" when it cannot be read or is not a skeleton.
ReferenceValues readSkeletonReferenceValues(const std::filesystem::path& path);
// The same for a skeleton.ply already read (a packed instance's member); `name` for messages.
ReferenceValues skeletonReferenceValuesOf(const std::string& bytes, const std::string& name);

// One tree's reference distributions as `sylva stats --reference` measures them: from the tree
// written as skeleton.ply (skeletonPly: float positions and radii) and read back, so a tree
// grown in memory (`sylva fit`) gives the values of its skeleton.ply in a dataset.
// Throws std::invalid_argument as referenceValues does.
ReferenceValues skeletonReferenceValues(const Tree& tree);

// Adds one tree's values to a species' pool (every value weighs 1, as in the stats).
void poolReferenceValues(ReferenceValues& pool, const ReferenceValues& tree);

// The KS distance of pooled values (any order) to a reference table: ksDistance of their
// sampleTable to it. None when `values` is empty. `sylva stats --reference` and `sylva fit`
// both compute D with it.
std::optional<double> referenceDistance(std::vector<double> values, const QuantileTable& table);

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
    // A reference file (readReference): also write reference.csv and reference.json, the KS
    // distance of every species' pooled distributions to it. Empty: none.
    std::filesystem::path reference;
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
    // With options.reference: species → distribution → one row of reference.csv.
    struct ReferenceComparison {
        size_t instances = 0;             // the species' instances whose skeleton was read
        size_t n = 0;                     // values pooled over them
        std::optional<double> d, median;  // KS distance and type-7 median; none when n = 0
    };
    std::map<std::string, std::map<std::string, ReferenceComparison>> reference;
};

// Reads DIR/manifest.jsonl and every DIR/manifest.shard-*.jsonl (records checked and deduplicated
// by id as readManifests does, first file wins, ordered by instance index) after checking the
// dataset's description (readDatasetDescription: dataset.json or the shards'), writes
// DIR/stats/species.csv, species.json, compare.csv and sweep.csv atomically, and with
// options.reference reference.csv and reference.json from the instances' skeleton.ply files. Throws
// DatasetStatsInputError on bad input (before writing anything: also a bad reference file, a listed
// skeleton that is missing or malformed, or no skeleton.ply in the manifest) and std::runtime_error
// on I/O failure.
DatasetStatsResult computeDatasetStats(const std::filesystem::path& dir,
                                       const DatasetStatsOptions& options = {});

}  // namespace sylva
