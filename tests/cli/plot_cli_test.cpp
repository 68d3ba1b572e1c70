// Bad [[plot]] specs through the real binary: each fixture in tests/data/plot/bad/ (negative
// density, density and count both or neither, a spacing or rows that cannot hold the stems, a
// DEM missing, unreadable, not single-channel or too small, an unknown process, lai set twice,
// …) gives exit 2, one line on stderr with its file:line:col and key, through `sylva validate`
// and `sylva build --out X`, and writes nothing (X is not created). A fixture states what its
// error must say in leading comments: `# expect: <substring>` and `# line: <n>`. And a valid
// plots-only dataset validates.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kSource = SYLVA_SOURCE_DIR;
const fs::path kPlotData = kSource / "tests" / "data" / "plot";

using SylvaRun = sylva::test::CliResult;

// Runs sylva with `args` in `dir`, its output kept beside `dir` (the tests check that the
// failed runs write nothing into it).
SylvaRun sylva(const std::vector<std::string>& args, const fs::path& dir) {
    sylva::test::CliOptions o;
    o.logDir = dir.parent_path();
    return sylva::test::runSylva(args, dir, o);
}

std::vector<std::string> badPlotFixtures() { return sylva::test::tomlFiles(kPlotData / "bad"); }

class PlotBadSpec : public ::testing::TestWithParam<std::string> {};

TEST_P(PlotBadSpec, OneLineErrorExitTwoAndNothingWritten) {
    sylva::test::expectBadSpecFixture(kPlotData / "bad" / GetParam());
}

INSTANTIATE_TEST_SUITE_P(Cli, PlotBadSpec, ::testing::ValuesIn(badPlotFixtures()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                             return sylva::test::identifier(fs::path(info.param).stem().string());
                         });

// The kinds of error issue 16 lists each have a fixture.
TEST(PlotBadSpecs, FixturesCoverTheIssuesErrors) {
    const std::vector<std::string> names = badPlotFixtures();
    for (const char* want :
         {"negative_density.toml", "density_and_count.toml", "neither_density_nor_count.toml",
          "hard_core_does_not_fit.toml", "strauss_hard_does_not_fit.toml", "rows_do_not_fit.toml",
          "dem_missing.toml", "dem_unreadable.toml", "dem_not_single_channel.toml",
          "dem_too_small.toml", "unknown_process.toml", "lai_plot_and_species.toml"}) {
        EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
    }
}

TEST(PlotValidate, PlotsOnlyDatasetIsValid) {
    TempDir t;
    const fs::path work = t / "work";
    fs::create_directories(work);
    const SylvaRun r = sylva({"validate", (kPlotData / "plots.toml").string()}, work);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("0 species, 6 instances, 5 plots (6 plot instances)"), std::string::npos)
        << r.out;
}

// A plot's sweep points are read with the plot's files read once: validating 2,000 points of a
// plot with five library species (three with sketch images) and a DEM took 159 s when every
// point loaded and validated every species file again (79 ms a point); read once it takes about
// a second. The 120 s watchdog leaves that a margin of two orders of magnitude on a loaded
// machine and still fails the per-point reading.
TEST(PlotValidate, ASweepOfThousandsOfPointsReadsEachFileOnce) {
    TempDir t;
    const fs::path work = t / "work";
    fs::create_directories(work);
    std::string spec =
        "name = \"wide-sweep\"\n[[plot]]\nname = \"stand\"\nwidth = 40.0\ndepth = 40.0\n"
        "[plot.terrain]\nkind = \"dem\"\nfile = '" +
        (kPlotData / "dem_small.png").string() + "'\nmetres_per_pixel = 3.0\n";
    for (const char* name :
         {"silver-birch", "cedar-of-lebanon", "stone-pine", "mango", "pedunculate-oak"}) {
        spec += "[[plot.species]]\nfile = '" +
                (kSource / "species" / "presets" / (std::string(name) + ".toml")).string() +
                "'\ncount = 3\n";
    }
    spec += "[[sweep]]\nplots = [\"stand\"]\npath = \"margin\"\nvalues = [";
    for (int i = 0; i < 2000; ++i) spec += (i ? ", " : "") + std::to_string(1 + 0.001 * i);
    spec += "]\n";
    const fs::path file = t / "sweep.toml";
    std::ofstream(file) << spec;
    sylva::test::CliOptions o;
    o.logDir = t.path();
    o.watchdog = std::chrono::seconds(120);
    const SylvaRun r = sylva::test::runSylva({"validate", file.string()}, work, o);
    EXPECT_FALSE(r.hung) << "validate of 2,000 sweep points ran over 120 s";
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("2000 instances, 2000 plots"), std::string::npos) << r.out;
}

// A 100 km² plot (a 10 km square of 100 m terrain cells) of two stems builds in bounded memory:
// its canopy-cover raster was 10¹⁰ cells of 0.1 m and the build ran out of memory in a second;
// the raster now coarsens to hold at most 4 × 10⁷ cells (1.58 m here), as plot.json says.
TEST(PlotBuild, AHundredSquareKilometrePlotBuildsInBoundedMemory) {
    TempDir t;
    const fs::path spec = t / "huge.toml";
    std::ofstream(spec) << "name = \"huge\"\n[[plot]]\nname = \"huge\"\nwidth = 10000.0\n"
                           "depth = 10000.0\n[plot.terrain]\ncell = 100.0\n[[plot.species]]\n"
                           "file = '"
                        << (kSource / "tests" / "data" / "tiny.toml").string() << "'\ncount = 2\n";
    sylva::test::CliOptions o;
    o.logDir = t.path();
    o.addressSpace = rlim_t{3} << 30;
    o.watchdog = std::chrono::seconds(120);
    const SylvaRun r =
        sylva::test::runSylva({"build", spec.string(), "--out", (t / "out").string()}, t.path(), o);
    ASSERT_EQ(r.code, 0) << sylva::test::describeRun(r);
    const nlohmann::json plot =
        nlohmann::json::parse(slurp(t / "out" / "plots" / "huge" / "huge-00000" / "plot.json"));
    EXPECT_NEAR(plot["canopy_cell_m"].get<double>(), 1.5814, 1e-4);
    EXPECT_EQ(plot["area_m2"].get<double>(), 1e8);
}

// A long plot shows how far it has come, and has a time budget of its own. Its progress lines
// (every 10 s of a plot's growth or scan; SYLVA_TEST_PROGRESS_EVERY=0 shows every step of
// this small plot) name the plot, the phase and the count; [budget] max_plot_seconds stops a
// plot that outlives it, alone, named in the summary, and a rerun retries it.
TEST(PlotBuild, ProgressLinesAndAPlotTimeBudget) {
    TempDir t;
    sylva::test::CliOptions o;
    o.logDir = t.path();
    o.env = {"SYLVA_TEST_PROGRESS_EVERY=0"};
    const fs::path scanPlot = kSource / "tests" / "data" / "scan" / "uls_plot.toml";
    const SylvaRun r = sylva::test::runSylva(
        {"build", scanPlot.string(), "--out", (t / "out").string()}, t.path(), o);
    ASSERT_EQ(r.code, 0) << sylva::test::describeRun(r);
    EXPECT_NE(r.err.find("sylva: stand-00000: growing "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("sylva: stand-00000: finishing "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(" trees (elapsed "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("sylva: stand-00000: scanning "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(" pulses (elapsed "), std::string::npos) << r.err;

    const fs::path budgeted = t / "budgeted.toml";
    std::ofstream(budgeted) << "name = \"budgeted\"\n[budget]\nmax_plot_seconds = 1e-6\n"
                               "[[plot]]\nname = \"stand\"\nwidth = 10.0\ndepth = 10.0\n"
                               "[[plot.species]]\nfile = '"
                            << (kSource / "tests" / "data" / "tiny.toml").string()
                            << "'\ncount = 3\n";
    const SylvaRun over = sylva::test::runSylva(
        {"build", budgeted.string(), "--out", (t / "over").string()}, t.path(), o);
    EXPECT_NE(over.code, 0) << sylva::test::describeRun(over);
    EXPECT_NE(over.err.find("budget max_plot_seconds = 1e-06 exceeded"), std::string::npos)
        << over.err;
    EXPECT_NE(over.err.find("failed: "), std::string::npos) << over.err;
}

// The columns of a tree table that leaves do not change (id, name, species, base, DBH,
// nearest-neighbour distance): heights, crown radii and leaf areas include the leaves, which a
// same_seed LAI axis scales, and the crown base is the lowest leaf or leaf-carrying branch,
// which its thinning can move (a low branch keeps leaves at one LAI and none at another).
std::string woodColumns(const std::string& csv) {
    std::string out, line;
    std::istringstream in(csv);
    while (std::getline(in, line)) {
        std::vector<std::string> cells;
        std::istringstream cs(line);
        for (std::string c; std::getline(cs, c, ',');) cells.push_back(c);
        for (size_t k : {0, 1, 2, 3, 4, 5, 7, 17}) out += (k < cells.size() ? cells[k] : "?") + ",";
        out += "\n";
    }
    return out;
}

// A swept plot builds one plot per point: the manifest records the point's values, the LAI of
// each point is its swept value (within 5 %), points of the same_seed axis stand the same stems
// (the tree tables' wood columns equal), points of the other axis do not.
TEST(PlotSweepBuild, PointsBuildWithTheirValues) {
    TempDir t;
    const fs::path work = t / "work";
    fs::create_directories(work);
    const fs::path out = t / "out";
    const SylvaRun r = sylva(
        {"build", (kPlotData / "sweep.toml").string(), "--out", out.string(), "--threads", "2"},
        work);
    ASSERT_EQ(r.code, 0) << r.err;
    std::map<std::string, nlohmann::json> records;
    std::istringstream manifest(slurp(out / "manifest.jsonl"));
    for (std::string line; std::getline(manifest, line);) {
        const nlohmann::json j = nlohmann::json::parse(line);
        records[j["id"].get<std::string>()] = j;
    }
    ASSERT_EQ(records.size(), 6u);
    const double lai[] = {0.005, 0.01, 0.005, 0.01};
    for (int k = 0; k < 4; ++k) {
        const std::string id = "stand-p00" + std::to_string(k) + "-00000";
        ASSERT_TRUE(records.count(id)) << id;
        const nlohmann::json& j = records[id];
        EXPECT_EQ(j["plot"], "stand-p00" + std::to_string(k));
        EXPECT_EQ(j["sweep"]["species[0].density"], k < 2 ? "200" : "400");
        EXPECT_NEAR(j["stats"]["lai"].get<double>(), lai[k], 0.05 * lai[k]) << id;
    }
    EXPECT_FALSE(records["other-00000"].contains("sweep"));
    auto table = [&](int k) {
        const std::string p = "stand-p00" + std::to_string(k);
        return slurp(out / "plots" / p / (p + "-00000") / "trees.csv");
    };
    EXPECT_EQ(woodColumns(table(0)), woodColumns(table(1)));
    EXPECT_NE(table(0), table(1));  // the leaves were scaled to another LAI
    EXPECT_EQ(woodColumns(table(2)), woodColumns(table(3)));
    EXPECT_NE(woodColumns(table(0)), woodColumns(table(2)));
}

}  // namespace
