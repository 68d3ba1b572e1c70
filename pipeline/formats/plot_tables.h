// A plot's tree table (trees.csv, trees.json) and statistics (plot.json) as text. Columns and
// units: docs/plots.md, "Outputs".
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "species/plot/inventory.h"

namespace sylva {

// CSV (RFC 4180, "\n" line ends): a header row, then one row per tree in table order. Lengths
// in metres with 3 decimals (millimetres), leaf area in m² with 4; an empty field for NaN or ∞
// (a crown base without leaves, the nearest neighbour of a lone tree).
std::string treeTableCsv(const std::vector<TreeRecord>& table);
// The same rows as a JSON array of objects with the CSV's column names (crown radii as an
// object "crown_radius": {"n": …, …}); null for NaN or ∞.
nlohmann::json treeTableJson(const std::vector<TreeRecord>& table);
// plot.json: the plot statistics (null for NaN).
nlohmann::json toJson(const PlotStatistics& stats);

}  // namespace sylva
