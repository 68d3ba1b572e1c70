#include "pipeline/formats/stats_json.h"

#include <cmath>

namespace sylva {

namespace {
// An undefined metric (NaN) is written as null.
nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }
nlohmann::json nums(const std::vector<double>& v) {
    nlohmann::json a = nlohmann::json::array();
    for (double x : v) a.push_back(num(x));
    return a;
}
}  // namespace

nlohmann::json toJson(const TreeStats& stats) {
    nlohmann::json j;  // nlohmann::json is an ordered-by-key map: dumps are deterministic
    j["nodes"] = stats.nodes;
    j["segments"] = stats.segments;
    j["endpoints"] = stats.endpoints;
    j["height_m"] = stats.height;
    j["root_depth_m"] = stats.rootDepth;
    j["crown_width_m"] = stats.crownWidth;
    j["total_length_m"] = stats.totalLength;
    j["crown_hull_volume_m3"] = stats.crownHullVolume;
    j["highest_order"] = stats.highestOrder;
    j["segments_per_order"] = stats.segmentsPerOrder;
    // Shape metrics (README "Metrics"); NaN (undefined) is written as null.
    j["strahler_order"] = stats.strahlerOrder;
    j["strahler_branches"] = stats.strahlerBranches;
    j["strahler_branch_length_m"] = nums(stats.strahlerBranchLength);
    j["bifurcation_ratios"] = nums(stats.bifurcationRatios);
    j["bifurcation_ratio_mean"] = num(stats.bifurcationRatioMean);
    j["forks"] = stats.forks;
    j["fork_angle_mean_deg"] = num(stats.forkAngleMean);
    j["fork_angle_std_deg"] = num(stats.forkAngleStd);
    j["radius_exponent_forks"] = stats.radiusExponentForks;
    j["radius_exponent_median"] = num(stats.radiusExponentMedian);
    j["radius_exponent_iqr"] = num(stats.radiusExponentIqr);
    j["tortuosity_mean"] = num(stats.tortuosityMean);
    j["tortuosity_max"] = num(stats.tortuosityMax);
    j["crown_base_height_m"] = num(stats.crownBaseHeight);
    j["crown_height_m"] = num(stats.crownHeight);
    j["crown_width_major_m"] = num(stats.crownWidthMajor);
    j["crown_depth_m"] = num(stats.crownDepth);
    j["crown_asymmetry_m"] = num(stats.crownAsymmetry);
    j["leaves"] = stats.leaves;
    j["leaf_area_m2"] = num(stats.leafArea);
    // Realism measures (docs/metrics.md, "Realism").
    j["lowest_shoot_y_m"] = num(stats.lowestShootY);
    j["below_ground_fraction"] = num(stats.belowGroundFraction);
    j["stems_at_base"] = stats.stemsAtBase;
    j["leader_lean_deg"] = num(stats.leaderLeanDeg);
    j["leaf_wood_distance_p95_m"] = num(stats.leafWoodDistanceP95);
    return j;
}

}  // namespace sylva
