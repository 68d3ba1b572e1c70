// `sylva fit` end to end: a small fit through the command line (1 and 2 threads give the same
// bytes), and every bad [fit] table in tests/data/fit/bad/ is one line naming file:line:col,
// exit 2, nothing written.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::CliOptions;
using sylva::test::CliResult;
using sylva::test::describeRun;
using sylva::test::runSylva;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kFitData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data" / "fit";

TEST(FitCli, OneAndTwoThreadsWriteTheSameFiles) {
    TempDir t;
    const std::string spec = (kFitData / "tiny-pipe.toml").string();
    std::vector<std::string> bytes;
    for (const char* threads : {"1", "2"}) {
        const fs::path out = t / threads / "tiny.toml";
        const CliResult r = runSylva(
            {"fit", spec, "--out", out.string(), "--threads", threads, "--evaluations", "10"},
            t.path());
        ASSERT_EQ(r.code, 0) << describeRun(r);
        EXPECT_NE(r.out.find("in 10 evaluations (0 from the log)"), std::string::npos) << r.out;
        EXPECT_NE(r.err.find("generation 1/1, 10 evaluations"), std::string::npos) << r.err;
        std::string all;
        for (const char* ext : {"", ".fit.jsonl", ".fit.md", ".fit.svg"}) {
            ASSERT_TRUE(fs::is_regular_file(out.string() + ext)) << out << ext;
            all += slurp(out.string() + ext) + "\n----\n";
        }
        bytes.push_back(all);
    }
    EXPECT_EQ(bytes[0], bytes[1]);
    // Run again: every evaluation comes from the log, the files are the same.
    const fs::path out = t / "1" / "tiny.toml";
    const CliResult again =
        runSylva({"fit", spec, "--out", out.string(), "--evaluations", "10"}, t.path());
    ASSERT_EQ(again.code, 0) << describeRun(again);
    EXPECT_NE(again.out.find("(10 from the log)"), std::string::npos) << again.out;
}

TEST(FitCli, BadOptionsAndFilesAreOneLineExitTwo) {
    TempDir t;
    const std::string spec = (kFitData / "tiny-pipe.toml").string();
    const fs::path work = t / "work";
    fs::create_directories(work);
    CliOptions o;
    o.logDir = t.path();
    struct Case {
        std::vector<std::string> args;
        std::string expect;
    };
    const std::vector<Case> cases = {
        {{"fit", spec, "--evaluations", "9"}, "--evaluations: expected at least 10"},
        {{"fit", spec, "--reference", "nope.json"}, "--reference: file not found: nope.json"},
        {{"fit", spec, "--seed", "-1"}, "--seed"},
        {{"fit", (fs::path(SYLVA_SOURCE_DIR) / "tests/data/tiny.toml").string()},
         "expected a [fit] table"},
    };
    for (const Case& c : cases) {
        const CliResult r = runSylva(c.args, work, o);
        EXPECT_EQ(r.code, 2) << describeRun(r);
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
        EXPECT_NE(r.err.find(c.expect), std::string::npos) << r.err;
    }
    EXPECT_TRUE(fs::is_empty(work)) << "a failed fit wrote into " << work;
}

class FitBadSpec : public ::testing::TestWithParam<std::string> {};

TEST_P(FitBadSpec, OneLineAtItsPlaceExitTwoNothingWritten) {
    const fs::path spec = kFitData / "bad" / GetParam();
    const auto [expect, line] = sylva::test::fixtureComments(spec);
    ASSERT_FALSE(expect.empty()) << spec;
    ASSERT_GT(line, 0) << spec;
    TempDir t;
    const fs::path work = t / "work";
    fs::create_directories(work);
    CliOptions o;
    o.logDir = t.path();
    expectOneLineAt(runSylva({"fit", spec.string(), "--out", "fit/x.toml"}, work, o), spec, line,
                    expect);
    EXPECT_TRUE(fs::is_empty(work)) << "the failed fit wrote into " << work;
    // The species itself is valid: `sylva validate` does not read [fit].
    const CliResult v = runSylva({"validate", spec.string()}, work, o);
    EXPECT_EQ(v.code, 0) << describeRun(v);
}

INSTANTIATE_TEST_SUITE_P(Fixtures, FitBadSpec,
                         ::testing::ValuesIn(sylva::test::tomlFiles(kFitData / "bad")),
                         [](const auto& info) {
                             return sylva::test::identifier(fs::path(info.param).stem().string());
                         });

}  // namespace
