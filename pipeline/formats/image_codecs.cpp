// See image_codecs.h for the formats and why the EXR encoder is sylva's own.
#include "pipeline/formats/image_codecs.h"

#include <Imath/half.h>
#include <cpuid.h>
#include <immintrin.h>
#include <png.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <csetjmp>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "pipeline/formats/deflate_runs.h"
#include "pipeline/formats/little_endian.h"

namespace sylva {

namespace {

// zlib's level for ZIP-compressed EXRs: measured on the 288 depth maps (half, 256²) of one tree
// of each library species, levels 1 / 4 / 6 gave 125 / 117 / 117 kB a tree (RLE: 200 kB) in
// 0.68 / 0.88 / 1.39 ms a map; OpenEXR 3's own default is also 4.
constexpr int kExrZipLevel = 4;

void checkSize(int width, int height, const char* what) {
    if (width <= 0 || height <= 0) {
        throw std::invalid_argument(std::string(what) + ": image size " + std::to_string(width) +
                                    "x" + std::to_string(height) + " is not positive");
    }
}

// Floats to halves as Imath's imath_float_to_half converts them (round to nearest even, overflow
// to infinity, subnormals kept). Imath itself uses the F16C instruction when it is compiled for
// it; Debian's build is for baseline x86-64, where its scalar conversion is about ten
// instructions with branches per pixel. Measured with callgrind on 10 ez-size trees with half
// depth (80 maps at 256²): the EXR encoder 128.5 → 77.3 M instructions, 1.61 → 0.97 M a map.
// The instruction gives the same bits for every number; NaNs (whose payloads the two treat
// differently) go through Imath's conversion.
#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("avx,f16c"))) void halvesF16c(const float* in, uint16_t* out, size_t n) {
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        const __m256 v = _mm256_loadu_ps(in + i);
        if (_mm256_movemask_ps(_mm256_cmp_ps(v, v, _CMP_UNORD_Q)) != 0) {
            for (size_t k = i; k < i + 8; ++k) out[k] = imath_float_to_half(in[k]);
            continue;
        }
        const __m128i h = _mm256_cvtps_ph(v, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
        _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i), h);
    }
    for (; i < n; ++i) out[i] = imath_float_to_half(in[i]);
}

// AVX (with the operating system's support for its registers) and F16C. F16C is read from
// CPUID itself: clang 14's __builtin_cpu_supports does not know the name.
bool hasF16c() {
    unsigned a = 0, b = 0, c = 0, d = 0;
    return __builtin_cpu_supports("avx") && __get_cpuid(1, &a, &b, &c, &d) && (c & bit_F16C) != 0;
}
#endif

// ---- PNG ----------------------------------------------------------------------------------

void appendToString(png_structp png, png_bytep data, png_size_t length) {
    auto* out = static_cast<std::string*>(png_get_io_ptr(png));
    out->append(reinterpret_cast<const char*>(data), length);
}

void noFlush(png_structp) {}

// libpng reports errors by longjmp; nothing with a destructor lives across setjmp here.
// pixels: rows of width × channels samples of bitDepth (8, or 16 as native uint16).
// `photo`: adaptive row filters and zlib's default level and strategy, for colour pictures
// (smooth gradients, no long runs); otherwise the fast settings of masks below.
bool pngEncode(int width, int height, int channels, int bitDepth, const uint8_t* pixels,
               std::string& out, std::string& error, bool photo = false) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    if (!png) {
        error = "libpng: cannot create a write struct";
        return false;
    }
    png_infop info = png_create_info_struct(png);
    if (!info || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, info ? &info : nullptr);
        error = "libpng failed";
        return false;
    }
    png_set_write_fn(png, &out, appendToString, noFlush);
    png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height),
                 bitDepth,
                 channels == 4   ? PNG_COLOR_TYPE_RGB_ALPHA
                 : channels == 3 ? PNG_COLOR_TYPE_RGB
                                 : PNG_COLOR_TYPE_GRAY,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    if (photo) {
        png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_ALL_FILTERS);
        png_set_compression_level(png, 6);
    } else {
        png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
        png_set_compression_level(png, 1);
        png_set_compression_strategy(png, Z_RLE);
        // zlib clears its hash table for every image: at libpng's default memLevel 8 that
        // costs as much as compressing a 256² silhouette (≈ 170 vs 100 µs); Z_RLE never uses
        // the hash.
        png_set_compression_mem_level(png, 6);
    }
    png_write_info(png, info);
    // PNG stores 16-bit samples big-endian: libpng swaps native little-endian ones.
    const uint16_t probe = 1;
    if (bitDepth == 16 && *reinterpret_cast<const uint8_t*>(&probe) == 1) png_set_swap(png);
    const size_t rowBytes = static_cast<size_t>(width) * channels * (bitDepth / 8);
    for (int y = 0; y < height; ++y) {
        png_write_row(png, pixels + static_cast<size_t>(y) * rowBytes);
    }
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    return true;
}

// ---- EXR ----------------------------------------------------------------------------------

void putAttribute(std::string& out, const char* name, const char* type, uint32_t size) {
    out.append(name).push_back('\0');
    out.append(type).push_back('\0');
    putU32(out, size);
}
void putBox(std::string& out, const char* name, int width, int height) {
    putAttribute(out, name, "box2i", 16);
    putU32(out, 0);
    putU32(out, 0);
    putU32(out, static_cast<uint32_t>(width - 1));
    putU32(out, static_cast<uint32_t>(height - 1));
}

// Length of the run of bytes equal to in[i] starting at i, at most `cap` and n − i.
size_t runLength(const uint8_t* in, size_t i, size_t n, size_t cap) {
    return runEnd(in, i + 1, std::min(n, i + cap), in[i]) - i;
}

void putU32BigEndian(std::string& out, uint32_t v) {
    char bytes[4];
    storeU32BigEndian(bytes, v);
    out.append(bytes, 4);
}

// A PNG chunk: length, type, data, CRC-32 of type and data (PNG §5.3).
void putChunk(std::string& out, const char* type, const std::string& data) {
    putU32BigEndian(out, static_cast<uint32_t>(data.size()));
    const size_t typeAt = out.size();
    out.append(type, 4);
    out.append(data);
    const auto* bytes = reinterpret_cast<const Bytef*>(out.data() + typeAt);
    putU32BigEndian(out,
                    static_cast<uint32_t>(crc32(0, bytes, static_cast<uInt>(4 + data.size()))));
}

// An 8-bit greyscale PNG whose rows are unfiltered (each row's filter byte 0) and whose one
// IDAT chunk is zlibRunsOfRows's stream: see image_codecs.h.
std::string encodeRunsPng(int width, int height, const uint8_t* pixels) {
    std::string out("\x89PNG\r\n\x1a\n", 8);
    std::string ihdr;
    putU32BigEndian(ihdr, static_cast<uint32_t>(width));
    putU32BigEndian(ihdr, static_cast<uint32_t>(height));
    // bit depth 8, greyscale, deflate, adaptive filtering (method 0), no interlace
    ihdr.append({8, 0, 0, 0, 0});
    putChunk(out, "IHDR", ihdr);
    putChunk(out, "IDAT",
             zlibRunsOfRows(pixels, static_cast<size_t>(width), static_cast<size_t>(height), 0));
    putChunk(out, "IEND", std::string());
    return out;
}

// The first j in [from, limit) where three equal bytes start (in[j] = in[j + 1] = in[j + 2],
// j + 2 < n), or limit. Eight starts at a time on little-endian hosts: the bytes of
// (x ^ y) | (y ^ z) over the words at j, j + 1, j + 2 are zero where a triple starts, and the
// lowest zero byte is found exactly by the borrow trick (false hits lie only above it).
size_t nextTriple(const uint8_t* in, size_t from, size_t limit, size_t n) {
    size_t j = from;
    if (isLittleEndian()) {
        constexpr uint64_t kOnes = 0x0101010101010101ull, kHighs = 0x8080808080808080ull;
        while (j + 8 <= limit && j + 10 <= n) {
            uint64_t x, y, z;
            std::memcpy(&x, in + j, 8);
            std::memcpy(&y, in + j + 1, 8);
            std::memcpy(&z, in + j + 2, 8);
            const uint64_t v = (x ^ y) | (y ^ z);
            const uint64_t zero = (v - kOnes) & ~v & kHighs;
            if (zero) return j + static_cast<size_t>(__builtin_ctzll(zero) >> 3);
            j += 8;
        }
    }
    while (j < limit && !(j + 2 < n && in[j] == in[j + 1] && in[j + 1] == in[j + 2])) ++j;
    return j;
}

// OpenEXR RLE of n bytes (see the header): appends to out, returns the encoded size.
size_t rleEncode(const uint8_t* in, size_t n, std::vector<uint8_t>& out) {
    constexpr size_t kMaxRun = 128, kMinRun = 3;
    out.clear();
    size_t i = 0;
    while (i < n) {
        const size_t run = runLength(in, i, n, kMaxRun);
        if (run >= kMinRun) {
            out.push_back(static_cast<uint8_t>(run - 1));
            out.push_back(in[i]);
            i += run;
            continue;
        }
        // A literal stretch: up to the next run of kMinRun equal bytes, at most kMaxRun.
        const size_t j = nextTriple(in, i + run, std::min(n, i + kMaxRun), n);
        out.push_back(static_cast<uint8_t>(-static_cast<int>(j - i)));
        out.insert(out.end(), in + i, in + j);
        i = j;
    }
    return out.size();
}

}  // namespace

void floatsToHalves(const float* in, uint16_t* out, size_t n) {
#if defined(__x86_64__) && defined(__GNUC__)
    static const bool f16c = hasF16c();
    if (f16c) {
        halvesF16c(in, out, n);
        return;
    }
#endif
    for (size_t i = 0; i < n; ++i) out[i] = imath_float_to_half(in[i]);
}

std::string encodeGreyPng(int width, int height, const uint8_t* pixels) {
    checkSize(width, height, "encodeGreyPng");
    return encodeRunsPng(width, height, pixels);
}

std::string encodeRgbPng(int width, int height, const uint8_t* rgb) {
    checkSize(width, height, "encodeRgbPng");
    std::string out;
    out.reserve(static_cast<size_t>(width) * height / 4 + 256);
    std::string error;
    if (!pngEncode(width, height, 3, 8, rgb, out, error)) throw std::runtime_error(error);
    return out;
}

std::string encodeRgbaPng(int width, int height, const uint8_t* rgba) {
    checkSize(width, height, "encodeRgbaPng");
    std::string out;
    out.reserve(static_cast<size_t>(width) * height + 256);
    std::string error;
    if (!pngEncode(width, height, 4, 8, rgba, out, error, true)) throw std::runtime_error(error);
    return out;
}

std::string encodeGrey16Png(int width, int height, const uint16_t* pixels) {
    checkSize(width, height, "encodeGrey16Png");
    std::string out;
    out.reserve(static_cast<size_t>(width) * height / 2 + 256);
    std::string error;
    if (!pngEncode(width, height, 1, 16, reinterpret_cast<const uint8_t*>(pixels), out, error)) {
        throw std::runtime_error(error);
    }
    return out;
}

std::string encodeFloatExr(int width, int height, const float* pixels, const std::string& channel,
                           bool half, ExrCompression compression) {
    checkSize(width, height, "encodeFloatExr");
    if (channel.empty() || channel.size() > 31) {
        throw std::invalid_argument("encodeFloatExr: channel name must have 1–31 characters");
    }
    const bool zip = compression == ExrCompression::kZip;
    std::string out;
    const size_t pixelBytes = half ? 2 : 4;
    const size_t lineBytes = static_cast<size_t>(width) * pixelBytes;
    // Scanlines per chunk: OpenEXR's RLE_COMPRESSION codes one, ZIP_COMPRESSION 16.
    const int blockLines = zip ? 16 : 1;
    const int chunks = (height + blockLines - 1) / blockLines;
    out.reserve(512 + static_cast<size_t>(height) * (16 + lineBytes / 16));
    // Magic number 20000630 and version 2 (single-part scanline, short names).
    putU32(out, 20000630u);
    putU32(out, 2u);
    // The required attributes, in name order as OpenEXR writes them.
    putAttribute(out, "channels", "chlist", static_cast<uint32_t>(channel.size() + 1 + 16 + 1));
    out.append(channel).push_back('\0');
    putU32(out, half ? 1 : 2);  // pixel type HALF or FLOAT
    putU32(out, 0);             // pLinear = 0, three reserved bytes
    putU32(out, 1);             // x sampling
    putU32(out, 1);             // y sampling
    out.push_back('\0');
    putAttribute(out, "compression", "compression", 1);
    out.push_back(zip ? 3 : 1);  // ZIP_COMPRESSION (16 lines) or RLE_COMPRESSION
    putBox(out, "dataWindow", width, height);
    putBox(out, "displayWindow", width, height);
    putAttribute(out, "lineOrder", "lineOrder", 1);
    out.push_back(0);  // INCREASING_Y
    putAttribute(out, "pixelAspectRatio", "float", 4);
    putFloat(out, 1.0f);
    putAttribute(out, "screenWindowCenter", "v2f", 8);
    putFloat(out, 0.0f);
    putFloat(out, 0.0f);
    putAttribute(out, "screenWindowWidth", "float", 4);
    putFloat(out, 1.0f);
    out.push_back('\0');  // end of header

    // Line offset table (one entry per chunk), filled in as the chunks are appended.
    const size_t tableAt = out.size();
    out.append(static_cast<size_t>(chunks) * 8, '\0');

    const size_t blockCapacity = lineBytes * blockLines;
    std::vector<uint8_t> split(blockCapacity), delta(blockCapacity), packed;
    packed.reserve(zip ? compressBound(static_cast<uLong>(blockCapacity))
                       : blockCapacity + blockCapacity / 64 + 8);
    std::vector<uint16_t> halves(half ? static_cast<size_t>(width) * blockLines : 0);
    std::string background;  // the chunk data of a whole chunk of background, encoded once
    // A background row is all +0.0, the one float whose bits are all zero: its bytes are OR-ed
    // a word at a time, 64 bytes between checks (a loop the compiler vectorises). Testing the
    // floats one by one was a quarter of the encoder's instructions on ez-size's depth maps.
    auto isBackground = [&](int y) {
        const auto* bytes =
            reinterpret_cast<const unsigned char*>(pixels + static_cast<size_t>(y) * width);
        const size_t n = 4 * static_cast<size_t>(width);
        size_t k = 0;
        for (; k + 64 <= n; k += 64) {
            uint64_t any = 0;
            for (size_t j = 0; j < 64; j += 8) {
                uint64_t word;
                std::memcpy(&word, bytes + k + j, 8);
                any |= word;
            }
            if (any != 0) return false;
        }
        uint64_t any = 0;
        for (; k < n; ++k) any |= bytes[k];
        return any == 0;
    };
    for (int c = 0; c < chunks; ++c) {
        const int y0 = c * blockLines;
        const int lines = std::min(blockLines, height - y0);
        const size_t blockBytes = lineBytes * lines;
        storeU64(&out[tableAt + 8 * static_cast<size_t>(c)], out.size());
        putU32(out, static_cast<uint32_t>(y0));
        // Most rows of a depth map are background (+0.0): such a chunk's data never changes.
        bool allBackground = lines == blockLines;
        for (int y = y0; y < y0 + lines && allBackground; ++y) allBackground = isBackground(y);
        if (allBackground && !background.empty()) {
            out += background;
            continue;
        }
        // The chunk's little-endian bytes b0 b1 (b2 b3) per pixel, line after line: the even
        // ones go to the first half, the odd ones to the second (each line has an even number
        // of bytes, so line by line). Separate buffers let the loops vectorise.
        const size_t second = blockBytes / 2;
        for (int i = 0; i < lines; ++i) {
            const float* row = pixels + static_cast<size_t>(y0 + i) * width;
            uint8_t* even = split.data() + i * (lineBytes / 2);
            uint8_t* odd = split.data() + second + i * (lineBytes / 2);
            if (half) {
                // Imath's conversion: round to nearest even, overflow to infinity.
                uint16_t* h = halves.data() + static_cast<size_t>(i) * width;
                floatsToHalves(row, h, static_cast<size_t>(width));
                for (int x = 0; x < width; ++x) {
                    even[x] = static_cast<uint8_t>(h[x]);
                    odd[x] = static_cast<uint8_t>(h[x] >> 8);
                }
            } else {
                int x = 0;
#if defined(__SSE2__)
                // Eight floats at a time: a float's bytes b0 b1 b2 b3 (x86 is little-endian)
                // are two 16-bit lanes; their low bytes (b0, b2) packed go to `even`, their high
                // bytes (b1, b3) to `odd` — what the scalar loop below stores, 16 at a time (it
                // was 16 instructions a pixel, a third of the encoder's on ez-size's maps).
                const __m128i lowBytes = _mm_set1_epi16(0x00ff);
                for (; x + 8 <= width; x += 8) {
                    const __m128i v0 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + x));
                    const __m128i v1 =
                        _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + x + 4));
                    const __m128i lo =
                        _mm_packus_epi16(_mm_and_si128(v0, lowBytes), _mm_and_si128(v1, lowBytes));
                    const __m128i hi =
                        _mm_packus_epi16(_mm_srli_epi16(v0, 8), _mm_srli_epi16(v1, 8));
                    _mm_storeu_si128(reinterpret_cast<__m128i*>(even + 2 * x), lo);
                    _mm_storeu_si128(reinterpret_cast<__m128i*>(odd + 2 * x), hi);
                }
#endif
                for (; x < width; ++x) {
                    uint32_t bits;
                    std::memcpy(&bits, &row[x], 4);
                    const size_t e = 2 * static_cast<size_t>(x);
                    even[e] = static_cast<uint8_t>(bits);
                    even[e + 1] = static_cast<uint8_t>(bits >> 16);
                    odd[e] = static_cast<uint8_t>(bits >> 8);
                    odd[e + 1] = static_cast<uint8_t>(bits >> 24);
                }
            }
        }
        delta[0] = split[0];
        for (size_t k = 1; k < blockBytes; ++k) {
            delta[k] = static_cast<uint8_t>(split[k] - split[k - 1] + 128);
        }
        size_t size = blockBytes;  // (no smaller: stored raw)
        if (zip) {
            uLongf zipped = static_cast<uLongf>(packed.capacity());
            packed.resize(packed.capacity());
            if (compress2(packed.data(), &zipped, delta.data(), static_cast<uLong>(blockBytes),
                          kExrZipLevel) != Z_OK) {
                throw std::runtime_error("encodeFloatExr: zlib failed");
            }
            size = zipped;
        } else {
            size = rleEncode(delta.data(), blockBytes, packed);
        }
        const size_t dataAt = out.size();
        if (size < blockBytes) {
            putU32(out, static_cast<uint32_t>(size));
            out.append(reinterpret_cast<const char*>(packed.data()), size);
        } else {  // would not shrink: stored raw (the pixels' own bytes), as OpenEXR does
            putU32(out, static_cast<uint32_t>(blockBytes));
            for (int i = 0; i < lines; ++i) {
                const float* row = pixels + static_cast<size_t>(y0 + i) * width;
                for (int x = 0; x < width; ++x) {
                    if (half) {
                        const uint16_t h = halves[static_cast<size_t>(i) * width + x];
                        out.push_back(static_cast<char>(h & 0xff));
                        out.push_back(static_cast<char>(h >> 8));
                        continue;
                    }
                    uint32_t bits;  // bit for bit: a float → double round trip could quiet a NaN
                    std::memcpy(&bits, &row[x], 4);
                    putU32(out, bits);
                }
            }
        }
        if (allBackground) background = out.substr(dataAt);
    }
    return out;
}

}  // namespace sylva
