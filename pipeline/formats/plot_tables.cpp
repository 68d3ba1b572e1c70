#include "pipeline/formats/plot_tables.h"

#include <cmath>
#include <cstdio>

#include "core/params.h"

namespace sylva {

namespace {

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

// A CSV field: quoted when it holds a comma, quote or line break (species names are words).
std::string field(const std::string& s) {
    if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
    std::string q = "\"";
    for (char c : s) {
        if (c == '"') q += '"';
        q += c;
    }
    return q + "\"";
}

}  // namespace

std::string treeTableCsv(const std::vector<TreeRecord>& table) {
    std::string out = "id,name,species,x,y,z,height,dbh,crown_base";
    for (const char* s : kCrownSectors) out += std::string(",crown_radius_") + s;
    out += ",nn_distance,leaf_area\n";
    for (const TreeRecord& r : table) {
        out += std::to_string(r.id) + "," + field(r.name) + "," + field(r.species);
        for (double v : {r.base.x, r.base.y, r.base.z, r.height, r.dbh, r.crownBase}) {
            out += "," + formatFixed(v, 3);
        }
        for (double v : r.crownRadius) out += "," + formatFixed(v, 3);
        out += "," + formatFixed(r.nearestNeighbour, 3) + "," + formatFixed(r.leafArea, 4) + "\n";
    }
    return out;
}

nlohmann::json treeTableJson(const std::vector<TreeRecord>& table) {
    nlohmann::json rows = nlohmann::json::array();
    for (const TreeRecord& r : table) {
        nlohmann::json crown = nlohmann::json::object();
        for (size_t k = 0; k < kCrownSectors.size(); ++k)
            crown[kCrownSectors[k]] = r.crownRadius[k];
        rows.push_back({{"id", r.id},
                        {"name", r.name},
                        {"species", r.species},
                        {"x", r.base.x},
                        {"y", r.base.y},
                        {"z", r.base.z},
                        {"height", r.height},
                        {"dbh", r.dbh},
                        {"crown_base", number(r.crownBase)},
                        {"crown_radius", crown},
                        {"nn_distance", number(r.nearestNeighbour)},
                        {"leaf_area", r.leafArea}});
    }
    return rows;
}

nlohmann::json toJson(const PlotStatistics& s) {
    const HeightDistribution& h = s.heights;
    nlohmann::json species = nlohmann::json::object();
    for (const auto& [name, n] : s.perSpecies) species[name] = n;
    return {{"trees", s.trees},
            {"area_m2", s.areaM2},
            {"stems_per_ha", number(s.stemsPerHa)},
            {"basal_area_m2_per_ha", number(s.basalAreaM2PerHa)},
            {"clark_evans", number(s.clarkEvans)},
            {"canopy_cover", number(s.canopyCover)},
            {"canopy_cell_m", s.canopyCellM},
            {"lai", number(s.lai)},
            {"leaf_area_index", number(s.leafAreaIndex)},
            {"mean_nn_distance", number(s.meanNearestNeighbour)},
            {"height",
             {{"min", number(h.min)},
              {"q1", number(h.q1)},
              {"median", number(h.median)},
              {"q3", number(h.q3)},
              {"max", number(h.max)},
              {"mean", number(h.mean)},
              {"bin_width", h.binWidth},
              {"histogram", h.histogram}}},
            {"species", species}};
}

}  // namespace sylva
