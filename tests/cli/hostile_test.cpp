// Hostile input, end to end (issue 15, item 5): every malformed species and dataset file in
// tests/data/hostile/ and every command-line misuse below makes the real binary (SYLVA_EXE)
// exit 2 with exactly ONE line on stderr that names the place (file:line:col and key, or the
// option), within 2 s, writing nothing — no --out directory, nothing in the working directory.
// "Within 2 s" is measured in CPU seconds (user + system) of the process, so that a loaded
// machine (ctest -j2 beside other jobs: 2.4 s of wall time for 0.2 s of work) does not fail it;
// the wall time is only bounded, at 30 s, against a run that hangs without working.
//
// A fixture states what its error must say in its leading comments:
//   # hostile: <what is wrong with it>
//   # at: <line>:<col> [<key path>]   the error is "<fixture>:<line>:<col>: <key path>: …"
//                                     (no key path for a TOML syntax error)
//   # expect: <substring>             (one or more)
// A species fixture is run through `validate`, `grow` and, listed in a dataset, `build`,
// whose error must then name the dataset line too ("uses_hostile.toml:3:8: species[0].file:
// in <fixture>:<line>:<col>: …"); a dataset fixture through `validate` and `build`. The
// broken images and SVGs they name are made by tests/data/hostile/make_images.py.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data";
const fs::path kHostile = kData / "hostile";
constexpr double kMaxCpuSeconds = 2.0;     // per run of the binary
constexpr double kMaxWallSeconds = 120.0;  // against a run that waits without working (a busy
                                           // machine starts a process in seconds)

using RunResult = sylva::test::CliResult;  // code, err, seconds, cpuSeconds used here

// Independent runs at the same time (process start-up dominates), stdout discarded.
std::vector<RunResult> runAll(const std::vector<std::vector<std::string>>& runs,
                              const fs::path& dir) {
    sylva::test::CliOptions o;
    o.keepStdout = false;
    return sylva::test::runAllSylva(runs, dir, o);
}

std::string describe(const std::vector<std::string>& args, const RunResult& r) {
    std::string cmd = "sylva";
    for (const auto& a : args) cmd += " '" + a + "'";
    return cmd + "\n  exit " + std::to_string(r.code) + " after " + std::to_string(r.seconds) +
           " s (" + std::to_string(r.cpuSeconds) + " s of CPU), stderr:\n" + r.err;
}

// Exit 2, exactly one line on stderr, in time.
void expectOneLine(const std::vector<std::string>& args, const RunResult& r) {
    EXPECT_EQ(r.code, 2) << describe(args, r);
    EXPECT_FALSE(r.err.empty()) << describe(args, r);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << describe(args, r);
    EXPECT_TRUE(!r.err.empty() && r.err.back() == '\n') << describe(args, r);
    EXPECT_LT(r.cpuSeconds, kMaxCpuSeconds) << describe(args, r);
    EXPECT_LT(r.seconds, kMaxWallSeconds) << describe(args, r);
}

// Nothing but `keep` in the working directory after the runs (no --out, no default out/).
void expectNothingWritten(const fs::path& dir, const std::vector<fs::path>& keep) {
    for (const auto& e : fs::directory_iterator(dir)) {
        if (std::find(keep.begin(), keep.end(), e.path()) == keep.end()) {
            ADD_FAILURE() << "written on bad input: " << e.path();
        }
    }
}

// --- the fixtures -------------------------------------------------------------------------

struct Fixture {
    fs::path path;
    std::string what;                 // # hostile:
    std::string at;                   // "<line>:<col>: <key>: " (or "<line>:<col>: ")
    std::vector<std::string> expect;  // # expect:
    bool dataset = false;
};

Fixture readFixture(const fs::path& p) {
    Fixture f;
    f.path = p;
    std::ifstream in(p, std::ios::binary);
    for (std::string l; std::getline(in, l);) {
        if (l.rfind("# hostile: ", 0) == 0) f.what = l.substr(11);
        if (l.rfind("# expect: ", 0) == 0) f.expect.push_back(l.substr(10));
        if (l.rfind("# at: ", 0) == 0) {
            const std::string v = l.substr(6);
            const size_t space = v.find(' ');
            f.at = space == std::string::npos
                       ? v + ": "
                       : v.substr(0, space) + ": " + v.substr(space + 1) + ": ";
        }
        if (l.rfind("[[species]]", 0) == 0 || l.rfind("species = ", 0) == 0) f.dataset = true;
    }
    return f;
}

std::vector<std::string> fixtureNames() {
    std::vector<std::string> names;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(kHostile, ec)) {
        if (e.path().extension() == ".toml") names.push_back(e.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

// The error names the fixture's place and key and says what it expects.
void expectFixtureError(const std::vector<std::string>& args, const RunResult& r,
                        const Fixture& f) {
    expectOneLine(args, r);
    const std::string at = "/" + f.path.filename().string() + ":" + f.at;
    EXPECT_NE(r.err.find(at), std::string::npos)
        << "expected \"" << at << "\" in: " << describe(args, r);
    for (const std::string& e : f.expect) {
        EXPECT_NE(r.err.find(e), std::string::npos)
            << "expected \"" << e << "\" in: " << describe(args, r);
    }
}

class HostileSpec : public ::testing::TestWithParam<std::string> {};

TEST_P(HostileSpec, OneLineAtTheKeyExitTwoNothingWrittenUnderTwoSeconds) {
    const Fixture f = readFixture(kHostile / GetParam());
    ASSERT_FALSE(f.what.empty()) << f.path << " has no '# hostile:' line";
    ASSERT_FALSE(f.at.empty()) << f.path << " has no '# at:' line";
    ASSERT_FALSE(f.expect.empty()) << f.path << " has no '# expect:' line";
    // A key path is required unless the file is not TOML at all.
    const bool syntax = std::any_of(f.expect.begin(), f.expect.end(), [](const std::string& e) {
        return e.find("TOML syntax error") != std::string::npos;
    });
    EXPECT_TRUE(syntax || std::count(f.at.begin(), f.at.end(), ':') == 3)
        << f.path << ": '# at:' names no key";
    TempDir t;
    const fs::path buildOut = t / "build_out", growOut = t / "grow_out";
    const fs::path wrapper = t / "uses_hostile.toml";
    std::vector<std::vector<std::string>> runs = {{"validate", f.path.string()}};
    if (f.dataset) {
        runs.push_back({"build", f.path.string(), "--out", buildOut.string()});
    } else {
        std::ofstream(wrapper) << "name = \"uses-hostile\"\n[[species]]\nfile = '"
                               << f.path.string() << "'\ncount = 2\n";
        runs.push_back({"grow", f.path.string(), "--out", growOut.string()});
        runs.push_back({"build", wrapper.string(), "--out", buildOut.string()});
    }
    const std::vector<RunResult> r = runAll(runs, t.path());
    for (size_t i = 0; i < r.size(); ++i) expectFixtureError(runs[i], r[i], f);
    if (!f.dataset) {
        // Through a dataset, the error names the dataset line that lists the species first.
        const std::string prefix = wrapper.string() + ":3:8: species[0].file: in ";
        EXPECT_EQ(r.back().err.rfind(prefix, 0), 0u) << "expected it to start with \"" << prefix
                                                     << "\": " << describe(runs.back(), r.back());
    }
    EXPECT_FALSE(fs::exists(buildOut));
    EXPECT_FALSE(fs::exists(growOut));
    expectNothingWritten(t.path(), {wrapper});
}

INSTANTIATE_TEST_SUITE_P(Cli, HostileSpec, ::testing::ValuesIn(fixtureNames()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                             return sylva::test::identifier(fs::path(info.param).stem().string());
                         });

TEST(HostileSpecs, AtLeastSixtyFixturesOfEveryKind) {
    const std::vector<std::string> names = fixtureNames();
    EXPECT_GE(names.size(), 60u);
    // Each kind of hostile input the issue lists has fixtures (by name prefix).
    for (const char* kind :
         {"int_key_",       "number_",      "vec3_",          "interval_",        "dist_",
          "unknown_key_",   "duplicate_",   "name_",          "syntax_",          "grammar_",
          "lsystem_",       "mask_",        "canopy_",        "guide_",           "visual_hull_",
          "stroke_image_",  "svg_",         "dataset_count_", "dataset_species_", "dataset_sweep_",
          "dataset_views_", "dataset_name_"}) {
        EXPECT_TRUE(std::any_of(names.begin(), names.end(),
                                [&](const std::string& n) { return n.rfind(kind, 0) == 0; }))
            << "no fixture named " << kind << "*";
    }
}

// --- command-line misuse --------------------------------------------------------------------

struct Misuse {
    std::vector<std::string> args;  // "OUT" becomes the scratch --out path
    std::vector<std::string> expect;
};

const std::string kDataset = (kData / "tiny_dataset.toml").string();
const std::string kSpecies = (kData / "tiny.toml").string();

const std::vector<Misuse> kMisuse = {
    // --threads: [0, 1024]
    {{"build", kDataset, "--out", "OUT", "--threads", "-1"},
     {"sylva build: --threads: expected an integer in [0, 1024]", "got \"-1\""}},
    {{"build", kDataset, "--out", "OUT", "--threads", "100000"}, {"--threads", "got \"100000\""}},
    {{"build", kDataset, "--out", "OUT", "--threads", "100000000"}, {"--threads", "[0, 1024]"}},
    {{"build", kDataset, "--out", "OUT", "--threads", "1.5"}, {"--threads", "got \"1.5\""}},
    {{"build", kDataset, "--out", "OUT", "--threads", "two"}, {"--threads", "got \"two\""}},
    {{"build", kDataset, "--out", "OUT", "--threads"}, {"--threads: expected a value"}},
    {{"build", kDataset, "--out", "OUT", "--threads", "1", "--threads", "2"},
     {"--threads: given more than once"}},
    {{"grow", kSpecies, "--out", "OUT", "--threads", "-1"}, {"sylva grow: --threads"}},
    // --shard: I/N with 0 ≤ I < N
    {{"build", kDataset, "--out", "OUT", "--shard", ""},
     {"sylva build: --shard: expected I/N", "got \"\""}},
    {{"build", kDataset, "--out", "OUT", "--shard", "3/2"}, {"--shard", "got \"3/2\""}},
    {{"build", kDataset, "--out", "OUT", "--shard", "2/2"}, {"--shard", "got \"2/2\""}},
    {{"build", kDataset, "--out", "OUT", "--shard", "0/0"}, {"--shard", "got \"0/0\""}},
    {{"build", kDataset, "--out", "OUT", "--shard", "a/b"}, {"--shard", "got \"a/b\""}},
    {{"build", kDataset, "--out", "OUT", "--shard", "-1/2"}, {"--shard"}},
    {{"build", kDataset, "--out", "OUT", "--shard", "+1/2"}, {"--shard"}},
    {{"build", kDataset, "--out", "OUT", "--shard", " 1/2"}, {"--shard"}},
    {{"build", kDataset, "--out", "OUT", "--shard", "1/2/3"}, {"--shard"}},
    {{"build", kDataset, "--out", "OUT", "--shard", "1/99999999999999999999"}, {"--shard"}},
    // --seed: a decimal integer in [0, 2⁶⁴ − 1], never wrapped around
    {{"grow", kSpecies, "--out", "OUT", "--seed", "banana"},
     {"sylva grow: --seed: expected an integer in [0, 18446744073709551615]", "\"banana\""}},
    {{"grow", kSpecies, "--out", "OUT", "--seed", "-1"}, {"--seed", "got \"-1\""}},
    {{"grow", kSpecies, "--out", "OUT", "--seed", "18446744073709551616"}, {"--seed"}},
    {{"grow", kSpecies, "--out", "OUT", "--seed", "1e3"}, {"--seed"}},
    {{"volume", kSpecies, "--out", "OUT", "--seed", "-5"}, {"sylva volume: --seed"}},
    // --voxel: finite metres > 0
    {{"volume", kSpecies, "--out", "OUT", "--voxel", "-0.1"},
     {"sylva volume: --voxel: expected a number of metres > 0", "got \"-0.1\""}},
    {{"volume", kSpecies, "--out", "OUT", "--voxel", "0"}, {"--voxel"}},
    {{"volume", kSpecies, "--out", "OUT", "--voxel", "nan"}, {"--voxel", "\"nan\""}},
    {{"volume", kSpecies, "--out", "OUT", "--voxel", "inf"}, {"--voxel"}},
    {{"volume", kSpecies, "--out", "OUT", "--voxel", "1e308"}, {"--voxel"}},
    {{"volume", kSpecies, "--out", "OUT", "--voxel", "1e-300"}, {"--voxel 1e-300 m is too fine"}},
    // misspelt and unknown options and commands, missing and extra arguments
    {{"build", kDataset, "--out", "OUT", "--thread", "2"},
     {"sylva build: unknown option --thread; did you mean --threads?"}},
    {{"grow", kSpecies, "--out", "OUT", "--sed", "5"},
     {"unknown option --sed; did you mean --seed?"}},
    {{"build", kDataset, "--out", "OUT", "--no-such-option"}, {"unknown option --no-such-option"}},
    {{"build"}, {"sylva build: SPEC is required"}},
    {{"build", "", "--out", "OUT"}, {"sylva build: SPEC: expected a path"}},
    {{"validate", ""}, {"sylva validate: SPEC: expected a path"}},
    {{"validate", kSpecies, kDataset}, {"sylva validate: unexpected argument"}},
    {{"grow", "", "--out", "OUT"}, {"sylva grow: SPECIES: expected a path"}},
    {{"stats", ""}, {"sylva stats: DIR: expected a path"}},
    {{"report", ""}, {"sylva report: DIR: expected a path"}},
    {{"gates", ""}, {"sylva gates: DIR: expected a path"}},
    {{"species", "list", ""}, {"sylva species list: DIR: expected a path"}},
    {{"species", "lst"}, {"sylva species: unknown subcommand \"lst\""}},
    {{"species"}, {"sylva species: expected a subcommand"}},
    {{"merge", "OUT"}, {"sylva merge: SHARD_DIRS is required"}},
    {{"stats", kData.string(), "--no-timing=x"},
     {"sylva stats: --no-timing: cannot take the value \"x\""}},
    {{"build", kSpecies, "--out", "OUT"}, {"this is a species file", "sylva grow"}},
    {{}, {"sylva: expected a command"}},
    {{"frobnicate"}, {"sylva: unknown command \"frobnicate\""}},
    {{"buidl", kDataset}, {"unknown command \"buidl\"; did you mean \"build\"?"}},
    {{"--threads", "2"}, {"sylva: unknown option --threads"}},
};

class HostileCli : public ::testing::TestWithParam<size_t> {};

TEST_P(HostileCli, OneLineNamingTheOptionExitTwoNothingWritten) {
    const Misuse& m = kMisuse[GetParam()];
    TempDir t;
    const fs::path out = t / "out_dir";
    std::vector<std::string> args = m.args;
    for (std::string& a : args) {
        if (a == "OUT") a = out.string();
    }
    const RunResult r = runAll({args}, t.path())[0];
    expectOneLine(args, r);
    for (const std::string& e : m.expect) {
        EXPECT_NE(r.err.find(e), std::string::npos)
            << "expected \"" << e << "\" in: " << describe(args, r);
    }
    EXPECT_FALSE(fs::exists(out)) << describe(args, r);
    expectNothingWritten(t.path(), {});
}

INSTANTIATE_TEST_SUITE_P(Cli, HostileCli, ::testing::Range<size_t>(0, kMisuse.size()),
                         [](const ::testing::TestParamInfo<size_t>& info) {
                             // "n07_build_threads_1_5": the index, then the arguments that are
                             // not paths.
                             std::string n = "n" + std::string(info.param < 10 ? "0" : "") +
                                             std::to_string(info.param);
                             for (const std::string& a : kMisuse[info.param].args) {
                                 if (a == "OUT" || a == "--out" || a.find('/') == 0) continue;
                                 std::string w;
                                 for (char c : a) {
                                     if (std::isalnum(static_cast<unsigned char>(c))) w += c;
                                 }
                                 if (!w.empty()) n += "_" + w;
                             }
                             return n;
                         });

}  // namespace
