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

std::string spec(bool half) {
    return "name = \"depth-half\"\nseed = 3\n[[species]]\nfile = \"" +
           (kData / "tiny.toml").string() +
           "\"\ncount = 3\n[outputs]\nskeleton = [\"ply\"]\n[views]\ncount = 3\n"
           "resolution = [96, 64]\ndepth = true\n" +
           (half ? "depth_half = true\n" : "");
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

}  // namespace
