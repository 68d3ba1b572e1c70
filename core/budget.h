// Per-tree budgets (issue 15): how large one tree may grow and how long its growth may take.
// Every size of a tree is bounded by a product of spec parameters that are each in range but
// whose product is not (endpoints per level × levels, a grammar's branching × depth, markers ×
// iterations). A budget makes that bound explicit:
//  - before growth, a species whose parameters certainly exceed a budget is a spec error at the
//    key that dominates (each method's reader estimates lower bounds of its sizes);
//  - during growth, the growth loops count what they build and look at the clock, and a tree
//    over a budget fails with BudgetExceeded (that instance only, in a build).
// The defaults are far above every shipped species (docs/specs.md, [budget]); a species or a
// dataset raises or lowers them with a [budget] table.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/errors.h"

namespace sylva {

// The defaults are about ten times the largest tree of any shipped spec (every species file and
// sweep point of species/, datasets/, bench/ and tests/data/, three seeds each, measured with
// the dataset's own tube settings: docs/specs.md, "Budgets"), so no shipped species comes near
// them. Only max_growth_seconds depends on the machine.
struct Budget {
    int64_t maxSkeletonNodes = 1'000'000;  // skeleton nodes of one tree (stats.nodes); largest
                                           // shipped: 95,736 (bench/table1.toml)
    int64_t maxGraphNodes = 4'000'000;     // the points a method grows through: the iterated
                                           // graph's Poisson nodes and endpoints (graph_nodes +
                                           // graph_endpoints), space colonization's markers
                                           // (markers_generated); largest: 376,490 (table1)
    int64_t maxLeaves = 1'500'000;         // leaves and fruit cards of one tree; largest: 148,200
                                           // (european-beech)
    int64_t maxTriangles = 40'000'000;     // mesh triangles (tubes and both faces of every
                                           // leaf), and the watertight mesh's; largest:
                                           // 3,203,732 (neem)
    int64_t maxViewPixels = 100'000'000;   // pixels of all views of one instance (dataset only;
                                           // all held in memory at once); largest: 524,288
    double maxGrowthSeconds = 600.0;       // wall-clock seconds of one tree's growth (the
                                           // method, [form], [leaves]); slowest: 23 s
    double maxPlotSeconds = 86400.0;       // wall-clock seconds of one plot's growth (every
                                           // tree, the LAI targets; dataset only); slowest
                                           // shipped: a few seconds
};

// The keys a [budget] table gives; the others keep the budget they are applied to.
struct BudgetTable {
    std::optional<int64_t> maxSkeletonNodes, maxGraphNodes, maxLeaves, maxTriangles, maxViewPixels;
    std::optional<double> maxGrowthSeconds, maxPlotSeconds;
    void applyTo(Budget& budget) const;
};

// A tree over a budget while it grows (or is meshed or rendered): a runtime failure of that
// tree, with a one-line message naming the budget and the size reached.
class BudgetExceeded : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

// A time budget: throws BudgetExceeded "budget KEY = LIMIT exceeded: DOING after S s; raise
// [budget] KEY or REMEDY" when `seconds` is over `limit`.
void checkSeconds(const char* key, double limit, double seconds, const char* doing,
                  const char* remedy);

// The budget of one tree with its deadline, handed to the growth loops. Checks are const and
// only read the clock, so parallel workers of one tree share a guard.
class GrowthGuard {
  public:
    explicit GrowthGuard(const Budget& budget);
    // No limits at all (tests and tools that call a method directly).
    static const GrowthGuard& unlimited();

    const Budget& budget() const { return budget_; }
    // Each throws BudgetExceeded when `count` is over its budget; `where` says what was being
    // built (", at level 3"), and may be empty.
    void skeletonNodes(int64_t count, const std::string& where = "") const;
    void graphNodes(int64_t count, const std::string& where = "") const;
    void leaves(int64_t count, const std::string& where = "") const;
    void triangles(int64_t count, const std::string& where = "") const;
    // Throws BudgetExceeded once the tree has grown for longer than max_growth_seconds.
    void time() const;
    // time() in an inner loop: `done` accumulates the loop's work (any unit of roughly
    // constant cost: points tested, nodes moved), and the clock is read once about every 10⁶.
    void work(uint64_t& done, uint64_t amount = 1) const {
        done += amount;
        if (done >= kWorkPerClockRead) {
            done = 0;
            time();
        }
    }
    double seconds() const;

  private:
    static constexpr uint64_t kWorkPerClockRead = 1u << 20;
    Budget budget_;
    std::chrono::steady_clock::time_point start_;
    bool timed_ = true;
};

// The budgets a size is held to.
enum class BudgetKind { kSkeletonNodes, kGraphNodes, kLeaves, kTriangles };
// "max_skeleton_nodes", …
const char* budgetKey(BudgetKind kind);
int64_t budgetOf(const Budget& budget, BudgetKind kind);

// A lower bound of one size of every tree a species grows with its parameters (distributions
// at their centres when validating, as drawn per instance), and the spec key that makes it.
struct SizeBound {
    BudgetKind kind = BudgetKind::kSkeletonNodes;
    double count = 0;  // the tree has at least this many
    SourcePos where;   // the key that dominates
    std::string keyPath;
    std::string what;  // "this level alone makes ≈ 1.0e6 endpoints"
};

// The bounds a species' reader could state (growth_method.h); empty when it knows none.
struct SizeEstimate {
    std::vector<SizeBound> bounds;
    void add(BudgetKind kind, double count, SourcePos where, std::string keyPath, std::string what);
    // The first bound over its budget, or nullptr; triangle bounds only when `meshed` (a
    // build that makes meshes or views).
    const SizeBound* over(const Budget& budget, bool meshed) const;
};
// "<what>, over the budget max_x = N; raise [budget] max_x or lower it" (no key path).
std::string overBudgetMessage(const SizeBound& bound, const Budget& budget);

// "999999", "1.0e9": a size for a message (exact below 10⁶, then 2 significant digits).
std::string formatSize(double count);

}  // namespace sylva
