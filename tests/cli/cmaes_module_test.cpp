// pagmo2 is a module opened on first use (pipeline/analysis/cmaes_module.h): `sylva fit` runs
// through it, and a fit without the module fails with one line before it writes anything (that
// start-up loads neither module: oiio_module_test.cpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::CliOptions;
using sylva::test::describeRun;
using sylva::test::runSylva;
using sylva::test::TempDir;

const fs::path kTinyFit = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data" / "fit" / "tiny-pipe.toml";

TEST(CliCmaesModule, AFitLoadsTheModuleAndWithoutItIsOneLineAndNoFiles) {
    TempDir t;
    CliOptions traced;
    traced.env = {"LD_DEBUG=libs"};
    const fs::path out = t / "a" / "tiny.toml";
    const auto fitted = runSylva(
        {"fit", kTinyFit.string(), "--out", out.string(), "--evaluations", "10"}, t.path(), traced);
    ASSERT_EQ(fitted.code, 0) << describeRun(fitted);
    EXPECT_NE(fitted.err.find("libsylva_cmaes.so"), std::string::npos);
    EXPECT_NE(fitted.err.find("libpagmo"), std::string::npos);
    EXPECT_TRUE(fs::is_regular_file(out));

    CliOptions missing;
    missing.env = {"SYLVA_CMAES_MODULE=" + (t / "nowhere" / "libsylva_cmaes.so").string()};
    const fs::path none = t / "b" / "tiny.toml";
    const auto failed =
        runSylva({"fit", kTinyFit.string(), "--out", none.string(), "--evaluations", "10"},
                 t.path(), missing);
    EXPECT_EQ(failed.code, 1) << describeRun(failed);
    EXPECT_EQ(std::count(failed.err.begin(), failed.err.end(), '\n'), 1) << failed.err;
    EXPECT_NE(failed.err.find("cannot load libsylva_cmaes.so"), std::string::npos) << failed.err;
    EXPECT_NE(failed.err.find("SYLVA_CMAES_MODULE"), std::string::npos) << failed.err;
    EXPECT_FALSE(fs::exists(t / "b"));
}

}  // namespace
