// The scan writers: LAS 1.4 (header, VLRs, records, extra bytes) decoded byte by byte against
// the specification's offsets, the ForestFormer3D PLY, TreeLearn's .npy, the trajectory and
// stations; and ScanOutputs.WritesFilesForReaders, the files the independent readers check
// (ctest scan_readers: tests/js/check_scan.mjs with the npm package `copc`,
// tests/python/test_scan_outputs.py with numpy).
#include "pipeline/formats/scan_writers.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <stdexcept>

#include "pipeline/formats/qsm_writer.h"
#include "species/spec/species.h"
#include "tests/pipeline/formats/formula_scan.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;
using test::formulaScan;

// Whether two byte strings are equal, naming the first difference (gtest's EXPECT_EQ would diff
// megabytes of binary line by line, quadratic in memory).
::testing::AssertionResult sameBytes(const std::string& a, const std::string& b) {
    if (a == b) return ::testing::AssertionSuccess();
    size_t k = 0;
    while (k < a.size() && k < b.size() && a[k] == b[k]) ++k;
    return ::testing::AssertionFailure()
           << "sizes " << a.size() << " and " << b.size() << ", first difference at byte " << k;
}

// Little-endian reads at byte offsets.
template <typename T>
T at(const std::string& b, size_t offset) {
    T v;
    EXPECT_LE(offset + sizeof(T), b.size());
    std::memcpy(&v, b.data() + offset, sizeof(T));  // the test host is little-endian (x86-64)
    return v;
}
std::string text(const std::string& b, size_t offset, size_t n) {
    std::string s = b.substr(offset, n);
    return s.substr(0, s.find('\0'));
}

constexpr size_t kWktVlrSize = 54;  // + the WKT and its NUL
size_t pointOffset() { return 375 + kWktVlrSize + std::strlen(kLasWkt) + 1 + 54 + 8 * 192; }

TEST(LasWriter, HeaderFieldsSitAtTheSpecificationsOffsets) {
    const ScanResult scan = formulaScan(300);
    const std::string b = lasBytes(scan);
    ASSERT_EQ(b.size(), pointOffset() + 300 * 49);
    EXPECT_EQ(b.substr(0, 4), "LASF");
    EXPECT_EQ(at<uint16_t>(b, 4), 0);   // file source ID
    EXPECT_EQ(at<uint16_t>(b, 6), 17);  // adjusted standard GPS time | WKT
    EXPECT_EQ(at<uint8_t>(b, 24), 1);   // version 1.4
    EXPECT_EQ(at<uint8_t>(b, 25), 4);
    EXPECT_EQ(text(b, 26, 32), "SIMULATION");
    EXPECT_EQ(text(b, 58, 32).rfind("sylva ", 0), 0u);
    EXPECT_EQ(at<uint16_t>(b, 90), 257);  // 2011-09-14: adjusted GPS time 0
    EXPECT_EQ(at<uint16_t>(b, 92), 2011);
    EXPECT_EQ(at<uint16_t>(b, 94), 375);
    EXPECT_EQ(at<uint32_t>(b, 96), pointOffset());
    EXPECT_EQ(at<uint32_t>(b, 100), 2u);  // VLRs
    EXPECT_EQ(at<uint8_t>(b, 104), 6);    // point format
    EXPECT_EQ(at<uint16_t>(b, 105), 49);  // 30 + 19 extra bytes
    EXPECT_EQ(at<uint32_t>(b, 107), 0u);  // legacy count: 0 for formats ≥ 6
    for (int k = 0; k < 5; ++k) EXPECT_EQ(at<uint32_t>(b, 111 + 4 * k), 0u);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(at<double>(b, 131 + 8 * a), 0.001);
    // Survey frame: x = x, y = −z, z = y. Offsets floor(min); bounds of the stored values.
    const double hi[3] = {-12.5 + 0.0731 * 299, -7.25 + 0.0517 * 299, -1.0 + 0.043 * 299};
    EXPECT_EQ(at<double>(b, 155), -13.0);
    EXPECT_EQ(at<double>(b, 163), -8.0);
    EXPECT_EQ(at<double>(b, 171), -1.0);
    const double minX = at<double>(b, 187), maxX = at<double>(b, 179);
    const double minY = at<double>(b, 203), maxY = at<double>(b, 195);
    const double minZ = at<double>(b, 219), maxZ = at<double>(b, 211);
    EXPECT_NEAR(minX, -12.5, 5e-4);
    EXPECT_NEAR(maxX, hi[0], 5e-4);
    EXPECT_NEAR(minY, -7.25, 5e-4);
    EXPECT_NEAR(maxY, hi[1], 5e-4);
    EXPECT_NEAR(minZ, -1.0, 5e-4);
    EXPECT_NEAR(maxZ, hi[2], 5e-4);
    EXPECT_EQ(at<uint64_t>(b, 227), 0u);  // waveform packets
    EXPECT_EQ(at<uint64_t>(b, 235), 0u);  // first EVLR
    EXPECT_EQ(at<uint32_t>(b, 243), 0u);  // EVLRs
    EXPECT_EQ(at<uint64_t>(b, 247), 300u);
    uint64_t byReturn[15] = {};
    for (const ScanPoint& p : scan.points) ++byReturn[p.returnNumber - 1];
    for (int k = 0; k < 15; ++k) {
        EXPECT_EQ(at<uint64_t>(b, 255 + 8 * k), byReturn[k]) << "return " << k + 1;
        EXPECT_GT(byReturn[k], 0u) << "the formula covers every return number";
    }
}

TEST(LasWriter, VlrsHoldTheWktAndTheExtraBytesDescriptors) {
    const ScanResult scan = formulaScan(300);
    const std::string b = lasBytes(scan);
    size_t o = 375;
    EXPECT_EQ(at<uint16_t>(b, o), 0);
    EXPECT_EQ(text(b, o + 2, 16), "LASF_Projection");
    EXPECT_EQ(at<uint16_t>(b, o + 18), 2112);
    const size_t wktSize = at<uint16_t>(b, o + 20);
    EXPECT_EQ(wktSize, std::strlen(kLasWkt) + 1);
    EXPECT_EQ(b.substr(o + 54, wktSize), std::string(kLasWkt) + '\0');
    o += 54 + wktSize;
    EXPECT_EQ(text(b, o + 2, 16), "LASF_Spec");
    EXPECT_EQ(at<uint16_t>(b, o + 18), 4);
    EXPECT_EQ(at<uint16_t>(b, o + 20), 8 * 192);
    o += 54;
    const char* names[8] = {"treeID",       "treeSP",  "semantic_seg", "hitObjectId",
                            "branch_order", "node_id", "elevation",    "label_purity"};
    const uint8_t types[8] = {6, 3, 1, 6, 1, 6, 4, 1};  // i32, u16, u8, i32, u8, i32, i16, u8
    // Known minima and maxima of the formula over i = 0 … 299 (the unscaled fields).
    const int64_t mins[6] = {0, 0, 0, 0, 0, -1}, maxs[6] = {5, 999, 3, 990, 3, 7};
    int total = 0;
    for (int k = 0; k < 8; ++k, o += 192) {
        EXPECT_EQ(at<uint16_t>(b, o), 0);
        EXPECT_EQ(at<uint8_t>(b, o + 2), types[k]) << names[k];
        EXPECT_EQ(text(b, o + 4, 32), names[k]);
        // (no_data) min max for the labels; scale alone for elevation and purity.
        EXPECT_EQ(at<uint8_t>(b, o + 3), k == 5 ? 7 : k < 6 ? 6 : 8) << names[k];
        if (k == 5) {
            EXPECT_EQ(at<int64_t>(b, o + 40), -1);
        }
        EXPECT_EQ(at<int64_t>(b, o + 64), k < 6 ? mins[k] : 0) << names[k];
        EXPECT_EQ(at<int64_t>(b, o + 88), k < 6 ? maxs[k] : 0) << names[k];
        EXPECT_EQ(at<double>(b, o + 112), k < 6 ? 0.0 : 0.01) << names[k];  // scale
        EXPECT_EQ(at<double>(b, o + 136), 0.0);                             // no offset
        EXPECT_FALSE(text(b, o + 160, 32).empty());
        total += kLasExtraBytes[k].size;
    }
    EXPECT_EQ(total, kLasExtraBytesSize);
    EXPECT_EQ(o, pointOffset());
}

TEST(LasWriter, RecordsDecodeToThePoints) {
    const ScanResult scan = formulaScan(300);
    LasOptions options;
    options.gpsStart = 123456.5;
    const std::string b = lasBytes(scan, options);
    const double off[3] = {-13, -8, -1};
    for (int i = 0; i < 300; ++i) {
        const ScanPoint& p = scan.points[i];
        const size_t o = pointOffset() + 49 * size_t(i);
        const Vec3 q = surveyFrame(p.x, p.y, p.z);
        for (int a = 0; a < 3; ++a) {
            EXPECT_NEAR(at<int32_t>(b, o + 4 * a) * 0.001 + off[a], q[a], 0.0005 + 1e-12);
        }
        EXPECT_EQ(at<uint16_t>(b, o + 12), p.intensity);
        EXPECT_EQ(at<uint8_t>(b, o + 14) & 15, p.returnNumber);
        EXPECT_EQ(at<uint8_t>(b, o + 14) >> 4, p.numberOfReturns);
        const uint8_t flags = at<uint8_t>(b, o + 15);
        EXPECT_EQ(flags & 15, 0);
        EXPECT_EQ((flags >> 4) & 3, p.channel);
        EXPECT_EQ((flags >> 6) & 1, p.scanDirection ? 1 : 0);
        EXPECT_EQ(flags >> 7, p.edgeOfFlightLine ? 1 : 0);
        EXPECT_EQ(at<uint8_t>(b, o + 16), p.classification);
        EXPECT_EQ(at<uint8_t>(b, o + 17), p.label.part);
        EXPECT_NEAR(at<int16_t>(b, o + 18) * 0.006, p.scanAngleDeg, 0.003 + 1e-6);
        EXPECT_EQ(at<uint16_t>(b, o + 20), p.sourceId);
        EXPECT_EQ(at<double>(b, o + 22), 123456.5 + p.gpsTime);
        EXPECT_EQ(at<int32_t>(b, o + 30), p.label.treeId);
        EXPECT_EQ(at<uint16_t>(b, o + 34), p.label.species);
        EXPECT_EQ(at<uint8_t>(b, o + 36), p.semantic);
        EXPECT_EQ(at<int32_t>(b, o + 37), p.label.objectId);
        EXPECT_EQ(at<uint8_t>(b, o + 41), p.label.branchOrder);
        EXPECT_EQ(at<int32_t>(b, o + 42), p.label.nodeId);
        EXPECT_NEAR(at<int16_t>(b, o + 46) * 0.01, p.elevationDeg, 0.005 + 1e-6);
        EXPECT_NEAR(at<uint8_t>(b, o + 48) * 0.01, p.labelPurity, 0.005 + 1e-6);
    }
}

TEST(LasWriter, AsprsClassesReplaceTheForInstanceCodesOnRequest) {
    // FOR-instance 0 … 6 → ASPRS unclassified 1, low vegetation 3, ground 2, unclassified 1,
    // and high vegetation 5 for stem, live and woody branches; nothing else changes.
    const uint8_t asprs[7] = {1, 3, 2, 1, 5, 5, 5};
    const ScanResult scan = formulaScan(70);
    LasOptions options;
    const std::string plain = lasBytes(scan, options);
    options.classes = LasClasses::kAsprs;
    const std::string b = lasBytes(scan, options);
    ASSERT_EQ(b.size(), plain.size());
    for (int i = 0; i < 70; ++i) {
        const size_t o = pointOffset() + 49 * size_t(i);
        EXPECT_EQ(at<uint8_t>(b, o + 16), asprs[scan.points[i].classification]) << i;
        EXPECT_EQ(at<uint8_t>(plain, o + 16), scan.points[i].classification) << i;
        EXPECT_EQ(at<uint8_t>(b, o + 36), scan.points[i].semantic);  // wood / leaf kept
    }
    std::string a = b, p = plain;
    for (int i = 0; i < 70; ++i)
        a[pointOffset() + 49 * size_t(i) + 16] = p[pointOffset() + 49 * size_t(i) + 16] = 0;
    EXPECT_EQ(a, p);
}

TEST(LasWriter, Format7ColoursPointsByClassOrTree) {
    const ScanResult scan = formulaScan(50);
    LasOptions options;
    options.colour = LasColour::kClass;
    const std::string b = lasBytes(scan, options);
    EXPECT_EQ(at<uint8_t>(b, 104), 7);
    EXPECT_EQ(at<uint16_t>(b, 105), 55);
    ASSERT_EQ(b.size(), pointOffset() + 50 * 55);
    for (int i = 0; i < 50; ++i) {
        const size_t o = pointOffset() + 55 * size_t(i);
        const auto c = lasClassColour(scan.points[i].classification);
        for (int k = 0; k < 3; ++k) EXPECT_EQ(at<uint16_t>(b, o + 30 + 2 * k), c[k] * 257);
        EXPECT_EQ(at<int32_t>(b, o + 36), scan.points[i].label.treeId);  // extras after RGB
    }
    EXPECT_EQ(lasClassColour(kForStem), (std::array<uint8_t, 3>{139, 69, 19}));
    EXPECT_EQ(lasTreeColour(0), (std::array<uint8_t, 3>{128, 128, 128}));
    for (int a = 1; a < 40; ++a) {
        for (int c = a + 1; c <= 40; ++c) EXPECT_NE(lasTreeColour(a), lasTreeColour(c));
    }
    options.colour = LasColour::kTree;
    const std::string t = lasBytes(scan, options);
    const size_t o = pointOffset() + 55 * 3;  // tree 3
    EXPECT_EQ(at<uint16_t>(t, o + 30), lasTreeColour(3)[0] * 257);
}

TEST(LasWriter, EmptyScanHasZeroBoundsAndNoRanges) {
    const std::string b = lasBytes(ScanResult{});
    ASSERT_EQ(b.size(), pointOffset());
    EXPECT_EQ(at<uint64_t>(b, 247), 0u);
    for (size_t o = 155; o < 227; o += 8) EXPECT_EQ(at<double>(b, o), 0.0) << o;
    const size_t eb = 375 + kWktVlrSize + std::strlen(kLasWkt) + 1 + 54;
    for (int k = 0; k < 6; ++k) EXPECT_EQ(at<uint8_t>(b, eb + 192 * k + 3), k == 5 ? 1 : 0);
}

TEST(LasWriter, CreationDateIsTheSurveyStartsDate) {
    EXPECT_EQ(lasCreationDate(0), (std::array<uint16_t, 2>{257, 2011}));
    EXPECT_EQ(lasCreationDate(-1e9), (std::array<uint16_t, 2>{6, 1980}));  // the GPS epoch
    // 2024-01-01 and 2024-12-31 (a leap year): (days since 1970 − 3657) × 86400 − 10⁹.
    EXPECT_EQ(lasCreationDate((19723.0 - 3657) * 86400 - 1e9), (std::array<uint16_t, 2>{1, 2024}));
    EXPECT_EQ(lasCreationDate((20088.0 - 3657) * 86400 - 1e9 + 86399),
              (std::array<uint16_t, 2>{366, 2024}));
    EXPECT_THROW(lasCreationDate(-2e9), std::invalid_argument);
    EXPECT_THROW(lasCreationDate(std::nan("")), std::invalid_argument);
}

TEST(LasWriter, BadPointsThrowAndWriteNothing) {
    test::TempDir dir;
    const fs::path path = dir.path() / "out" / "scan.las";  // not even "out" may appear
    auto bad = [&](auto change) {
        ScanResult scan = formulaScan(10);
        change(scan.points[7]);
        EXPECT_THROW(writeLas(path, scan), std::invalid_argument);
        EXPECT_THROW(writeForestFormerPly(dir.path() / "out" / "scan.ply", scan),
                     std::invalid_argument);
        EXPECT_THROW(writeTreeLearnNpy(dir.path() / "out" / "scan.npy", scan),
                     std::invalid_argument);
        EXPECT_TRUE(fs::is_empty(dir.path()));
    };
    bad([](ScanPoint& p) { p.returnNumber = 0; });
    bad([](ScanPoint& p) { p.returnNumber = 3, p.numberOfReturns = 2; });
    bad([](ScanPoint& p) { p.returnNumber = 1, p.numberOfReturns = 16; });
    bad([](ScanPoint& p) { p.channel = 4; });
    bad([](ScanPoint& p) { p.x = std::numeric_limits<double>::quiet_NaN(); });
    bad([](ScanPoint& p) { p.gpsTime = std::numeric_limits<double>::infinity(); });
    // Too wide for the scale: 3000 km at 1 mm does not fit 32-bit integers.
    ScanResult wide = formulaScan(2);
    wide.points[1].x = 3e6;
    EXPECT_THROW(writeLas(path, wide), std::invalid_argument);
    LasOptions zero;
    zero.scale = 0;
    EXPECT_THROW(writeLas(path, formulaScan(2), zero), std::invalid_argument);
    EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(LasWriter, FileIsTheBytesAndStreamsAcrossBlocks) {
    // More points than one encoding block (65536): the streamed file equals the in-memory bytes
    // and the last point is where it should be.
    test::TempDir dir;
    const ScanResult scan = formulaScan(70000);
    LasOptions options;
    options.colour = LasColour::kTree;
    writeLas(dir.path() / "scan.las", scan, options);
    const std::string b = lasBytes(scan, options);
    EXPECT_TRUE(sameBytes(test::slurp(dir.path() / "scan.las"), b));
    EXPECT_EQ(at<int32_t>(b, pointOffset() + 55 * size_t(69999) + 36), 69999 % 6);
    writeLas(dir.path() / "again.las", scan, options);
    EXPECT_TRUE(sameBytes(test::slurp(dir.path() / "again.las"), b));
    writeForestFormerPly(dir.path() / "scan.ply", scan);
    EXPECT_TRUE(sameBytes(test::slurp(dir.path() / "scan.ply"), forestFormerPlyBytes(scan)));
    writeTreeLearnNpy(dir.path() / "scan.npy", scan);
    EXPECT_TRUE(sameBytes(test::slurp(dir.path() / "scan.npy"), treeLearnNpyBytes(scan)));
    for (const auto& e : fs::directory_iterator(dir.path())) {
        EXPECT_EQ(e.path().string().find(".tmp."), std::string::npos) << e.path();
    }
}

TEST(LasWriter, ASpoolOnDiskWritesTheBytesOfThePointsInMemory) {
    // The spool keeps 1,000 points in memory and the rest (69,000) in its unnamed file, handing
    // them out in blocks that do not line up with the encoder's: LAS, PLY and .npy are the bytes
    // of the same points in a ScanResult, and nothing named is left in the directory.
    test::TempDir dir;
    const ScanResult scan = formulaScan(70000);
    ScanPointSpool spool(dir.path() / "spool", 1000);
    for (size_t i = 0; i < scan.points.size(); i += 777) {
        spool.append(scan.points.data() + i, std::min<size_t>(777, scan.points.size() - i));
    }
    ASSERT_EQ(spool.size(), 70000u);
    EXPECT_EQ(spool.bytesOnDisk(), 70000u * sizeof(ScanPoint));
    LasOptions options;
    options.colour = LasColour::kClass;
    writeLas(dir.path() / "scan.las", spool, options);
    EXPECT_TRUE(sameBytes(test::slurp(dir.path() / "scan.las"), lasBytes(scan, options)));
    writeForestFormerPly(dir.path() / "scan.ply", spool);
    EXPECT_TRUE(sameBytes(test::slurp(dir.path() / "scan.ply"), forestFormerPlyBytes(scan)));
    writeTreeLearnNpy(dir.path() / "scan.npy", spool);
    EXPECT_TRUE(sameBytes(test::slurp(dir.path() / "scan.npy"), treeLearnNpyBytes(scan)));
    EXPECT_TRUE(fs::is_empty(dir.path() / "spool"));
}

TEST(LasWriter, BadPointInASpoolThrowsAndWritesNothing) {
    test::TempDir dir;
    ScanResult scan = formulaScan(5000);
    scan.points[4321].x = std::numeric_limits<double>::quiet_NaN();
    ScanPointSpool spool(dir.path(), 1000);
    spool.append(scan.points);
    try {
        writeLas(dir.path() / "scan.las", spool);
        FAIL() << "a NaN coordinate was written";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("scan point 4321"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(dir.path() / "scan.las"));
}

TEST(ForestFormerPly, HeaderAndRecordsAsTheLoaderReadsThem) {
    const ScanResult scan = formulaScan(20);
    const std::string b = forestFormerPlyBytes(scan);
    const std::string header =
        "ply\nformat binary_little_endian 1.0\nelement vertex 20\n"
        "property double x\nproperty double y\nproperty double z\n"
        "property int semantic_seg\nproperty int treeID\nend_header\n";
    ASSERT_EQ(b.substr(0, header.size()), header);
    ASSERT_EQ(b.size(), header.size() + 20 * 32);
    for (int i = 0; i < 20; ++i) {
        const ScanPoint& p = scan.points[i];
        const size_t o = header.size() + 32 * size_t(i);
        EXPECT_EQ(at<double>(b, o), p.x);
        EXPECT_EQ(at<double>(b, o + 8), -p.z);
        EXPECT_EQ(at<double>(b, o + 16), p.y);
        EXPECT_EQ(at<int32_t>(b, o + 24), p.semantic);
        EXPECT_EQ(at<int32_t>(b, o + 28), p.label.treeId);
    }
}

TEST(TreeLearnNpy, LabelsFollowTreeLearnsLoader) {
    ScanPoint p;
    p.classification = kForTerrain, p.label.treeId = 3;
    EXPECT_EQ(treeLearnLabel(p), 0);  // ground overrules a tree id, as load_data does
    p.classification = kForLowVegetation, p.label.treeId = 0;
    EXPECT_EQ(treeLearnLabel(p), 0);
    p.classification = kForStem, p.label.treeId = 7;
    EXPECT_EQ(treeLearnLabel(p), 7);
    p.classification = kForLiveBranches, p.label.treeId = 0;
    EXPECT_EQ(treeLearnLabel(p), -1);
    p.classification = kForOutPoints, p.label.treeId = 0;
    EXPECT_EQ(treeLearnLabel(p), -1);

    const ScanResult scan = formulaScan(30);
    const std::string b = treeLearnNpyBytes(scan);
    ASSERT_EQ(b.substr(0, 6), "\x93NUMPY");
    EXPECT_EQ(at<uint8_t>(b, 6), 1);
    const size_t headerLen = at<uint16_t>(b, 8);
    EXPECT_EQ((10 + headerLen) % 64, 0u);
    const std::string dict = b.substr(10, headerLen);
    EXPECT_EQ(dict.rfind("{'descr': '<f8', 'fortran_order': False, 'shape': (30, 4), }", 0), 0u);
    EXPECT_EQ(dict.back(), '\n');
    ASSERT_EQ(b.size(), 10 + headerLen + 30 * 32);
    for (int i = 0; i < 30; ++i) {
        const size_t o = 10 + headerLen + 32 * size_t(i);
        const ScanPoint& q = scan.points[i];
        EXPECT_EQ(at<double>(b, o), q.x);
        EXPECT_EQ(at<double>(b, o + 8), -q.z);
        EXPECT_EQ(at<double>(b, o + 16), q.y);
        EXPECT_EQ(at<double>(b, o + 24), treeLearnLabel(q));
    }
}

TEST(ScanTrajectory, CsvAndStationsInTheSurveyFrame) {
    const ScanResult scan = formulaScan(4);
    EXPECT_EQ(trajectoryCsv(scan, 100),
              "gps_time,x,y,z,heading_deg,channel\n"
              "100.000000,0.0000,20.0000,60.0000,90.0000,0\n"
              "100.100000,1.5000,17.7500,61.0000,90.0000,1\n"
              "100.200000,3.0000,15.5000,62.0000,90.0000,2\n");
    const nlohmann::json s = stationsJson(scan, 100);
    ASSERT_EQ(s.size(), 3u);
    EXPECT_EQ(s[1]["station"], 1);
    EXPECT_EQ(s[1]["channel"], 1);
    EXPECT_EQ(s[1]["x"], 1.5);
    EXPECT_EQ(s[1]["y"], 17.75);
    EXPECT_EQ(s[1]["z"], 61.0);
    EXPECT_DOUBLE_EQ(s[1]["gps_time"].get<double>(), 100.1);
}

// The files the independent readers check, into $SYLVA_SCAN_OUT (or a scratch directory):
// formula.las (format 6, gpsStart 123456.5), formula_rgb.las (format 7 by class), both as LAZ
// too (formula.laz, formula_rgb.laz, in chunks of 64 points),
// formula.ply, formula.npy, trajectory.csv, stations.json (300 points of formulaScan), and
// the QSM tables of a small hand-built tree (qsm.csv, qsm.txt).
TEST(ScanOutputs, WritesFilesForReaders) {
    const char* outEnv = std::getenv("SYLVA_SCAN_OUT");
    test::TempDir scratch;
    const fs::path out = outEnv ? fs::path(outEnv) : scratch.path();
    const ScanResult scan = formulaScan(300);
    LasOptions options;
    options.gpsStart = 123456.5;
    writeLas(out / "formula.las", scan, options);
    options.lazChunkPoints = 64;  // several chunks, the last one partial
    writeLaz(out / "formula.laz", scan, options);
    options.colour = LasColour::kClass;
    writeLas(out / "formula_rgb.las", scan, options);
    writeLaz(out / "formula_rgb.laz", scan, options);
    writeForestFormerPly(out / "formula.ply", scan);
    writeTreeLearnNpy(out / "formula.npy", scan);
    writeTrajectory(out / "trajectory.csv", scan, 123456.5);
    writeStations(out / "stations.json", scan, 123456.5);
    // A trunk of 4 segments with a lateral of 2 and a sub-lateral of 1, and a root.
    Tree t;
    test::addNode(t, -1, {0, 0, 0}, 0.2, 0);
    test::addNode(t, 0, {0, 1, 0}, 0.16, 0);
    test::addNode(t, 1, {0, 2, 0}, 0.12, 0);
    test::addNode(t, 2, {0, 3, 0}, 0.08, 0);
    test::addNode(t, 3, {0, 4, 0}, 0.04, 0);
    test::addNode(t, 1, {1, 1.5, 0}, 0.05, 1);
    test::addNode(t, 5, {2, 2, 0}, 0.03, 1);
    test::addNode(t, 5, {1, 1.5, -1}, 0.02, 2);
    test::addNode(t, 0, {0, -0.5, 0}, 0.1, 0, kRootPart);
    writeQsmCylinders(out / "qsm.csv", t, out / "qsm.txt");
    // For looking at (docs/scanning.md): $SYLVA_QSM_SPECIES, a species file, grown with seed 1,
    // its cylinders in species_qsm.csv.
    if (const char* species = std::getenv("SYLVA_QSM_SPECIES")) {
        writeQsmCylinders(out / "species_qsm.csv",
                          growSpecies(loadSpecies(species), 1, nullptr, true).tree);
    }
    for (const char* f :
         {"formula.las", "formula_rgb.las", "formula.laz", "formula_rgb.laz", "formula.ply",
          "formula.npy", "trajectory.csv", "stations.json", "qsm.csv", "qsm.txt"}) {
        EXPECT_TRUE(fs::is_regular_file(out / f)) << f;
    }
}

}  // namespace
}  // namespace sylva
