#include "volumes/image_file.h"

#include <png.h>
#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "volumes/oiio_module.h"

namespace sylva {

namespace {

const unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

[[noreturn]] void fail(const std::string& path, const std::string& why) {
    throw ImageError("cannot read the image " + path + ": " + why);
}

// The header's dimensions against the limits, before anything is allocated for the pixels.
void checkDimensions(const std::string& path, int64_t w, int64_t h, int64_t channels,
                     const ImageLimits& limits = ImageLimits{}) {
    if (w <= 0 || h <= 0) {
        fail(path,
             "it declares " + std::to_string(w) + " × " + std::to_string(h) + " pixels: no pixels");
    }
    if (w > limits.maxSide || h > limits.maxSide || w * h > limits.maxPixels) {
        fail(path, "it declares " + std::to_string(w) + " × " + std::to_string(h) +
                       " pixels; at most " + std::to_string(limits.maxSide) + " on a side and " +
                       std::to_string(limits.maxPixels) + " in all");
    }
    if (channels < 1 || channels > kMaxImageChannels) {
        fail(path, "it declares " + std::to_string(channels) + " channels; expected 1 to " +
                       std::to_string(kMaxImageChannels));
    }
}

bool hasPngExtension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".png";
}

uint32_t bigEndian32(const unsigned char* b) {
    return (uint32_t(b[0]) << 24) | (uint32_t(b[1]) << 16) | (uint32_t(b[2]) << 8) | b[3];
}

// libpng's callbacks: errors are kept (and end the read through longjmp), warnings (benign
// problems such as an ancillary chunk's bad CRC, which libpng skips) are dropped, reads past
// the end of the file are errors. Nothing reaches stderr.
struct PngSource {
    std::FILE* file = nullptr;
    char error[256] = {0};
    bool truncated = false;
};

void pngError(png_structp png, png_const_charp message) {
    auto* s = static_cast<PngSource*>(png_get_error_ptr(png));
    std::snprintf(s->error, sizeof s->error, "%s", message ? message : "PNG error");
    std::longjmp(png_jmpbuf(png), 1);
}

void pngWarning(png_structp, png_const_charp) {}

void pngRead(png_structp png, png_bytep data, png_size_t length) {
    auto* s = static_cast<PngSource*>(png_get_io_ptr(png));
    if (std::fread(data, 1, length, s->file) != length) {
        s->truncated = true;
        png_error(png, "the file ends too early");
    }
}

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};

// A PNG's samples as libpng hands them over, one row after another (16-bit samples in the
// machine's byte order, or scaled to 8 bits when `eightBit`).
struct PngRows {
    int width = 0, height = 0, channels = 0, bitDepth = 0;
    std::vector<unsigned char> rows;
};

// Decodes a PNG with the expansions OpenImageIO applies (palette → RGB, grey of 1–4 bits → 8
// bits, tRNS → alpha). The header is checked against `limits` before any pixel buffer exists,
// and the pixel buffers are allocated before setjmp, so a longjmp skips no destructor.
PngRows decodePng(const std::string& path, std::FILE* file, const unsigned char header[33],
                  const ImageLimits& limits, bool eightBit) {
    // IHDR is the first chunk, 13 bytes: width, height, bit depth, colour type, ….
    if (bigEndian32(header + 8) != 13 || std::memcmp(header + 12, "IHDR", 4) != 0) {
        fail(path, "corrupt PNG: the first chunk is not IHDR");
    }
    const int64_t w = bigEndian32(header + 16), h = bigEndian32(header + 20);
    const int colourType = header[25];
    const int64_t declaredChannels = colourType == 2   ? 3
                                     : colourType == 4 ? 2
                                     : colourType == 6 ? 4
                                     : colourType == 3 ? 4
                                                       : 1;
    checkDimensions(path, w, h, declaredChannels, limits);

    PngRows out;
    std::vector<png_bytep> rowPointers;
    PngSource source;
    source.file = file;
    std::rewind(file);
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &source, pngError, pngWarning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_read_struct(png ? &png : nullptr, nullptr, nullptr);
        fail(path, "out of memory");
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        fail(path, source.truncated
                       ? "truncated: the file ends before the PNG's end (its IEND chunk)"
                       : std::string("corrupt PNG data: ") + source.error);
    }
    png_set_read_fn(png, &source, pngRead);
    png_set_user_limits(png, static_cast<png_uint_32>(limits.maxSide),
                        static_cast<png_uint_32>(limits.maxSide));
    png_set_chunk_malloc_max(png, 8u << 20);  // text and other ancillary chunks: 8 MiB each
    png_set_keep_unknown_chunks(png, PNG_HANDLE_CHUNK_NEVER, nullptr, 0);
    png_read_info(png, info);
    const int bitDepth = png_get_bit_depth(png, info);
    const int type = png_get_color_type(png, info);
    if (type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (type == PNG_COLOR_TYPE_GRAY && bitDepth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    const uint16_t probe = 1;
    if (bitDepth == 16 && eightBit) {
        png_set_scale_16(png);  // round(v · 255 / 65535)
    } else if (bitDepth == 16 && *reinterpret_cast<const uint8_t*>(&probe) == 1) {
        png_set_swap(png);
    }
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    out.width = static_cast<int>(png_get_image_width(png, info));
    out.height = static_cast<int>(png_get_image_height(png, info));
    out.channels = png_get_channels(png, info);
    out.bitDepth = png_get_bit_depth(png, info);
    const size_t rowBytes = png_get_rowbytes(png, info);
    out.rows.resize(rowBytes * out.height);
    rowPointers.resize(out.height);
    for (int y = 0; y < out.height; ++y) rowPointers[y] = out.rows.data() + rowBytes * y;
    png_read_image(png, rowPointers.data());
    png_read_end(png, nullptr);  // the chunks after the image data, up to IEND
    png_destroy_read_struct(&png, &info, nullptr);
    return out;
}

// A PNG as float samples, integer samples scaled as OpenImageIO scales them: float(v) · (1/max).
ImageFile readPng(const std::string& path, std::FILE* file, const unsigned char header[33]) {
    const PngRows png = decodePng(path, file, header, ImageLimits{}, false);
    ImageFile img;
    img.width = png.width;
    img.height = png.height;
    img.channels = png.channels;
    img.alphaChannel = (img.channels == 2 || img.channels == 4) ? img.channels - 1 : -1;
    const size_t samples = static_cast<size_t>(img.width) * img.height * img.channels;
    img.pixels.resize(samples);
    img.integerMax = png.bitDepth == 16 ? 65535.0 : 255.0;
    if (png.bitDepth == 16) {
        const float scale = 1.0f / 65535.0f;
        const auto* src = reinterpret_cast<const uint16_t*>(png.rows.data());
        for (size_t i = 0; i < samples; ++i) img.pixels[i] = float(src[i]) * scale;
    } else {
        const float scale = 1.0f / 255.0f;
        for (size_t i = 0; i < samples; ++i) img.pixels[i] = float(png.rows[i]) * scale;
    }
    return img;
}

// Any other format OpenImageIO reads (through its module, oiio_module.h): the header first
// (dimensions checked), then the pixels.
ImageFile readWithOiio(const std::string& path) {
    ImageFile img;
    std::string error;
    const auto check = [&](int w, int h, int channels, int depth) {
        checkDimensions(path, w, h, channels);
        if (depth > 1) fail(path, "it is a volume image (depth " + std::to_string(depth) + ")");
    };
    const OiioModule* module = nullptr;
    try {
        module = &oiioModule();
    } catch (const std::runtime_error& e) {
        fail(path, e.what());
    }
    if (!module->readFile(path, check, img, error)) fail(path, error);
    return img;
}

// Opens `path` for reading, refusing what is not a regular file (a FIFO would block fopen, a
// device never end), and reads the first 33 bytes (the signature and IHDR) into `header`.
std::unique_ptr<std::FILE, FileCloser> openImage(const std::string& path, unsigned char* header,
                                                 size_t& got) {
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) fail(path, "not a regular file");
    std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
    if (!file) fail(path, std::strerror(errno));
    got = std::fread(header, 1, 33, file.get());
    if (got == 0) fail(path, "the file is empty");
    return file;
}

// A PNG held in memory as a FILE, its first 33 bytes read into `header`.
std::unique_ptr<std::FILE, FileCloser> openPngBytes(const std::string& bytes,
                                                    const std::string& name,
                                                    unsigned char* header) {
    if (bytes.empty()) fail(name, "the file is empty");
    if (!hasPngSignature(bytes)) {
        fail(name, "not a PNG file (it does not start with the PNG signature)");
    }
    if (bytes.size() < 33) fail(name, "truncated: the file ends inside the PNG header");
    std::unique_ptr<std::FILE, FileCloser> file(
        fmemopen(const_cast<char*>(bytes.data()), bytes.size(), "rb"));
    if (!file) fail(name, std::strerror(errno));
    if (std::fread(header, 1, 33, file.get()) != 33) {
        fail(name, "truncated: the file ends inside the PNG header");
    }
    return file;
}

Image8 toImage8(PngRows&& png) {
    Image8 img;
    img.width = png.width;
    img.height = png.height;
    img.channels = png.channels;
    img.pixels = std::move(png.rows);
    return img;
}

}  // namespace

bool hasPngSignature(const std::string& bytes) {
    return bytes.size() >= 8 && std::memcmp(bytes.data(), kPngSignature, 8) == 0;
}

ImageFile readImageFile(const std::string& path) {
    unsigned char header[33] = {0};
    size_t got = 0;
    auto file = openImage(path, header, got);
    if (got >= 8 && std::memcmp(header, kPngSignature, 8) == 0) {
        if (got < sizeof header) {
            fail(path, "truncated: the file ends inside the PNG header");
        }
        return readPng(path, file.get(), header);
    }
    if (hasPngExtension(path)) {
        fail(path, "not a PNG file (it does not start with the PNG signature)");
    }
    file.reset();
    return readWithOiio(path);
}

Image8 readPng8File(const std::string& path, const ImageLimits& limits) {
    unsigned char header[33] = {0};
    size_t got = 0;
    auto file = openImage(path, header, got);
    if (got < 8 || std::memcmp(header, kPngSignature, 8) != 0) {
        fail(path, "not a PNG file (it does not start with the PNG signature)");
    }
    if (got < sizeof header) fail(path, "truncated: the file ends inside the PNG header");
    return toImage8(decodePng(path, file.get(), header, limits, true));
}

Image8 readPng8Bytes(const std::string& bytes, const std::string& name, const ImageLimits& limits) {
    unsigned char header[33] = {0};
    auto file = openPngBytes(bytes, name, header);
    return toImage8(decodePng(name, file.get(), header, limits, true));
}

}  // namespace sylva
