// Scans through the real binary (issue 17): bad [scan] tables in a dataset — negative pulse
// rate, a station below the terrain, a zero field of view, an unknown format, a TLS key on an
// ALS scan — exit 2 with one line naming file:line:col and the key, and write nothing; scans of
// trees and of a plot give byte-identical files on 1 and 2 threads and as two shards, and the
// LAS, PLY and manifest agree on the point count. Each bad fixture in
// tests/data/scan/bad_datasets/ states its error in `# expect:` and `# line:` comments.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::CliResult;
using sylva::test::describeRun;
using sylva::test::runSylva;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kScanData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data" / "scan";

std::vector<std::string> badFixtures() {
    return sylva::test::tomlFiles(kScanData / "bad_datasets");
}

class ScanBadDataset : public ::testing::TestWithParam<std::string> {};

TEST_P(ScanBadDataset, OneLineErrorExitTwoAndNothingWritten) {
    sylva::test::expectBadSpecFixture(kScanData / "bad_datasets" / GetParam());
}

INSTANTIATE_TEST_SUITE_P(Cli, ScanBadDataset, ::testing::ValuesIn(badFixtures()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                             return sylva::test::identifier(fs::path(info.param).stem().string());
                         });

// The kinds of bad scanner spec issue 17 names each have a fixture.
TEST(ScanBadDatasets, FixturesCoverTheIssuesErrors) {
    const std::vector<std::string> names = badFixtures();
    for (const char* want :
         {"negative_pulse_rate.toml", "station_below_terrain.toml", "zero_field_of_view.toml"}) {
        EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
    }
}

// Every regular file under `dir` but the run log and lock, by relative path.
std::map<std::string, std::string> filesUnder(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (!e.is_regular_file()) continue;
        const std::string rel = e.path().lexically_relative(dir).generic_string();
        if (rel == "runs.jsonl" || rel == "manifest.jsonl" || rel == "dataset.json" ||
            rel.rfind("stats/", 0) == 0) {
            continue;
        }
        files[rel] = slurp(e.path());
    }
    return files;
}

std::vector<nlohmann::json> manifest(const fs::path& file) {
    std::vector<nlohmann::json> out;
    std::istringstream in(slurp(file));
    for (std::string line; std::getline(in, line);) {
        nlohmann::json j = nlohmann::json::parse(line);
        j.erase("timing");
        out.push_back(j);
    }
    return out;
}

uint64_t lasPointCount(const std::string& bytes) {
    uint64_t n = 0;
    if (bytes.size() >= 255) std::memcpy(&n, bytes.data() + 247, 8);
    return n;
}

// Where a LAS file's records start, their length, and the coordinates' scale and offset.
struct LasLayout {
    uint32_t first = 0;
    uint16_t length = 0;
    double scale[3] = {}, offset[3] = {};
};
LasLayout lasLayout(const std::string& las) {
    LasLayout l;
    std::memcpy(&l.first, las.data() + 96, 4);
    std::memcpy(&l.length, las.data() + 105, 2);
    std::memcpy(l.scale, las.data() + 131, 24);
    std::memcpy(l.offset, las.data() + 155, 24);
    return l;
}

// Builds `spec` (one instance) into t/out: its manifest records and its scan.las.
void buildOneScan(const fs::path& spec, const TempDir& t, std::vector<nlohmann::json>& recs,
                  std::string& las) {
    const CliResult r = runSylva({"build", spec.string(), "--out", (t / "out").string()}, t.path());
    ASSERT_EQ(r.code, 0) << describeRun(r);
    recs = manifest(t / "out" / "manifest.jsonl");
    ASSERT_EQ(recs.size(), 1u);
    las = slurp(t / "out" / recs[0]["files"]["scan_las"].get<std::string>());
    ASSERT_GE(las.size(), 375u);
}

void expectSameScans(const fs::path& spec) {
    TempDir t;
    const fs::path one = t / "one", two = t / "two", shards = t / "shards";
    for (const auto& args : std::vector<std::vector<std::string>>{
             {"build", spec.string(), "--out", one.string(), "--threads", "1"},
             {"build", spec.string(), "--out", two.string(), "--threads", "2"},
             {"build", spec.string(), "--out", shards.string(), "--shard", "0/2"},
             {"build", spec.string(), "--out", shards.string(), "--shard", "1/2"}}) {
        const CliResult r = runSylva(args, t.path());
        ASSERT_EQ(r.code, 0) << describeRun(r);
    }
    const auto a = filesUnder(one), b = filesUnder(two);
    ASSERT_FALSE(a.empty());
    EXPECT_EQ(a.size(), b.size());
    for (const auto& [name, bytes] : a) {
        ASSERT_TRUE(b.count(name)) << name;
        EXPECT_TRUE(bytes == b.at(name)) << name << " differs between 1 and 2 threads";
    }
    for (const auto& [name, bytes] : filesUnder(shards)) {
        if (name.rfind("manifest.shard-", 0) == 0 || name.rfind("dataset.shard-", 0) == 0 ||
            name.rfind("runs.shard-", 0) == 0) {
            continue;  // the shards' own records
        }
        ASSERT_TRUE(a.count(name)) << name;
        EXPECT_TRUE(bytes == a.at(name)) << name << " differs between a shard and the whole";
    }
    EXPECT_EQ(manifest(one / "manifest.jsonl"), manifest(two / "manifest.jsonl"));

    // The point counts agree: manifest, LAS header, ForestFormer3D PLY header.
    int scans = 0;
    for (const nlohmann::json& rec : manifest(one / "manifest.jsonl")) {
        ASSERT_TRUE(rec.contains("scan")) << rec["id"];
        const uint64_t points = rec["scan"]["points"].get<uint64_t>();
        EXPECT_GT(points, 0u) << rec["id"];
        const std::string las = slurp(one / rec["files"]["scan_las"].get<std::string>());
        EXPECT_EQ(las.compare(0, 4, "LASF"), 0);
        EXPECT_EQ(lasPointCount(las), points) << rec["id"];
        if (rec["files"].contains("scan_laz")) {  // tls_trees.toml: as checked by test-scan-readers
            const std::string laz = slurp(one / rec["files"]["scan_laz"].get<std::string>());
            EXPECT_EQ(laz.compare(0, 4, "LASF"), 0);
            EXPECT_EQ(lasPointCount(laz), points) << rec["id"];
        }
        const std::string ply =
            slurp(one / rec["files"]["scan_forestformer_ply"].get<std::string>());
        EXPECT_NE(ply.find("element vertex " + std::to_string(points) + "\n"), std::string::npos);
        const double hit = rec["scan"]["wood_surface_hit_mean"].get<double>();
        EXPECT_GT(hit, 0.0) << rec["id"];
        EXPECT_LT(hit, 1.0) << rec["id"];
        ++scans;
    }
    EXPECT_GT(scans, 0);
}

TEST(CliScan, TreesScanTheSameOnOneAndTwoThreadsAndAsShards) {
    expectSameScans(kScanData / "tls_trees.toml");
}

TEST(CliScan, PlotScansTheSameOnOneAndTwoThreadsAndAsShards) {
    expectSameScans(kScanData / "uls_plot.toml");
}

// The ULS plot's points_per_m2 is over its 20 m x 20 m area: the points above it (LAS survey
// frame x east, y north = scene −z), not those of the 2 m margin, over 400 m².
TEST(CliScan, PlotDensityCountsThePointsAboveTheArea) {
    TempDir t;
    std::vector<nlohmann::json> recs;
    std::string las;
    ASSERT_NO_FATAL_FAILURE(buildOneScan(kScanData / "uls_plot.toml", t, recs, las));
    const LasLayout L = lasLayout(las);
    const uint32_t first = L.first;
    const uint16_t length = L.length;
    const double *scale = L.scale, *offset = L.offset;
    const uint64_t n = lasPointCount(las);
    ASSERT_EQ(las.size(), first + n * length);
    uint64_t inside = 0, nearEdge = 0;  // within 1 mm of the edge: either side after rounding
    for (uint64_t i = 0; i < n; ++i) {
        int32_t xy[2];
        std::memcpy(xy, las.data() + first + i * length, 8);
        const double x = xy[0] * scale[0] + offset[0], y = xy[1] * scale[1] + offset[1];
        const double m = std::max(std::abs(x), std::abs(y));
        if (m <= 10.0 - 0.001)
            ++inside;
        else if (m <= 10.0 + 0.001)
            ++nearEdge;
    }
    const double density = recs[0]["scan"]["points_per_m2"].get<double>();
    EXPECT_LT(inside + nearEdge, n) << "the margin has points";
    EXPECT_GE(density, inside / 400.0 - 1e-9);
    EXPECT_LE(density, (inside + nearEdge) / 400.0 + 1e-9);
}

// [scan] las_classes = "asprs": the classification byte holds ASPRS's classes — the tree's points
// (wood and leaves, semantic_seg 2 and 3) high vegetation 5, the terrain (semantic 1) ground 2.
TEST(CliScan, AsprsClassesNameTheTreeHighVegetation) {
    TempDir t;
    std::vector<nlohmann::json> recs;
    std::string las;
    ASSERT_NO_FATAL_FAILURE(
        buildOneScan(kScanData.parent_path() / "keys" / "scan-las-classes.toml", t, recs, las));
    const LasLayout L = lasLayout(las);
    const uint32_t first = L.first;
    const uint16_t length = L.length;
    ASSERT_EQ(length, 49);
    const uint64_t n = lasPointCount(las);
    std::map<int, int> byClass;
    for (uint64_t i = 0; i < n; ++i) {
        const uint8_t cls = static_cast<uint8_t>(las[first + i * length + 16]);
        const uint8_t semantic = static_cast<uint8_t>(las[first + i * length + 36]);
        EXPECT_EQ(cls, semantic == 1 ? 2 : 5) << "point " << i << " semantic " << int(semantic);
        ++byClass[cls];
    }
    EXPECT_GT(byClass[2], 100);
    EXPECT_GT(byClass[5], 100);
}

// A scan's points go to the writers through a spool on disk: a TLS scan of 1.8 million points
// (the station looking down at the ground square, every pulse a return; 144 MB as ScanPoints,
// 83 MB of LAS) builds within 64 MiB of `sylva --help`'s peak resident size, under a 4 GiB
// address-space limit and a watchdog. Before the spool the points were held whole: 575 MB peak
// for twice this scan. The LAS holds every point the manifest counts, and the spool leaves no
// file behind.
TEST(CliScan, ALargeScanIsWrittenInBoundedMemory) {
    TempDir t;
    std::ofstream(t / "big.toml")
        << "name = \"scan-memory\"\nseed = 3\n[[species]]\nfile = '"
        << (kScanData.parent_path() / "tiny.toml").string()
        << "'\ncount = 1\n[outputs]\nskeleton = [\"ply\"]\n[scan]\nplatform = \"tls\"\n"
           "stations = [{ x = 0.0, z = 0.5, height = 1.5 }]\nhorizontal_step_deg = 0.1\n"
           "vertical_step_deg = 0.1\nhorizontal_fov_deg = 360\nvertical_fov_deg = 50\n"
           "vertical_centre_deg = -60\nsub_rays = 1\nformats = [\"las\"]\n";
    sylva::test::CliOptions o;
    o.addressSpace = rlim_t{4} << 30;
    o.watchdog = std::chrono::seconds(300);
    const std::vector<CliResult> r = sylva::test::runAllSylva(
        {{"--help"}, {"build", "big.toml", "--out", "out", "--threads", "2"}}, t.path(), o);
    ASSERT_EQ(r[0].code, 0) << describeRun(r[0]);
    ASSERT_EQ(r[1].code, 0) << describeRun(r[1]);
    EXPECT_LT(r[1].maxRssKiB, r[0].maxRssKiB + 64 * 1024) << describeRun(r[1]);
    const std::vector<nlohmann::json> recs = manifest(t / "out" / "manifest.jsonl");
    ASSERT_EQ(recs.size(), 1u);
    const uint64_t points = recs[0]["scan"]["points"].get<uint64_t>();
    EXPECT_GT(points, 1700000u);
    const fs::path las = t / "out" / recs[0]["files"]["scan_las"].get<std::string>();
    std::string header(375, '\0');
    std::ifstream(las, std::ios::binary).read(header.data(), 375);
    EXPECT_EQ(lasPointCount(header), points);
    uint32_t first = 0;  // header and VLRs, then format-6 records of 30 + 19 extra bytes
    std::memcpy(&first, header.data() + 96, 4);
    EXPECT_EQ(fs::file_size(las), first + 49 * points);
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(las.parent_path())) {
        names.push_back(e.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, (std::vector<std::string>{"qsm.csv", "qsm_treeqsm.txt", "scan.las",
                                               "scan_stations.json", "scan_trajectory.csv",
                                               "skeleton.ply"}));
}

}  // namespace
