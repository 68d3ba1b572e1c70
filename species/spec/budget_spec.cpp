#include "species/spec/budget_spec.h"

namespace sylva {

BudgetTable readBudget(Params& b, bool dataset) {
    BudgetTable t;
    const Budget defaults;
    // A budget is a bound, not a trait that varies from tree to tree: plain numbers only.
    // Every key is asked (absent ones too), so a misspelt one gets its suggestion.
    auto plain = [&](const char* key) {
        const toml::node* n = b.has(key) ? b.raw(key) : nullptr;
        if (n && n->is_table()) b.fail(key, "expected a plain number (no distribution)");
        return n != nullptr;
    };
    auto count = [&](const char* key, int64_t fallback, double hi, std::optional<int64_t>& out) {
        const bool given = plain(key);
        const int64_t v = b.integer(key, fallback, Range::closed(1, hi));
        if (given) out = v;
    };
    count("max_skeleton_nodes", defaults.maxSkeletonNodes, 2e9, t.maxSkeletonNodes);
    count("max_graph_nodes", defaults.maxGraphNodes, 1e12, t.maxGraphNodes);
    count("max_leaves", defaults.maxLeaves, 2e9, t.maxLeaves);
    count("max_triangles", defaults.maxTriangles, 2e9, t.maxTriangles);
    if (dataset) count("max_view_pixels", defaults.maxViewPixels, 1e13, t.maxViewPixels);
    const bool seconds = plain("max_growth_seconds");
    const double s =
        b.number("max_growth_seconds", defaults.maxGrowthSeconds, Range::leftOpen(0, 1e7));
    if (seconds) t.maxGrowthSeconds = s;
    if (dataset) {
        const bool given = plain("max_plot_seconds");
        const double v =
            b.number("max_plot_seconds", defaults.maxPlotSeconds, Range::leftOpen(0, 1e7));
        if (given) t.maxPlotSeconds = v;
    }
    b.finish();
    return t;
}

}  // namespace sylva
