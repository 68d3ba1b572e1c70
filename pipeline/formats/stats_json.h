// JSON form of TreeStats (kept out of species/, which stays JSON-free).
#pragma once

#include <nlohmann/json.hpp>

#include "species/model/tree_stats.h"

namespace sylva {

// Keys: nodes, segments, endpoints, height_m, root_depth_m, crown_width_m, total_length_m,
// crown_hull_volume_m3, highest_order, segments_per_order (array indexed by order).
nlohmann::json toJson(const TreeStats& stats);

}  // namespace sylva
