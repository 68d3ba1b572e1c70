// `sylva report`: see report.h. The page is plain HTML + inline SVG (no JavaScript), so it
// opens offline in any browser and can be archived with the dataset.
#include "pipeline/analysis/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <numeric>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/atomic_file.h"
#include "core/errors.h"
#include "core/input_file.h"
#include "pipeline/analysis/dataset_reader.h"
#include "pipeline/analysis/dataset_stats.h"
#include "pipeline/analysis/quantile_sketch.h"
#include "pipeline/batch/output_lock.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace sylva {

// --- statistics helpers ------------------------------------------------------------------------

// Quantiles, the KS test and W1 are the ones `sylva stats` uses
// (pipeline/analysis/dataset_stats.h).

std::vector<double> niceTicks(double lo, double hi, int target) {
    if (!std::isfinite(lo) || !std::isfinite(hi)) return {0.0, 1.0};
    if (hi < lo) std::swap(lo, hi);
    if (hi - lo < 1e-12 * std::max(1.0, std::fabs(hi))) {  // a constant: a unit span around it
        double pad = lo == 0.0 ? 1.0 : std::fabs(lo) * 0.1;
        lo -= pad;
        hi += pad;
    }
    double raw = (hi - lo) / std::max(1, target);
    double mag = std::pow(10.0, std::floor(std::log10(raw)));
    double step = mag;
    for (double m : {1.0, 2.0, 5.0, 10.0}) {
        step = m * mag;
        if (step >= raw) break;
    }
    double first = std::floor(lo / step + 1e-9) * step;
    double last = std::ceil(hi / step - 1e-9) * step;
    std::vector<double> t;
    for (double v = first; v <= last + step * 1e-6; v += step) {
        t.push_back(std::fabs(v) < step * 1e-9 ? 0.0 : v);
    }
    return t;
}

std::string metricUnit(const std::string& m) {
    auto ends = [&](const char* s) {
        std::string x(s);
        return m.size() > x.size() && m.compare(m.size() - x.size(), x.size(), x) == 0;
    };
    if (ends("_m3")) return "m³";
    if (ends("_m2")) return "m²";
    if (ends("_ms")) return "ms";
    if (ends("_m")) return "m";
    if (ends("_deg")) return "°";
    return "";
}

std::string metricTheme(const std::string& m, bool perView) {
    auto starts = [&](const char* p) { return m.rfind(p, 0) == 0; };
    static const std::set<std::string> kSize = {"height_m",
                                                "total_length_m",
                                                "root_depth_m",
                                                "lowest_shoot_y_m",
                                                "nodes",
                                                "segments",
                                                "endpoints",
                                                "below_ground_fraction",
                                                "mesh_vertices",
                                                "mesh_triangles",
                                                "wood_triangles",
                                                "watertight_vertices",
                                                "watertight_triangles"};
    static const std::set<std::string> kBranching = {"forks",
                                                     "highest_order",
                                                     "strahler_order",
                                                     "bifurcation_ratio_mean",
                                                     "fork_angle_mean_deg",
                                                     "fork_angle_std_deg",
                                                     "radius_exponent_median",
                                                     "radius_exponent_iqr",
                                                     "radius_exponent_forks",
                                                     "tortuosity_mean",
                                                     "tortuosity_max",
                                                     "stems_at_base",
                                                     "leader_lean_deg"};
    if (starts("timing.")) return "timing";
    if (m == "leaves" || starts("leaf_")) return "leaves";  // leaf_pixel_fraction too
    if (starts("crown_")) return "crown";
    if (perView || m == "silhouette_coverage" || m == "fractal_dimension") return "views";
    if (kSize.count(m)) return "size";
    if (kBranching.count(m)) return "branching";
    return "method";
}

std::vector<std::string> relativeLinks(const std::string& html) {
    static const std::regex re(R"re((?:src|href)\s*=\s*"([^"]*)")re");
    std::vector<std::string> out;
    for (auto it = std::sregex_iterator(html.begin(), html.end(), re); it != std::sregex_iterator();
         ++it) {
        std::string v = (*it)[1].str();
        if (v.empty() || v[0] == '#') continue;
        if (v.find("://") != std::string::npos || v.rfind("data:", 0) == 0 ||
            v.rfind("mailto:", 0) == 0)
            continue;
        out.push_back(v);
    }
    return out;
}

namespace {

// --- input -----------------------------------------------------------------------------------

// One record's numbers as the report uses them. Numeric `stats` keys become metrics; an array
// stat of the same length in every record (one value per view) becomes its mean; timing keys
// become "timing.<key>".
struct Record {
    std::string id, species;
    std::map<std::string, double> metrics;
    std::map<std::string, std::string> sweep;
};

std::string sweepValueString(const json& v) {
    if (v.is_string()) return v.get<std::string>();
    return v.dump();
}

// The per-view stats of the dataset's manifests (a first pass: which array stats have one
// length in every record).
std::set<std::string> perViewStats(const fs::path& dir) {
    std::map<std::string, std::set<size_t>> arrayLengths;
    forEachManifestRecord(dir, [&](ManifestRecord& m) {
        const json& j = m.json;
        if (!j.contains("stats")) return;
        for (const auto& [k, v] : j["stats"].items()) {
            if (!v.is_array()) continue;
            bool numeric =
                std::all_of(v.begin(), v.end(), [](const json& x) { return x.is_number(); });
            arrayLengths[k].insert(numeric ? v.size() : 0);
        }
    });
    std::set<std::string> perView;
    for (const auto& [k, lengths] : arrayLengths) {
        if (lengths.size() == 1 && *lengths.begin() > 0) perView.insert(k);
    }
    return perView;
}

Record reportRecord(const json& j, const std::set<std::string>& perView) {
    Record r;
    // A plot's record is grouped under its plot's name, as sylva stats does.
    r.species = (j.contains("species") ? j["species"] : j["plot"]).get<std::string>();
    r.id = j["id"].get<std::string>();
    if (j.contains("stats") && j["stats"].is_object()) {
        for (const auto& [k, v] : j["stats"].items()) {
            if (v.is_number()) {
                r.metrics[k] = v.get<double>();
            } else if (v.is_array() && perView.count(k) && !v.empty()) {
                double s = 0.0;
                for (const auto& x : v) s += x.get<double>();
                r.metrics[k] = s / static_cast<double>(v.size());
            }
        }
    }
    if (j.contains("timing") && j["timing"].is_object()) {
        for (const auto& [k, v] : j["timing"].items()) {
            if (v.is_number()) r.metrics["timing." + k] = v.get<double>();
        }
    }
    if (j.contains("sweep") && j["sweep"].is_object()) {
        for (const auto& [k, v] : j["sweep"].items()) r.sweep[k] = sweepValueString(v);
    }
    return r;
}

// A metric's values of one species (or sweep point), streamed: a QuantileSketch (the values as
// they came while there are at most 2,048, a KLL sketch beyond), the extremes, and the 150
// smallest and largest values — the dots a strip past the whiskers can show.
struct ValueStream {
    static constexpr size_t kTail = 150;
    QuantileSketch sketch;
    double min = INFINITY, max = -INFINITY;
    std::vector<double> low, high;  // heaps: the kTail smallest (max-heap), largest (min-heap)
    void add(double x) {
        sketch.add(x);
        min = std::min(min, x);
        max = std::max(max, x);
        auto keep = [x](std::vector<double>& heap, auto better) {
            if (heap.size() < kTail) {
                heap.push_back(x);
                std::push_heap(heap.begin(), heap.end(), better);
            } else if (better(x, heap.front())) {
                std::pop_heap(heap.begin(), heap.end(), better);
                heap.back() = x;
                std::push_heap(heap.begin(), heap.end(), better);
            }
        };
        keep(low, std::less<double>());
        keep(high, std::greater<double>());
    }
    size_t n() const { return static_cast<size_t>(sketch.count()); }
};

// --- formatting ------------------------------------------------------------------------------

std::string esc(const std::string& s) {
    std::string o;
    for (char c : s) {
        switch (c) {
            case '&':
                o += "&amp;";
                break;
            case '<':
                o += "&lt;";
                break;
            case '>':
                o += "&gt;";
                break;
            case '"':
                o += "&quot;";
                break;
            default:
                o += c;
        }
    }
    return o;
}

// Percent-encodes a path segment (species names are usually [a-z0-9-] and pass unchanged).
std::string urlSegment(const std::string& s) {
    std::string o;
    for (unsigned char c : s) {
        if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
            o += static_cast<char>(c);
        } else {
            char b[4];
            std::snprintf(b, sizeof b, "%%%02X", c);
            o += b;
        }
    }
    return o;
}

std::string urlDecode(const std::string& s) {
    std::string o;
    for (size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '%' && i + 2 < s.size()) {
            o += static_cast<char>(std::strtol(s.substr(i + 1, 2).c_str(), nullptr, 16));
            i += 2;
        } else {
            o += s[i];
        }
    }
    return o;
}

std::string num(double v, int digits = 4) {
    if (!std::isfinite(v)) return "–";
    char b[64];
    std::snprintf(b, sizeof b, "%.*g", digits, v);
    return b;
}

std::string px(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.1f", v);
    return b;
}

std::string axisTitle(const std::string& metric, const std::set<std::string>& perView) {
    std::string t = metric;
    if (perView.count(metric)) t += " (mean over views)";
    std::string u = metricUnit(metric);
    if (!u.empty()) t += " [" + u + "]";
    return t;
}

struct Summary {
    size_t n = 0;
    double mean = 0, sd = 0, q05 = 0, q25 = 0, q50 = 0, q75 = 0, q95 = 0, min = 0, max = 0;
};

Summary plotSummary(std::vector<double> v) {
    Summary s;
    s.n = v.size();
    if (v.empty()) return s;
    std::sort(v.begin(), v.end());
    s.mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
    double ss = 0;
    for (double x : v) ss += (x - s.mean) * (x - s.mean);
    s.sd = v.size() > 1 ? std::sqrt(ss / static_cast<double>(v.size() - 1)) : 0.0;
    s.q05 = quantileType7(v, 0.05);
    s.q25 = quantileType7(v, 0.25);
    s.q50 = quantileType7(v, 0.5);
    s.q75 = quantileType7(v, 0.75);
    s.q95 = quantileType7(v, 0.95);
    s.min = v.front();
    s.max = v.back();
    return s;
}

// The same from a stream: exactly as above while it holds its values, from its sketch beyond.
Summary plotSummary(const ValueStream& v) {
    if (v.sketch.exact()) return plotSummary(v.sketch.values());
    Summary s;
    s.n = v.n();
    s.mean = v.sketch.mean();
    s.sd = v.sketch.sd().value_or(0.0);
    s.q05 = v.sketch.quantile(0.05);
    s.q25 = v.sketch.quantile(0.25);
    s.q50 = v.sketch.quantile(0.5);
    s.q75 = v.sketch.quantile(0.75);
    s.q95 = v.sketch.quantile(0.95);
    s.min = v.min;
    s.max = v.max;
    return s;
}

// Deterministic jitter in [-1, 1] for the strip plot (a hash of the point's rank).
double jitter(size_t i) {
    uint64_t z = (i + 1) * 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) / static_cast<double>(1ull << 53) * 2.0 - 1.0;
}

const char* kPalette[] = {"#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e",
                          "#e6ab02", "#a6761d", "#666666", "#1f78b4", "#b2df8a"};

const char* speciesColour(size_t index) {
    return kPalette[index % (sizeof kPalette / sizeof *kPalette)];
}

// Below this many values a species' row shows its instances and median only: the quartiles
// and q05/q95 whiskers of two or three values are not worth drawing.
constexpr size_t kMinInstancesForBox = 5;

// Width of the species label column of every box plot (SVG user units), from the longest
// name at ~7 units per character of the 11-unit font (a little over its widest lower-case
// average), so that all plots of a page align.
double speciesLabelWidth(const std::vector<std::string>& species) {
    size_t longest = 0;
    for (const auto& s : species) longest = std::max(longest, s.size());
    return std::clamp(7.0 * static_cast<double>(longest), 36.0, 160.0);
}

// One grid cell: the metric as the caption and a horizontal box plot with a row per species
// that has values of it (a species without one gets no row; the caption's note names it):
// whiskers q05–q95, box q25–q75, median line, mean diamond, and the individual instances as a
// jittered strip. The SVG scales with its cell (viewBox, width 100%).
std::string boxPlotFigure(const std::string& metric, const std::vector<std::string>& species,
                          const std::map<std::string, ValueStream>& values,
                          const std::set<std::string>& perView, double labelWidth) {
    std::vector<size_t> rows;  // indices into `species`: colours stay the species' own
    std::vector<std::string> missing;
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < species.size(); ++i) {
        auto it = values.find(species[i]);
        if (it == values.end() || it->second.n() == 0) {
            missing.push_back(species[i]);
            continue;
        }
        rows.push_back(i);
        lo = std::min(lo, it->second.min), hi = std::max(hi, it->second.max);
    }
    std::vector<double> ticks = niceTicks(lo, hi, 4);
    // x1 leaves half of the widest tick label ("20000", "0.0004") to the right of the axis.
    const double W = 360, x0 = labelWidth + 12, x1 = W - 22, top = 6, row = 24;
    const double yAxis = top + row * static_cast<double>(rows.size()) + 2;
    const double height = yAxis + 20;
    double d0 = ticks.front(), d1 = ticks.back();
    auto X = [&](double v) { return x0 + (v - d0) / (d1 - d0) * (x1 - x0); };
    std::ostringstream o;
    o << "<figure class=\"plot\" data-metric=\"" << esc(metric) << "\"><figcaption>"
      << esc(axisTitle(metric, perView));
    if (!missing.empty()) {
        o << " <span class=\"missing\">· no value for ";
        for (size_t i = 0; i < missing.size(); ++i) o << (i ? ", " : "") << esc(missing[i]);
        o << "</span>";
    }
    o << "</figcaption>\n<svg class=\"plot\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W
      << "\" height=\"" << px(height) << "\" viewBox=\"0 0 " << W << " " << px(height)
      << "\" role=\"img\" aria-label=\"" << esc(metric) << "\">\n";
    for (double t : ticks) {
        o << "<line x1=\"" << px(X(t)) << "\" x2=\"" << px(X(t)) << "\" y1=\"" << px(top - 4)
          << "\" y2=\"" << px(yAxis) << "\" class=\"grid\"/>"
          << "<line x1=\"" << px(X(t)) << "\" x2=\"" << px(X(t)) << "\" y1=\"" << px(yAxis)
          << "\" y2=\"" << px(yAxis + 4) << "\" class=\"axis\"/>"
          << "<text x=\"" << px(X(t)) << "\" y=\"" << px(yAxis + 15)
          << "\" text-anchor=\"middle\" class=\"tick\">" << num(t, 6) << "</text>\n";
    }
    o << "<line x1=\"" << px(x0) << "\" x2=\"" << px(x1) << "\" y1=\"" << px(yAxis) << "\" y2=\""
      << px(yAxis) << "\" class=\"axis\"/>\n";
    for (size_t r = 0; r < rows.size(); ++r) {
        const std::string& name = species[rows[r]];
        const std::string colour = speciesColour(rows[r]);
        const ValueStream& stream = values.at(name);
        const double yc = top + row * (static_cast<double>(r) + 0.5);
        const Summary s = plotSummary(stream);
        // The dots: the values as they came while the stream holds them all, else its tails.
        std::vector<double> v = stream.sketch.exact() ? stream.sketch.values() : stream.low;
        if (!stream.sketch.exact()) {
            std::sort(v.begin(), v.end());
            std::vector<double> high = stream.high;
            std::sort(high.begin(), high.end());
            v.insert(v.end(), high.begin(), high.end());
        }
        o << "<g data-species=\"" << esc(name) << "\"><title>" << esc(name) << ": n " << s.n
          << ", mean " << num(s.mean) << ", sd " << num(s.sd) << ", q05 " << num(s.q05) << ", q25 "
          << num(s.q25) << ", median " << num(s.q50) << ", q75 " << num(s.q75) << ", q95 "
          << num(s.q95) << "</title>\n";
        o << "<text x=\"" << px(x0 - 6) << "\" y=\"" << px(yc + 4)
          << "\" text-anchor=\"end\" class=\"tick\">" << esc(name) << "</text>\n";
        const bool box = s.n >= kMinInstancesForBox;
        if (box) {
            o << "<line x1=\"" << px(X(s.q05)) << "\" x2=\"" << px(X(s.q95)) << "\" y1=\"" << px(yc)
              << "\" y2=\"" << px(yc) << "\" stroke=\"" << colour << "\"/>";
            for (double w : {s.q05, s.q95}) {
                o << "<line x1=\"" << px(X(w)) << "\" x2=\"" << px(X(w)) << "\" y1=\"" << px(yc - 4)
                  << "\" y2=\"" << px(yc + 4) << "\" stroke=\"" << colour << "\"/>";
            }
            o << "<rect x=\"" << px(X(s.q25)) << "\" y=\"" << px(yc - 8) << "\" width=\""
              << px(std::max(1.0, X(s.q75) - X(s.q25))) << "\" height=\"16\" fill=\"" << colour
              << "\" fill-opacity=\"0.25\" stroke=\"" << colour << "\"/>";
        }
        o << "<line x1=\"" << px(X(s.q50)) << "\" x2=\"" << px(X(s.q50)) << "\" y1=\"" << px(yc - 8)
          << "\" y2=\"" << px(yc + 8) << "\" stroke=\"" << colour << "\" stroke-width=\"2.5\"/>\n";
        // The strip: every instance when there are few, else only those past the whiskers.
        for (size_t i = 0; i < v.size(); ++i) {
            if (s.n > 300 && v[i] >= s.q05 && v[i] <= s.q95) continue;
            o << "<circle cx=\"" << px(X(v[i])) << "\" cy=\"" << px(yc + 5.0 * jitter(i))
              << "\" r=\"" << (box ? "1.6" : "2.6") << "\" fill=\"" << colour
              << "\" fill-opacity=\"" << (box ? "0.55" : "0.8") << "\"/>";
        }
        if (box) {
            const double xm = X(s.mean);
            o << "\n<path d=\"M" << px(xm) << " " << px(yc - 5) << " L" << px(xm + 4) << " "
              << px(yc) << " L" << px(xm) << " " << px(yc + 5) << " L" << px(xm - 4) << " "
              << px(yc) << " Z\" fill=\"#fff\" stroke=\"#000\"/>";
        }
        o << "</g>\n";
    }
    o << "</svg></figure>\n";
    return o.str();
}

struct SweepPoint {
    std::string label;
    double x = 0;
    Summary s;
};

// Mean of `metric` against the swept value, with a ±1 sd band and the point means marked.
std::string sweepSvg(const std::string& species, const std::string& path, const std::string& metric,
                     const std::vector<SweepPoint>& pts, bool numericX,
                     const std::set<std::string>& perView) {
    const double W = 360, H = 250, x0 = 70, x1 = W - 14, y0 = 30, y1 = H - 52;
    double lo = INFINITY, hi = -INFINITY;
    for (const auto& p : pts) {
        lo = std::min(lo, p.s.mean - p.s.sd);
        hi = std::max(hi, p.s.mean + p.s.sd);
    }
    std::vector<double> yt = niceTicks(lo, hi, 5);
    std::vector<double> xt;
    if (numericX && pts.size() <= 8) {  // few sweep points: a tick at each value
        for (const auto& p : pts) xt.push_back(p.x);
        double pad = 0.06 * (pts.back().x - pts.front().x);
        xt.insert(xt.begin(), pts.front().x - pad);
        xt.push_back(pts.back().x + pad);
    } else if (numericX) {
        xt = niceTicks(pts.front().x, pts.back().x, 5);
    } else {
        xt = {-0.5, static_cast<double>(pts.size()) - 0.5};
    }
    double xd0 = xt.front(), xd1 = xt.back();
    auto X = [&](double v) { return x0 + (v - xd0) / (xd1 - xd0) * (x1 - x0); };
    auto Y = [&](double v) { return y1 - (v - yt.front()) / (yt.back() - yt.front()) * (y1 - y0); };
    std::ostringstream o;
    o << "<svg class=\"plot sweep\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W
      << "\" height=\"" << H << "\" viewBox=\"0 0 " << W << " " << H << "\">\n";
    o << "<text x=\"" << px(x0) << "\" y=\"16\" class=\"label\">" << esc(species) << ": "
      << esc(metric) << "</text>\n";
    for (double t : yt) {
        o << "<line x1=\"" << px(x0) << "\" x2=\"" << px(x1) << "\" y1=\"" << px(Y(t)) << "\" y2=\""
          << px(Y(t)) << "\" class=\"grid\"/><text x=\"" << px(x0 - 6) << "\" y=\"" << px(Y(t) + 4)
          << "\" text-anchor=\"end\" class=\"tick\">" << num(t, 6) << "</text>\n";
    }
    if (numericX) {
        for (size_t k = 0; k < xt.size(); ++k) {
            if (pts.size() <= 8 && (k == 0 || k + 1 == xt.size())) continue;  // the padding
            double t = xt[k];
            o << "<line x1=\"" << px(X(t)) << "\" x2=\"" << px(X(t)) << "\" y1=\"" << px(y1)
              << "\" y2=\"" << px(y1 + 5) << "\" class=\"axis\"/><text x=\"" << px(X(t))
              << "\" y=\"" << px(y1 + 18) << "\" text-anchor=\"middle\" class=\"tick\">"
              << num(t, 6) << "</text>\n";
        }
    } else {
        for (size_t i = 0; i < pts.size(); ++i) {
            o << "<text x=\"" << px(X(static_cast<double>(i))) << "\" y=\"" << px(y1 + 18)
              << "\" text-anchor=\"middle\" class=\"tick\">" << esc(pts[i].label) << "</text>\n";
        }
    }
    o << "<line x1=\"" << px(x0) << "\" x2=\"" << px(x1) << "\" y1=\"" << px(y1) << "\" y2=\""
      << px(y1) << "\" class=\"axis\"/><line x1=\"" << px(x0) << "\" x2=\"" << px(x0) << "\" y1=\""
      << px(y0) << "\" y2=\"" << px(y1) << "\" class=\"axis\"/>\n";
    o << "<text x=\"" << px((x0 + x1) / 2) << "\" y=\"" << px(H - 14)
      << "\" text-anchor=\"middle\" class=\"label\">" << esc(path) << "</text>\n";
    std::string u = metricUnit(metric);
    o << "<text x=\"11\" y=\"" << px((y0 + y1) / 2) << "\" transform=\"rotate(-90 11 "
      << px((y0 + y1) / 2) << ")\" text-anchor=\"middle\" class=\"tick\">"
      << (u.empty() ? std::string(perView.count(metric) ? "view mean" : "value") : esc(u))
      << "</text>\n";
    auto xOf = [&](size_t i) { return numericX ? pts[i].x : static_cast<double>(i); };
    std::ostringstream band, line;
    for (size_t i = 0; i < pts.size(); ++i)
        band << (i ? " L" : "M") << px(X(xOf(i))) << " " << px(Y(pts[i].s.mean + pts[i].s.sd));
    for (size_t i = pts.size(); i-- > 0;)
        band << " L" << px(X(xOf(i))) << " " << px(Y(pts[i].s.mean - pts[i].s.sd));
    for (size_t i = 0; i < pts.size(); ++i)
        line << (i ? " L" : "M") << px(X(xOf(i))) << " " << px(Y(pts[i].s.mean));
    o << "<path d=\"" << band.str() << " Z\" fill=\"#1b9e77\" fill-opacity=\"0.2\"/>\n";
    o << "<path d=\"" << line.str() << "\" fill=\"none\" stroke=\"#1b9e77\" stroke-width=\"2\"/>\n";
    for (size_t i = 0; i < pts.size(); ++i) {
        o << "<circle cx=\"" << px(X(xOf(i))) << "\" cy=\"" << px(Y(pts[i].s.mean))
          << "\" r=\"3\" fill=\"#1b9e77\"><title>" << esc(path) << " = " << esc(pts[i].label)
          << ": n " << pts[i].s.n << ", mean " << num(pts[i].s.mean) << ", sd " << num(pts[i].s.sd)
          << "</title></circle>\n";
    }
    o << "</svg>\n";
    return o.str();
}

const char* kCss = R"css(
body { font: 14px/1.45 system-ui, sans-serif; margin: 24px auto; padding: 0 20px;
       max-width: 1480px; color: #222; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; margin-top: 1.8em; }
h3 { margin: 1.4em 0 0.4em; } h3 .note { font-weight: normal; font-size: 13px; }
table { border-collapse: collapse; margin: 0.6em 0; }
td, th { border: 1px solid #ddd; padding: 3px 8px; text-align: right; }
th { background: #f3f3f3; } td.l, th.l { text-align: left; }
tr.top td { font-weight: bold; } td.strong { background: #ffe08a; }
td.few { color: #888; font-style: italic; }
tr.group th { background: #e8eef3; text-align: left; }
.facts td:first-child { text-align: left; color: #555; } .facts td.l { max-width: 24em; }
.row > div { flex: 1 1 560px; min-width: 0; }
.row { display: flex; flex-wrap: wrap; gap: 0 28px; align-items: flex-start; }
.sheets { display: flex; flex-wrap: wrap; gap: 16px; }
.sheets figure { margin: 0; } .sheets img { max-width: 560px; border: 1px solid #ccc; image-rendering: pixelated; }
.plots { display: grid; grid-template-columns: repeat(auto-fill, minmax(320px, 1fr)); gap: 10px; }
figure.plot { margin: 0; padding: 6px 8px 4px; border: 1px solid #e4e4e4; border-radius: 4px;
              background: #fff; min-width: 0; }
figure.plot figcaption { font-size: 13px; font-weight: 600; margin-bottom: 2px;
                         overflow-wrap: anywhere; }
figure.plot .missing { font-weight: normal; color: #888; }
svg.plot { display: block; width: 100%; height: auto; background: #fff; }
.plots > svg.plot { border: 1px solid #e4e4e4; border-radius: 4px; }
svg .grid { stroke: #eee; } svg .axis { stroke: #444; }
svg text { font: 11px system-ui, sans-serif; fill: #333; } svg text.label { font-size: 12px; }
.legend { display: flex; flex-wrap: wrap; gap: 4px 16px; margin: 0.4em 0; }
.legend span::before { content: ""; display: inline-block; width: 11px; height: 11px;
                       margin-right: 5px; vertical-align: -1px; background: var(--c); }
details > summary { cursor: pointer; color: #333; margin: 0.4em 0; }
.note { color: #666; }
)css";

// The plot groups in page order: id (metricTheme), heading, what the group holds.
struct Theme {
    const char* id;
    const char* title;
    const char* note;
};
const Theme kThemes[] = {
    {"size", "Size", "height, extent, length, skeleton and mesh counts"},
    {"branching", "Branching", "forks, orders, angles, radius exponents, tortuosity, stems, lean"},
    {"crown", "Crown", "crown base, height, width, depth, hull volume, asymmetry"},
    {"leaves", "Leaves", "leaf count, area, triangles, support, share of the views' pixels"},
    {"views", "Views", "measured on the rendered silhouettes: the mean over an instance's views"},
    {"method", "Method counters", "the growth methods' own counters (docs/methods/)"},
    {"timing", "Timing", "per instance and stage, in milliseconds"},
};

// Everything the page is made of, read once: dataset.json, the manifest's records, species in
// dataset.json order (then any others in manifest order), each metric's values per species.
struct ReportData {
    json info;
    std::string name;
    size_t records = 0;  // manifest records read
    size_t skipped = 0;  // torn last lines of the manifests (a build killed or still writing)
    std::set<std::string> perView;
    std::vector<std::string> species;
    std::map<std::string, size_t> perSpeciesCount;
    // metric -> species -> values; constant metrics are listed, not plotted.
    std::map<std::string, std::map<std::string, ValueStream>> values;
    // species -> swept path -> value -> metric -> values
    std::map<std::string,
             std::map<std::string, std::map<std::string, std::map<std::string, ValueStream>>>>
        sweeps;
    std::vector<std::string> metrics, constant, timing;
    // theme id -> the metrics plotted under it (metrics, then timing), in name order.
    std::map<std::string, std::vector<std::string>> byTheme;
    double labelWidth = 36;  // of the box plots' species column
    bool anySweep = false;
    std::vector<json> runs;  // runs.jsonl: one line per build (or merge) run
};

// Reads the dataset directory; bad input (not a dataset, no record) throws InputError.
ReportData readReportData(const fs::path& dir) {
    ReportData d;
    d.info = readDatasetDescription(dir);
    // The run log: lines that are not objects are left out, as are fields of the wrong type.
    if (std::error_code ec; fs::exists(dir / "runs.jsonl", ec)) {
        InputFile runs(dir / "runs.jsonl");
        std::string line;
        while (runs.next(line, kMaxManifestLineBytes) == InputFile::Line::complete) {
            json r = json::parse(line, nullptr, false);
            if (r.is_object()) d.runs.push_back(std::move(r));
        }
    }
    // The manifests streamed twice, a record at a time: which stats are per view, then every
    // record into its species' (and sweep point's) value streams.
    d.perView = perViewStats(dir);
    d.name = d.info.value("name", dir.filename().string());
    if (d.info.contains("species") && d.info["species"].is_array()) {
        for (const auto& s : d.info["species"]) {
            if (s.is_object() && s.contains("name") && s["name"].is_string())
                d.species.push_back(s["name"].get<std::string>());
        }
    }
    const ManifestStream read = forEachManifestRecord(dir, [&](ManifestRecord& m) {
        const Record r = reportRecord(m.json, d.perView);
        if (std::find(d.species.begin(), d.species.end(), r.species) == d.species.end())
            d.species.push_back(r.species);
        ++d.perSpeciesCount[r.species];
        for (const auto& [k, v] : r.metrics) {
            if (std::isfinite(v)) d.values[k][r.species].add(v);
        }
        for (const auto& [path, value] : r.sweep) {
            auto& streams = d.sweeps[r.species][path][value];
            for (const auto& [k, v] : r.metrics) {
                if (std::isfinite(v)) streams[k].add(v);
            }
        }
        if (!r.sweep.empty()) d.anySweep = true;
    });
    d.records = read.records;
    d.skipped = read.tornLines;
    if (d.records == 0) throw InputError(dir.string() + ": the manifest has no record");
    d.species.erase(
        std::remove_if(d.species.begin(), d.species.end(),
                       [&](const std::string& s) { return !d.perSpeciesCount.count(s); }),
        d.species.end());

    for (const auto& [m, bySpecies] : d.values) {
        double lo = INFINITY, hi = -INFINITY;
        for (const auto& [s, v] : bySpecies) lo = std::min(lo, v.min), hi = std::max(hi, v.max);
        if (m.rfind("timing.", 0) == 0) {
            d.timing.push_back(m);
        } else if (hi > lo) {
            d.metrics.push_back(m);
        } else {
            // A method's counter is constant for the species that have it, not for the dataset.
            std::string only;
            if (bySpecies.size() < d.species.size()) {
                for (const auto& [sp, v] : bySpecies) only += (only.empty() ? "" : ", ") + sp;
                only = " (" + only + " only)";
            }
            d.constant.push_back(m + " = " + num(lo) + only);
        }
    }
    for (const auto& m : d.metrics) d.byTheme[metricTheme(m, d.perView.count(m) > 0)].push_back(m);
    for (const auto& m : d.timing) d.byTheme["timing"].push_back(m);
    d.labelWidth = speciesLabelWidth(d.species);
    return d;
}

// The page head, the title and the section index.
void writeHead(std::ostream& h, const ReportData& d, const fs::path& dir) {
    h << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>sylva "
         "report: "
      << esc(d.name) << "</title>\n<style>" << kCss << "</style>\n</head>\n<body>\n";
    h << "<h1>" << esc(d.name) << "</h1>\n";
    if (d.info.contains("description") && d.info["description"].is_string())
        h << "<p>" << esc(d.info["description"].get<std::string>()) << "</p>\n";
    h << "<p class=\"note\">Written by <code>sylva report</code> from <a "
         "href=\"../dataset.json\">dataset.json</a>";
    if (fs::exists(dir / "manifest.jsonl"))
        h << " and <a href=\"../manifest.jsonl\">manifest.jsonl</a>";
    h << ". Sections: <a href=\"#facts\">facts</a> · <a href=\"#sheets\">contact sheets</a> · <a "
         "href=\"#distributions\">distributions</a> (";
    bool first = true;
    for (const Theme& t : kThemes) {
        if (!d.byTheme.count(t.id)) continue;
        h << (first ? "" : ", ") << "<a href=\"#theme-" << t.id << "\">" << t.title << "</a>";
        first = false;
    }
    h << ") · <a href=\"#compare\">comparison</a>";
    if (d.anySweep) h << " · <a href=\"#sweeps\">sweeps</a>";
    h << " · <a href=\"#summary\">summary table</a></p>\n";
}

// The dataset's facts (dataset.json), the mean timings per species and the species table.
void writeFacts(std::ostream& h, const ReportData& d) {
    h << "<h2 id=\"facts\">Dataset</h2>\n<div class=\"row\">\n<table class=\"facts\">\n";
    auto fact = [&](const std::string& k, const std::string& v) {
        h << "<tr><td>" << esc(k) << "</td><td class=\"l\">" << esc(v) << "</td></tr>\n";
    };
    auto scalar = [](const json& v) {
        if (v.is_string()) return v.get<std::string>();
        if (v.is_number_float()) return num(v.get<double>(), 6);
        return v.dump();
    };
    for (const char* k : {"name", "seed", "fingerprint", "status", "threads"}) {
        if (d.info.contains(k)) fact(k, scalar(d.info[k]));
    }
    if (d.info.contains("wall_seconds") && d.info["wall_seconds"].is_number())
        fact("build time", num(d.info["wall_seconds"].get<double>(), 4) + " s");
    if (d.info.contains("trees_per_second") && d.info["trees_per_second"].is_number())
        fact("throughput", num(d.info["trees_per_second"].get<double>(), 4) + " trees/s");
    // How it was built: the run log (older datasets kept this in dataset.json, above).
    if (!d.runs.empty()) {
        double wall = 0;
        int64_t threads = 0;
        std::map<std::string, int> statuses;
        for (const json& r : d.runs) {
            // A run line's fields as the build writes them; one of another type counts as absent.
            auto text = [&](const char* key, const char* absent) {
                return r.contains(key) && r[key].is_string() ? r[key].get<std::string>()
                                                             : std::string(absent);
            };
            ++statuses[text("status", "?")];
            if (text("command", "") != "build") continue;
            if (r.contains("wall_seconds") && r["wall_seconds"].is_number())
                wall += r["wall_seconds"].get<double>();
            if (r.contains("threads") && r["threads"].is_number_integer())
                threads = std::max(threads, r["threads"].get<int64_t>());
        }
        std::string runs = std::to_string(d.runs.size()) + " (";
        for (const auto& [status, n] : statuses)
            runs += (runs.back() == '(' ? "" : ", ") + std::to_string(n) + " " + status;
        fact("runs", runs + ")");
        fact("build time", num(wall, 4) + " s (sum of the build runs)");
        if (threads > 0) fact("threads", std::to_string(threads) + " (most in a run)");
    }
    if (d.info.contains("shard") && d.info["shard"].is_object())
        fact("shard", std::to_string(d.info["shard"].value("index", 0)) + " of " +
                          std::to_string(d.info["shard"].value("count", 1)));
    if (d.info.contains("counts") && d.info["counts"].is_object()) {
        for (const auto& [k, v] : d.info["counts"].items()) fact("count: " + k, scalar(v));
    }
    fact("manifest records read",
         std::to_string(d.records) +
             (d.skipped ? " (" + std::to_string(d.skipped) + " torn last lines left out)"
                        : std::string()));
    if (d.info.contains("versions") && d.info["versions"].is_object()) {
        std::string v;
        for (const auto& [k, x] : d.info["versions"].items())
            v += (v.empty() ? "" : ", ") + k + " " + scalar(x);
        fact("versions", v);
    }
    h << "</table>\n<div>\n";  // beside the facts: timings and the species table
    if (!d.timing.empty()) {
        h << "<table><tr><th class=\"l\">species</th>";
        for (const auto& t : d.timing) h << "<th>mean " << esc(t.substr(7)) << "</th>";
        h << "</tr>\n";
        for (const auto& s : d.species) {
            h << "<tr><td class=\"l\">" << esc(s) << "</td>";
            for (const auto& t : d.timing) {
                auto it = d.values.at(t).find(s);
                h << "<td>"
                  << (it == d.values.at(t).end() ? "–"
                                                 : num(plotSummary(it->second).mean, 3) + " ms")
                  << "</td>";
            }
            h << "</tr>\n";
        }
        h << "</table>\n";
    }
    if (d.info.contains("species") && d.info["species"].is_array()) {
        h << "<table><tr><th class=\"l\">species</th><th class=\"l\">method</th><th>count</th>"
             "<th>sweep points</th><th class=\"l\">file</th><th "
             "class=\"l\">description</th></tr>\n";
        for (const auto& s : d.info["species"]) {
            if (!s.is_object()) continue;
            h << "<tr><td class=\"l\">" << esc(s.contains("name") ? scalar(s["name"]) : "")
              << "</td><td class=\"l\">" << esc(s.contains("method") ? scalar(s["method"]) : "")
              << "</td><td>" << esc(s.contains("count") ? scalar(s["count"]) : "") << "</td><td>"
              << esc(s.contains("sweep_points") ? scalar(s["sweep_points"]) : "")
              << "</td><td class=\"l\">" << esc(s.contains("file") ? scalar(s["file"]) : "")
              << "</td><td class=\"l\">"
              << esc(s.contains("description") ? scalar(s["description"]) : "") << "</td></tr>\n";
        }
        h << "</table>\n";
    }
    h << "</div>\n</div>\n";
}

// The species contact sheets, linked relatively (../contact/<species>.png).
void writeContactSheets(std::ostream& h, const ReportData& d, const fs::path& dir) {
    h << "<h2 id=\"sheets\">Contact sheets</h2>\n<div class=\"sheets\">\n";
    for (const auto& s : d.species) {
        if (fs::exists(dir / "contact" / (s + ".png"))) {
            std::string src = "../contact/" + urlSegment(s) + ".png";
            h << "<figure><a href=\"" << src << "\"><img src=\"" << src << "\" alt=\"" << esc(s)
              << " contact sheet\"></a><figcaption>" << esc(s) << " (" << d.perSpeciesCount.at(s)
              << " instances)</figcaption></figure>\n";
        } else {
            h << "<p class=\"note\">" << esc(s) << ": no contact sheet (the dataset has no "
              << "views).</p>\n";
        }
    }
    h << "</div>\n";
}

// mean ± sd (median) of every plotted metric per species, grouped by theme, and the constant
// metrics; folded (a <details>), the plots above hold the same.
void writeSummaryTable(std::ostream& h, const ReportData& d) {
    h << "<h2 id=\"summary\">Per-species summary</h2>\n<details>\n<summary>The table: mean ± sd "
         "(median) of each metric per species (– : the species has no value of it); array "
         "metrics (one value per view) are averaged over the views first.</summary>\n"
         "<table><tr><th class=\"l\">metric</th>";
    for (const auto& s : d.species)
        h << "<th>" << esc(s) << " (n " << d.perSpeciesCount.at(s) << ")</th>";
    h << "</tr>\n";
    for (const Theme& t : kThemes) {
        auto group = d.byTheme.find(t.id);
        if (group == d.byTheme.end() || std::string(t.id) == "timing") continue;
        h << "<tr class=\"group\"><th colspan=\"" << d.species.size() + 1 << "\">" << t.title
          << "</th></tr>\n";
        for (const auto& m : group->second) {
            h << "<tr><td class=\"l\">" << esc(axisTitle(m, d.perView)) << "</td>";
            for (const auto& s : d.species) {
                auto it = d.values.at(m).find(s);
                if (it == d.values.at(m).end()) {
                    h << "<td>–</td>";
                    continue;
                }
                Summary x = plotSummary(it->second);
                h << "<td>" << num(x.mean) << " ± " << num(x.sd, 3) << " (" << num(x.q50)
                  << ")</td>";
            }
            h << "</tr>\n";
        }
    }
    h << "</table>\n</details>\n";
    if (!d.constant.empty()) {
        h << "<p class=\"note\">Constant over the dataset, or over the species that have it "
             "(not plotted): ";
        for (size_t i = 0; i < d.constant.size(); ++i) h << (i ? ", " : "") << esc(d.constant[i]);
        h << ".</p>\n";
    }
}

// A box plot per metric in a grid per theme, timings last; returns the number of plots.
size_t writeDistributions(std::ostream& h, const ReportData& d) {
    size_t plots = 0;
    h << "<h2 id=\"distributions\">Distributions</h2>\n<p class=\"note\">Box: q25–q75; thick "
         "line: median; whiskers: q05–q95; diamond: mean; dots: instances (only those past the "
         "whiskers above 300 per species; a species with fewer than "
      << kMinInstancesForBox
      << " values shows its instances and median only). A species without a value of a metric "
         "(a method's own counter, a null) has no row in its plot.</p>\n<div class=\"legend\">";
    for (size_t i = 0; i < d.species.size(); ++i) {
        h << "<span style=\"--c: " << speciesColour(i) << "\">" << esc(d.species[i]) << " (n "
          << d.perSpeciesCount.at(d.species[i]) << ")</span>";
    }
    h << "</div>\n";
    for (const Theme& t : kThemes) {
        auto group = d.byTheme.find(t.id);
        if (group == d.byTheme.end()) continue;
        h << "<h3 id=\"theme-" << t.id << "\">" << t.title << " <span class=\"note\">— " << t.note
          << "</span></h3>\n<div class=\"plots\">\n";
        for (const auto& m : group->second) {
            h << boxPlotFigure(m, d.species, d.values.at(m), d.perView, d.labelWidth);
            ++plots;
        }
        h << "</div>\n";
    }
    return plots;
}

// For every pair of species, the five metrics that separate them best (KS D, then W1).
void writeComparison(std::ostream& h, const ReportData& d) {
    h << "<h2 id=\"compare\">Species comparison</h2>\n";
    if (d.species.size() < 2) {
        h << "<p class=\"note\">One species: nothing to compare.</p>\n";
    } else {
        h << "<p class=\"note\">For every pair of species, the five metrics that separate them "
             "best (two-sample Kolmogorov–Smirnov D, largest first, ties broken by |mean "
             "difference| / pooled sd). Bold: the strongest; highlighted: D ≥ 0.5. p: the KS "
             "p-value, given only when both species have at least "
          << kMinInstancesForP
          << " values of the metric (\"too few instances\" otherwise: D and W1 then describe "
             "the instances at hand, not the species). W1: Wasserstein-1 distance, in the "
             "metric's unit.</p>\n<table><tr><th class=\"l\">species a</th><th class=\"l\">"
             "species b</th><th class=\"l\">metric</th><th>n a / b</th><th>mean a</th><th>mean "
             "b</th><th>KS D</th><th>p</th><th>W1</th></tr>\n";
        for (size_t a = 0; a < d.species.size(); ++a) {
            for (size_t b = a + 1; b < d.species.size(); ++b) {
                struct Row {
                    std::string m;
                    double d, w, ma, mb, p, effect;
                    size_t na, nb;
                };
                std::vector<Row> rows;
                for (const auto& m : d.metrics) {
                    auto ia = d.values.at(m).find(d.species[a]),
                         ib = d.values.at(m).find(d.species[b]);
                    if (ia == d.values.at(m).end() || ib == d.values.at(m).end()) continue;
                    const QuantileSketch &qa = ia->second.sketch, &qb = ib->second.sketch;
                    KsResult ks;
                    double w = 0;
                    if (qa.exact() && qb.exact()) {
                        const std::vector<double> xa = qa.sortedValues(), xb = qb.sortedValues();
                        ks = ksTwoSample(xa, xb);
                        w = wasserstein1(xa, xb);
                    } else {  // from the sketches, p asymptotic (as sylva stats)
                        const auto wa = qa.weighted(), wb = qb.weighted();
                        ks.d = weightedKsDistance(wa, wb);
                        ks.p = ksAsymptoticP(ks.d, static_cast<double>(qa.count()),
                                             static_cast<double>(qb.count()));
                        w = weightedWasserstein(wa, wb);
                    }
                    Summary sa = plotSummary(ia->second), sb = plotSummary(ib->second);
                    double pooled = std::sqrt(0.5 * (sa.sd * sa.sd + sb.sd * sb.sd));
                    double effect = pooled > 0 ? std::fabs(sa.mean - sb.mean) / pooled
                                               : (sa.mean != sb.mean ? INFINITY : 0.0);
                    rows.push_back({m, ks.d, w, sa.mean, sb.mean, ks.p, effect, ia->second.n(),
                                    ib->second.n()});
                }
                std::stable_sort(rows.begin(), rows.end(), [](const Row& x, const Row& y) {
                    return x.d != y.d ? x.d > y.d : x.effect > y.effect;
                });
                if (rows.size() > 5) rows.resize(5);
                for (size_t i = 0; i < rows.size(); ++i) {
                    const Row& r = rows[i];
                    std::string u = metricUnit(r.m);
                    const bool few = std::min(r.na, r.nb) < kMinInstancesForP;
                    h << "<tr" << (i == 0 ? " class=\"top\"" : "") << "><td class=\"l\">"
                      << esc(d.species[a]) << "</td><td class=\"l\">" << esc(d.species[b])
                      << "</td><td class=\"l\">" << esc(r.m) << "</td><td>" << r.na << " / " << r.nb
                      << "</td><td>" << num(r.ma) << "</td><td>" << num(r.mb) << "</td><td"
                      << (r.d >= 0.5 ? " class=\"strong\"" : "") << ">" << num(r.d, 3) << "</td>"
                      << (few ? "<td class=\"few\">too few instances</td>"
                              : "<td>" + num(r.p, 2) + "</td>")
                      << "<td>" << num(r.w) << (u.empty() ? "" : " " + esc(u)) << "</td></tr>\n";
                }
            }
        }
        h << "</table>\n";
    }
}

// Per species and swept path, the four metrics whose means vary most with the swept value;
// returns the number of plots.
size_t writeSweeps(std::ostream& h, const ReportData& d) {
    size_t plots = 0;
    h << "<h2 id=\"sweeps\">Sweeps</h2>\n<p class=\"note\">Per species and swept path: the "
         "mean of each metric against the swept value (line), ±1 sd (band); the four "
         "metrics whose means vary most with the value (largest share of variance between "
         "sweep points) are shown.</p>\n";
    for (const auto& s : d.species) {
        auto bySpecies = d.sweeps.find(s);
        if (bySpecies == d.sweeps.end()) continue;
        for (const auto& [path, groups] : bySpecies->second) {
            if (groups.size() < 2) continue;
            bool numericX = true;
            std::vector<std::pair<double, std::string>> order;
            for (const auto& g : groups) {
                char* end = nullptr;
                double x = std::strtod(g.first.c_str(), &end);
                if (end == g.first.c_str() || *end != '\0' || !std::isfinite(x)) numericX = false;
                order.emplace_back(x, g.first);
            }
            if (numericX) std::sort(order.begin(), order.end());
            struct Scored {
                double eta2;
                std::string m;
                std::vector<SweepPoint> pts;
            };
            std::vector<Scored> scored;
            for (const auto& m : d.metrics) {
                std::vector<SweepPoint> pts;
                for (const auto& [x, label] : order) {
                    const auto& streams = groups.at(label);
                    auto it = streams.find(m);
                    if (it == streams.end() || it->second.n() == 0) continue;
                    pts.push_back({label, x, plotSummary(it->second)});
                }
                if (pts.size() < 2) continue;
                // The share of variance between sweep points, from each point's n, mean and sd:
                // total = Σ (n − 1) sd² + Σ n (mean − grand)², between = the second sum.
                double n = 0, sum = 0;
                for (const auto& p : pts) {
                    n += static_cast<double>(p.s.n);
                    sum += static_cast<double>(p.s.n) * p.s.mean;
                }
                const double grand = sum / n;
                double within = 0, between = 0;
                for (const auto& p : pts) {
                    within += (static_cast<double>(p.s.n) - 1) * p.s.sd * p.s.sd;
                    between += static_cast<double>(p.s.n) * (p.s.mean - grand) * (p.s.mean - grand);
                }
                const double total = within + between;
                if (total <= 0) continue;
                scored.push_back({between / total, m, std::move(pts)});
            }
            std::stable_sort(scored.begin(), scored.end(),
                             [](const Scored& x, const Scored& y) { return x.eta2 > y.eta2; });
            if (scored.size() > 4) scored.resize(4);
            h << "<h3>" << esc(s) << " · " << esc(path) << "</h3>\n<div class=\"plots\">\n";
            for (const auto& sc : scored) {
                h << sweepSvg(s, path, sc.m, sc.pts, numericX, d.perView);
                ++plots;
            }
            h << "</div>\n";
        }
    }
    return plots;
}

// Every relative link of the page resolves from `reportDir` (created, so "../x" resolves).
void checkLinks(const std::string& html, const fs::path& reportDir) {
    fs::create_directories(reportDir);
    for (const std::string& link : relativeLinks(html)) {
        std::string file = urlDecode(link.substr(0, link.find_first_of("#?")));
        if (!fs::exists(reportDir / file)) {
            throw std::runtime_error("report: the link \"" + link + "\" does not resolve");
        }
    }
}

}  // namespace

ReportResult writeReport(const fs::path& dir) {
    // DIR/report/ is written into the dataset: not while a build (or another report) runs there.
    std::unique_ptr<OutputLock> lock;
    std::error_code ec;
    if (fs::is_directory(dir, ec)) lock = std::make_unique<OutputLock>(dir, "sylva report");
    const ReportData d = readReportData(dir);
    ReportResult result;
    result.instances = d.records;
    result.species = d.species.size();
    result.metrics = d.metrics.size();
    std::ostringstream h;
    writeHead(h, d, dir);
    writeFacts(h, d);
    writeContactSheets(h, d, dir);
    result.plots += writeDistributions(h, d);
    writeComparison(h, d);
    if (d.anySweep) {
        result.sweepPlots = writeSweeps(h, d);
        result.plots += result.sweepPlots;
    }
    writeSummaryTable(h, d);
    h << "</body>\n</html>\n";
    const std::string html = h.str();
    const fs::path reportDir = dir / "report";
    checkLinks(html, reportDir);
    result.index = reportDir / "index.html";
    writeFileAtomic(result.index, html);
    return result;
}

}  // namespace sylva
