// `sylva stats`: the statistics against hand-computed answers, and the dataset reader on a
// finished, a sharded, a torn and a missing dataset.
#include "pipeline/analysis/dataset_stats.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "pipeline/batch/build.h"
#include "pipeline/batch/dataset.h"
#include "pipeline/formats/skeleton_writers.h"
#include "species/model/reference_metrics.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using namespace sylva;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data";

void spit(const fs::path& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary);
    out << bytes;
}

TEST(DatasetStats, QuantilesType7AndSummary) {
    // 1..10: h = 9p; q05 → h 0.45 → 1.45, q25 → 2.25 → 3.25, q50 → 5.5, q75 → 6.75 → 7.75,
    // q95 → 8.55 → 9.55. mean 5.5, sample variance Σ(x−5.5)²/9 = 82.5/9, cv = sd/5.5.
    MetricSummary s = summarize({10, 3, 1, 2, 4, 5, 6, 7, 8, 9});
    EXPECT_EQ(s.count, 10u);
    EXPECT_DOUBLE_EQ(s.mean, 5.5);
    ASSERT_TRUE(s.sd && s.cv);
    EXPECT_NEAR(*s.sd, std::sqrt(82.5 / 9), 1e-12);
    EXPECT_NEAR(*s.cv, std::sqrt(82.5 / 9) / 5.5, 1e-12);
    EXPECT_NEAR(s.q05, 1.45, 1e-12);
    EXPECT_NEAR(s.q25, 3.25, 1e-12);
    EXPECT_NEAR(s.q50, 5.5, 1e-12);
    EXPECT_NEAR(s.q75, 7.75, 1e-12);
    EXPECT_NEAR(s.q95, 9.55, 1e-12);
    // One value: every quantile is it; no sd, no cv.
    MetricSummary one = summarize({4});
    EXPECT_FALSE(one.sd);
    EXPECT_FALSE(one.cv);
    EXPECT_EQ(one.q05, 4);
    EXPECT_EQ(one.q95, 4);
    // Mean 0: no cv.
    EXPECT_FALSE(summarize({-1, 1}).cv);
}

TEST(DatasetStats, KsAndWassersteinByHand) {
    // a = {1,2,3}, b = {2,3,4,5}. F_a − F_b on [1,2): 1/3 − 0; [2,3): 2/3 − 1/4 = 5/12;
    // [3,4): 1 − 1/2 = 1/2; [4,5): 1 − 3/4 = 1/4; then 0. D = 1/2.
    // W1 = 1/3 + 5/12 + 1/2 + 1/4 = 18/12 = 1.5 (= mean b − mean a, as F_a ≥ F_b everywhere).
    // Exact p: of the C(7,3) = 35 equally likely orders of 3 + 4 distinct values, 23 have
    // D ≥ 1/2 (counted by enumerating all 35), so p = 23/35.
    const std::vector<double> a{1, 2, 3}, b{2, 3, 4, 5};
    KsResult ks = ksTwoSample(a, b);
    EXPECT_DOUBLE_EQ(ks.d, 0.5);
    EXPECT_NEAR(ks.p, 23.0 / 35.0, 1e-12);
    EXPECT_DOUBLE_EQ(wasserstein1(a, b), 1.5);
    EXPECT_DOUBLE_EQ(wasserstein1(b, a), 1.5);
    KsResult ba = ksTwoSample(b, a);
    EXPECT_DOUBLE_EQ(ba.d, 0.5);
    EXPECT_NEAR(ba.p, 23.0 / 35.0, 1e-12);

    // Crossing CDFs: {0,10} vs {5}: |F| = 1/2 on [0,5) and on [5,10): W1 = 2.5 + 2.5 = 5, D = 1/2.
    // p: of the 3 orders of 2 + 1 values, the single value first or last gives D = 1, the middle
    // D = 1/2, so P(D ≥ 1/2) = 1.
    EXPECT_DOUBLE_EQ(wasserstein1({0, 10}, {5}), 5.0);
    EXPECT_DOUBLE_EQ(ksTwoSample({0, 10}, {5}).d, 0.5);
    EXPECT_NEAR(ksTwoSample({0, 10}, {5}).p, 1.0, 1e-12);
    // Disjoint: {1,2} vs {3,4}: D = 1, exact p = 2/C(4,2) = 1/3; W1 = 2.
    EXPECT_DOUBLE_EQ(ksTwoSample({1, 2}, {3, 4}).d, 1.0);
    EXPECT_NEAR(ksTwoSample({1, 2}, {3, 4}).p, 1.0 / 3.0, 1e-12);
    EXPECT_DOUBLE_EQ(wasserstein1({1, 2}, {3, 4}), 2.0);
    // Identical samples: D = 0, p = 1, W1 = 0.
    EXPECT_EQ(ksTwoSample({1, 2, 2}, {1, 2, 2}).d, 0.0);
    EXPECT_EQ(ksTwoSample({1, 2, 2}, {1, 2, 2}).p, 1.0);
    EXPECT_EQ(wasserstein1({1, 2, 2}, {1, 2, 2}), 0.0);

    // Asymptotic branch (n_a·n_b = 40000 > 10000): a = 0..199, b = 20..219 → D = 20/200 = 0.1,
    // nₑ = 100, λ = (10 + 0.12 + 0.011)·0.1 = 1.0131, Q(λ) = 2 Σ (−1)^(j−1) e^(−2j²λ²)
    // = 0.256221185 (summed in Python). W1 = 20 (a shift).
    std::vector<double> big, shifted;
    for (int i = 0; i < 200; ++i) {
        big.push_back(i);
        shifted.push_back(i + 20);
    }
    KsResult as = ksTwoSample(big, shifted);
    EXPECT_NEAR(as.d, 0.1, 1e-12);
    EXPECT_NEAR(as.p, 0.25622118507, 1e-9);
    EXPECT_NEAR(wasserstein1(big, shifted), 20.0, 1e-9);
}

// A small dataset: the two tiny test species, a 2-point sweep, 4 instances each → 16 trees,
// skeletons and two 32 × 24 views (so silhouette_coverage is a per-view array).
std::string writeDatasetSpec(const fs::path& dir) {
    fs::path spec = dir / "ds.toml";
    spit(spec,
         "name = \"stats-test\"\nseed = 11\n"
         "[[species]]\nfile = \"" +
             (kData / "tiny.toml").string() +
             "\"\ncount = 4\n"
             "[[species]]\nfile = \"" +
             (kData / "tiny_var.toml").string() +
             "\"\ncount = 4\n"
             "[[sweep]]\npath = \"levels[1].endpoints\"\nvalues = [2, 3]\n"
             "[outputs]\nskeleton = [\"ply\"]\nspecies_sheet = 0\n"
             "[views]\ncount = 2\nresolution = [32, 24]\ndepth = false\nlabels = false\n"
             "contact_sheet = false\n");
    return spec.string();
}

void build(const std::string& spec, const fs::path& out, int shard = 0, int shards = 1) {
    BuildOptions o;
    o.out = out;
    o.threads = 2;
    o.shardIndex = shard;
    o.shardCount = shards;
    o.progress = false;
    BuildSummary s = buildDataset(loadDataset(spec), o);
    ASSERT_EQ(s.failed, 0);
}

TEST(DatasetStats, ShardsGiveTheSameFilesAsTheWholeBuild) {
    TempDir t;
    std::string spec = writeDatasetSpec(t.path());
    const fs::path whole = t.path() / "whole", sharded = t.path() / "sharded";
    build(spec, whole);
    build(spec, sharded, 0, 2);
    build(spec, sharded, 1, 2);
    ASSERT_FALSE(fs::exists(sharded / "manifest.jsonl"));

    // Timings differ between two builds, so compare without them: byte for byte.
    DatasetStatsOptions noTiming;
    noTiming.timing = false;
    DatasetStatsResult w = computeDatasetStats(whole, noTiming);
    fs::path wholeCopy = t.path() / "whole-stats";
    fs::copy(whole / "stats", wholeCopy);
    DatasetStatsResult s = computeDatasetStats(sharded, noTiming);
    EXPECT_EQ(w.instances, 16u);
    EXPECT_EQ(s.instances, 16u);
    EXPECT_EQ(s.manifests.size(), 2u);
    for (const char* f : {"species.csv", "species.json", "compare.csv", "sweep.csv"}) {
        EXPECT_EQ(slurp(wholeCopy / f), slurp(sharded / "stats" / f)) << f;
    }
    // With timings: the shards and their concatenation (a merged manifest) agree byte for byte,
    // and a directory holding both counts each instance once.
    computeDatasetStats(sharded);
    fs::path cat = t.path() / "cat";
    fs::create_directories(cat);
    spit(cat / "manifest.jsonl", slurp(sharded / "manifest.shard-0-of-2.jsonl") +
                                     slurp(sharded / "manifest.shard-1-of-2.jsonl"));
    fs::copy_file(whole / "dataset.json", cat / "dataset.json");
    computeDatasetStats(cat);
    fs::copy_file(cat / "manifest.jsonl", sharded / "manifest.jsonl");
    DatasetStatsResult both = computeDatasetStats(sharded);
    EXPECT_EQ(both.instances, 16u);
    for (const char* f : {"species.csv", "species.json", "compare.csv", "sweep.csv"}) {
        EXPECT_EQ(slurp(cat / "stats" / f), slurp(sharded / "stats" / f)) << f;
    }

    // Content: both species, per-view elements and their mean, timings, sweep values in order.
    std::string csv = slurp(cat / "stats" / "species.csv");
    EXPECT_EQ(csv.rfind("species,metric,count,mean,sd,cv,q05,q25,q50,q75,q95\n", 0), 0u);
    EXPECT_NE(csv.find("\ntiny,height_m,8,"), std::string::npos);
    EXPECT_NE(csv.find("\ntiny-var,height_m,8,"), std::string::npos);
    EXPECT_NE(csv.find("\ntiny,silhouette_coverage[1],8,"), std::string::npos);
    EXPECT_NE(csv.find("\ntiny,silhouette_coverage_mean,8,"), std::string::npos);
    EXPECT_NE(csv.find("\ntiny,timing.grow_ms,8,"), std::string::npos);
    std::string cmp = slurp(cat / "stats" / "compare.csv");
    EXPECT_EQ(cmp.rfind("species_a,species_b,metric,n_a,n_b,ks_d,ks_p,wasserstein,rank\n", 0), 0u);
    EXPECT_NE(cmp.find("\ntiny,tiny-var,height_m,8,8,"), std::string::npos);
    EXPECT_NE(cmp.find(",1\n"), std::string::npos);
    std::string sweep = slurp(cat / "stats" / "sweep.csv");
    size_t v2 = sweep.find("\ntiny,levels[1].endpoints,2,height_m,4,");
    size_t v3 = sweep.find("\ntiny,levels[1].endpoints,3,height_m,4,");
    EXPECT_NE(v2, std::string::npos);
    EXPECT_NE(v3, std::string::npos);
    EXPECT_LT(v2, v3);
    EXPECT_NE(both.summary.find("tiny vs tiny-var:"), std::string::npos);
}

TEST(DatasetStats, SpeciesCsvMatchesHandComputedManifest) {
    // Two species with known values; a torn last line (no '\n') is ignored, not an error, and
    // the manifest file is left as it is.
    TempDir t;
    std::string m =
        R"({"id":"a-0","index":0,"species":"a","stats":{"h":1,"v":[1,3]},"sweep":{"p":"10"}})"
        "\n"
        R"({"id":"a-1","index":1,"species":"a","stats":{"h":2,"v":[2,4]},"sweep":{"p":"9"}})"
        "\n"
        R"({"id":"a-2","index":2,"species":"a","stats":{"h":3,"v":[3,5]},"sweep":{"p":"10"}})"
        "\n"
        R"({"id":"b-0","index":3,"species":"b","stats":{"h":2,"v":[0,0]}})"
        "\n"
        R"({"id":"b-1","index":4,"species":"b","stats":{"h":3,"v":[0,0]}})"
        "\n"
        R"({"id":"b-2","index":5,"species":"b","stats":{"h":4,"v":[0,0]}})"
        "\n"
        R"({"id":"b-3","index":6,"species":"b","stats":{"h":5)";
    spit(t.path() / "manifest.jsonl", m);
    spit(t.path() / "dataset.json", R"({"name":"hand"})");
    DatasetStatsResult r = computeDatasetStats(t.path());
    EXPECT_EQ(slurp(t.path() / "manifest.jsonl"), m);
    EXPECT_EQ(r.ignoredPartialLines, 1u);
    EXPECT_EQ(r.instances, 6u);
    EXPECT_EQ(slurp(t.path() / "stats" / "species.csv"),
              "species,metric,count,mean,sd,cv,q05,q25,q50,q75,q95\n"
              "a,h,3,2,1,0.5,1.1,1.5,2,2.5,2.9\n"
              "a,v[0],3,2,1,0.5,1.1,1.5,2,2.5,2.9\n"
              "a,v[1],3,4,1,0.25,3.1,3.5,4,4.5,4.9\n"
              "a,v_mean,3,3,1,0.3333333333,2.1,2.5,3,3.5,3.9\n"
              "b,h,3,3,1,0.3333333333,2.1,2.5,3,3.5,3.9\n"
              "b,v[0],3,0,0,,0,0,0,0,0\n"
              "b,v[1],3,0,0,,0,0,0,0,0\n"
              "b,v_mean,3,0,0,,0,0,0,0,0\n");
    // h: {1,2,3} vs {2,3,4}: F_a − F_b = 1/3 on [1,4), so D = 1/3 and W1 = 1; p = 1, as every
    // order of 3 + 3 values already has |F_a − F_b| = 1/3 after its first value.
    // v[0], v[1], v_mean: every a above every b (or equal): D = 1, p = 2/C(6,3) = 0.1.
    std::string cmp = slurp(t.path() / "stats" / "compare.csv");
    EXPECT_NE(cmp.find("a,b,h,3,3,0.3333333333,1,1,4\n"), std::string::npos) << cmp;
    // Ranking by D, ties by W1 / pooled sd: v[1] (W1 4, sd 0.71) > v_mean (3) > v[0] (2).
    EXPECT_NE(cmp.find("a,b,v[1],3,3,1,0.1,4,1\n"), std::string::npos) << cmp;
    EXPECT_NE(cmp.find("a,b,v_mean,3,3,1,0.1,3,2\n"), std::string::npos) << cmp;
    EXPECT_NE(cmp.find("a,b,v[0],3,3,1,0.1,2,3\n"), std::string::npos) << cmp;
    EXPECT_NE(r.summary.find("  a vs b: v[1] (D 1.00, p 0.1), v_mean"), std::string::npos)
        << r.summary;
    DatasetStatsOptions capped;
    capped.maxPairsListed = 0;
    std::string s = computeDatasetStats(t.path(), capped).summary;
    EXPECT_EQ(s.find("a vs b"), std::string::npos) << s;
    EXPECT_NE(s.find("and 1 more pairs in compare.csv"), std::string::npos) << s;
    // Sweep values in numeric order (9 before 10), only for the species that has the sweep.
    EXPECT_EQ(slurp(t.path() / "stats" / "sweep.csv"),
              "species,path,value,metric,count,mean,sd,q25,q75\n"
              "a,p,9,h,1,2,,2,2\n"
              "a,p,9,v[0],1,2,,2,2\n"
              "a,p,9,v[1],1,4,,4,4\n"
              "a,p,9,v_mean,1,3,,3,3\n"
              "a,p,10,h,2,2,1.414213562,1.5,2.5\n"
              "a,p,10,v[0],2,2,1.414213562,1.5,2.5\n"
              "a,p,10,v[1],2,4,1.414213562,3.5,4.5\n"
              "a,p,10,v_mean,2,3,1.414213562,2.5,3.5\n");
}

TEST(DatasetStats, MissingOrEmptyDirectoryIsBadInput) {
    TempDir t;
    // Bad input, through the library (the CLI maps InputError to exit 2: tests/cli).
    auto message = [&] {
        try {
            computeDatasetStats(t.path());
        } catch (const DatasetStatsInputError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_THROW(computeDatasetStats(t.path() / "nope"), DatasetStatsInputError);
    EXPECT_NE(message().find("no manifest.jsonl"), std::string::npos) << message();
    // A manifest without the description the build writes first: not a dataset.
    spit(t.path() / "manifest.jsonl", R"({"id":"a-0","ind)");
    EXPECT_NE(message().find("no dataset.json (not a dataset directory)"), std::string::npos)
        << message();
    // A manifest with only a torn line: no complete record yet.
    spit(t.path() / "dataset.json", R"({"name":"d"})");
    EXPECT_NE(message().find("no complete record"), std::string::npos) << message();
    // A malformed line that is not the last one.
    spit(t.path() / "manifest.jsonl", "{oops\n{\"id\":\"a\",\"index\":0,\"species\":\"a\"}\n");
    EXPECT_NE(message().find("manifest.jsonl:1: not a manifest record"), std::string::npos)
        << message();
    EXPECT_FALSE(fs::exists(t.path() / "stats"));
}

// --- comparison with a reference (sylva stats --reference) -----------------------------------

QuantileTable uniformTable(double lo, double hi, int steps = 50) {
    QuantileTable t;
    for (int k = 0; k <= steps; ++k) {
        t.p.push_back(static_cast<double>(k) / steps);
        t.q.push_back(lo + (hi - lo) * k / steps);
    }
    return t;
}

TEST(ReferenceStats, QuantileTableCdfIsPiecewiseLinearWithJumpsAtRepeatedQuantiles) {
    const QuantileTable t{{0, 0.5, 1}, {0, 1, 3}};
    EXPECT_EQ(quantileTableCdf(t, -1), 0);
    EXPECT_EQ(quantileTableCdf(t, 0), 0);
    EXPECT_DOUBLE_EQ(quantileTableCdf(t, 0.5), 0.25);
    EXPECT_DOUBLE_EQ(quantileTableCdf(t, 1), 0.5);
    EXPECT_DOUBLE_EQ(quantileTableCdf(t, 2), 0.75);
    EXPECT_EQ(quantileTableCdf(t, 3), 1);
    EXPECT_EQ(quantileTableCdf(t, 9), 1);
    EXPECT_DOUBLE_EQ(quantileTableQuantile(t, 0.25), 0.5);
    EXPECT_DOUBLE_EQ(quantileTableQuantile(t, 0.75), 2);
    EXPECT_EQ(quantileTableQuantile(t, 1), 3);
    // Half the mass at 1: F jumps from 0 to 0.5 there (right-continuous), then rises to 1 at 2.
    const QuantileTable mass{{0, 0.5, 1}, {1, 1, 2}};
    EXPECT_EQ(quantileTableCdf(mass, 1, true), 0);
    EXPECT_EQ(quantileTableCdf(mass, 1), 0.5);
    EXPECT_DOUBLE_EQ(quantileTableCdf(mass, 1.5), 0.75);
    EXPECT_DOUBLE_EQ(quantileTableCdf(mass, 1.5, true), 0.75);
    EXPECT_EQ(quantileTableCdf(mass, 2, true), 1);
    // A sample's table: p_i = i/(n−1); one value is a jump from 0 to 1.
    const QuantileTable s = sampleTable({1, 2, 2, 5});
    EXPECT_EQ(s.p, (std::vector<double>{0, 1.0 / 3, 2.0 / 3, 1}));
    EXPECT_DOUBLE_EQ(quantileTableQuantile(s, 0.5), 2);  // = quantileType7
    const QuantileTable one = sampleTable({4});
    EXPECT_EQ(quantileTableCdf(one, 4, true), 0);
    EXPECT_EQ(quantileTableCdf(one, 4), 1);
}

TEST(ReferenceStats, KsDistanceToAQuantileTableByHand) {
    // (A shipped table against its own quantiles, D = 0: EveryShippedTreeqsmTable, below.)
    // Uniform on [0.2, 1.2] against uniform on [0, 1]: F_ref − F = 0.2 on [0.2, 1].
    const QuantileTable u = uniformTable(0, 1);
    std::vector<double> shifted;
    for (int i = 0; i <= 100; ++i) shifted.push_back(0.2 + i / 100.0);
    EXPECT_NEAR(ksDistance(sampleTable(shifted), u), 0.2, 1e-12);
    EXPECT_NEAR(ksDistance(u, sampleTable(shifted)), 0.2, 1e-12);
    // One value 0.6: F jumps 0 → 1 where F_ref = 0.6, so D = max(0.6, 0.4).
    EXPECT_NEAR(ksDistance(sampleTable({0.6}), u), 0.6, 1e-12);
    // {0.25, 0.25, 0.75}: F = 0.5 + (x − 0.25) on [0.25, 0.75] (a jump of 1/2 at 0.25), so
    // F − F_ref = 0.25 there, and 0.25 just below 0.25 too.
    EXPECT_NEAR(ksDistance(sampleTable({0.25, 0.25, 0.75}), u), 0.25, 1e-12);
    // Disjoint supports: 1.
    EXPECT_EQ(ksDistance(sampleTable({2, 3}), u), 1.0);
}

// Every TreeQSM table shipped (the pooled broadleaf trees, its two halves and the temperate
// trees of Wytham Woods) reads, is named after its file and holds the eight distributions on the
// same 2 % grid over enough trees and values; radius ratios lie below TreeQSM's cap, angles in
// [0, 180]; and a sample equal to a table's quantiles (evenly spaced p) has its CDF: D = 0 (the
// exponent's tables have point masses at 0.5 and 6).
TEST(ReferenceStats, EveryShippedTreeqsmTable) {
    struct File {
        std::string stem;
        size_t trees, minTrees, minValues;  // the file's trees; per distribution, at least
    };
    const fs::path dir = fs::path(SYLVA_SOURCE_DIR) / "species" / "reference";
    for (const File& f : std::vector<File>{{"treeqsm-broadleaf", 51, 30, 800},
                                           {"treeqsm-broadleaf-fit", 26, 16, 400},
                                           {"treeqsm-broadleaf-holdout", 25, 16, 400},
                                           {"treeqsm-temperate", 21, 16, 400}}) {
        const Reference ref = readReference(dir / (f.stem + ".json"));
        EXPECT_EQ(ref.name, f.stem);
        ASSERT_EQ(ref.distributions.size(), static_cast<size_t>(kReferenceDistributions)) << f.stem;
        for (const char* name : kReferenceDistributionNames) {
            const Reference::Distribution& d = ref.distributions.at(name);
            EXPECT_EQ(d.table.p.size(), 51u) << f.stem << " " << name;  // every 2 %
            EXPECT_GE(d.trees, f.minTrees) << f.stem << " " << name;
            EXPECT_LE(d.trees, f.trees) << f.stem << " " << name;
            EXPECT_GE(d.n, f.minValues) << f.stem << " " << name;
            EXPECT_EQ(ksDistance(sampleTable(d.table.q), d.table), 0.0) << f.stem << " " << name;
        }
        EXPECT_LT(ref.distributions.at("radius_ratio").table.q.back(), kReferenceCapRatio)
            << f.stem;
        EXPECT_GE(ref.distributions.at("branch_angle_deg").table.q.front(), 0.0) << f.stem;
        EXPECT_LE(ref.distributions.at("branch_angle_deg").table.q.back(), 180.0) << f.stem;
    }
}

TEST(ReferenceStats, BadReferenceFilesAreOneLineInputErrors) {
    TempDir t;
    const fs::path f = t.path() / "ref.json";
    auto message = [&](const std::string& text) {
        spit(f, text);
        try {
            readReference(f);
        } catch (const DatasetStatsInputError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    const std::string pre = f.string() + ": ";
    const std::string ok = R"("p": [0, 0.5, 1], "q": [0, 1, 2])";
    EXPECT_EQ(message("{\"distributions\": {\"radius_ratio\": {" + ok + "}}}"), "no error");
    EXPECT_EQ(message("{oops"), pre + "not JSON");
    EXPECT_EQ(message("[]"), pre + "expected a JSON object with an object \"distributions\"");
    EXPECT_EQ(message(R"({"distributions": {}})"), pre + "\"distributions\" is empty");
    EXPECT_EQ(message("{\"distributions\": {\"radius_ratios\": {" + ok + "}}}"),
              pre +
                  "distributions.radius_ratios: unknown distribution; expected one of "
                  "radius_ratio, radius_exponent, branch_angle_deg, tip_path_ratio, "
                  "branch_length_order1, branch_length_order2, branch_length_order3, "
                  "tip_height_ratio");
    EXPECT_EQ(message(R"({"distributions": {"radius_ratio": {"p": [0, 1]}}})"),
              pre + "distributions.radius_ratio: expected an array \"q\"");
    EXPECT_EQ(message(R"({"distributions": {"radius_ratio": {"p": [0, 1], "q": [0, "x"]}}})"),
              pre + "distributions.radius_ratio.q: expected finite numbers");
    EXPECT_EQ(message(R"({"distributions": {"radius_ratio": {"p": [0, 1], "q": [0, 1, 2]}}})"),
              pre + "distributions.radius_ratio: expected as many p as q, at least two");
    EXPECT_EQ(message(R"({"distributions": {"radius_ratio": {"p": [0.1, 1], "q": [0, 1]}}})"),
              pre + "distributions.radius_ratio.p: expected 0 first and 1 last");
    EXPECT_EQ(
        message(
            R"({"distributions": {"radius_ratio": {"p": [0, 0.5, 0.5, 1], "q": [0, 1, 1, 2]}}})"),
        pre + "distributions.radius_ratio.p: expected strictly increasing probabilities");
    EXPECT_EQ(message(R"({"distributions": {"radius_ratio": {"p": [0, 0.5, 1], "q": [0, 2, 1]}}})"),
              pre + "distributions.radius_ratio.q: expected non-decreasing quantiles");
    EXPECT_EQ(message("{\"distributions\": {\"radius_ratio\": {" + ok + ", \"n\": -3}}}"),
              pre + "distributions.radius_ratio.n: expected a count (an integer >= 0)");
    fs::remove(f);
    EXPECT_EQ(message("").find(pre), 0u);  // spit recreated it empty: not JSON
    EXPECT_THROW(readReference(t.path() / "missing.json"), DatasetStatsInputError);
    EXPECT_THROW(readReference(t.path()), DatasetStatsInputError);  // a directory
}

// A trunk of 1 m forking into a continuing limb and an order-1 branch at 45° of radius
// `lateral` (the parent's radius is 0.25; radii exact in skeleton.ply's floats).
Tree forkTree(double lateral) {
    Tree t;
    test::addNode(t, -1, {0, 0, 0}, 0.25);
    test::addNode(t, 0, {0, 1, 0}, 0.25);
    test::addNode(t, 1, {0, 2, 0}, 0.2);
    test::addNode(t, 1, {0.5, 1.5, 0}, lateral, 1);
    return t;
}

TEST(ReferenceStats, SpeciesPooledOverTheirInstancesSkeletons) {
    TempDir t;
    const fs::path dir = t.path() / "ds";
    fs::create_directories(dir / "trees");
    spit(dir / "trees" / "a0.ply", skeletonPly(forkTree(0.125)));
    spit(dir / "trees" / "a1.ply", skeletonPly(forkTree(0.1875)));
    spit(
        dir / "manifest.jsonl",
        R"({"id":"a-0","index":0,"species":"a","habit":"tree","files":{"skeleton_ply":"trees/a0.ply"}})"
        "\n"
        R"({"id":"a-1","index":1,"species":"a","habit":"tree","files":{"skeleton_ply":"trees/a1.ply"}})"
        "\n"
        R"({"id":"b-0","index":2,"species":"b","stats":{"h":1}})"
        "\n");
    spit(dir / "dataset.json", R"({"name":"ds"})");
    // The reference: radius ratios uniform on [0, 1], branch angles uniform on [0°, 180°].
    const fs::path ref = t.path() / "ref.json";
    spit(ref, R"({"name": "test", "distributions": {
        "radius_ratio": {"p": [0, 1], "q": [0, 1], "n": 100},
        "branch_angle_deg": {"p": [0, 0.5, 1], "q": [0, 90, 180]}}})");
    DatasetStatsOptions o;
    o.timing = false;
    o.reference = ref;
    const DatasetStatsResult r = computeDatasetStats(dir, o);
    // a: ratios {0.5, 0.75}: F = uniform on [0.5, 0.75], so D = F_ref(0.5) = 0.5, median 0.625.
    // Angles {45, 45}: a jump from 0 to 1 at 45° where F_ref = 0.25: D = 0.75.
    const auto& ra = r.reference.at("a").at("radius_ratio");
    EXPECT_EQ(ra.instances, 2u);
    EXPECT_EQ(ra.n, 2u);
    ASSERT_TRUE(ra.d && ra.median);
    EXPECT_EQ(*ra.d, 0.5);
    EXPECT_EQ(*ra.median, 0.625);
    const auto& aa = r.reference.at("a").at("branch_angle_deg");
    EXPECT_EQ(aa.n, 2u);
    ASSERT_TRUE(aa.d);
    EXPECT_NEAR(*aa.d, 0.75, 1e-6);
    // Only the distributions the reference holds; b has no skeleton: no values, no D.
    EXPECT_EQ(r.reference.at("a").size(), 2u);
    const auto& rb = r.reference.at("b").at("radius_ratio");
    EXPECT_EQ(rb.instances, 0u);
    EXPECT_EQ(rb.n, 0u);
    EXPECT_FALSE(rb.d);
    const std::string csv = slurp(dir / "stats" / "reference.csv");
    EXPECT_EQ(csv.rfind("species,habit,distribution,instances,n,d,median,reference_n,"
                        "reference_median\n"
                        "a,tree,radius_ratio,2,2,0.5,0.625,100,0.5\n",
                        0),
              0u)
        << csv;
    EXPECT_NE(csv.find("\na,tree,branch_angle_deg,2,2,0.75"), std::string::npos) << csv;
    EXPECT_NE(csv.find("\nb,,radius_ratio,0,0,,,100,0.5\nb,,branch_angle_deg,0,0,,,0,90\n"),
              std::string::npos)
        << csv;
    const std::string json = slurp(dir / "stats" / "reference.json");
    EXPECT_NE(json.find("\"name\": \"test\""), std::string::npos);
    EXPECT_NE(r.summary.find("  a: radius_ratio 0.5 branch_angle_deg 0.75"), std::string::npos)
        << r.summary;
    EXPECT_NE(r.summary.find("  b: radius_ratio - branch_angle_deg -"), std::string::npos)
        << r.summary;

    // Bad input, before anything is written: a listed skeleton missing or malformed, no
    // skeleton listed at all, a bad reference file.
    auto message = [&](const fs::path& reference) {
        fs::remove_all(dir / "stats");
        DatasetStatsOptions bad = o;
        bad.reference = reference;
        try {
            computeDatasetStats(dir, bad);
        } catch (const DatasetStatsInputError& e) {
            EXPECT_FALSE(fs::exists(dir / "stats"));
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_EQ(message(t.path() / "none.json"),
              (t.path() / "none.json").string() + ": cannot read (No such file or directory)");
    spit(dir / "trees" / "a1.ply", "ply\nformat ascii 1.0\nend_header\n");
    EXPECT_EQ(message(ref), (dir / "trees" / "a1.ply").string() +
                                ": expected format binary_little_endian, got ascii");
    fs::remove(dir / "trees" / "a1.ply");
    EXPECT_EQ(message(ref), (dir / "trees" / "a1.ply").string() +
                                ": cannot read (No such file or directory); the manifest "
                                "lists it as skeleton_ply");
    spit(dir / "manifest.jsonl", R"({"id":"b-0","index":2,"species":"b","stats":{"h":1}})"
                                 "\n");
    EXPECT_NE(message(ref).find("the manifest lists none"), std::string::npos);
}

}  // namespace
