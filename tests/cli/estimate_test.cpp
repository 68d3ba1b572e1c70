// `sylva build --estimate` through the real binary: the bytes and files it reports per instance
// are those of the same instances in a real build of the spec (byte for byte: outputs are
// deterministic), its totals are per-instance figures × instance counts (of the dataset and of
// a shard), plots are measured like trees, nothing is written to --out and its scratch
// directory ($TMPDIR/sylva-estimate-*) is gone afterwards, and bad input is one line, exit 2.
// Times are only checked to be > 0.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::describeRun;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data";
// 2 species × 2 sweep points × 3 = 12 tiny trees with skeletons (ply, swc), a mesh, 2 views
// with labels and contact sheets.
const fs::path kTwoSpecies = kData / "merge_dataset.toml";
// 3 tiny trees, then plots "tiny-slope" (2) and "tiny-round" (1) with meshes, views, depth,
// labels and ids.
const fs::path kPlots = kData / "plot" / "build_plot.toml";

// Runs sylva in `work` with TMPDIR=`work`/scratch (made here), so the test sees the scratch.
sylva::test::CliResult sylva(const std::vector<std::string>& args, const fs::path& work) {
    fs::create_directories(work / "scratch");
    sylva::test::CliOptions o;
    o.env = {"TMPDIR=" + (work / "scratch").string()};
    o.logDir = work.parent_path();
    return sylva::test::runSylva(args, work, o);
}

bool isEmptyDir(const fs::path& dir) { return fs::is_directory(dir) && fs::is_empty(dir); }

// Sizes, count and per-kind bytes of the files under `dir`, as a reader that does not share
// the estimate's code sees them (the kind from the file name, spelled out here).
struct DirBytes {
    uint64_t bytes = 0, files = 0;
    std::map<std::string, uint64_t> byKind;
};
std::string kindOf(const fs::path& rel) {
    const std::string p = rel.generic_string(), name = rel.filename().string();
    if (p.rfind("views/", 0) == 0) {
        if (name.find("_depth.") != std::string::npos) return "depth";
        if (name.find("_label.") != std::string::npos) return "labels";
        if (name.find("_id.") != std::string::npos) return "ids";
        return "views";
    }
    if (name == "transforms.json" || name == "transforms_top.json") return "views";
    if (name.rfind("skeleton.", 0) == 0) return "skeleton";
    if (name.rfind("mesh", 0) == 0 || name.rfind("scene.", 0) == 0) return "mesh";
    if (name == "points.ply") return "points";
    if (name == "contact.png" || name == "preview.png") return "previews";
    if (name == "stats.json" || name == "plot.json" || name.rfind("trees.", 0) == 0) {
        return "stats";
    }
    return "other";
}
DirBytes dirBytes(const fs::path& dir) {
    DirBytes d;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (!e.is_regular_file()) continue;
        d.bytes += e.file_size();
        ++d.files;
        d.byKind[kindOf(e.path().lexically_relative(dir))] += e.file_size();
    }
    return d;
}

// The real manifest's line for `id`, without its timing block, re-serialised as sylva writes it
// (nlohmann's sorted keys and shortest round-trip numbers give back the same text).
uint64_t manifestBytesWithoutTiming(const fs::path& manifest, const std::string& id) {
    std::ifstream in(manifest);
    for (std::string line; std::getline(in, line);) {
        nlohmann::json r = nlohmann::json::parse(line);
        if (r["id"] != id) continue;
        r.erase("timing");
        return r.dump().size() + 1;
    }
    ADD_FAILURE() << id << " is not in " << manifest;
    return 0;
}

// Every sample's bytes, files and kinds against the real build's directory of that instance;
// the row's means against the mean of the real directories; its totals = mean × count.
void expectRowsMatchRealBuild(const nlohmann::json& estimate, const fs::path& real,
                              const std::string& treesOrPlots) {
    for (const nlohmann::json& row : estimate["rows"]) {
        const std::string name = row["name"];
        SCOPED_TRACE(name);
        const fs::path base = real / (row["kind"] == "plot" ? "plots" : treesOrPlots) / name;
        double bytes = 0, files = 0, manifest = 0;
        ASSERT_GT(row["samples"].size(), 0u);
        for (const nlohmann::json& s : row["samples"]) {
            const std::string id = s["id"];
            ASSERT_FALSE(s.contains("error")) << s.dump();
            const DirBytes d = dirBytes(base / id);
            EXPECT_EQ(s["bytes"].get<uint64_t>(), d.bytes) << id;
            EXPECT_EQ(s["files"].get<uint64_t>(), d.files) << id;
            for (const auto& [kind, b] : d.byKind) {
                EXPECT_EQ(s["bytes_by_kind"].value(kind, uint64_t{0}), b) << id << " " << kind;
            }
            EXPECT_GT(s["cpu_seconds"].get<double>(), 0.0) << id;
            EXPECT_GT(s["wall_seconds"].get<double>(), 0.0) << id;
            const uint64_t m = manifestBytesWithoutTiming(real / "manifest.jsonl", id);
            EXPECT_EQ(s["manifest_bytes"].get<uint64_t>(), m) << id;
            bytes += static_cast<double>(d.bytes);
            files += static_cast<double>(d.files);
            manifest += static_cast<double>(m);
        }
        const double n = static_cast<double>(row["samples"].size());
        EXPECT_EQ(row["bytes_per_instance"].get<double>(), bytes / n);
        EXPECT_EQ(row["files_per_instance"].get<double>(), files / n);
        EXPECT_EQ(row["manifest_bytes_per_instance"].get<double>(), manifest / n);
        const auto count = row["instances"].get<int64_t>();
        EXPECT_EQ(row["bytes"].get<int64_t>(), std::llround(bytes / n * count));
        EXPECT_EQ(row["files"].get<int64_t>(), std::llround(files / n * count));
        EXPECT_GT(row["cpu_seconds_per_instance"].get<double>(), 0.0);
    }
}

// Two species, two samples each (the first two instances of each species in the dataset's
// order: sweep point 0, indices 0 and 1), against a real build of the whole spec.
TEST(BuildEstimate, BytesPerTreeAreTheRealBuildsFilesOfTheSameInstances) {
    TempDir t;
    const fs::path work = t / "work";
    const auto e = sylva({"build", kTwoSpecies.string(), "--out", "out", "--estimate",
                          "--estimate-samples", "2", "--estimate-json", "estimate.json"},
                         work);
    ASSERT_EQ(e.code, 0) << describeRun(e);
    EXPECT_FALSE(fs::exists(work / "out")) << "--estimate wrote its --out";
    EXPECT_TRUE(isEmptyDir(work / "scratch")) << "the scratch directory was left behind";
    const nlohmann::json j = nlohmann::json::parse(slurp(work / "estimate.json"));
    ASSERT_EQ(j["rows"].size(), 2u);
    EXPECT_EQ(j["rows"][0]["name"], "tiny");
    EXPECT_EQ(j["rows"][1]["name"], "tiny-var");
    for (const nlohmann::json& row : j["rows"]) {
        EXPECT_EQ(row["instances"], 6);  // 2 sweep points × 3
        ASSERT_EQ(row["samples"].size(), 2u);
        const std::string species = row["name"];
        EXPECT_EQ(row["samples"][0]["id"], species + "-p000-00000");
        EXPECT_EQ(row["samples"][1]["id"], species + "-p000-00001");
        EXPECT_GT(row["bytes_per_instance_by_kind"].value("views", 0.0), 0.0);
        EXPECT_GT(row["bytes_per_instance_by_kind"].value("labels", 0.0), 0.0);
        EXPECT_GT(row["bytes_per_instance_by_kind"].value("mesh", 0.0), 0.0);
        EXPECT_GT(row["bytes_per_instance_by_kind"].value("skeleton", 0.0), 0.0);
    }
    // The table names both species and the totals.
    EXPECT_NE(e.out.find("tiny-var"), std::string::npos) << e.out;
    EXPECT_NE(e.out.find("dataset: 12 instances"), std::string::npos) << e.out;

    const auto b = sylva({"build", kTwoSpecies.string(), "--out", "real"}, work);
    ASSERT_EQ(b.code, 0) << describeRun(b);
    expectRowsMatchRealBuild(j, work / "real", "trees");
    int64_t bytes = 0, files = 0;
    for (const nlohmann::json& row : j["rows"]) {
        bytes += row["bytes"].get<int64_t>() + row["manifest_bytes"].get<int64_t>();
        files += row["files"].get<int64_t>();
    }
    EXPECT_NEAR(j["totals"]["bytes"].get<double>(), static_cast<double>(bytes), 2.0);
    EXPECT_NEAR(j["totals"]["files"].get<double>(), static_cast<double>(files), 2.0);
    EXPECT_EQ(j["totals"]["instances"], 12);

    // Deterministic: a second estimate reports the same bytes (times vary).
    const auto again = sylva({"build", kTwoSpecies.string(), "--estimate", "--estimate-json",
                              "again.json", "--threads", "1"},
                             work);
    ASSERT_EQ(again.code, 0) << describeRun(again);
    const nlohmann::json k = nlohmann::json::parse(slurp(work / "again.json"));
    for (size_t r = 0; r < 2; ++r) {
        EXPECT_EQ(k["rows"][r]["bytes_per_instance"], j["rows"][r]["bytes_per_instance"]);
        EXPECT_EQ(k["rows"][r]["bytes_per_instance_by_kind"],
                  j["rows"][r]["bytes_per_instance_by_kind"]);
    }
    EXPECT_EQ(k["cores"], 1);
}

// A 600,000-tree job sized from one sample, for shard 3 of 8: the totals are per-tree × count,
// the shard's are per-tree × its 75,000 instances; an existing --out is left as it was.
TEST(BuildEstimate, ALargeShardedJobScalesOneSampleAndLeavesOutAlone) {
    TempDir t;
    const fs::path work = t / "work";
    fs::create_directories(work / "out");
    {
        std::ofstream(work / "out" / "keep.txt") << "not the estimate's\n";
        std::ofstream spec(work / "big.toml");
        spec << "name = \"big\"\nseed = 3\n[[species]]\nfile = \""
             << (kData / "tiny.toml").generic_string()
             << "\"\ncount = 600000\n[views]\ncount = 2\nresolution = [32, 32]\n";
    }
    const auto e = sylva({"build", "big.toml", "--out", "out", "--shard", "3/8", "--estimate",
                          "--estimate-samples", "1", "--estimate-json", "e.json", "--threads", "4"},
                         work);
    ASSERT_EQ(e.code, 0) << describeRun(e);
    EXPECT_TRUE(isEmptyDir(work / "scratch"));
    std::vector<fs::path> inOut;
    for (const auto& f : fs::recursive_directory_iterator(work / "out")) inOut.push_back(f.path());
    ASSERT_EQ(inOut.size(), 1u);
    EXPECT_EQ(slurp(work / "out" / "keep.txt"), "not the estimate's\n");

    const nlohmann::json j = nlohmann::json::parse(slurp(work / "e.json"));
    ASSERT_EQ(j["rows"].size(), 1u);
    const nlohmann::json& row = j["rows"][0];
    EXPECT_EQ(row["instances"], 600000);
    EXPECT_EQ(row["instances_in_shard"], 75000);
    ASSERT_EQ(row["samples"].size(), 1u);
    EXPECT_EQ(row["samples"][0]["id"], "tiny-00000");
    const double perTree = row["bytes_per_instance"].get<double>();
    const double manifest = row["manifest_bytes_per_instance"].get<double>();
    const double cpu = row["cpu_seconds_per_instance"].get<double>();
    EXPECT_GT(perTree, 0.0);
    const double files = row["files_per_instance"].get<double>();
    EXPECT_GE(files, 4.0);  // skeleton.ply, 2 views, transforms.json (and a contact sheet)
    EXPECT_EQ(j["totals"]["instance_bytes"].get<int64_t>(), std::llround(perTree * 600000));
    EXPECT_EQ(j["totals"]["bytes"].get<int64_t>(),
              std::llround(perTree * 600000 + manifest * 600000));
    EXPECT_EQ(j["totals"]["files"].get<int64_t>(), std::llround(files * 600000));
    EXPECT_DOUBLE_EQ(j["totals"]["cpu_hours"].get<double>(), cpu * 600000 / 3600);
    EXPECT_DOUBLE_EQ(j["totals"]["wall_hours"].get<double>(), cpu * 600000 / 4 / 3600);
    EXPECT_EQ(j["shard"]["index"], 3);
    EXPECT_EQ(j["shard"]["count"], 8);
    EXPECT_EQ(j["shard"]["instances"], 75000);
    EXPECT_EQ(j["shard"]["instance_bytes"].get<int64_t>(), std::llround(perTree * 75000));
    EXPECT_EQ(j["shard"]["files"].get<int64_t>(), std::llround(files * 75000));
    EXPECT_EQ(j["cores"], 4);
    EXPECT_NE(e.out.find("shard 3/8: 75000 instances"), std::string::npos) << e.out;
}

// Plots are measured per plot, like trees: against a real build of the same spec.
TEST(BuildEstimate, PlotsAreMeasuredPerPlot) {
    TempDir t;
    const fs::path work = t / "work";
    const auto e = sylva({"build", kPlots.string(), "--estimate", "--estimate-samples", "1",
                          "--estimate-json", "plots.json"},
                         work);
    ASSERT_EQ(e.code, 0) << describeRun(e);
    EXPECT_TRUE(isEmptyDir(work / "scratch"));
    const nlohmann::json j = nlohmann::json::parse(slurp(work / "plots.json"));
    ASSERT_EQ(j["rows"].size(), 3u);
    EXPECT_EQ(j["rows"][0]["kind"], "species");
    EXPECT_EQ(j["rows"][1]["kind"], "plot");
    EXPECT_EQ(j["rows"][1]["name"], "tiny-slope");
    EXPECT_EQ(j["rows"][1]["instances"], 2);
    EXPECT_EQ(j["rows"][2]["name"], "tiny-round");
    for (size_t r = 1; r < 3; ++r) {
        EXPECT_GT(j["rows"][r]["bytes_per_instance_by_kind"].value("ids", 0.0), 0.0);
        EXPECT_GT(j["rows"][r]["bytes_per_instance_by_kind"].value("stats", 0.0), 0.0);
    }
    const auto b = sylva({"build", kPlots.string(), "--out", "real"}, work);
    ASSERT_EQ(b.code, 0) << describeRun(b);
    expectRowsMatchRealBuild(j, work / "real", "trees");
}

// Bad input: one line on stderr, exit 2, nothing written (no --out, no scratch left).
TEST(BuildEstimate, BadInputIsOneLineExitTwo) {
    TempDir t;
    const fs::path work = t / "work";
    const std::string spec = kTwoSpecies.string();
    const std::string badSpec = (kData / "bad" / "dataset_missing_species_file.toml").string();
    struct Case {
        std::vector<std::string> args;
        std::string expect;
    };
    const std::vector<Case> cases = {
        {{"build", spec, "--out", "out", "--estimate", "--estimate-samples", "0"},
         "--estimate-samples: expected an integer in [1, 1000], got \"0\""},
        {{"build", spec, "--out", "out", "--estimate", "--estimate-samples", "-1"},
         "--estimate-samples: expected an integer in [1, 1000], got \"-1\""},
        {{"build", spec, "--out", "out", "--estimate", "--estimate-samples", "1001"},
         "--estimate-samples: expected an integer in [1, 1000], got \"1001\""},
        {{"build", spec, "--out", "out", "--estimate-samples", "2"},
         "--estimate-samples: needs --estimate"},
        {{"build", spec, "--out", "out", "--estimate-json", "x.json"},
         "--estimate-json: needs --estimate"},
        {{"build", spec, "--out", "out", "--estimate", "--estimate-json", ""},
         "--estimate-json: expected a file"},
        {{"build", badSpec, "--out", "out", "--estimate"}, "dataset_missing_species_file.toml:11:"},
    };
    for (const Case& c : cases) {
        const auto r = sylva(c.args, work);
        SCOPED_TRACE(c.args.back());
        EXPECT_EQ(r.code, 2) << describeRun(r);
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << describeRun(r);
        EXPECT_NE(r.err.find(c.expect), std::string::npos) << describeRun(r);
        EXPECT_FALSE(fs::exists(work / "out"));
        EXPECT_FALSE(fs::exists(work / "x.json"));
        EXPECT_TRUE(isEmptyDir(work / "scratch"));
    }
}

}  // namespace
