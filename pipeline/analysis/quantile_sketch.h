// A stream of numbers summarised in bounded memory, for `sylva stats` over manifests of any
// length: the values themselves while there are at most kExact of them (every statistic then
// exact, as from the sorted list), then a KLL sketch (Karnin, Lang & Liberty, "Optimal Quantile
// Approximation in Streams", FOCS 2016): compactors of capacity k·(2/3)^depth, each compaction
// keeping every other sorted item from a random offset at twice the weight. With k = 200 its
// normalised rank error is about 1.3 % (Apache DataSketches' table for k = 200; measured here
// in tests/pipeline/analysis/quantile_sketch_test.cpp: below 1 % on 10⁶ values), its memory
// about 3k values (≈ 5 KB) whatever the count. The offsets come from a generator seeded by the
// caller, so one stream in one order gives the same sketch every time. Mean and standard
// deviation are exact in both modes (Welford's running sums in sketch mode; from the sorted
// values while exact). No library: none in Debian implements KLL or t-digest for C++.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

namespace sylva {

class QuantileSketch {
  public:
    static constexpr size_t kExact = 2048;  // values kept as they are
    static constexpr int kK = 200;          // the top compactor's capacity

    explicit QuantileSketch(uint64_t seed = 0x5eed) : rng_(seed) {}
    void add(double x);

    uint64_t count() const { return n_; }
    bool exact() const { return levels_.empty(); }
    // Exact mode: the values, sorted; and as they came.
    std::vector<double> sortedValues() const;
    const std::vector<double>& values() const { return values_; }
    // The stream as sorted (value, weight) pairs, weights summing to count(): each value once
    // with weight 1 while exact, each retained item with its compactor's weight 2^depth after.
    std::vector<std::pair<double, uint64_t>> weighted() const;
    // The q-quantile, type 7 (linear between order statistics at h = (n − 1)q): exact while
    // exact, on the weighted items' ranks after.
    double quantile(double q) const;
    double mean() const;
    std::optional<double> sd() const;  // sample (n − 1); none below 2 values
    size_t retained() const;           // values held (the sketch's memory ÷ 8 bytes)

  private:
    void compress();
    uint64_t nextBit();
    std::vector<double> values_;               // exact mode
    std::vector<std::vector<double>> levels_;  // sketch mode: compactor h, items of weight 2^h
    uint64_t n_ = 0;
    double mean_ = 0, m2_ = 0;  // Welford
    uint64_t rng_;
};

// Kolmogorov–Smirnov D and Wasserstein-1 distance between two streams' weighted samples (their
// exact values when both are exact): sup |F_a − F_b| over the merged values, and ∫ |F_a − F_b|.
double weightedKsDistance(const std::vector<std::pair<double, uint64_t>>& a,
                          const std::vector<std::pair<double, uint64_t>>& b);
double weightedWasserstein(const std::vector<std::pair<double, uint64_t>>& a,
                           const std::vector<std::pair<double, uint64_t>>& b);

}  // namespace sylva
