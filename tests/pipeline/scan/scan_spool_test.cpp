// The scan point spool: points handed back in order, whole, as often as asked, from memory and
// from its unnamed file; the file made only when the memory is full, and never visible by name.
#include "pipeline/scan/scan_spool.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <vector>

#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

ScanPoint pointNumber(uint64_t i) {
    ScanPoint p;
    p.x = 0.5 * static_cast<double>(i);
    p.y = -1.0 * static_cast<double>(i % 97);
    p.z = 3.0;
    p.pulse = i;
    p.label.nodeId = static_cast<int32_t>(i % 11) - 1;
    p.returnNumber = 1;
    p.numberOfReturns = 1;
    return p;
}

// Every point the spool hands out, checked against pointNumber in order; returns the count and
// the largest block.
std::pair<uint64_t, size_t> readBack(const ScanPointSpool& spool) {
    uint64_t next = 0;
    size_t largest = 0;
    spool.forEachBlock([&](const ScanPoint* p, size_t n) {
        largest = std::max(largest, n);
        for (size_t i = 0; i < n; ++i, ++next) {
            const ScanPoint want = pointNumber(next);
            ASSERT_EQ(p[i].pulse, want.pulse);
            ASSERT_EQ(p[i].x, want.x);
            ASSERT_EQ(p[i].y, want.y);
            ASSERT_EQ(p[i].label.nodeId, want.label.nodeId);
        }
    });
    return {next, largest};
}

TEST(ScanPointSpool, HandsBackEveryPointInOrderFromMemoryAndDisk) {
    test::TempDir dir;
    ScanPointSpool spool(dir.path() / "instance", 64);
    std::vector<ScanPoint> block;
    uint64_t n = 0;
    for (size_t size : {1, 13, 64, 0, 200, 7, 63, 1}) {  // 349 points in uneven blocks
        block.clear();
        for (size_t i = 0; i < size; ++i) block.push_back(pointNumber(n++));
        spool.append(block);
    }
    EXPECT_EQ(spool.size(), 349u);
    EXPECT_EQ(spool.bytesOnDisk(), 320u * sizeof(ScanPoint));  // 5 full blocks of 64
    for (int pass = 0; pass < 2; ++pass) {                     // as often as asked
        const auto [count, largest] = readBack(spool);
        EXPECT_EQ(count, 349u);
        EXPECT_LE(largest, 64u);  // memory stays one block
    }
    // The file has no name: the directory (made for it) is empty.
    ASSERT_TRUE(fs::is_directory(dir.path() / "instance"));
    EXPECT_TRUE(fs::is_empty(dir.path() / "instance"));
}

TEST(ScanPointSpool, ASmallScanNeverTouchesTheDisk) {
    test::TempDir dir;
    ScanPointSpool spool(dir.path() / "instance", 64);
    std::vector<ScanPoint> points;
    for (uint64_t i = 0; i < 63; ++i) points.push_back(pointNumber(i));
    spool.append(points);
    EXPECT_EQ(spool.bytesOnDisk(), 0u);
    EXPECT_EQ(readBack(spool).first, 63u);
    EXPECT_FALSE(fs::exists(dir.path() / "instance"));
}

TEST(ScanPointSpool, AnEmptySpoolHandsOutNothing) {
    test::TempDir dir;
    const ScanPointSpool spool(dir.path());
    int calls = 0;
    spool.forEachBlock([&](const ScanPoint*, size_t) { ++calls; });
    EXPECT_EQ(calls, 0);
    EXPECT_EQ(spool.size(), 0u);
}

TEST(ScanPointSpool, ADirectoryThatCannotBeMadeIsOneClearError) {
    test::TempDir dir;
    std::ofstream(dir.path() / "file") << "x";
    ScanPointSpool spool(dir.path() / "file" / "sub", 4);
    std::vector<ScanPoint> points(4, pointNumber(0));
    try {
        spool.append(points);
        FAIL() << "spilled into a path under a regular file";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("scan point spool"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("file/sub"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace sylva
