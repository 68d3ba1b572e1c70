#include "core/budget.h"

#include <cmath>
#include <cstdio>
#include <limits>

namespace sylva {

void BudgetTable::applyTo(Budget& b) const {
    if (maxSkeletonNodes) b.maxSkeletonNodes = *maxSkeletonNodes;
    if (maxGraphNodes) b.maxGraphNodes = *maxGraphNodes;
    if (maxLeaves) b.maxLeaves = *maxLeaves;
    if (maxTriangles) b.maxTriangles = *maxTriangles;
    if (maxViewPixels) b.maxViewPixels = *maxViewPixels;
    if (maxGrowthSeconds) b.maxGrowthSeconds = *maxGrowthSeconds;
    if (maxPlotSeconds) b.maxPlotSeconds = *maxPlotSeconds;
}

std::string formatSize(double count) {
    char buf[64];
    if (!std::isfinite(count) || count > 1e300) return "> 1e300";
    if (std::abs(count) < 1e6) {
        std::snprintf(buf, sizeof buf, "%.0f", count);
        return buf;
    }
    const int exponent = static_cast<int>(std::floor(std::log10(std::abs(count))));
    double mantissa = count / std::pow(10.0, exponent);
    std::snprintf(buf, sizeof buf, "%.1fe%d", mantissa, exponent);
    return buf;
}

const char* budgetKey(BudgetKind kind) {
    switch (kind) {
        case BudgetKind::kGraphNodes:
            return "max_graph_nodes";
        case BudgetKind::kLeaves:
            return "max_leaves";
        case BudgetKind::kTriangles:
            return "max_triangles";
        case BudgetKind::kSkeletonNodes:
        default:
            return "max_skeleton_nodes";
    }
}

int64_t budgetOf(const Budget& b, BudgetKind kind) {
    switch (kind) {
        case BudgetKind::kGraphNodes:
            return b.maxGraphNodes;
        case BudgetKind::kLeaves:
            return b.maxLeaves;
        case BudgetKind::kTriangles:
            return b.maxTriangles;
        case BudgetKind::kSkeletonNodes:
        default:
            return b.maxSkeletonNodes;
    }
}

void SizeEstimate::add(BudgetKind kind, double count, SourcePos where, std::string keyPath,
                       std::string what) {
    bounds.push_back({kind, count, std::move(where), std::move(keyPath), std::move(what)});
}

const SizeBound* SizeEstimate::over(const Budget& budget, bool meshed) const {
    for (const SizeBound& b : bounds) {
        if (b.kind == BudgetKind::kTriangles && !meshed) continue;
        if (!(b.count <= static_cast<double>(budgetOf(budget, b.kind)))) return &b;
    }
    return nullptr;
}

std::string overBudgetMessage(const SizeBound& bound, const Budget& budget) {
    const std::string key = budgetKey(bound.kind);
    return bound.what + ", over the budget " + key + " = " +
           std::to_string(budgetOf(budget, bound.kind)) + "; raise [budget] " + key +
           " or lower it";
}

GrowthGuard::GrowthGuard(const Budget& budget)
    : budget_(budget), start_(std::chrono::steady_clock::now()) {}

const GrowthGuard& GrowthGuard::unlimited() {
    static const GrowthGuard guard = [] {
        Budget b;
        constexpr int64_t kAll = std::numeric_limits<int64_t>::max();
        b.maxSkeletonNodes = b.maxGraphNodes = b.maxLeaves = b.maxTriangles = b.maxViewPixels =
            kAll;
        b.maxGrowthSeconds = std::numeric_limits<double>::infinity();
        GrowthGuard g(b);
        g.timed_ = false;
        return g;
    }();
    return guard;
}

namespace {
[[noreturn]] void exceeded(const char* key, int64_t budget, int64_t count, const char* what,
                           const std::string& where) {
    throw BudgetExceeded("budget " + std::string(key) + " = " + std::to_string(budget) +
                         " exceeded: " + formatSize(static_cast<double>(count)) + " " + what +
                         where + "; raise [budget] " + key + " or lower the sizes");
}
}  // namespace

void GrowthGuard::skeletonNodes(int64_t count, const std::string& where) const {
    if (count > budget_.maxSkeletonNodes) {
        exceeded("max_skeleton_nodes", budget_.maxSkeletonNodes, count, "skeleton nodes", where);
    }
}

void GrowthGuard::graphNodes(int64_t count, const std::string& where) const {
    if (count > budget_.maxGraphNodes) {
        exceeded("max_graph_nodes", budget_.maxGraphNodes, count, "graph nodes or markers", where);
    }
}

void GrowthGuard::leaves(int64_t count, const std::string& where) const {
    if (count > budget_.maxLeaves)
        exceeded("max_leaves", budget_.maxLeaves, count, "leaves", where);
}

void GrowthGuard::triangles(int64_t count, const std::string& where) const {
    if (count > budget_.maxTriangles) {
        exceeded("max_triangles", budget_.maxTriangles, count, "triangles", where);
    }
}

double GrowthGuard::seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void checkSeconds(const char* key, double limit, double seconds, const char* doing,
                  const char* remedy) {
    if (!(seconds > limit)) return;
    char buf[300];
    std::snprintf(buf, sizeof buf,
                  "budget %s = %g exceeded: %s after %.1f s; raise [budget] %s or %s", key, limit,
                  doing, seconds, key, remedy);
    throw BudgetExceeded(buf);
}

void GrowthGuard::time() const {
    if (!timed_) return;
    checkSeconds("max_growth_seconds", budget_.maxGrowthSeconds, seconds(), "still growing",
                 "lower the sizes");
}

}  // namespace sylva
