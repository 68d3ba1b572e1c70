// A set of instance positions held as sorted, disjoint runs [begin, end): what a build has
// recorded. Memory is one map node (≈ 48 bytes) per run, not per instance: a build records its
// instances in position order, so what a manifest holds is a few long runs with a hole per
// failed tree (a run of 10⁹ recorded instances is one node). A bitmap over the shard would cost
// range / 8 bytes whatever was built (125 MB for an unsharded 10⁹-instance dataset, 1.1 PB at
// kMaxInstances), so it cannot serve the largest datasets.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>

namespace sylva {

class InstanceSet {
  public:
    // Adds `position` (no-op when present). O(log runs).
    void insert(int64_t position);
    bool contains(int64_t position) const;
    // How many positions of [lo, hi) are in the set. O(runs in [lo, hi) + log runs).
    int64_t countIn(int64_t lo, int64_t hi) const;
    // The first position ≥ `from` and < `hi` that is (not) in the set, or `hi`. O(log runs).
    int64_t nextPresent(int64_t from, int64_t hi) const;
    int64_t nextMissing(int64_t from, int64_t hi) const;
    // Number of runs: the set's memory is about 48 bytes each.
    size_t runs() const { return runs_.size(); }
    int64_t size() const { return size_; }

  private:
    std::map<int64_t, int64_t> runs_;  // begin -> end (exclusive); disjoint, never adjacent
    int64_t size_ = 0;
};

}  // namespace sylva
