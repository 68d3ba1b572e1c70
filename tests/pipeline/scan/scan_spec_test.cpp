// Reading [scan] tables: defaults per platform, units (degrees and milliradians in the file,
// radians inside), and every bad spec in tests/data/scan/bad/ failing with one line that names
// its file:line:col and key. A fixture states what its error must say in leading comments:
// `# expect: <substring>` and `# line: <n>`.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/errors.h"
#include "pipeline/scan/scan_options.h"
#include "tests/test_support.h"

namespace fs = std::filesystem;
using namespace sylva;

namespace {

const fs::path kData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data";

}  // namespace

TEST(ScanSpec, TlsKeysInTheirUnits) {
    const ScanOptions o = loadScanSpec((kData / "scan" / "scan-tls.toml").string());
    EXPECT_EQ(o.platform, ScanPlatform::kTls);
    ASSERT_EQ(o.stations.size(), 4u);
    EXPECT_DOUBLE_EQ(o.stations[0].x, -10);
    EXPECT_DOUBLE_EQ(o.stations[1].height, 1.5);  // the default
    EXPECT_DOUBLE_EQ(o.stations[2].height, 1.3);
    EXPECT_NEAR(o.horizontalStep, 0.06 * kPi / 180, 1e-15);
    EXPECT_NEAR(o.beamDivergence, 0.35e-3, 1e-15);
    EXPECT_EQ(o.subRays, 19);
    EXPECT_EQ(o.maxReturns, 15);
    EXPECT_DOUBLE_EQ(o.reflectanceLeaf, 0.3);
}

TEST(ScanSpec, AirborneDefaultsArePerPlatform) {
    const ScanOptions u = loadScanSpec((kData / "scan" / "scan-uls.toml").string());
    EXPECT_EQ(u.platform, ScanPlatform::kUls);
    EXPECT_EQ(u.mirror, MirrorPattern::kRotating);
    EXPECT_DOUBLE_EQ(u.altitude, 60);
    EXPECT_DOUBLE_EQ(u.rangeNoise, 0.015);  // miniVUX-1UAV accuracy (not set in the file)
    EXPECT_NEAR(u.heading, kPi / 2, 1e-15);
    const ScanOptions a = loadScanSpec((kData / "scan" / "scan-als.toml").string());
    EXPECT_EQ(a.platform, ScanPlatform::kAls);
    EXPECT_DOUBLE_EQ(a.stripSpacing, 150);
    EXPECT_EQ(a.maxReturns, 4);
    EXPECT_DOUBLE_EQ(a.minSeparation, 3.5);
    EXPECT_EQ(a.maxPulses, 1000000u);
}

TEST(ScanSpec, BadSpecsFailWithOneLineAtTheirKey) {
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(kData / "scan" / "bad")) {
        if (e.path().extension() == ".toml") files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    ASSERT_GE(files.size(), 10u);
    for (const char* must :
         {"negative_pulse_rate.toml", "station_below_terrain.toml", "zero_field_of_view.toml"}) {
        EXPECT_TRUE(fs::exists(kData / "scan" / "bad" / must)) << must;
    }
    for (const fs::path& f : files) {
        SCOPED_TRACE(f.filename().string());
        const auto [expect, line] = sylva::test::fixtureComments(f);
        ASSERT_FALSE(expect.empty());
        ASSERT_GT(line, 0);
        try {
            loadScanSpec(f.string());
            ADD_FAILURE() << "accepted";
        } catch (const SpecError& e) {
            const std::string m = e.what();
            EXPECT_EQ(m.find('\n'), std::string::npos) << m;
            const std::string at = f.filename().string() + ":" + std::to_string(line) + ":";
            EXPECT_NE(m.find(at), std::string::npos) << "expected " << at << " in " << m;
            for (const std::string& x : expect) {
                EXPECT_NE(m.find(x), std::string::npos) << "expected \"" << x << "\" in " << m;
            }
        }
    }
}
