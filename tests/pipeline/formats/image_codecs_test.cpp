// sylva's own EXR encoder and the libpng encoder, checked against the reference readers
// (OpenEXR and libpng through OIIO): every pixel must come back bit for bit.
#include "pipeline/formats/image_codecs.h"

#include <Imath/half.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

void writeBytes(const fs::path& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Decodes an EXR through OIIO (OpenEXR) and checks it is one FLOAT channel `channel`,
// compressed as `compression` says.
std::vector<float> readExr(const fs::path& p, int w, int h, const std::string& channel = "Y",
                           const std::string& compression = "rle") {
    auto in = OIIO::ImageInput::open(p.string());
    EXPECT_TRUE(in) << OIIO::geterror();
    if (!in) return {};
    const OIIO::ImageSpec& spec = in->spec();
    EXPECT_EQ(spec.width, w);
    EXPECT_EQ(spec.height, h);
    EXPECT_EQ(spec.full_width, w);
    EXPECT_EQ(spec.full_height, h);
    EXPECT_EQ(spec.x, 0);
    EXPECT_EQ(spec.y, 0);
    EXPECT_EQ(spec.nchannels, 1);
    EXPECT_EQ(spec.channelnames.at(0), channel);
    EXPECT_EQ(spec.format, OIIO::TypeDesc::FLOAT);
    EXPECT_EQ(spec.get_string_attribute("compression"), compression);
    std::vector<float> back(static_cast<size_t>(w) * h);
    EXPECT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, back.data())) << in->geterror();
    return back;
}

bool sameBits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// Rows built to hit every branch of the run coder: constant rows (runs longer than the
// 128-byte cap), stretches of equal pixels of every length 1–300, literal stretches longer than
// 128 bytes, and a row of random bits that cannot shrink (stored raw).
std::vector<float> awkwardImage(int w, int h, uint32_t seed) {
    std::mt19937 rng(seed);
    std::vector<float> img(static_cast<size_t>(w) * h, 0.0f);
    for (int y = 0; y < h; ++y) {
        float* row = img.data() + static_cast<size_t>(y) * w;
        switch (y % 5) {
            case 0:  // background
                break;
            case 1: {  // runs of growing length
                int x = 0, len = 1;
                while (x < w) {
                    const float v = std::uniform_real_distribution<float>(0.5f, 30.0f)(rng);
                    for (int k = 0; k < len && x < w; ++k) row[x++] = v;
                    len = len % 300 + 1;
                }
                break;
            }
            case 2:  // random bits: incompressible (NaN payloads and infinities included)
                for (int x = 0; x < w; ++x) {
                    const uint32_t bits = rng();
                    std::memcpy(&row[x], &bits, 4);
                }
                break;
            case 3:  // a smooth depth ramp with a background margin
                for (int x = w / 5; x < w - w / 5; ++x) row[x] = 2.0f + 0.01f * x + 0.001f * y;
                break;
            default:  // special values
                for (int x = 0; x < w; ++x) {
                    const float s[] = {-0.0f, std::numeric_limits<float>::infinity(),
                                       std::numeric_limits<float>::denorm_min(), -1.5f, 1e30f};
                    row[x] = s[(x / 3) % 5];
                }
        }
    }
    return img;
}

// Each size's awkward image (seeded by `salt`) written with `compression` and read back through
// OpenEXR bit for bit, the file saying `word`.
void expectRoundTrips(const std::vector<std::pair<int, int>>& sizes, ExrCompression compression,
                      const std::string& word, uint32_t salt) {
    TempDir dir;
    for (const auto& [w, h] : sizes) {
        const std::vector<float> img = awkwardImage(w, h, static_cast<uint32_t>(w) * salt + h);
        const fs::path p =
            dir.path() / ("img_" + std::to_string(w) + "x" + std::to_string(h) + ".exr");
        writeBytes(p, encodeFloatExr(w, h, img.data(), "Y", false, compression));
        EXPECT_TRUE(sameBits(readExr(p, w, h, "Y", word), img)) << word << " " << w << "x" << h;
    }
}

TEST(ImageCodecs, ExrRoundTripsBitExactThroughOpenExr) {
    expectRoundTrips({{1, 1}, {3, 5}, {1, 7}, {257, 11}, {256, 256}, {1000, 6}},
                     ExrCompression::kRle, "rle", 131);
}

// Only +0.0 is background: rows of -0.0, and rows of +0.0 with one other value at the start, in
// the second 64 bytes or in the last (tail) pixel, are coded as pixels, each read back bit for bit
// (RLE and ZIP, 37 pixels a row: two 64-byte blocks and a 20-byte tail).
TEST(ImageCodecs, ExrBackgroundRowsAreExactlyThePositiveZeroOnes) {
    TempDir dir;
    const int w = 37, h = 6;
    std::vector<float> img(static_cast<size_t>(w) * h, 0.0f);
    for (int x = 0; x < w; ++x) img[1 * w + x] = -0.0f;
    img[2 * w + 0] = std::numeric_limits<float>::denorm_min();
    img[3 * w + 16] = -0.0f;
    img[4 * w + w - 1] = std::numeric_limits<float>::denorm_min();
    for (auto [compression, word] :
         {std::pair{ExrCompression::kRle, "rle"}, std::pair{ExrCompression::kZip, "zip"}}) {
        const fs::path p = dir.path() / (std::string(word) + ".exr");
        writeBytes(p, encodeFloatExr(w, h, img.data(), "Y", false, compression));
        EXPECT_TRUE(sameBits(readExr(p, w, h, "Y", word), img)) << word;
    }
}

TEST(ImageCodecs, ExrChannelNameAndCompressionPayOff) {
    TempDir dir;
    const int w = 256, h = 256;
    // A depth map: a disc of tree in the middle, background 0 elsewhere.
    std::vector<float> depth(static_cast<size_t>(w) * h, 0.0f);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const double r = std::hypot(x - 128.0, y - 128.0);
            if (r < 60) depth[static_cast<size_t>(y) * w + x] = static_cast<float>(10.0 + r / 30);
        }
    }
    const std::string bytes = encodeFloatExr(w, h, depth.data(), "depth");
    writeBytes(dir.path() / "d.exr", bytes);
    EXPECT_TRUE(sameBits(readExr(dir.path() / "d.exr", w, h, "depth"), depth));
    // RLE: background rows take 4 bytes per 128, so the file is far below the raw 256 KiB.
    EXPECT_LT(bytes.size(), static_cast<size_t>(w) * h * 4 / 4);
    // Incompressible rows are stored raw: exactly 4 w bytes of data per chunk.
    std::vector<float> noise(static_cast<size_t>(w) * h);
    std::mt19937 rng(7);
    for (float& v : noise) {
        const uint32_t bits = rng();
        std::memcpy(&v, &bits, 4);
    }
    const std::string raw = encodeFloatExr(w, h, noise.data(), "depth");
    // 281 header bytes for channel "depth" (8 magic and version, 272 for the eight required
    // attributes, 1 terminator), the offset table, then h chunks of (y, size, 4 w bytes).
    EXPECT_EQ(raw.size(), 281 + static_cast<size_t>(h) * 8 + static_cast<size_t>(h) * (8 + 4 * w));
    writeBytes(dir.path() / "n.exr", raw);
    EXPECT_TRUE(sameBits(readExr(dir.path() / "n.exr", w, h, "depth"), noise));
}

// depth_half: the channel is HALF. OpenEXR (through OIIO) must give back, bit for bit, each
// value rounded to half by Imath; a smooth depth map takes about half the bytes of FLOAT.
TEST(ImageCodecs, HalfExrRoundTripsAsImathsRoundingInHalfTheBytes) {
    TempDir dir;
    const int w = 301, h = 40;
    std::vector<float> img = awkwardImage(w, h, 17);
    for (float& v : img) {
        if (!std::isfinite(v) || std::abs(v) > 60000.0f) v = 7.25f;  // keep to half's range
    }
    const fs::path p = dir.path() / "h.exr";
    writeBytes(p, encodeFloatExr(w, h, img.data(), "Y", true));
    auto in = OIIO::ImageInput::open(p.string());
    ASSERT_TRUE(in) << OIIO::geterror();
    EXPECT_EQ(in->spec().format, OIIO::TypeDesc::HALF);
    EXPECT_EQ(in->spec().get_string_attribute("compression"), "rle");
    std::vector<uint16_t> back(static_cast<size_t>(w) * h);
    ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::HALF, back.data())) << in->geterror();
    size_t wrong = 0;
    for (size_t k = 0; k < img.size(); ++k) wrong += back[k] != Imath::half(img[k]).bits();
    EXPECT_EQ(wrong, 0u);

    // A depth map: a disc of smooth depths on background.
    std::vector<float> depth(256 * 256, 0.0f);
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x)
            if ((x - 128) * (x - 128) + (y - 128) * (y - 128) < 90 * 90)
                depth[y * 256 + x] = 20.0f + 0.013f * x - 0.007f * y;
    const size_t full = encodeFloatExr(256, 256, depth.data()).size();
    const size_t halfSize = encodeFloatExr(256, 256, depth.data(), "Y", true).size();
    EXPECT_LT(halfSize, full * 6 / 10) << halfSize << " vs " << full;
}

// floatsToHalves (eight at a time with F16C where the CPU has it) gives Imath's scalar
// conversion bit for bit: over every 4093rd float bit pattern (both signs, zeros, subnormals,
// every exponent, NaNs and infinities), the halves' rounding ties (odd multiples of half a
// half-ulp, at normal and subnormal scales) and the overflow threshold, at every offset of an
// 8-wide block so that NaNs land in vector and tail positions.
TEST(ImageCodecs, FloatsToHalvesIsImathsConversionBitForBit) {
    std::vector<float> in;
    for (uint64_t bits = 0; bits <= 0xffffffffull; bits += 4093) {
        float f;
        const uint32_t b = static_cast<uint32_t>(bits);
        std::memcpy(&f, &b, 4);
        in.push_back(f);
    }
    for (int e = -26; e <= 16; ++e) {
        for (int m = 0; m < 64; ++m) {
            const float tie = std::ldexp(static_cast<float>(2 * m + 1), e - 12);  // x.5 ulp
            in.push_back(tie);
            in.push_back(-tie);
            in.push_back(std::nextafter(tie, 0.0f));
            in.push_back(std::nextafter(tie, 1e30f));
        }
    }
    for (float f :
         {65504.0f, 65519.0f, 65520.0f, 65536.0f, 6.1035156e-05f, 5.9604645e-08f, 2.9802322e-08f,
          2.9802326e-08f, std::numeric_limits<float>::infinity(),
          -std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN(),
          std::numeric_limits<float>::signaling_NaN(), -0.0f, 0.0f}) {
        in.push_back(f);
    }
    for (size_t offset = 0; offset < 8; ++offset) {
        std::vector<uint16_t> out(in.size() - offset);
        floatsToHalves(in.data() + offset, out.data(), out.size());
        size_t wrong = 0;
        for (size_t k = 0; k < out.size(); ++k) {
            wrong += out[k] != imath_float_to_half(in[offset + k]);
        }
        EXPECT_EQ(wrong, 0u) << "offset " << offset << " of " << out.size();
    }
}

// ZIP: chunks of 16 lines (the last one shorter), read back bit for bit by OpenEXR (through
// OIIO) for FLOAT and HALF; incompressible chunks stored raw; a depth map in fewer bytes than
// RLE's.
TEST(ImageCodecs, ZipExrRoundTripsBitExactInSixteenLineChunks) {
    expectRoundTrips({{1, 1}, {3, 5}, {257, 16}, {256, 17}, {1000, 40}, {256, 256}},
                     ExrCompression::kZip, "zip", 7);
    TempDir dir;
    // HALF through ZIP: each value as Imath rounds it.
    const int w = 301, h = 40;
    std::vector<float> img = awkwardImage(w, h, 23);
    for (float& v : img) {
        if (!std::isfinite(v) || std::abs(v) > 60000.0f) v = 3.5f;
    }
    const fs::path p = dir.path() / "zh.exr";
    writeBytes(p, encodeFloatExr(w, h, img.data(), "Y", true, ExrCompression::kZip));
    auto in = OIIO::ImageInput::open(p.string());
    ASSERT_TRUE(in) << OIIO::geterror();
    EXPECT_EQ(in->spec().format, OIIO::TypeDesc::HALF);
    std::vector<uint16_t> back(static_cast<size_t>(w) * h);
    ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::HALF, back.data())) << in->geterror();
    size_t wrong = 0;
    for (size_t k = 0; k < img.size(); ++k) wrong += back[k] != Imath::half(img[k]).bits();
    EXPECT_EQ(wrong, 0u);

    // Noise: every chunk stored raw, 16 lines of 4 w bytes after its (y, size).
    const int nw = 64, nh = 40;
    std::vector<float> noise(static_cast<size_t>(nw) * nh);
    std::mt19937 rng(11);
    for (float& v : noise) {
        const uint32_t bits = rng();
        std::memcpy(&v, &bits, 4);
    }
    const std::string raw =
        encodeFloatExr(nw, nh, noise.data(), "depth", false, ExrCompression::kZip);
    // 281 header bytes for channel "depth", 3 offsets, chunks of 16, 16 and 8 lines.
    EXPECT_EQ(raw.size(), 281 + 3 * 8 + 3 * 8 + static_cast<size_t>(nh) * 4 * nw);
    writeBytes(dir.path() / "zn.exr", raw);
    EXPECT_TRUE(sameBits(readExr(dir.path() / "zn.exr", nw, nh, "depth", "zip"), noise));

    // A depth map (a disc of smooth depths on background, as half): ZIP below RLE.
    std::vector<float> depth(256 * 256, 0.0f);
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x)
            if ((x - 128) * (x - 128) + (y - 128) * (y - 128) < 90 * 90)
                depth[y * 256 + x] = 20.0f + 0.013f * x - 0.007f * y + 0.3f * ((x * 7 + y * 3) % 5);
    const size_t rle = encodeFloatExr(256, 256, depth.data(), "Y", true).size();
    const size_t zip =
        encodeFloatExr(256, 256, depth.data(), "Y", true, ExrCompression::kZip).size();
    EXPECT_LT(zip, rle * 8 / 10) << zip << " vs " << rle;
}

TEST(ImageCodecs, EqualPixelsGiveEqualBytes) {
    const std::vector<float> img = awkwardImage(64, 40, 3);
    EXPECT_EQ(encodeFloatExr(64, 40, img.data()), encodeFloatExr(64, 40, img.data()));
    std::vector<uint8_t> grey(64 * 40);
    for (size_t k = 0; k < grey.size(); ++k) grey[k] = static_cast<uint8_t>(k * 7 % 251);
    EXPECT_EQ(encodeGreyPng(64, 40, grey.data()), encodeGreyPng(64, 40, grey.data()));
}

TEST(ImageCodecs, PngRoundTripsThroughLibpng) {
    TempDir dir;
    std::mt19937 rng(11);
    const int sizes[][2] = {{1, 1}, {256, 256}, {1000, 3}, {3, 1000}};
    for (const auto& s : sizes) {
        const int w = s[0], h = s[1];
        std::vector<uint8_t> grey(static_cast<size_t>(w) * h);
        for (size_t k = 0; k < grey.size(); ++k) {
            // Half silhouette-like runs of 0 / 255, half random bytes.
            grey[k] =
                k < grey.size() / 2 ? ((k / 37) % 3 == 0 ? 255 : 0) : static_cast<uint8_t>(rng());
        }
        const fs::path p = dir.path() / ("g" + std::to_string(w) + ".png");
        writeBytes(p, encodeGreyPng(w, h, grey.data()));
        auto in = OIIO::ImageInput::open(p.string());
        ASSERT_TRUE(in) << OIIO::geterror();
        EXPECT_EQ(in->spec().width, w);
        EXPECT_EQ(in->spec().height, h);
        EXPECT_EQ(in->spec().nchannels, 1);
        EXPECT_EQ(in->spec().format, OIIO::TypeDesc::UINT8);
        std::vector<uint8_t> back(grey.size());
        ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT8, back.data()));
        EXPECT_EQ(back, grey) << w << "x" << h;
    }
}

TEST(ImageCodecs, NonPositiveSizesAreRejected) {
    const float f = 0.0f;
    const uint8_t b = 0;
    EXPECT_THROW(encodeFloatExr(0, 1, &f), std::invalid_argument);
    EXPECT_THROW(encodeFloatExr(1, -1, &f), std::invalid_argument);
    EXPECT_THROW(encodeFloatExr(1, 1, &f, ""), std::invalid_argument);
    EXPECT_THROW(encodeGreyPng(0, 5, &b), std::invalid_argument);
}

}  // namespace
}  // namespace sylva
