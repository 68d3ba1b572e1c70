// The budget of one tree (core/budget.h): its counters, its deadline, size bounds and messages.
#include "core/budget.h"

#include <gtest/gtest.h>

#include <string>

namespace sylva {
namespace {

// The message of the BudgetExceeded `f` throws ("" when it throws none).
template <class F>
std::string exceeded(F&& f) {
    try {
        f();
    } catch (const BudgetExceeded& e) {
        return e.what();
    }
    return "";
}

TEST(Budget, CountsUpToTheBudgetPassAndOneMoreFails) {
    Budget b;
    b.maxSkeletonNodes = 100;
    b.maxGraphNodes = 200;
    b.maxLeaves = 300;
    b.maxTriangles = 400;
    const GrowthGuard g(b);
    EXPECT_EQ(exceeded([&] { g.skeletonNodes(100); }), "");
    EXPECT_EQ(exceeded([&] { g.graphNodes(200); }), "");
    EXPECT_EQ(exceeded([&] { g.leaves(300); }), "");
    EXPECT_EQ(exceeded([&] { g.triangles(400); }), "");
    EXPECT_EQ(exceeded([&] { g.skeletonNodes(101, " at levels[2]"); }),
              "budget max_skeleton_nodes = 100 exceeded: 101 skeleton nodes at levels[2]; raise "
              "[budget] max_skeleton_nodes or lower the sizes");
    EXPECT_NE(exceeded([&] { g.graphNodes(201); }).find("budget max_graph_nodes = 200 exceeded"),
              std::string::npos);
    EXPECT_NE(exceeded([&] { g.leaves(301); }).find("budget max_leaves = 300 exceeded: 301 leaves"),
              std::string::npos);
    EXPECT_NE(exceeded([&] {
                  g.triangles(4000000);
              }).find("budget max_triangles = 400 exceeded: 4.0e6 triangles"),
              std::string::npos);
}

TEST(Budget, DeadlineIsCheckedCooperatively) {
    Budget b;
    b.maxGrowthSeconds = 1e-9;  // over after any work at all
    const GrowthGuard g(b);
    EXPECT_NE(exceeded([&] { g.time(); }).find("budget max_growth_seconds = 1e-09 exceeded"),
              std::string::npos);
    // work() reads the clock once per 2²⁰ units: not before, then at once.
    uint64_t done = 0;
    EXPECT_EQ(exceeded([&] { g.work(done, (1u << 20) - 1); }), "");
    EXPECT_NE(exceeded([&] { g.work(done, 1); }), "");
    const GrowthGuard generous{Budget{}};
    EXPECT_EQ(exceeded([&] { generous.time(); }), "");
}

TEST(Budget, UnlimitedNeverFails) {
    const GrowthGuard& g = GrowthGuard::unlimited();
    EXPECT_EQ(exceeded([&] {
                  g.skeletonNodes(int64_t(1) << 62);
                  g.graphNodes(int64_t(1) << 62);
                  g.leaves(int64_t(1) << 62);
                  g.triangles(int64_t(1) << 62);
                  g.time();
              }),
              "");
}

TEST(Budget, TableOverridesOnlyTheKeysItGives) {
    Budget b;
    BudgetTable t;
    t.maxLeaves = 7;
    t.maxGrowthSeconds = 3.5;
    t.applyTo(b);
    EXPECT_EQ(b.maxLeaves, 7);
    EXPECT_EQ(b.maxGrowthSeconds, 3.5);
    EXPECT_EQ(b.maxSkeletonNodes, Budget{}.maxSkeletonNodes);
    EXPECT_EQ(b.maxTriangles, Budget{}.maxTriangles);
}

TEST(Budget, FirstBoundOverItsBudgetAndTrianglesOnlyWhenMeshed) {
    Budget b;
    b.maxSkeletonNodes = 10;
    b.maxTriangles = 10;
    SizeEstimate e;
    e.add(BudgetKind::kSkeletonNodes, 10, {"f.toml", 3, 1}, "a", "ten");
    e.add(BudgetKind::kTriangles, 11, {"f.toml", 4, 1}, "b", "eleven triangles");
    e.add(BudgetKind::kSkeletonNodes, 12, {"f.toml", 5, 1}, "c", "twelve nodes");
    ASSERT_NE(e.over(b, true), nullptr);
    EXPECT_EQ(e.over(b, true)->keyPath, "b");
    ASSERT_NE(e.over(b, false), nullptr);
    EXPECT_EQ(e.over(b, false)->keyPath, "c");
    EXPECT_EQ(overBudgetMessage(*e.over(b, false), b),
              "twelve nodes, over the budget max_skeleton_nodes = 10; raise [budget] "
              "max_skeleton_nodes or lower it");
    b.maxSkeletonNodes = 12;
    EXPECT_EQ(e.over(b, false), nullptr);
}

TEST(Budget, SizesAreExactBelowAMillion) {
    EXPECT_EQ(formatSize(0), "0");
    EXPECT_EQ(formatSize(999999), "999999");
    EXPECT_EQ(formatSize(1e6), "1.0e6");
    EXPECT_EQ(formatSize(4.3e6 + 1), "4.3e6");
    EXPECT_EQ(formatSize(2.7e11), "2.7e11");
    EXPECT_EQ(formatSize(1e301), "> 1e300");
}

}  // namespace
}  // namespace sylva
