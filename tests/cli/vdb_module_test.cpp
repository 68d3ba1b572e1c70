// OpenVDB is a module opened on first use (volumes/vdb_module.h): a species with a level-set
// crown grows through it, one without never loads it, and one that needs it without the module
// fails with one line and writes nothing (that start-up loads no module: oiio_module_test.cpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::CliOptions;
using sylva::test::describeRun;
using sylva::test::runSylva;
using sylva::test::TempDir;

const fs::path kSource = SYLVA_SOURCE_DIR;

TEST(CliVdbModule, ALevelSetCrownLoadsTheModuleOthersDoNotAndWithoutItIsOneLine) {
    TempDir t;
    // xm-h's crown is realised as a level set (`voxel_size`).
    const std::string levelSet = (kSource / "species/papers/xu-mould-2012/xm-h.toml").string();
    CliOptions traced;
    traced.env = {"LD_DEBUG=libs"};
    const auto grown =
        runSylva({"grow", levelSet, "--seed", "1", "--out", (t / "a").string()}, t.path(), traced);
    ASSERT_EQ(grown.code, 0) << describeRun(grown);
    EXPECT_NE(grown.err.find("libsylva_vdb.so"), std::string::npos);
    EXPECT_NE(grown.err.find("libopenvdb"), std::string::npos);
    EXPECT_GT(fs::file_size(t / "a" / "skeleton.ply"), 1000u);

    const std::string plain = (kSource / "tests/data/tiny.toml").string();
    const auto other =
        runSylva({"grow", plain, "--seed", "1", "--out", (t / "b").string()}, t.path(), traced);
    ASSERT_EQ(other.code, 0) << describeRun(other);
    EXPECT_NE(other.err.find("libtbb"), std::string::npos) << "LD_DEBUG printed no library list";
    EXPECT_EQ(other.err.find("libsylva_vdb.so"), std::string::npos);
    EXPECT_EQ(other.err.find("libopenvdb"), std::string::npos);

    CliOptions missing;
    missing.env = {"SYLVA_VDB_MODULE=" + (t / "nowhere" / "libsylva_vdb.so").string()};
    const auto failed =
        runSylva({"grow", levelSet, "--seed", "1", "--out", (t / "c").string()}, t.path(), missing);
    EXPECT_NE(failed.code, 0) << describeRun(failed);
    EXPECT_EQ(std::count(failed.err.begin(), failed.err.end(), '\n'), 1) << failed.err;
    EXPECT_NE(failed.err.find("cannot load libsylva_vdb.so"), std::string::npos) << failed.err;
    EXPECT_NE(failed.err.find("SYLVA_VDB_MODULE"), std::string::npos) << failed.err;
    EXPECT_FALSE(fs::exists(t / "c"));
}

// A build whose outputs need a module opens it before it writes anything: without it, one line
// naming the module and no output directory (not a failure per tree). Watertight meshes need
// OpenVDB's; colour views as JPEG, OpenImageIO's.
TEST(CliVdbModule, ABuildThatNeedsAMissingModuleIsOneLineAndWritesNothing) {
    TempDir t;
    const std::string tiny = (kSource / "tests/data/tiny.toml").string();
    const std::string head = "name = \"needs\"\nseed = 1\n[[species]]\nfile = \"" + tiny +
                             "\"\ncount = 2\n[outputs]\nskeleton = [\"ply\"]\n";
    std::ofstream(t / "watertight.toml") << head << "mesh = [\"ply\"]\nwatertight = true\n";
    std::ofstream(t / "jpeg.toml")
        << head
        << "[views]\ncount = 1\nresolution = [32, 32]\ncolour = true\n"
           "colour_format = \"jpg\"\ncolour_background = \"colour\"\ncontact_sheet = false\n";
    for (const auto& [spec, env, module] :
         {std::tuple{"watertight.toml", "SYLVA_VDB_MODULE", "libsylva_vdb.so"},
          std::tuple{"jpeg.toml", "SYLVA_OIIO_MODULE", "libsylva_oiio.so"}}) {
        CliOptions missing;
        missing.env = {std::string(env) + "=" + (t / "nowhere" / module).string()};
        const fs::path out = t / (std::string(spec) + ".out");
        const auto failed =
            runSylva({"build", (t / spec).string(), "--out", out.string()}, t.path(), missing);
        EXPECT_EQ(failed.code, 1) << spec << ": " << describeRun(failed);
        EXPECT_EQ(std::count(failed.err.begin(), failed.err.end(), '\n'), 1) << failed.err;
        EXPECT_NE(failed.err.find(std::string("cannot load ") + module), std::string::npos)
            << failed.err;
        EXPECT_FALSE(fs::exists(out)) << spec;
        // With the module, the same spec builds.
        const fs::path built = t / (std::string(spec) + ".built");
        const auto ok = runSylva({"build", (t / spec).string(), "--out", built.string()}, t.path());
        EXPECT_EQ(ok.code, 0) << spec << ": " << describeRun(ok);
    }
}

}  // namespace
