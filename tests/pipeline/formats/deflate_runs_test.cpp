// zlibRuns's streams, inflated by zlib (which also checks the Adler-32): every byte must come
// back, on inputs that reach each branch of the encoder — no runs, runs split across the
// 258-byte copy limit, one byte, nothing, codes that must be cut to 15 bits.
#include "pipeline/formats/deflate_runs.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <random>
#include <string>
#include <vector>

namespace sylva {
namespace {

std::vector<uint8_t> inflateAll(const std::string& z, size_t size) {
    std::vector<uint8_t> out(size + 1);
    uLongf n = static_cast<uLongf>(out.size());
    const int rc = uncompress(out.data(), &n, reinterpret_cast<const Bytef*>(z.data()),
                              static_cast<uLong>(z.size()));
    EXPECT_EQ(rc, Z_OK);
    out.resize(rc == Z_OK ? n : 0);
    return out;
}

void expectRoundTrip(const std::vector<uint8_t>& data, const char* what) {
    const std::string z = zlibRuns(data.data(), data.size());
    EXPECT_EQ(inflateAll(z, data.size()), data) << what;
}

TEST(DeflateRuns, EveryKindOfInputInflatesBack) {
    expectRoundTrip({}, "empty");
    expectRoundTrip({7}, "one byte");
    expectRoundTrip({0, 0}, "two equal bytes");
    expectRoundTrip(std::vector<uint8_t>(1 << 20, 0), "a megabyte of zeros");
    expectRoundTrip(std::vector<uint8_t>(1 << 20, 255), "a megabyte of 255");

    std::mt19937 rng(5);
    std::vector<uint8_t> noise(100000);
    for (uint8_t& b : noise) b = static_cast<uint8_t>(rng());
    expectRoundTrip(noise, "random bytes");

    // Runs of every length from 1 to 800 (around 258, 259, 260, 261, 516 …), alternating.
    std::vector<uint8_t> runs;
    for (int len = 1; len <= 800; ++len) runs.insert(runs.end(), len, len % 2 ? 200 : 3);
    expectRoundTrip(runs, "runs of 1…800");
}

// The encoder reuses its run list from call to call on a thread and gives a large one back:
// each stream must hold its own input only, around a list of more than 2^18 runs (600,000
// alternating bytes) and after it.
TEST(DeflateRuns, SuccessiveInputsOnOneThreadAreIndependent) {
    std::vector<uint8_t> alternating(600000);
    for (size_t k = 0; k < alternating.size(); ++k) alternating[k] = k % 2 ? 9 : 4;
    const std::vector<uint8_t> small = {1, 1, 1, 1, 2};
    expectRoundTrip(small, "small, first");
    expectRoundTrip(alternating, "600,000 runs");
    expectRoundTrip(small, "small, after a large list");
    expectRoundTrip(alternating, "600,000 runs again");
    const std::vector<uint8_t> rows = {5, 5, 6, 6};  // two rows of two pixels
    const std::string z = zlibRunsOfRows(rows.data(), 2, 2, 0);
    EXPECT_EQ(inflateAll(z, 6), (std::vector<uint8_t>{0, 5, 5, 0, 6, 6}));
}

// Symbol frequencies in a Fibonacci sequence make a Huffman tree as deep as there are symbols:
// 25 literal values whose counts are 2, 3, 5, 8 … 196418, each alone (no runs), with the end of
// block's count of 1, need codes of up to 24 bits before the limit cuts them to 15. (Counts from
// 1, 1 would tie with the end of block's, and ties taken leaf first make a shallower tree.)
TEST(DeflateRuns, CodesDeeperThanFifteenBitsAreLimited) {
    std::vector<uint64_t> counts = {2, 3};
    while (counts.size() < 25)
        counts.push_back(counts[counts.size() - 1] + counts[counts.size() - 2]);
    std::vector<uint8_t> data;
    // Interleave the values so that no byte repeats: a round-robin over those still owed.
    std::vector<uint64_t> owed = counts;
    for (bool any = true; any;) {
        any = false;
        for (size_t v = 0; v < owed.size(); ++v) {
            if (owed[v] == 0) continue;
            if (!data.empty() && data.back() == 10 + v) continue;
            data.push_back(static_cast<uint8_t>(10 + v));
            --owed[v];
            any = true;
        }
    }
    ASSERT_GT(data.size(), 250000u);
    expectRoundTrip(data, "Fibonacci frequencies");

    // The same values as runs of 1 to 4 bytes and, every 97th, of 259: the encoder writes a
    // run's tokens at once, so a run of three carries three of the longest (15-bit) literal
    // codes and a run of four one with a copy. The rarest values get the longest codes.
    std::vector<uint8_t> runs;
    for (size_t k = 0; k < data.size(); ++k) {
        const size_t length = k % 97 == 0 ? 259 : 1 + k % 4;
        runs.insert(runs.end(), length, data[k]);
    }
    expectRoundTrip(runs, "Fibonacci frequencies in runs of 1 to 4 and 259");
}

// The checksum is summed over runs with its reductions deferred: on megabytes of short bright
// runs (the sums grow fastest), runs across the points where it reduces, and runs longer than
// its deferral, the stream's last four bytes are zlib's own adler32 of the data.
TEST(DeflateRuns, ChecksumIsZlibsOverManyMegabytes) {
    std::mt19937 rng(11);
    std::vector<uint8_t> data;
    auto shortRuns = [&](size_t bytes) {
        for (size_t end = data.size() + bytes; data.size() < end;) {
            const size_t len = 1 + rng() % 700;
            data.insert(data.end(), len, data.size() % 2 ? 254 : 255);
        }
    };
    shortRuns(3u << 20);
    data.insert(data.end(), (1u << 20) - 1, 255);  // just under the deferral
    data.insert(data.end(), 1u << 20, 17);         // at it
    shortRuns(1u << 20);
    data.insert(data.end(), 5u << 20, 255);  // far over it
    shortRuns(2u << 20);
    const std::string z = zlibRuns(data.data(), data.size());
    uLong expected = adler32(0L, Z_NULL, 0);
    expected = adler32(expected, data.data(), static_cast<uInt>(data.size()));
    const auto* tail = reinterpret_cast<const uint8_t*>(z.data() + z.size() - 4);
    const uLong ours =
        (uLong(tail[0]) << 24) | (uLong(tail[1]) << 16) | (uLong(tail[2]) << 8) | tail[3];
    EXPECT_EQ(ours, expected);
    EXPECT_EQ(inflateAll(z, data.size()), data);
}

// Rows with a filter byte each: the PNG layout.
TEST(DeflateRuns, RowsArePrefixedByTheFilterByte) {
    const size_t w = 97, h = 31;
    std::vector<uint8_t> pixels(w * h);
    for (size_t k = 0; k < pixels.size(); ++k) pixels[k] = (k / 13) % 4 == 0 ? 255 : 0;
    std::vector<uint8_t> expected;
    for (size_t y = 0; y < h; ++y) {
        expected.push_back(0);
        expected.insert(expected.end(), pixels.begin() + y * w, pixels.begin() + (y + 1) * w);
    }
    EXPECT_EQ(inflateAll(zlibRunsOfRows(pixels.data(), w, h, 0), expected.size()), expected);
}

// The tokens are zlib's with Z_RLE: on a silhouette-like image the stream is no more than a few
// percent larger than zlib's (which may start new blocks with new codes).
TEST(DeflateRuns, AsSmallAsZlibsRunLengthStrategy) {
    const int w = 256, h = 256;
    std::vector<uint8_t> img(static_cast<size_t>(w) * h, 0);
    for (int y = 40; y < 230; ++y) {
        const int half = 10 + (y - 40) / 3 + ((y * 7) % 5);
        for (int x = 128 - half; x < 128 + half; ++x) img[static_cast<size_t>(y) * w + x] = 255;
    }
    const std::string ours = zlibRuns(img.data(), img.size());
    z_stream s{};
    ASSERT_EQ(deflateInit2(&s, 1, Z_DEFLATED, 15, 8, Z_RLE), Z_OK);
    std::vector<uint8_t> out(img.size() + 1024);
    s.next_in = img.data();
    s.avail_in = static_cast<uInt>(img.size());
    s.next_out = out.data();
    s.avail_out = static_cast<uInt>(out.size());
    ASSERT_EQ(deflate(&s, Z_FINISH), Z_STREAM_END);
    const size_t zlibSize = s.total_out;
    deflateEnd(&s);
    EXPECT_LE(ours.size(), zlibSize * 105 / 100) << ours.size() << " vs zlib " << zlibSize;
    EXPECT_EQ(inflateAll(ours, img.size()), img);
}

}  // namespace
}  // namespace sylva
