#include "pipeline/stats_json.h"

namespace sylva {

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
    return j;
}

}  // namespace sylva
