// QuantileSketch (pipeline/analysis/quantile_sketch.h): exact below kExact values, a KLL sketch
// above with its rank error measured on a million known values, bounded memory, the same sketch
// for the same stream, and the weighted KS / Wasserstein distances against the exact ones.
#include "pipeline/analysis/quantile_sketch.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "pipeline/analysis/dataset_stats.h"

namespace {

using namespace sylva;

// 0 … n − 1 in a scrambled order (a multiplier coprime with n).
std::vector<double> permutation(int64_t n) {
    std::vector<double> v(static_cast<size_t>(n));
    for (int64_t i = 0; i < n; ++i) v[static_cast<size_t>(i)] = static_cast<double>((i * 7919) % n);
    return v;
}

TEST(QuantileSketch, ExactBelowTheCapacity) {
    QuantileSketch s;
    std::vector<double> v;
    for (double x : permutation(QuantileSketch::kExact)) {
        s.add(x * 0.5);
        v.push_back(x * 0.5);
    }
    ASSERT_TRUE(s.exact());
    std::sort(v.begin(), v.end());
    for (double q : {0.0, 0.05, 0.25, 0.5, 0.75, 0.95, 1.0}) {
        EXPECT_EQ(s.quantile(q), quantileType7(v, q)) << q;
    }
    EXPECT_EQ(s.mean(), summarize(v).mean);
    EXPECT_EQ(*s.sd(), *summarize(v).sd);
    s.add(1.0);
    EXPECT_FALSE(s.exact());
}

TEST(QuantileSketch, RankErrorBelowOnePercentOnAMillionValuesInBoundedMemory) {
    const int64_t n = 1'000'000;
    QuantileSketch s(42);
    for (double x : permutation(n)) s.add(x);
    EXPECT_EQ(s.count(), static_cast<uint64_t>(n));
    uint64_t weight = 0;
    for (const auto& [x, w] : s.weighted()) weight += w;
    EXPECT_EQ(weight, static_cast<uint64_t>(n));  // compactions keep the total weight
    EXPECT_LT(s.retained(), 3u * QuantileSketch::kK + 64);
    double worst = 0;
    for (int k = 1; k < 100; ++k) {
        const double q = k / 100.0;
        // The values are the ranks themselves: the quantile's normalised rank error.
        worst = std::max(worst, std::fabs(s.quantile(q) / static_cast<double>(n - 1) - q));
    }
    EXPECT_LT(worst, 0.01);
    EXPECT_NEAR(s.mean(), (n - 1) / 2.0, 1e-6 * n);
    EXPECT_NEAR(*s.sd(), std::sqrt((static_cast<double>(n) * n - 1) / 12.0), 1e-6 * n);

    // The same stream, the same sketch; another seed, another (equally good) sketch.
    QuantileSketch again(42), other(43);
    for (double x : permutation(n)) {
        again.add(x);
        other.add(x);
    }
    EXPECT_EQ(again.weighted(), s.weighted());
    EXPECT_NE(other.weighted(), s.weighted());
}

TEST(QuantileSketch, WeightedDistancesMatchTheExactOnesAndTheSketches) {
    std::vector<double> a, b;
    for (int i = 0; i < 300; ++i) a.push_back(std::sin(i * 1.7) + 0.1);
    for (int i = 0; i < 200; ++i) b.push_back(std::cos(i * 0.9) * 1.2);
    QuantileSketch sa, sb;
    for (double x : a) sa.add(x);
    for (double x : b) sb.add(x);
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    EXPECT_DOUBLE_EQ(weightedKsDistance(sa.weighted(), sb.weighted()), ksTwoSample(a, b).d);
    EXPECT_NEAR(weightedWasserstein(sa.weighted(), sb.weighted()), wasserstein1(a, b), 1e-12);

    // Two large streams shifted by 0.1 of their range: D = 0.1 and W1 = 0.1·range, sketched.
    QuantileSketch la(1), lb(2);
    const int64_t n = 200'000;
    for (double x : permutation(n)) {
        la.add(x / n);
        lb.add(x / n + 0.1);
    }
    EXPECT_NEAR(weightedKsDistance(la.weighted(), lb.weighted()), 0.1, 0.01);
    EXPECT_NEAR(weightedWasserstein(la.weighted(), lb.weighted()), 0.1, 0.005);
}

}  // namespace
