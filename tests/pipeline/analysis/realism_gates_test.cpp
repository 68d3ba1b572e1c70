// The realism gates (pipeline/analysis/realism_gates.h): each gate's measure and bound on
// hand-written manifest records with known answers, and the library itself — 16 trees of every
// species in species/presets/ built from datasets/realism-gates.toml, every gate passed.
#include "pipeline/analysis/realism_gates.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>

#include "pipeline/batch/build.h"
#include "pipeline/batch/dataset.h"

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
              {"leaf_pixel_fraction", 0.5},
              {"crown_width_major_m", 6.0},
              {"crown_depth_m", 4.0}}}};
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
    // Crown diameter 5 m over heights 9, 10, 11: ratios 5/9, 1/2, 5/11.
    const double a = 5.0 / 9, b = 0.5, c = 5.0 / 11, m = (a + b + c) / 3;
    const double sd = std::sqrt(((a - m) * (a - m) + (b - m) * (b - m) + (c - m) * (c - m)) / 2);
    EXPECT_NEAR(gate(r[0], "crown_shape_cv").value, sd / m, 1e-12);
    EXPECT_FALSE(gate(r[0], "spread").applies);  // no skeletons or views given
    EXPECT_FALSE(gate(r[0], "seed_iou").applies);
}

// Instances whose skeletons give `per` values of every reference distribution, evenly spread
// over [lo, lo + width · (reference IQR)] (so the pooled IQR is ≈ width/2 of the reference's),
// and 2×2 masks.
std::vector<InstanceShape> shapes(size_t n, double width, std::vector<uint8_t> mask) {
    std::vector<InstanceShape> out(n);
    for (size_t i = 0; i < n; ++i) {
        for (int k = 0; k < kReferenceDistributions; ++k) {
            for (int v = 0; v < 10; ++v) {
                const double t = (i * 10 + v) / (n * 10.0 - 1);
                out[i].reference[k].push_back(1 + t * width * kSpreadGateIqr[k]);
            }
        }
        out[i].maskWidth = out[i].maskHeight = 2;
        out[i].mask = mask;
    }
    return out;
}

TEST(RealismGates, SpreadHoldsForksAndBranchesToHalfTheReferenceIqr) {
    const std::vector<nlohmann::json> recs = species("x", "tree");
    // Uniform values: IQR = width/2 of the reference's.
    std::vector<InstanceShape> wide = shapes(3, 1.2, {1, 1, 0, 0});
    wide[1].mask = {1, 0, 1, 0};
    wide[2].mask = {0, 1, 1, 1};
    const SpeciesGates ok = evaluateGates(recs, &wide)[0];
    EXPECT_TRUE(gate(ok, "spread").applies);
    EXPECT_NEAR(gate(ok, "spread").value, 0.6, 0.01);
    EXPECT_TRUE(gate(ok, "spread").pass);
    const std::vector<InstanceShape> narrow = shapes(3, 0.9, {1, 1, 0, 0});
    EXPECT_NEAR(gate(evaluateGates(recs, &narrow)[0], "spread").value, 0.45, 0.01);
    EXPECT_FALSE(gate(evaluateGates(recs, &narrow)[0], "spread").pass);
    // One distribution without spread fails it, and is named.
    std::vector<InstanceShape> fixed = wide;
    for (auto& s : fixed) s.reference[kRadiusExponent].assign(10, 2.3);
    const GateResult& g = gate(evaluateGates(recs, &fixed)[0], "spread");
    EXPECT_EQ(g.value, 0.0);
    EXPECT_EQ(g.detail, "radius_exponent");
    // Conifers are held to the fork distributions only: their branches may be regular.
    std::vector<nlohmann::json> firs = species("x", "conifer");
    std::vector<InstanceShape> whorls = wide;
    for (auto& s : whorls) s.reference[kBranchAngle].assign(10, 80.0);
    EXPECT_TRUE(gate(evaluateGates(firs, &whorls)[0], "spread").pass);
    EXPECT_FALSE(gate(evaluateGates(recs, &whorls)[0], "spread").pass);
    // Fewer than 20 values of every distribution: not gated.
    const std::vector<InstanceShape> few = shapes(1, 0.1, {1, 1, 0, 0});
    const std::vector<nlohmann::json> one(recs.begin(), recs.begin() + 1);
    EXPECT_FALSE(gate(evaluateGates(one, &few)[0], "spread").applies);
}

TEST(RealismGates, SeedsMustNotBeClonesFromTheSameCamera) {
    const std::vector<nlohmann::json> recs = species("x", "tree");
    // IoU of {1,1,0,0} and {1,0,1,0}: 1/3; with {0,1,1,1}: 1/4 and 1/4.
    std::vector<InstanceShape> s = shapes(3, 1.2, {1, 1, 0, 0});
    s[1].mask = {1, 0, 1, 0};
    s[2].mask = {0, 1, 1, 1};
    EXPECT_NEAR(gate(evaluateGates(recs, &s)[0], "seed_iou").value, 1.0 / 3, 1e-12);
    EXPECT_TRUE(gate(evaluateGates(recs, &s)[0], "seed_iou").pass);
    // Two clones fail it.
    s[2].mask = s[0].mask;
    EXPECT_EQ(gate(evaluateGates(recs, &s)[0], "seed_iou").value, 1.0);
    EXPECT_FALSE(gate(evaluateGates(recs, &s)[0], "seed_iou").pass);
    // A view from another azimuth is not compared.
    s[2].azimuthDeg = 90;
    EXPECT_NEAR(gate(evaluateGates(recs, &s)[0], "seed_iou").value, 1.0 / 3, 1e-12);
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
