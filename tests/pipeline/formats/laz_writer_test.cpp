// The LAZ writer against the LAS writer: sylva's LAZ decompressed by laz-perf's own reader
// (lazperf::reader::mem_file, which reads the header, the LASzip VLR and the chunk table) gives
// writeLas's records byte for byte; the header and the VLRs are the LAS file's but for the
// compression bit, the VLR count and the offset to the points; the chunk table locates every
// chunk, each decompressed on its own. The JavaScript side (laz-perf's WebAssembly build through
// the npm package `copc`) reads formula.laz in tests/js/check_scan.mjs.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <lazperf/lazperf.hpp>
#include <lazperf/readers.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "pipeline/formats/scan_writers.h"
#include "tests/pipeline/formats/formula_scan.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

using test::formulaScan;

template <typename T>
T at(const std::string& b, size_t offset) {
    T v{};
    EXPECT_LE(offset + sizeof(T), b.size());
    if (offset + sizeof(T) <= b.size()) std::memcpy(&v, b.data() + offset, sizeof(T));
    return v;
}

// Where the LAS 1.4 header keeps what LAZ changes.
constexpr size_t kPointOffsetAt = 96, kVlrCountAt = 100, kFormatAt = 104, kRecordLengthAt = 105;
constexpr size_t kPointCountAt = 247;

// Checks `laz` against `las` (the same points and options), written in chunks of `chunkPoints`.
void expectLazOfLas(const std::string& las, const std::string& laz, uint32_t chunkPoints) {
    const uint32_t lasOffset = at<uint32_t>(las, kPointOffsetAt);
    const uint8_t format = at<uint8_t>(las, kFormatAt);
    const int items = format == 7 ? 3 : 2;  // POINT14 (+ RGB14) + BYTE14
    const uint32_t lazVlrSize = 54 + 34 + 6 * items;
    const uint32_t lazOffset = at<uint32_t>(laz, kPointOffsetAt);
    ASSERT_EQ(lazOffset, lasOffset + lazVlrSize);

    // The header: the LAS header but for three fields.
    ASSERT_GE(laz.size(), lazOffset + 8u);
    EXPECT_EQ(at<uint32_t>(las, kVlrCountAt), 2u);
    EXPECT_EQ(at<uint32_t>(laz, kVlrCountAt), 3u);
    EXPECT_EQ(at<uint8_t>(laz, kFormatAt), format | 128);
    for (size_t k = 0; k < 375; ++k) {
        if (k >= kPointOffsetAt && k <= kFormatAt) continue;
        ASSERT_EQ(laz[k], las[k]) << "header byte " << k;
    }
    // The LAS file's VLRs, then the LASzip VLR.
    EXPECT_EQ(laz.substr(375, lasOffset - 375), las.substr(375, lasOffset - 375));
    const size_t v = lasOffset;
    EXPECT_EQ(laz.substr(v + 2, 16), std::string("laszip encoded\0\0", 16));
    EXPECT_EQ(at<uint16_t>(laz, v + 18), 22204);
    EXPECT_EQ(at<uint16_t>(laz, v + 20), 34 + 6 * items);
    const size_t d = v + 54;
    EXPECT_EQ(at<uint16_t>(laz, d), 3);       // compressor: layered chunked (formats 6–10)
    EXPECT_EQ(at<uint16_t>(laz, d + 2), 0);   // coder: arithmetic
    EXPECT_EQ(at<uint32_t>(laz, d + 8), 0u);  // options
    EXPECT_EQ(at<uint32_t>(laz, d + 12), chunkPoints);
    EXPECT_EQ(at<uint16_t>(laz, d + 32), items);
    std::vector<std::array<uint16_t, 3>> expectItems{{10, 30, 3}};
    if (format == 7) expectItems.push_back({11, 6, 3});
    expectItems.push_back({14, 19, 3});
    for (int k = 0; k < items; ++k) {
        for (int f = 0; f < 3; ++f) {
            EXPECT_EQ(at<uint16_t>(laz, d + 34 + 6 * k + 2 * f), expectItems[k][f])
                << "item " << k << " field " << f;
        }
    }

    // Every record, decompressed by laz-perf's reader, is the LAS record.
    const uint64_t n = at<uint64_t>(las, kPointCountAt);
    const uint16_t length = at<uint16_t>(las, kRecordLengthAt);
    ASSERT_EQ(las.size(), lasOffset + n * length);
    std::string copy = laz;
    lazperf::reader::mem_file reader(copy.data(), copy.size());
    ASSERT_EQ(reader.pointCount(), n);
    EXPECT_EQ(reader.header().point_format_id, format);
    EXPECT_EQ(reader.header().point_record_length, length);
    EXPECT_EQ(reader.lazVlr().chunk_size, chunkPoints);
    std::vector<char> record(length);
    for (uint64_t i = 0; i < n; ++i) {
        reader.readPoint(record.data());
        ASSERT_EQ(std::string(record.data(), length), las.substr(lasOffset + i * length, length))
            << "record " << i;
    }

    // The chunk table, behind the last chunk: version 0, the chunk count, the chunks' sizes;
    // each chunk, started where the sizes say, decompresses on its own to its records.
    const uint64_t table = at<uint64_t>(laz, lazOffset);
    const uint64_t chunks = (n + chunkPoints - 1) / chunkPoints;
    ASSERT_LE(table + 8, laz.size());
    EXPECT_EQ(at<uint32_t>(laz, table), 0u);
    ASSERT_EQ(at<uint32_t>(laz, table + 4), chunks);
    if (chunks == 0) {  // no entries (as LASzip writes an empty file)
        EXPECT_EQ(laz.size(), table + 8);
        return;
    }
    size_t cursor = table + 8;
    const std::vector<uint32_t> sizes = lazperf::decompress_chunk_table(
        [&](unsigned char* b, size_t len) {
            ASSERT_LE(cursor + len, laz.size());
            std::memcpy(b, laz.data() + cursor, len);
            cursor += len;
        },
        chunks);
    ASSERT_EQ(sizes.size(), chunks);
    uint64_t start = lazOffset + 8;
    for (uint64_t c = 0; c < chunks; ++c) {
        lazperf::reader::chunk_decompressor chunk(format, 19, laz.data() + start);
        const uint64_t first = c * chunkPoints, last = std::min(n, first + chunkPoints);
        for (uint64_t i = first; i < last; ++i) {
            chunk.decompress(record.data());
            ASSERT_EQ(std::string(record.data(), length),
                      las.substr(lasOffset + i * length, length))
                << "chunk " << c << " record " << i;
        }
        start += sizes[c];
    }
    EXPECT_EQ(start, table) << "the chunks end where the table starts";
}

TEST(LazWriter, DecompressesToTheLasRecordsFormat6And7) {
    const ScanResult scan = formulaScan(300);
    LasOptions options;
    options.gpsStart = 123456.5;
    options.lazChunkPoints = 64;  // 4 full chunks and one of 44 points
    for (LasColour colour : {LasColour::kNone, LasColour::kClass, LasColour::kTree}) {
        SCOPED_TRACE(static_cast<int>(colour));
        options.colour = colour;
        expectLazOfLas(lasBytes(scan, options), lazBytes(scan, options), 64);
    }
    options.classes = LasClasses::kAsprs;
    expectLazOfLas(lasBytes(scan, options), lazBytes(scan, options), 64);
}

TEST(LazWriter, FileIsTheBytesAndChunksOfTheDefaultSize) {
    // 70000 points: two chunks of the default 50000, over the writer's 65536-point blocks.
    const ScanResult scan = formulaScan(70000);
    test::TempDir dir;
    writeLaz(dir.path() / "a.laz", scan);
    const std::string laz = test::slurp(dir.path() / "a.laz");
    EXPECT_EQ(laz, lazBytes(scan));
    expectLazOfLas(lasBytes(scan), laz, 50000);
    EXPECT_LT(laz.size() * 3, lasBytes(scan).size()) << "compressed to under a third";
    for (const auto& e : fs::directory_iterator(dir.path())) {
        EXPECT_EQ(e.path().filename(), "a.laz") << "no temp file left";
    }
}

TEST(LazWriter, EmptyScanHasAnEmptyChunkTable) {
    const ScanResult empty;
    const std::string laz = lazBytes(empty);
    expectLazOfLas(lasBytes(empty), laz, 50000);
    const uint32_t offset = at<uint32_t>(laz, kPointOffsetAt);
    EXPECT_EQ(laz.size(), offset + 8 + 8u) << "offset, version, zero chunks";
}

TEST(LazWriter, RejectsZeroChunkSizeAndBadPointsWritingNothing) {
    LasOptions options;
    options.lazChunkPoints = 0;
    EXPECT_THROW(lazBytes(formulaScan(3), options), std::invalid_argument);
    ScanResult bad = formulaScan(3);
    bad.points[1].returnNumber = 0;
    test::TempDir dir;
    EXPECT_THROW(writeLaz(dir.path() / "sub" / "bad.laz", bad), std::invalid_argument);
    EXPECT_FALSE(fs::exists(dir.path() / "sub"));
}

}  // namespace
}  // namespace sylva
