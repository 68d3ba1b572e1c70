#include "pipeline/analysis/realism_gates.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include "core/errors.h"
#include "species/model/tree_metrics.h"

namespace sylva {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The stat of every instance that defines it (JSON null and absent keys are left out).
std::vector<double> values(const std::vector<const nlohmann::json*>& records, const char* key) {
    std::vector<double> v;
    for (const nlohmann::json* r : records) {
        const nlohmann::json& stats = (*r)["stats"];
        if (stats.contains(key) && stats[key].is_number()) v.push_back(stats[key].get<double>());
    }
    return v;
}

double mean(const std::vector<double>& v) {
    if (v.empty()) return kNaN;
    double s = 0;
    for (double x : v) s += x;
    return s / static_cast<double>(v.size());
}

double sampleCv(const std::vector<double>& v) {
    if (v.size() < 2) return kNaN;
    const double m = mean(v);
    double ss = 0;
    for (double x : v) ss += (x - m) * (x - m);
    return std::sqrt(ss / static_cast<double>(v.size() - 1)) / m;
}

double minOf(const std::vector<double>& v) {
    return v.empty() ? kNaN : *std::min_element(v.begin(), v.end());
}
double maxOf(const std::vector<double>& v) {
    return v.empty() ? kNaN : *std::max_element(v.begin(), v.end());
}

bool within(double v, double lo, double hi) { return !std::isnan(v) && v >= lo && v <= hi; }

SpeciesGates evaluateSpecies(const std::string& name,
                             const std::vector<const nlohmann::json*>& records) {
    SpeciesGates s;
    s.species = name;
    s.habit = (*records.front()).value("habit", "");
    s.instances = static_cast<int>(records.size());
    const bool oneStem = s.habit == "tree" || s.habit == "conifer" || s.habit == "palm";
    const bool leafy = maxOf(values(records, "leaves")) > 0;

    auto add = [&](const char* gate, bool applies, double value, bool pass) {
        s.gates.push_back({gate, applies, !applies || pass, value});
    };
    const double lowest = minOf(values(records, "lowest_shoot_y_m"));
    add("ground", true, lowest, !std::isnan(lowest) && lowest >= -0.02);
    const double exponent = quantile(values(records, "radius_exponent_median"), 0.5);
    add("radius_exponent", true, exponent, within(exponent, 1.8, 3.0));
    const double bifurcation = mean(values(records, "bifurcation_ratio_mean"));
    add("bifurcation_ratio", s.habit != "palm", bifurcation, within(bifurcation, 2.5, 8.0));
    const double cv = sampleCv(values(records, "height_m"));
    add("height_cv", true, cv, within(cv, 0.05, 0.30));
    const std::vector<double> support = values(records, "leaf_wood_distance_p95_m");
    const double farthest = maxOf(support);
    add("leaf_support", leafy, farthest, support.size() == records.size() && farthest <= 0.15);
    const std::vector<double> stems = values(records, "stems_at_base");
    const bool allOne = stems.size() == records.size() &&
                        std::all_of(stems.begin(), stems.end(), [](double x) { return x == 1; });
    add("stems_at_base", oneStem, maxOf(stems), allOne);
    const std::vector<double> lean = values(records, "leader_lean_deg");
    const double steepest = maxOf(lean);
    add("leader_lean", s.habit == "conifer", steepest,
        lean.size() == records.size() && steepest <= 3.0);
    const double foliage = mean(values(records, "leaf_pixel_fraction"));
    add("leaf_pixels", leafy, foliage, !std::isnan(foliage) && foliage >= 0.30);
    return s;
}

std::string cell(const GateResult& g) {
    if (!g.applies) return "–";
    std::ostringstream o;
    if (std::isnan(g.value)) {
        o << "n/a";
    } else {
        o.precision(g.gate == "stems_at_base" ? 1 : 3);
        o << g.value;
    }
    if (!g.pass) o << " ✗";
    return o.str();
}

}  // namespace

bool SpeciesGates::pass() const {
    return std::all_of(gates.begin(), gates.end(), [](const GateResult& g) { return g.pass; });
}

const std::vector<GateSpec>& realismGates() {
    static const std::vector<GateSpec> gates = {
        {"ground", "min lowest_shoot_y_m (m)", "≥ −0.02"},
        {"radius_exponent", "median radius_exponent_median", "in [1.8, 3.0]"},
        {"bifurcation_ratio", "mean bifurcation_ratio_mean", "in [2.5, 8] (not palms)"},
        {"height_cv", "coefficient of variation of height_m", "in [0.05, 0.30]"},
        {"leaf_support", "max leaf_wood_distance_p95_m (m)", "≤ 0.15 (leafy species)"},
        {"stems_at_base", "stems_at_base of every instance", "1 (tree, conifer, palm)"},
        {"leader_lean", "max leader_lean_deg (°)", "≤ 3 (conifers)"},
        {"leaf_pixels", "mean leaf_pixel_fraction", "≥ 0.30 (leafy species)"},
    };
    return gates;
}

std::vector<SpeciesGates> evaluateGates(const std::vector<nlohmann::json>& records) {
    std::vector<std::string> order;
    std::map<std::string, std::vector<const nlohmann::json*>> bySpecies;
    for (const nlohmann::json& r : records) {
        const std::string name = r.value("species", "");
        if (!bySpecies.count(name)) order.push_back(name);
        bySpecies[name].push_back(&r);
    }
    std::vector<SpeciesGates> out;
    for (const std::string& name : order) out.push_back(evaluateSpecies(name, bySpecies[name]));
    return out;
}

std::vector<SpeciesGates> evaluateGates(const std::filesystem::path& datasetDir) {
    std::ifstream in(datasetDir / "manifest.jsonl");
    if (!in) {
        throw InputError(datasetDir.string() + ": no manifest.jsonl (not a built dataset)");
    }
    std::vector<nlohmann::json> records;
    for (std::string line; std::getline(in, line);) {
        nlohmann::json r = nlohmann::json::parse(line, nullptr, false);
        if (!r.is_discarded() && r.is_object()) records.push_back(std::move(r));
    }
    return evaluateGates(records);
}

std::string gatesMarkdown(const std::vector<SpeciesGates>& species) {
    std::ostringstream o;
    o << "| species | habit | n |";
    for (const GateSpec& g : realismGates()) o << " " << g.name << " |";
    o << "\n|---|---|---|";
    for (size_t i = 0; i < realismGates().size(); ++i) o << "---|";
    o << "\n";
    for (const SpeciesGates& s : species) {
        o << "| `" << s.species << "` | " << s.habit << " | " << s.instances << " |";
        for (const GateResult& g : s.gates) o << " " << cell(g) << " |";
        o << "\n";
    }
    return o.str();
}

}  // namespace sylva
