#include "pipeline/analysis/realism_gates.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include "core/errors.h"
#include "core/input_file.h"
#include "pipeline/analysis/dataset_reader.h"
#include "pipeline/analysis/dataset_stats.h"
#include "pipeline/batch/pack.h"
#include "species/model/tree_metrics.h"
#include "volumes/image_file.h"

namespace sylva {

const std::array<double, kReferenceDistributions> kSpreadGateIqr = {
    0.31110,    // radius_ratio: 0.470–0.781
    2.611508,   // radius_exponent: 1.927–4.538
    51.78500,   // branch_angle_deg: 37.0–88.8°
    0,          // tip_path_ratio: per tip, not per fork or branch
    0.192226,   // branch_length_order1: 0.032–0.224
    0.0909515,  // branch_length_order2: 0.024–0.115
    0,          // branch_length_order3: the finest twigs, which a skeleton may not model
    0,          // tip_height_ratio: per tip
};

namespace {

constexpr uint64_t kMaxTransformsBytes = uint64_t(16) << 20;  // 8 views: a few kB
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A record's stats object (an empty one where it has none).
const nlohmann::json& statsOf(const nlohmann::json& record) {
    static const nlohmann::json none = nlohmann::json::object();
    const auto it = record.find("stats");
    return it != record.end() && it->is_object() ? *it : none;
}

// The stat of every instance that defines it (JSON null and absent keys are left out).
std::vector<double> values(const std::vector<const nlohmann::json*>& records, const char* key) {
    std::vector<double> v;
    for (const nlohmann::json* r : records) {
        const nlohmann::json& stats = statsOf(*r);
        if (stats.contains(key) && stats[key].is_number()) v.push_back(stats[key].get<double>());
    }
    return v;
}

// A record's string field ("" where it has none or another type).
std::string textOf(const nlohmann::json& record, const char* key) {
    const auto it = record.find(key);
    return it != record.end() && it->is_string() ? it->get<std::string>() : std::string();
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

// Forks and branches that a species must have before its spread is held to the reference's.
constexpr size_t kSpreadMinValues = 20;

// The smallest ratio of a pooled interquartile range to the reference's (kSpreadGateIqr) over the
// distributions the habit is held to (the fork distributions for every habit, the branch
// distributions for broadleaf trees, as the reference is of broadleaf trees), with the
// distribution's name.
std::pair<double, std::string> spreadRatio(const std::string& habit,
                                           const std::vector<const InstanceShape*>& shapes) {
    ReferenceValues pooled;
    for (const InstanceShape* s : shapes) poolReferenceValues(pooled, s->reference);
    std::pair<double, std::string> worst{kNaN, ""};
    for (int k = 0; k < kReferenceDistributions; ++k) {
        if (!(kSpreadGateIqr[k] > 0)) continue;
        const bool fork = k == kRadiusRatio || k == kRadiusExponent;
        if (!fork && habit != "tree") continue;
        if (pooled[k].size() < kSpreadMinValues) continue;
        const MetricSummary q = summarize(pooled[k]);
        const double ratio = (q.q75 - q.q25) / kSpreadGateIqr[k];
        if (std::isnan(worst.first) || ratio < worst.first) {
            worst = {ratio, kReferenceDistributionNames[k]};
        }
    }
    return worst;
}

// Masks compared by the seed gate: the first this many instances' first views.
constexpr size_t kSeedGateInstances = 4;

// The largest intersection over union of the first views of the species' first instances
// whose first view has the first one's azimuth and size (the same camera, framed to each
// tree); NaN with fewer than two.
double largestSeedIou(const std::vector<const InstanceShape*>& shapes) {
    std::vector<const InstanceShape*> views;
    for (const InstanceShape* s : shapes) {
        if (views.size() == kSeedGateInstances) break;
        if (s->mask.empty()) continue;
        if (!views.empty() &&
            (s->azimuthDeg != views[0]->azimuthDeg || s->maskWidth != views[0]->maskWidth ||
             s->maskHeight != views[0]->maskHeight)) {
            continue;
        }
        views.push_back(s);
    }
    double largest = kNaN;
    for (size_t a = 0; a < views.size(); ++a) {
        for (size_t b = a + 1; b < views.size(); ++b) {
            size_t both = 0, either = 0;
            for (size_t i = 0; i < views[a]->mask.size(); ++i) {
                const bool x = views[a]->mask[i] != 0, y = views[b]->mask[i] != 0;
                both += x && y;
                either += x || y;
            }
            const double iou = either ? static_cast<double>(both) / either : 1.0;
            if (std::isnan(largest) || iou > largest) largest = iou;
        }
    }
    return largest;
}

SpeciesGates evaluateSpecies(const std::string& name,
                             const std::vector<const nlohmann::json*>& records,
                             const std::vector<const InstanceShape*>& shapes) {
    SpeciesGates s;
    s.species = name;
    s.habit = textOf(*records.front(), "habit");
    s.instances = static_cast<int>(records.size());
    const bool oneStem = s.habit == "tree" || s.habit == "conifer" || s.habit == "palm";
    const bool leafy = maxOf(values(records, "leaves")) > 0;

    auto add = [&](const char* gate, bool applies, double value, bool pass) {
        s.gates.push_back({gate, applies, !applies || pass, value, ""});
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

    // Crown shape per instance: mean crown diameter (its two principal extents) over height.
    std::vector<double> shape;
    for (const nlohmann::json* r : records) {
        const nlohmann::json& st = statsOf(*r);
        auto number = [&](const char* key) {
            return st.contains(key) && st[key].is_number() ? st[key].get<double>() : kNaN;
        };
        const double w = 0.5 * (number("crown_width_major_m") + number("crown_depth_m"));
        const double h = number("height_m");
        if (std::isfinite(w) && h > 0) shape.push_back(w / h);
    }
    const double shapeCv = sampleCv(shape);
    add("crown_shape_cv", true, shapeCv, within(shapeCv, 0.08, 1e300));
    const auto [spread, which] =
        shapes.empty() ? std::pair<double, std::string>{kNaN, ""} : spreadRatio(s.habit, shapes);
    add("spread", !std::isnan(spread), spread, spread >= 0.5);
    s.gates.back().detail = which;
    const double seedIou = largestSeedIou(shapes);
    add("seed_iou", !std::isnan(seedIou), seedIou, seedIou < 0.85);
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
        if (!g.detail.empty()) o << " (" << g.detail << ")";
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
        {"crown_shape_cv", "coefficient of variation of crown diameter / height_m", "≥ 0.08"},
        {"spread", "smallest pooled IQR / the reference's, per fork and branch distribution",
         "≥ 0.5 (20+ values)"},
        {"seed_iou", "largest silhouette IoU of 4 instances' first views (same camera)", "< 0.85"},
    };
    return gates;
}

std::vector<SpeciesGates> evaluateGates(const std::vector<nlohmann::json>& records,
                                        const std::vector<InstanceShape>* shapes) {
    std::vector<std::string> order;
    std::map<std::string, std::vector<const nlohmann::json*>> bySpecies;
    std::map<std::string, std::vector<const InstanceShape*>> shapesOf;
    for (size_t i = 0; i < records.size(); ++i) {
        const std::string name = textOf(records[i], "species");
        if (!bySpecies.count(name)) order.push_back(name);
        bySpecies[name].push_back(&records[i]);
        if (shapes && i < shapes->size()) shapesOf[name].push_back(&(*shapes)[i]);
    }
    std::vector<SpeciesGates> out;
    for (const std::string& name : order) {
        out.push_back(evaluateSpecies(name, bySpecies[name], shapesOf[name]));
    }
    return out;
}

std::vector<SpeciesGates> evaluateGates(const std::filesystem::path& datasetDir) {
    // The dataset's description and records, checked (dataset_reader.h); plots are not gated.
    ManifestRead read = readManifests(datasetDir);
    (void)readDatasetDescription(datasetDir);
    std::vector<nlohmann::json> records;
    std::vector<std::string> packs;  // a packed record's tar, else ""
    for (ManifestRecord& r : read.records) {
        if (r.plot) continue;
        records.push_back(std::move(r.json));
        packs.push_back(r.pack);
    }
    DatasetFiles packed(datasetDir);
    // A member of a packed record's tar. Thrown: InputError naming it.
    auto bytesOf = [&](size_t i, const std::string& file) {
        std::optional<std::string> b = packed.read(packs[i], file);
        if (!b) throw InputError((datasetDir / packs[i]).string() + ": no member " + file);
        return std::move(*b);
    };
    std::vector<InstanceShape> shapes(records.size());
    for (size_t i = 0; i < records.size(); ++i) {
        const nlohmann::json& files = records[i].value("files", nlohmann::json::object());
        auto file = [&](const char* key) -> std::string {
            return files.contains(key) ? files[key].get<std::string>() : "";
        };
        if (const std::string skeleton = file("skeleton_ply"); !skeleton.empty()) {
            shapes[i].reference =
                packs[i].empty()
                    ? readSkeletonReferenceValues(datasetDir / skeleton)
                    : skeletonReferenceValuesOf(bytesOf(i, skeleton), packs[i] + ": " + skeleton);
        }
        const std::string transforms = file("transforms");
        if (transforms.empty()) continue;
        const std::filesystem::path tpath =
            datasetDir / (packs[i].empty() ? transforms : packs[i] + "/" + transforms);
        const nlohmann::json t = nlohmann::json::parse(
            packs[i].empty() ? readInputFile(tpath, kMaxTransformsBytes, "a transforms.json")
                             : bytesOf(i, transforms),
            nullptr, false);
        const bool framed = t.is_object() && t.contains("frames") && t["frames"].is_array() &&
                            !t["frames"].empty() && t["frames"][0].is_object();
        const nlohmann::json frame = framed ? t["frames"][0] : nlohmann::json();
        if (!framed || !frame.contains("mask_path") || !frame["mask_path"].is_string() ||
            !frame.contains("azimuth_deg") || !frame["azimuth_deg"].is_number() ||
            !isPathInside(frame["mask_path"].get<std::string>())) {
            throw InputError(tpath.string() +
                             ": expected frames[0] with azimuth_deg and mask_path, a relative "
                             "path beside it");
        }
        Image8 mask;
        try {
            const std::string maskPath = frame["mask_path"].get<std::string>();
            mask = packs[i].empty()
                       ? readPng8File((tpath.parent_path() / maskPath).string(), kViewImageLimits)
                       : readPng8Bytes(bytesOf(i, maskPath), packs[i] + ": " + maskPath,
                                       kViewImageLimits);
        } catch (const ImageError& e) {
            throw InputError(e.what());
        }
        shapes[i].maskWidth = mask.width;
        shapes[i].maskHeight = mask.height;
        shapes[i].azimuthDeg = frame["azimuth_deg"].get<double>();
        shapes[i].mask.resize(static_cast<size_t>(mask.width) * mask.height);
        for (size_t k = 0; k < shapes[i].mask.size(); ++k) {
            shapes[i].mask[k] = mask.pixels[k * mask.channels] > 127;
        }
    }
    return evaluateGates(records, &shapes);
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
