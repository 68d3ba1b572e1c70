// Images a spec names (volumes/image_file.h): a valid PNG of every colour type and bit depth
// reads exactly as OpenImageIO reads it (the decoder it replaced for PNG, so crowns stay
// byte-identical), and a broken or oversized one is an ImageError naming the problem, thrown
// before any large allocation, with nothing printed on stderr (libpng printed its own lines).
#include "volumes/image_file.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "volumes/canopy_envelope.h"
#include "volumes/mask.h"
#include "volumes/revolution.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;
const fs::path kImages = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data" / "hostile" / "images";
const fs::path kSketches = fs::path(SYLVA_SOURCE_DIR) / "species" / "sketches";

// OpenImageIO's float read of the whole image, alpha unassociated.
ImageFile readWithOiio(const fs::path& path) {
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path.string(), &config);
    EXPECT_TRUE(in) << path;
    ImageFile img;
    if (!in) return img;
    img.width = in->spec().width;
    img.height = in->spec().height;
    img.channels = in->spec().nchannels;
    img.alphaChannel = in->spec().alpha_channel;
    img.pixels.resize(size_t(img.width) * img.height * img.channels);
    EXPECT_TRUE(in->read_image(0, 0, 0, img.channels, OIIO::TypeDesc::FLOAT, img.pixels.data()));
    return img;
}

void expectSameAsOiio(const fs::path& path) {
    SCOPED_TRACE(path.string());
    const ImageFile ours = readImageFile(path.string());
    const ImageFile oiio = readWithOiio(path);
    ASSERT_EQ(ours.width, oiio.width);
    ASSERT_EQ(ours.height, oiio.height);
    ASSERT_EQ(ours.channels, oiio.channels);
    EXPECT_EQ(ours.alphaChannel, oiio.alphaChannel);
    ASSERT_EQ(ours.pixels.size(), oiio.pixels.size());
    size_t differ = 0;
    for (size_t i = 0; i < ours.pixels.size(); ++i) differ += ours.pixels[i] != oiio.pixels[i];
    EXPECT_EQ(differ, 0u) << "samples differ from OpenImageIO's (bit for bit)";
}

TEST(ImageFile, EveryColourTypeAndDepthReadsAsOpenImageIOReadsIt) {
    for (const char* name : {"ok_grey8.png", "ok_grey16.png", "ok_grey1.png", "ok_grey_alpha8.png",
                             "ok_rgb8.png", "ok_rgba8.png", "ok_palette.png", "ok_palette_trns.png",
                             "ok_interlaced.png", "ok_side_16384.png"}) {
        expectSameAsOiio(kImages / name);
    }
    // Known answers: grey 8-bit (x·19 + y·7) mod 256 / 255; 1-bit expanded to 0 or 1.
    const ImageFile grey = readImageFile((kImages / "ok_grey8.png").string());
    EXPECT_EQ(grey.at(5, 3, 0), float((5 * 19 + 3 * 7) % 256) * (1.0f / 255.0f));
    const ImageFile bits = readImageFile((kImages / "ok_grey1.png").string());
    EXPECT_EQ(bits.at(0, 0, 0), 1.0f);  // 0b10110010: first pixel set
    EXPECT_EQ(bits.at(1, 0, 0), 0.0f);
    const ImageFile trns = readImageFile((kImages / "ok_palette_trns.png").string());
    EXPECT_EQ(trns.channels, 4);
    EXPECT_EQ(trns.alphaChannel, 3);
}

TEST(ImageFile, EveryShippedSketchReadsAsOpenImageIOReadsIt) {
    int n = 0;
    for (const auto& e : fs::directory_iterator(kSketches)) {
        if (e.path().extension() != ".png") continue;
        expectSameAsOiio(e.path());
        ++n;
    }
    EXPECT_GE(n, 10);
}

// The message of the ImageError reading `name` throws, with nothing printed meanwhile.
std::string errorOf(const std::string& name) {
    ::testing::internal::CaptureStderr();
    std::string message;
    try {
        readImageFile((kImages / name).string());
    } catch (const ImageError& e) {
        message = e.what();
    }
    const std::string printed = ::testing::internal::GetCapturedStderr();
    EXPECT_EQ(printed, "") << name << " printed on stderr";
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    return message;
}

TEST(ImageFile, BrokenImagesAreOneLineErrorsAndPrintNothing) {
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"empty.png", "the file is empty"},
        {"text.png", "not a PNG file"},
        {"signature_only.png", "truncated: the file ends inside the PNG header"},
        {"truncated.png", "truncated: the file ends before the PNG's end"},
        {"no_iend.png", "truncated"},
        {"bad_crc.png", "corrupt PNG data"},
        {"garbage_idat.png", "corrupt PNG data"},
        {"short_idat.png", "corrupt PNG data"},
        {"bad_depth.png", "corrupt PNG data"},
        {"zero_width.png", "it declares 0 × 10 pixels: no pixels"},
        {"huge_dims.png", "it declares 100000 × 100000 pixels; at most 16384 on a side"},
        {"wide.png", "it declares 20000 × 10 pixels"},
        {"no_such_file.png", "No such file or directory"},
    };
    for (const auto& [name, want] : cases) {
        const std::string message = errorOf(name);
        EXPECT_EQ(message.rfind("cannot read the image " + (kImages / name).string() + ": ", 0), 0u)
            << message;
        EXPECT_NE(message.find(want), std::string::npos) << name << ": " << message;
    }
}

TEST(ImageFile, TheReadersOfMasksLayersAndStrokesUseTheChecks) {
    const std::string truncated = (kImages / "truncated.png").string();
    const std::string huge = (kImages / "huge_dims.png").string();
    ::testing::internal::CaptureStderr();
    EXPECT_THROW(readMask(truncated, false), MaskError);
    EXPECT_THROW(readMask(huge, false), MaskError);  // not std::bad_alloc
    EXPECT_THROW(readCanopyImage(truncated), ImageError);
    EXPECT_THROW(readCanopyImage(huge), ImageError);
    EXPECT_THROW(traceStrokeImage(truncated, 0, 5), StrokeError);
    EXPECT_THROW(traceStrokeImage(huge, 0, 5), StrokeError);
    EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

// The file's bytes, for the in-memory reader.
std::string bytesOf(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(ImageFile, EightBitReadsAreTheFloatReadsRounded) {
    for (const char* name :
         {"ok_grey8.png", "ok_grey16.png", "ok_grey1.png", "ok_grey_alpha8.png", "ok_rgb8.png",
          "ok_rgba8.png", "ok_palette.png", "ok_palette_trns.png", "ok_interlaced.png"}) {
        SCOPED_TRACE(name);
        const ImageFile ref = readImageFile((kImages / name).string());
        const Image8 file = readPng8File((kImages / name).string(), kViewImageLimits);
        const Image8 mem = readPng8Bytes(bytesOf(kImages / name), name, kViewImageLimits);
        ASSERT_EQ(file.width, ref.width);
        ASSERT_EQ(file.height, ref.height);
        ASSERT_EQ(file.channels, ref.channels);
        ASSERT_EQ(file.pixels.size(), ref.pixels.size());
        EXPECT_EQ(mem.pixels, file.pixels);
        size_t differ = 0;
        for (size_t i = 0; i < ref.pixels.size(); ++i) {
            // v / 255 or v / 65535 back to 8 bits: v · 255 / 65535 has no ties to round.
            differ += file.pixels[i] != std::lround(double(ref.pixels[i]) * 255.0);
        }
        EXPECT_EQ(differ, 0u);
    }
}

TEST(ImageFile, EightBitReadsTakeTheirLimitsFromTheCaller) {
    // 4100 × 4100 pixels: more than a species image may have (4096²), within a view's limits.
    const fs::path dir = fs::temp_directory_path() / ("sylva_png8_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const fs::path big = dir / "big.png";
    {
        const int side = 4100;
        std::vector<uint8_t> px(size_t(side) * side, 0);
        px[size_t(4099) * side + 4098] = 200;
        auto out = OIIO::ImageOutput::create(big.string());
        ASSERT_TRUE(out);
        ASSERT_TRUE(out->open(big.string(), OIIO::ImageSpec(side, side, 1, OIIO::TypeDesc::UINT8)));
        ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px.data()));
        ASSERT_TRUE(out->close());
    }
    EXPECT_THROW(readImageFile(big.string()), ImageError);
    const Image8 view = readPng8File(big.string(), kViewImageLimits);
    ASSERT_EQ(view.width, 4100);
    ASSERT_EQ(view.height, 4100);
    EXPECT_EQ(view.pixels[size_t(4099) * 4100 + 4098], 200);
    EXPECT_EQ(view.pixels[size_t(4099) * 4100 + 4099], 0);
    fs::remove_all(dir);

    // Tight limits refuse before decoding, in one line; the file's name leads the message.
    const ImageLimits tiny{8, 64};
    for (const char* name : {"ok_grey8.png", "huge_dims.png"}) {
        try {
            readPng8Bytes(bytesOf(kImages / name), name, tiny);
            ADD_FAILURE() << name << " read within 8 × 8";
        } catch (const ImageError& e) {
            const std::string m = e.what();
            EXPECT_EQ(m.rfind(std::string("cannot read the image ") + name + ": it declares ", 0),
                      0u)
                << m;
            EXPECT_NE(m.find("at most 8 on a side and 64 in all"), std::string::npos) << m;
        }
    }
    // Broken files are the same one-line errors as the float reader's.
    for (const char* name : {"truncated.png", "bad_crc.png", "text.png", "empty.png"}) {
        EXPECT_THROW(readPng8Bytes(bytesOf(kImages / name), name, kViewImageLimits), ImageError)
            << name;
        EXPECT_THROW(readPng8File((kImages / name).string(), kViewImageLimits), ImageError) << name;
    }
}

}  // namespace
}  // namespace sylva
