// The realism gates over the library itself (pipeline/analysis/realism_gates.h): 16 trees of
// every species in species/presets/ built from datasets/realism-gates.toml, every gate passed,
// each species' size and crown proportions inside those measured on its species (or genus) in
// the Biomass And Allometry Database (species/reference/baad-allometry.json), and the broadleaves
// as near the measured trees held out of fitting as docs/library.md says they are.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <vector>

#include "pipeline/analysis/dataset_stats.h"
#include "pipeline/analysis/realism_gates.h"
#include "pipeline/batch/build.h"
#include "pipeline/batch/dataset.h"
#include "pipeline/formats/skeleton_reader.h"
#include "species/model/tree_metrics.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Per species, the median over its instances of height, crown diameter / height (the mean of
// the crown's two principal extents) and crown depth / height, as baad-allometry.json names
// them.
std::map<std::string, std::map<std::string, double>> allometry(const fs::path& manifest) {
    std::map<std::string, std::map<std::string, std::vector<double>>> values;
    std::ifstream in(manifest);
    for (std::string line; std::getline(in, line);) {
        const nlohmann::json r = nlohmann::json::parse(line);
        const nlohmann::json& st = r["stats"];
        const double h = st["height_m"].get<double>();
        auto& v = values[r["species"].get<std::string>()];
        v["height_m"].push_back(h);
        v["crown_diameter_ratio"].push_back(
            0.5 * (st["crown_width_major_m"].get<double>() + st["crown_depth_m"].get<double>()) /
            h);
        v["crown_depth_ratio"].push_back(st["crown_height_m"].get<double>() / h);
    }
    std::map<std::string, std::map<std::string, double>> out;
    for (auto& [species, byKey] : values) {
        for (auto& [key, v] : byKey) out[species][key] = median(v);
    }
    return out;
}

// Per species (trees; not palms or bamboo, whose crowns of fronds or culms are no pipe-model
// forks), the forks at least 2 cm thick whose thickest child is under half their radius: a stub
// under sprouts. Of the TreeQSM reference trees' forks 0.4 % are (tree-weighted; the median tree
// has none); the library bounds its forks at 0.5 (`pipe_min_child_ratio`), so it has none.
std::map<std::string, int> forkSteps(const fs::path& manifest, const fs::path& root) {
    std::map<std::string, int> steps;
    std::ifstream in(manifest);
    for (std::string line; std::getline(in, line);) {
        const nlohmann::json r = nlohmann::json::parse(line);
        const std::string habit = r.value("habit", "");
        if (habit == "palm" || habit == "clump") continue;
        const std::string species = r["species"].get<std::string>();
        const fs::path file = root / r["files"]["skeleton_ply"].get<std::string>();
        std::ifstream s(file, std::ios::binary);
        const std::string bytes((std::istreambuf_iterator<char>(s)), {});
        const Tree tree = readSkeletonPly(bytes, file.string());
        const ChildIndex kids(tree);
        int& n = steps[species];
        for (int32_t i = 0; i < static_cast<int32_t>(tree.nodes.size()); ++i) {
            if (kids.offset[i + 1] - kids.offset[i] < 2 || tree.nodes[i].radius < 0.02) continue;
            double thickest = 0.0;
            for (int32_t k = kids.offset[i]; k < kids.offset[i + 1]; ++k) {
                thickest = std::max(thickest, tree.nodes[kids.child[k]].radius);
            }
            if (thickest < 0.5 * tree.nodes[i].radius * (1 - 1e-6)) ++n;
        }
    }
    return steps;
}

// The library: every species in species/presets/, 16 trees each, passes every gate. The table
// is printed (and written to $SYLVA_GATES_TABLE when set, for the README).
TEST(RealismGates, EveryLibrarySpeciesPasses) {
    const fs::path source = SYLVA_SOURCE_DIR;
    const DatasetSpec spec = loadDataset((source / "datasets/realism-gates.toml").string());
    std::set<std::string> listed, presets;
    for (const SpeciesEntry& e : spec.species) {
        EXPECT_EQ(e.count, 16) << e.species.path;
        listed.insert(fs::weakly_canonical(e.species.path).string());
    }
    for (const auto& e : fs::directory_iterator(source / "species/presets")) {
        if (e.path().extension() == ".toml") presets.insert(fs::weakly_canonical(e.path()));
    }
    EXPECT_EQ(listed, presets) << "datasets/realism-gates.toml must list every preset";
    ASSERT_GE(presets.size(), 1u);

    const fs::path out = fs::temp_directory_path() / ("sylva_gates_" + std::to_string(getpid()));
    fs::remove_all(out);
    BuildOptions o;
    o.out = out;
    o.progress = false;
    const BuildSummary b = buildDataset(spec, o);
    EXPECT_EQ(b.failed, 0);
    const std::vector<SpeciesGates> gates = evaluateGates(out);
    const auto measured = allometry(out / "manifest.jsonl");
    const auto steps = forkSteps(out / "manifest.jsonl", out);
    DatasetStatsOptions statsOptions;
    statsOptions.timing = false;
    statsOptions.reference = source / "species/reference/treeqsm-broadleaf-holdout.json";
    const DatasetStatsResult held = computeDatasetStats(out, statsOptions);
    fs::remove_all(out);
    EXPECT_GE(steps.size(), 30u);
    for (const auto& [species, n] : steps) EXPECT_EQ(n, 0) << species << ": forks thicker than 2 x";
    const std::string table = gatesMarkdown(gates);
    std::cout << table;
    if (const char* path = std::getenv("SYLVA_GATES_TABLE")) std::ofstream(path) << table;
    EXPECT_EQ(gates.size(), presets.size());
    for (const SpeciesGates& s : gates) {
        EXPECT_EQ(s.instances, 16) << s.species;
        for (const GateResult& g : s.gates) {
            EXPECT_TRUE(g.pass) << s.species << ": " << g.gate << " = " << g.value << " "
                                << g.detail;
        }
    }

    // Inside the range BAAD observed on the species, or on its genus where the species has no
    // record (at least 10 trees of a measure), where BAAD's trees reach the species' height:
    // saplings' proportions say nothing of grown trees (BAAD's european ash are 2–6 m
    // understorey saplings, its figs 19 forest saplings up to 10.7 m).
    std::ifstream bin(source / "species/reference/baad-allometry.json");
    const nlohmann::json baad = nlohmann::json::parse(bin);
    int checked = 0;
    for (const auto& [species, entry] : baad["species"].items()) {
        const nlohmann::json* block = entry.contains("species") ? &entry["species"]
                                      : entry.contains("genus") ? &entry["genus"]
                                                                : nullptr;
        if (!block || !measured.count(species)) continue;
        if (!block->contains("height_m") ||
            (*block)["height_m"]["max"].get<double>() < measured.at(species).at("height_m")) {
            continue;
        }
        for (const char* key : {"height_m", "crown_diameter_ratio", "crown_depth_ratio"}) {
            if (!block->contains(key) || (*block)[key]["n"].get<int>() < 10) continue;
            const double v = measured.at(species).at(key);
            EXPECT_GE(v, (*block)[key]["min"].get<double>()) << species << " " << key;
            EXPECT_LE(v, (*block)[key]["max"].get<double>()) << species << " " << key;
            ++checked;
        }
    }
    EXPECT_GE(checked, 20);

    // Against the 25 measured trees held out of fitting, on the six distributions of the aim
    // (docs/library.md: D < 0.2 on four of six and < 0.3 on all six): every broadleaf but the two
    // whose form conflicts with the measured trees' (a draped column, a fastigiate column) meets
    // it, and the mean D and the count below 0.2 are no worse than docs/library.md and the README
    // give. The build is deterministic, so these are the same numbers on every run.
    // The six: the reference distributions up to order-2 branch lengths, in enum order.
    const std::set<std::string> outOfAim = {"ashoka", "lombardy-poplar"};
    double sum = 0.0;
    int count = 0, below = 0;
    size_t broadleaves = 0;
    std::set<std::string> missing;
    for (const SpeciesGates& s : gates) {
        if (s.habit != "tree") continue;
        ++broadleaves;
        int under02 = 0;
        bool under03 = true;
        for (int k = kRadiusRatio; k <= kBranchLengthOrder2; ++k) {
            const char* d = kReferenceDistributionNames[k];
            const auto& c = held.reference.at(s.species).at(d);
            ASSERT_TRUE(c.d.has_value()) << s.species << " " << d;
            sum += *c.d;
            ++count;
            below += *c.d < 0.2;
            under02 += *c.d < 0.2;
            under03 = under03 && *c.d < 0.3;
        }
        if (!(under02 >= 4 && under03)) missing.insert(s.species);
    }
    EXPECT_EQ(broadleaves, 27u);
    EXPECT_EQ(missing, outOfAim) << "broadleaves out of the aim against the held-out trees";
    EXPECT_LE(sum / count, 0.150) << "mean held-out D";
    EXPECT_GE(below, 137) << "held-out distances below 0.2, of " << count;
}

}  // namespace
}  // namespace sylva
