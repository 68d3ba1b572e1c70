// [views] depth_half: the same build with the depth EXRs' channel as HALF. OpenEXR (through
// OpenImageIO, not sylva's reader) must find every pixel equal to the FLOAT build's value
// rounded to half by Imath, and the files smaller.
#include <Imath/half.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::describeRun;
using sylva::test::runAllSylva;
using sylva::test::TempDir;

const fs::path kData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data";

std::string spec(bool half, const std::string& more = "") {
    return "name = \"depth-half\"\nseed = 3\n[[species]]\nfile = \"" +
           (kData / "tiny.toml").string() +
           "\"\ncount = 3\n[outputs]\nskeleton = [\"ply\"]\n[views]\ncount = 3\n"
           "resolution = [96, 64]\ndepth = true\n" +
           (half ? "depth_half = true\n" : "") + more;
}

TEST(CliDepthHalf, EveryPixelIsTheFloatDepthRoundedToHalf) {
    TempDir t;
    std::ofstream(t / "float.toml") << spec(false);
    std::ofstream(t / "half.toml") << spec(true);
    for (const auto& r :
         runAllSylva({{"build", (t / "float.toml").string(), "--out", (t / "f").string()},
                      {"build", (t / "half.toml").string(), "--out", (t / "h").string()}},
                     t.path())) {
        ASSERT_EQ(r.code, 0) << describeRun(r);
    }
    int maps = 0;
    uintmax_t floatBytes = 0, halfBytes = 0;
    for (const auto& e : fs::recursive_directory_iterator(t / "f")) {
        if (e.path().filename().string().find("_depth.exr") == std::string::npos) continue;
        const fs::path other = t / "h" / fs::relative(e.path(), t / "f");
        ASSERT_TRUE(fs::exists(other)) << other;
        floatBytes += fs::file_size(e.path());
        halfBytes += fs::file_size(other);
        auto f = OIIO::ImageInput::open(e.path().string());
        auto h = OIIO::ImageInput::open(other.string());
        ASSERT_TRUE(f && h) << OIIO::geterror();
        EXPECT_EQ(f->spec().format, OIIO::TypeDesc::FLOAT);
        EXPECT_EQ(h->spec().format, OIIO::TypeDesc::HALF);
        ASSERT_EQ(f->spec().image_pixels(), h->spec().image_pixels());
        std::vector<float> depth(f->spec().image_pixels());
        std::vector<uint16_t> halves(depth.size());
        ASSERT_TRUE(f->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, depth.data()));
        ASSERT_TRUE(h->read_image(0, 0, 0, 1, OIIO::TypeDesc::HALF, halves.data()));
        size_t wrong = 0, tree = 0;
        for (size_t k = 0; k < depth.size(); ++k) {
            wrong += halves[k] != Imath::half(depth[k]).bits();
            tree += depth[k] > 0;
        }
        EXPECT_EQ(wrong, 0u) << e.path();
        EXPECT_GT(tree, 0u) << e.path();
        ++maps;
    }
    EXPECT_EQ(maps, 9);
    // Tiny trees on 96×64 maps: the per-line chunk headers (16 bytes a line) are much of each
    // file, so the saving is smaller than on a library tree's 256² maps (0.54×).
    EXPECT_LT(halfBytes, floatBytes * 9 / 10) << halfBytes << " vs " << floatBytes;
}

// [views] depth_compression = "zip": every depth map, FLOAT and HALF, holds the very pixels of
// the RLE build (read by OpenImageIO's OpenEXR), says "zip", and the maps take fewer bytes.
TEST(CliDepthHalf, ZipCompressionKeepsEveryPixel) {
    TempDir t;
    std::ofstream(t / "rle.toml") << spec(false);
    std::ofstream(t / "zip.toml") << spec(false, "depth_compression = \"zip\"\n");
    std::ofstream(t / "ziph.toml") << spec(true, "depth_compression = \"zip\"\n");
    std::ofstream(t / "rleh.toml") << spec(true, "depth_compression = \"rle\"\n");
    for (const auto& r :
         runAllSylva({{"build", (t / "rle.toml").string(), "--out", (t / "r").string()},
                      {"build", (t / "zip.toml").string(), "--out", (t / "z").string()},
                      {"build", (t / "ziph.toml").string(), "--out", (t / "zh").string()},
                      {"build", (t / "rleh.toml").string(), "--out", (t / "rh").string()}},
                     t.path())) {
        ASSERT_EQ(r.code, 0) << describeRun(r);
    }
    auto read = [](const fs::path& p, std::string& compression) {
        auto in = OIIO::ImageInput::open(p.string());
        EXPECT_TRUE(in) << OIIO::geterror();
        std::vector<float> v;
        if (!in) return v;
        compression = in->spec().get_string_attribute("compression");
        v.resize(in->spec().image_pixels());
        EXPECT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, v.data()));
        return v;
    };
    for (const auto& [plain, zipped] : {std::pair{"r", "z"}, std::pair{"rh", "zh"}}) {
        int maps = 0;
        uintmax_t rleBytes = 0, zipBytes = 0;
        for (const auto& e : fs::recursive_directory_iterator(t / plain)) {
            if (e.path().filename().string().find("_depth.exr") == std::string::npos) continue;
            const fs::path other = t / zipped / fs::relative(e.path(), t / plain);
            ASSERT_TRUE(fs::exists(other)) << other;
            rleBytes += fs::file_size(e.path());
            zipBytes += fs::file_size(other);
            std::string c1, c2;
            const std::vector<float> a = read(e.path(), c1), b = read(other, c2);
            EXPECT_EQ(c1, "rle");
            EXPECT_EQ(c2, "zip");
            ASSERT_EQ(a.size(), b.size());
            size_t wrong = 0, tree = 0;
            for (size_t k = 0; k < a.size(); ++k) {
                wrong += a[k] != b[k];
                tree += a[k] > 0;
            }
            EXPECT_EQ(wrong, 0u) << other;
            EXPECT_GT(tree, 0u) << other;
            ++maps;
        }
        EXPECT_EQ(maps, 9) << zipped;
        EXPECT_LT(zipBytes, rleBytes) << zipped << ": " << zipBytes << " vs " << rleBytes;
    }
}

}  // namespace
