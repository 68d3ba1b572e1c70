// OpenImageIO is a module opened on first use (volumes/oiio_module.h): a process that reads no
// image in another format than PNG never loads it, and one that needs it without the module
// fails with one line.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::CliOptions;
using sylva::test::describeRun;
using sylva::test::runSylva;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kSource = SYLVA_SOURCE_DIR;

// The dynamic loader lists every library it loads (LD_DEBUG=libs, on stderr): no module (nor
// its library) is loaded at start — OpenImageIO here, pagmo2 (cmaes_module_test.cpp), OpenVDB
// (vdb_module_test.cpp).
TEST(CliOiioModule, StartUpLoadsNoModule) {
    TempDir t;
    CliOptions o;
    o.env = {"LD_DEBUG=libs"};
    const auto r = runSylva({"--help"}, t.path(), o);
    EXPECT_EQ(r.code, 0) << describeRun(r);
    EXPECT_NE(r.err.find("libtbb"), std::string::npos) << "LD_DEBUG printed no library list";
    EXPECT_EQ(r.err.find("libOpenImageIO"), std::string::npos);
    EXPECT_EQ(r.err.find("libsylva_oiio"), std::string::npos);
    EXPECT_EQ(r.err.find("libpagmo"), std::string::npos);
    EXPECT_EQ(r.err.find("libsylva_cmaes"), std::string::npos);
    EXPECT_EQ(r.err.find("libopenvdb"), std::string::npos);
    EXPECT_EQ(r.err.find("libsylva_vdb"), std::string::npos);
}

// xm-mask-oak with its mask as a JPEG (written here through OpenImageIO): grown through the
// module; with SYLVA_OIIO_MODULE naming no file, one line and exit 2, while the PNG original
// still grows (PNG never needs the module).
TEST(CliOiioModule, AJpegMaskIsReadThroughTheModuleAndAMissingModuleIsOneLine) {
    TempDir t;
    const fs::path png = kSource / "species/sketches/oak-mask.png";
    const fs::path jpg = t / "oak-mask.jpg";
    {
        auto in = OIIO::ImageInput::open(png.string());
        ASSERT_TRUE(in) << OIIO::geterror();
        OIIO::ImageSpec spec = in->spec();
        std::vector<unsigned char> px(spec.image_pixels() * spec.nchannels);
        ASSERT_TRUE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, px.data()));
        const int channels = std::min(spec.nchannels, 3);  // JPEG has no alpha
        OIIO::ImageSpec outSpec(spec.width, spec.height, channels, OIIO::TypeDesc::UINT8);
        auto out = OIIO::ImageOutput::create(jpg.string());
        ASSERT_TRUE(out && out->open(jpg.string(), outSpec));
        ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px.data(),
                                     spec.nchannels * sizeof(unsigned char)));
        ASSERT_TRUE(out->close());
    }
    std::string species = slurp(kSource / "species/papers/liu-2020/xm-mask-oak.toml");
    for (size_t at; (at = species.find("../../sketches/oak-mask.png")) != std::string::npos;) {
        species.replace(at, std::string("../../sketches/oak-mask.png").size(), jpg.string());
    }
    std::ofstream(t / "oak-jpeg.toml") << species;

    const auto grown = runSylva(
        {"grow", (t / "oak-jpeg.toml").string(), "--seed", "1", "--out", (t / "a").string()},
        t.path());
    ASSERT_EQ(grown.code, 0) << describeRun(grown);
    EXPECT_GT(fs::file_size(t / "a" / "skeleton.ply"), 1000u);

    CliOptions missing;
    missing.env = {"SYLVA_OIIO_MODULE=" + (t / "nowhere" / "libsylva_oiio.so").string()};
    const auto failed = runSylva(
        {"grow", (t / "oak-jpeg.toml").string(), "--seed", "1", "--out", (t / "b").string()},
        t.path(), missing);
    EXPECT_EQ(failed.code, 2) << describeRun(failed);
    EXPECT_EQ(std::count(failed.err.begin(), failed.err.end(), '\n'), 1) << failed.err;
    EXPECT_NE(failed.err.find("oak-jpeg.toml:"), std::string::npos) << failed.err;
    EXPECT_NE(failed.err.find("libsylva_oiio.so"), std::string::npos) << failed.err;
    EXPECT_FALSE(fs::exists(t / "b"));

    const auto fromPng =
        runSylva({"grow", (kSource / "species/papers/liu-2020/xm-mask-oak.toml").string(), "--seed",
                  "1", "--out", (t / "c").string()},
                 t.path(), missing);
    EXPECT_EQ(fromPng.code, 0) << describeRun(fromPng);
}

// A view larger than the species images image_file.h reads (16384 × 1025 > 4096² pixels): the
// species sheet decodes it with the views' own limits (readPng8Bytes, kViewImageLimits) and the
// build succeeds.
TEST(CliSpeciesSheet, ViewsLargerThanSpeciesImageLimitsStillMakeTheSheet) {
    TempDir t;
    std::ofstream(t / "wide.toml")
        << "name = \"wide\"\nseed = 3\n[[species]]\nfile = \""
        << (kSource / "tests/data/tiny.toml").string()
        << "\"\ncount = 1\n[outputs]\nskeleton = [\"ply\"]\nspecies_sheet = 1\n[views]\n"
           "count = 1\nresolution = [16384, 1025]\ncontact_sheet = false\n";
    const auto r =
        runSylva({"build", (t / "wide.toml").string(), "--out", (t / "out").string()}, t.path());
    ASSERT_EQ(r.code, 0) << describeRun(r);
    EXPECT_TRUE(fs::is_regular_file(t / "out" / "contact" / "tiny.png"));
}

}  // namespace
