#include "pipeline/batch/dataset.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "pipeline/batch/pack.h"
#include "pipeline/scan/scan_pattern.h"
#include "species/plot/plot_spec.h"
#include "species/spec/budget_spec.h"

namespace sylva {

namespace fs = std::filesystem;

uint64_t instanceSeed(uint64_t datasetSeed, const std::string& species, const std::string& pointKey,
                      int64_t index) {
    uint64_t h = hashCombine(datasetSeed, hashString(species));
    h = hashCombine(h, hashString(pointKey));
    return hashCombine(h, static_cast<uint64_t>(index));
}

bool isDatasetFile(const toml::table& t) {
    return (t.contains("species") && t["species"].is_array()) ||
           (t.contains("plot") && t["plot"].is_array());
}

namespace {

std::string valueText(const toml::node& n) {
    if (auto i = n.as_integer()) return std::to_string(i->get());
    if (auto f = n.as_floating_point()) {
        std::ostringstream s;
        s.precision(12);
        s << f->get();
        return s.str();
    }
    if (auto s = n.as_string()) return s->get();
    if (auto b = n.as_boolean()) return b->get() ? "true" : "false";
    return "?";
}

SweepAxis parseSweep(Params& p) {
    SweepAxis a;
    a.where = p.whereTable();
    a.path = p.string("path");
    a.species = p.stringArray("species");
    a.plots = p.stringArray("plots");  // an axis over plots' own keys (docs/plots.md, "Sweeps")
    if (p.has("species") && p.has("plots")) {
        p.fail("plots", "expected either species or plots for one axis, not both");
    }
    if (p.has("plots") && a.plots.empty()) p.fail("plots", "expected at least one plot name");
    if (p.has("species") && a.species.empty()) {
        p.fail("species",
               "expected at least one species name (leave the key out to sweep every species)");
    }
    // same_seed: every point of this axis grows from the same instance seeds, so only the
    // swept parameter differs (e.g. grammar.max_depth → growth stages of one tree).
    a.sameSeed = p.boolean("same_seed", false);
    if (p.has("values") == p.has("range")) {
        p.failHere("a sweep needs exactly one of `values = [...]` or `range = {from, to, steps}`");
    }
    auto add = [&](const toml::node& n) {
        toml::table holder;
        if (auto i = n.as_integer())
            holder.insert("v", i->get());
        else if (auto f = n.as_floating_point())
            holder.insert("v", f->get());
        else if (auto s = n.as_string())
            holder.insert("v", s->get());
        else if (auto b = n.as_boolean())
            holder.insert("v", b->get());
        else
            p.fail("values", "sweep values must be numbers, strings or booleans");
        a.labels.push_back(valueText(*holder.get("v")));
        a.values.push_back(std::move(holder));
    };
    if (p.has("values")) {
        const toml::node* v = p.raw("values");
        const toml::array* arr = v->as_array();
        if (!arr || arr->empty()) p.fail("values", "expected a non-empty array");
        for (const auto& e : *arr) add(e);
    } else {
        Params r = p.table("range");
        double from = r.number("from", Range::any());
        double to = r.number("to", Range::any());
        int64_t steps = r.integer("steps", Range::closed(1, 100000));
        bool integer = r.boolean("integer", false);
        r.finish();
        for (int64_t k = 0; k < steps; ++k) {
            double t = steps == 1 ? 0.0 : static_cast<double>(k) / (steps - 1);
            double v = from + (to - from) * t;
            toml::table holder;
            if (integer)
                holder.insert("v", static_cast<int64_t>(std::llround(v)));
            else
                holder.insert("v", v);
            add(*holder.get("v"));
        }
    }
    p.finish();
    return a;
}

// An error inside a species file, reported at the dataset line that names the file, on one
// line: "ds.toml:5:8: species[0].file: in tiny.toml:19:9: levels[0].nodes: expected …".
[[noreturn]] void failInSpeciesFile(const SpeciesEntry& entry, const SpecError& e) {
    throw SpecError(entry.fileWhere, entry.fileKey, std::string("in ") + e.what());
}

// [[species]]: each file loaded and checked once, names unique; their bytes join the
// fingerprint.
void readSpeciesEntries(Params& p, DatasetSpec& d, std::string& fingerprintBytes) {
    std::vector<Params> entries = p.tableArray("species");
    if (entries.empty() && !p.has("plot")) {
        p.fail("species", p.has("method") && !p.has("species")
                              ? "expected at least one [[species]] entry: this is a species "
                                "file (it has a method), not a dataset (sylva grow grows one "
                                "tree of it)"
                              : "expected at least one [[species]] entry (or a [[plot]])");
    }
    std::set<std::string> names;
    fs::path base = fs::path(d.path).parent_path();
    for (Params& e : entries) {
        SpeciesEntry entry;
        std::string file = e.string("file");
        fs::path resolved = fs::path(file).is_absolute() ? fs::path(file) : base / file;
        if (!fs::is_regular_file(resolved)) {
            e.fail("file", "species file not found: " + resolved.string());
        }
        entry.fileWhere = e.where("file");
        entry.fileKey = e.path("file");
        try {
            entry.species = loadSpecies(resolved.lexically_normal().string());
        } catch (const SpecError& err) {
            failInSpeciesFile(entry, err);
        }
        // Params reads integers through a double, exact up to kMaxInstances (any larger integer
        // stays above it); the error shows a large integer's own digits.
        if (const toml::node* c = e.raw("count");
            c && c->as_integer() && c->as_integer()->get() > kMaxInstances) {
            e.fail("count", "expected an integer in [0, 9e+15] (the largest dataset), got " +
                                std::to_string(c->as_integer()->get()));
        }
        entry.count = e.integer("count", Range::closed(0, static_cast<double>(kMaxInstances)));
        entry.countWhere = e.where("count");
        entry.keyPath = e.prefix();
        e.finish();
        if (!names.insert(entry.species.name).second) {
            e.fail("file", "species \"" + entry.species.name +
                               "\" is listed twice (species names must be unique)");
        }
        fingerprintBytes += fileBytes(entry.species.path);
        d.species.push_back(std::move(entry));
    }
}

// Every species a sweep names is in the dataset.
void checkSweptSpecies(const DatasetSpec& d) {
    std::set<std::string> names;
    for (const SpeciesEntry& e : d.species) names.insert(e.species.name);
    for (const SweepAxis& a : d.sweeps) {
        for (const std::string& s : a.species) {
            if (!names.count(s)) {
                std::string hint;
                if (auto c = closestWord(s, names)) hint = "; did you mean \"" + *c + "\"?";
                throw SpecError(a.where, "sweep.species",
                                "no species named \"" + s + "\" in this dataset" + hint);
            }
        }
    }
}

// [scan]: what the scan writes (read here), then the scanner's own keys (readScanOptions).
void readScan(Params& t, ScanOutputs& scan) {
    scan.enabled = true;
    if (t.has("formats")) {
        scan.las = scan.laz = scan.forestFormer = scan.treeLearn = false;
        const std::vector<std::string> formats = t.stringArray("formats");
        if (formats.empty())
            t.fail("formats",
                   "expected at least one of \"las\", \"laz\", \"forestformer\", \"treelearn\"");
        for (const std::string& f : formats) {
            if (f == "las")
                scan.las = true;
            else if (f == "laz")
                scan.laz = true;
            else if (f == "forestformer")
                scan.forestFormer = true;
            else if (f == "treelearn")
                scan.treeLearn = true;
            else
                t.fail("formats",
                       "expected \"las\", \"laz\", \"forestformer\" or \"treelearn\", got \"" + f +
                           "\"");
        }
    }
    scan.colour = t.choice(
        "las_colour", scan.colour,
        {{"none", LasColour::kNone}, {"class", LasColour::kClass}, {"tree", LasColour::kTree}});
    scan.classes =
        t.choice("las_classes", scan.classes,
                 {{"for-instance", LasClasses::kForInstance}, {"asprs", LasClasses::kAsprs}});
    scan.options = readScanOptions(t);
}

// Every TLS station within max_range of every plot it scans (the plot's area and the terrain
// margin around it, horizontally): a station farther off would record nothing of the plot, where
// the build would run and write an empty scan. `t` is the [scan] table, for the station's place.
void checkStationsReachPlots(Params& t, const DatasetSpec& d) {
    const ScanOptions& o = d.outputs.scan.options;
    if (o.platform != ScanPlatform::kTls) return;
    std::vector<Params> stations = t.tableArray("stations");
    for (size_t i = 0; i < stations.size() && i < o.stations.size(); ++i) {
        const TlsStation& st = o.stations[i];
        for (const PlotSpec& plot : d.plots) {
            double dx = 0, dz = 0, gap = 0;
            if (plot.area.shape == PlotArea::Shape::kCircle) {
                gap = std::hypot(st.x, st.z) - plot.area.radius - plot.margin;
                dx = std::abs(st.x), dz = std::abs(st.z);
            } else {
                dx = std::abs(st.x) - plot.area.halfX() - plot.margin;
                dz = std::abs(st.z) - plot.area.halfZ() - plot.margin;
                gap = std::hypot(std::max(dx, 0.0), std::max(dz, 0.0));
            }
            if (gap <= o.maxRange) continue;
            stations[i].fail(dx >= dz ? "x" : "z",
                             "expected a station within max_range (" + formatNumber(o.maxRange) +
                                 " m) of plot \"" + plot.name + "\", got one " +
                                 formatNumber(gap, 4) + " m from its area and " +
                                 formatNumber(plot.margin) +
                                 " m margin: it would record nothing of the plot");
        }
    }
}

// An ALS/ULS survey of each plot within 1e9 pulses (after a `pulses` cap), counted before
// anything is built: the strips cover the plot's area, known from the spec. A tree's ground
// square is known only once grown (the scanner checks it then); here its smallest, the margin
// around a point, so a survey too large for any tree is refused before anything is written. `t`
// is the [scan] table, for the place.
void checkAirborneSurveys(Params& t, const DatasetSpec& d) {
    const ScanOptions& o = d.outputs.scan.options;
    if (o.platform == ScanPlatform::kTls) return;
    auto check = [&](double hx, double hz, const std::string& what) {
        Aabb area;
        area.extend(Vec3{-hx, 0, -hz});
        area.extend(Vec3{hx, 0, hz});
        const double all = static_cast<double>(ScanPattern(area, o).count());
        const double pulses =
            o.maxPulses > 0 ? std::min(all, static_cast<double>(o.maxPulses)) : all;
        if (pulses <= kMaxScanSurveyPulses) return;
        const char* key = o.maxPulses > 0       ? "pulses"
                          : t.has("pulse_rate") ? "pulse_rate"
                                                : "platform";
        t.fail(key, "expected at most 1e9 pulses in the survey of " + what + ", got " +
                        formatNumber(pulses, 3) + " over its " + formatNumber(2 * hx, 4) + " × " +
                        formatNumber(2 * hz, 4) +
                        " m; cap them with `pulses` (≤ 1e9), fly faster or pulse slower");
    };
    for (const PlotSpec& plot : d.plots) {
        check(plot.area.halfX(), plot.area.halfZ(), "plot \"" + plot.name + "\"");
    }
    if (!d.species.empty()) {
        check(kTreeGroundMargin, kTreeGroundMargin, "a tree (its smallest ground square)");
    }
}

// [outputs] (without the [views] table); defaults come from OutputOptions.
void readOutputs(Params& o, OutputOptions& out) {
    std::vector<std::string> sk = o.stringArray("skeleton");
    if (o.has("skeleton")) {
        out.ply = out.swc = false;
        for (const auto& f : sk) {
            if (f == "ply")
                out.ply = true;
            else if (f == "swc")
                out.swc = true;
            else
                o.fail("skeleton",
                       "unknown skeleton format \"" + f + "\" (known: \"ply\", \"swc\")");
        }
    }
    out.preview = o.boolean("preview", out.preview);
    out.leafOutlines = o.boolean("leaf_outlines", out.leafOutlines);
    out.qsm = o.boolean("qsm", out.qsm);  // the default is set from [scan] before
    out.previewSize =
        static_cast<int>(o.integer("preview_size", out.previewSize, Range::closed(16, 8192)));
    for (const auto& f : o.stringArray("mesh")) {
        if (f != "ply" && f != "glb" && f != "obj") {
            o.fail("mesh", "unknown mesh format \"" + f + "\" (known: \"ply\", \"glb\", \"obj\")");
        }
        if (std::find(out.meshFormats.begin(), out.meshFormats.end(), f) == out.meshFormats.end()) {
            out.meshFormats.push_back(f);
        }
    }
    if (auto t = o.optionalTable("tubes")) {
        TubeOptions& tb = out.tubes;
        tb.minSides = static_cast<int>(t->integer("min_sides", tb.minSides, Range::closed(3, 256)));
        tb.maxSides = static_cast<int>(t->integer("max_sides", tb.maxSides, Range::closed(3, 256)));
        if (tb.maxSides < tb.minSides) t->fail("max_sides", "expected max_sides ≥ min_sides");
        tb.edgeLength = t->number("edge_length", tb.edgeLength, Range::positive());
        tb.minRadius = t->number("min_radius", tb.minRadius, Range::nonNegative());
        tb.dropThin = t->boolean("drop_thin", tb.dropThin);
        t->finish();
    }
    if (const toml::node* w = o.raw("watertight"); w && w->is_boolean()) {
        out.watertight = o.boolean("watertight", out.watertight);
    } else if (auto wt = o.optionalTable("watertight")) {
        out.watertight = true;
        out.watertightOptions.voxelSize =
            wt->number("voxel_size", out.watertightOptions.voxelSize, Range::closed(1e-4, 10));
        out.vdb = wt->boolean("vdb", out.vdb);
        wt->finish();
    }
    if (out.watertight && out.meshFormats.empty()) {
        o.fail("watertight", "needs a mesh format: set mesh = [\"ply\"] (or glb, obj)");
    }
    out.textures = o.boolean("textures", out.textures);
    auto has = [&](const char* f) {
        return std::find(out.meshFormats.begin(), out.meshFormats.end(), f) !=
               out.meshFormats.end();
    };
    if (out.textures && !has("glb") && !has("obj")) {
        o.fail("textures", "needs a textured mesh format: set mesh = [\"glb\"] (or obj)");
    }
    out.meshCompression =
        o.choice("mesh_compression", std::string("none"), {"none", "meshopt", "draco"});
    if (out.meshCompression != "none" && !has("glb")) {
        o.fail("mesh_compression", "compresses GLB meshes: set mesh = [\"glb\"] as well");
    }
    out.leafInstances = o.boolean("leaf_instances", out.leafInstances);
    if (out.leafInstances && !has("glb")) {
        o.fail("leaf_instances",
               "instances the leaves of GLB meshes: set mesh = [\"glb\"] as well");
    }
    out.speciesSheet =
        static_cast<int>(o.integer("species_sheet", out.speciesSheet, Range::closed(0, 10000)));
    const bool tar = o.choice("pack", std::string("none"), {"none", "tar"}) == "tar";
    const int64_t perShard = o.integer("pack_instances", 256, Range::closed(1, kMaxPackInstances));
    if (!tar && o.raw("pack_instances")) {
        o.fail("pack_instances", "sets the instances per tar shard: set pack = \"tar\" as well");
    }
    out.packInstances = tar ? perShard : 0;
    o.finish();
}

// [views]; defaults come from ViewOptions, except `count`: a [views] table without it asks
// for kDefaultViewCount views (no table: none).
constexpr int kDefaultViewCount = 8;
// The [views] colour keys (pipeline/render/colour_render.h ColourOptions).
void readColour(Params& v, ColourOptions& co) {
    co.enabled = v.boolean("colour", co.enabled);
    co.samples = static_cast<int>(v.integer("colour_samples", co.samples, Range::closed(1, 256)));
    co.aoRays = static_cast<int>(v.integer("colour_ao_rays", co.aoRays, Range::closed(0, 64)));
    co.background = v.choice("colour_background", co.background,
                             {{"transparent", ColourBackground::kTransparent},
                              {"colour", ColourBackground::kColour},
                              {"sky", ColourBackground::kSky}});
    if (v.has("colour_background_colour")) {
        const std::string text = v.string("colour_background_colour");
        if (!parseHexColour(text, co.backgroundColour)) {
            v.fail("colour_background_colour",
                   "expected an sRGB colour \"#rrggbb\" (six hex digits), got \"" + text + "\"");
        }
    } else {
        v.raw("colour_background_colour");
    }
    std::tie(co.sunElevationDeg[0], co.sunElevationDeg[1]) =
        v.interval("colour_sun_elevation_deg", {co.sunElevationDeg[0], co.sunElevationDeg[1]},
                   Range::closed(1, 90));
    co.unlit =
        v.choice("colour_lighting", std::string("sun-and-sky"), {"sun-and-sky", "none"}) == "none";
    co.autoExposure = v.boolean("colour_auto_exposure", co.autoExposure);
    std::tie(co.exposureEv[0], co.exposureEv[1]) = v.interval(
        "colour_exposure_ev", {co.exposureEv[0], co.exposureEv[1]}, Range::closed(-8, 8));
    co.jpeg = v.choice("colour_format", std::string("png"), {"png", "jpg"}) == "jpg";
    co.jpegQuality =
        static_cast<int>(v.integer("colour_jpeg_quality", co.jpegQuality, Range::closed(1, 100)));
    if (co.jpeg && co.background == ColourBackground::kTransparent) {
        v.fail("colour_format",
               "\"jpg\" has no alpha: give colour_background = \"colour\" or \"sky\" with it");
    }
}

void readViews(Params& v, ViewOptions& vo, RenderOptions& ro, ColourOptions& co) {
    vo.count = static_cast<int>(v.integer("count", kDefaultViewCount, Range::closed(0, 1000)));
    if (v.has("elevations_deg") && v.has("elevation_range_deg")) {
        v.fail("elevation_range_deg", "give either elevations_deg or elevation_range_deg");
    }
    if (v.has("elevation_range_deg")) {
        auto [lo, hi] = v.interval("elevation_range_deg", {0, 0}, Range::closed(-89, 89));
        vo.elevationsDeg = {lo, hi};
        vo.elevationRange = true;
    } else if (v.has("elevations_deg")) {
        const toml::array* a = v.raw("elevations_deg")->as_array();
        if (!a || a->empty()) v.fail("elevations_deg", "expected a non-empty array of degrees");
        vo.elevationsDeg.clear();
        for (size_t i = 0; i < a->size(); ++i) {
            auto x = a->get(i)->value<double>();
            if (!x || !(*x >= -89 && *x <= 89)) {
                v.fail("elevations_deg", "expected degrees in [-89, 89]");
            }
            vo.elevationsDeg.push_back(*x);
        }
    }
    if (v.has("azimuth_offset_deg")) {
        vo.randomAzimuth = false;
        vo.azimuthOffsetDeg =
            v.number("azimuth_offset_deg", vo.azimuthOffsetDeg, Range::closed(-360, 360));
    }
    std::string proj = v.choice("projection", vo.orthographic ? "orthographic" : "perspective",
                                {"perspective", "orthographic"});
    vo.orthographic = proj == "orthographic";
    vo.fovDeg = v.number("fov_deg", vo.fovDeg, Range::closed(1, 170));
    if (const toml::node* r = v.raw("resolution")) {
        const toml::array* a = r->as_array();
        // Integers only: value<int64_t>() would also take a whole float such as 64.0.
        auto w = a && a->size() == 2 && a->get(0)->is_integer() ? a->get(0)->value<int64_t>()
                                                                : std::nullopt;
        auto h = a && a->size() == 2 && a->get(1)->is_integer() ? a->get(1)->value<int64_t>()
                                                                : std::nullopt;
        if (!w || !h || *w < 8 || *h < 8 || *w > 16384 || *h > 16384) {
            v.fail("resolution", "expected [width, height] in whole pixels, 8 to 16384");
        }
        vo.width = static_cast<int>(*w);
        vo.height = static_cast<int>(*h);
    }
    vo.margin = v.number("margin", vo.margin, Range::closed(0.5, 10));
    vo.depth = v.boolean("depth", vo.depth);
    vo.depthHalf = v.boolean("depth_half", vo.depthHalf);
    if (vo.depthHalf && !vo.depth) v.fail("depth_half", "needs depth = true");
    if (v.has("depth_compression")) {
        vo.depthZip = v.choice("depth_compression", "rle", {"rle", "zip"}) == "zip";
        if (!vo.depth) v.fail("depth_compression", "needs depth = true");
    }
    vo.depthPng = v.boolean("depth_png", vo.depthPng);
    vo.labels = v.boolean("labels", vo.labels);
    vo.pointCloud = v.boolean("point_cloud", vo.pointCloud);
    if (vo.pointCloud && !vo.depth) v.fail("point_cloud", "needs depth = true");
    vo.contactSheet = v.boolean("contact_sheet", vo.contactSheet);
    ro.minWidthPx = v.number("min_width_px", ro.minWidthPx, Range::closed(0, 64));
    readColour(v, co);
    v.finish();
}

// The views of one instance are held in memory together: their pixels are held to the
// dataset's max_view_pixels, before anything is built.
void checkViewPixels(Params& v, const ViewOptions& vo, const BudgetTable& table) {
    Budget budget;
    table.applyTo(budget);
    const double pixels = double(vo.count) * vo.width * vo.height;
    if (pixels > static_cast<double>(budget.maxViewPixels)) {
        const char* key = v.has("resolution") ? "resolution" : "count";
        v.fail(key, std::to_string(vo.count) + " views of " + std::to_string(vo.width) + " × " +
                        std::to_string(vo.height) + " pixels make " + formatSize(pixels) +
                        " pixels per instance, over the budget max_view_pixels = " +
                        std::to_string(budget.maxViewPixels) +
                        "; raise [budget] max_view_pixels or lower it");
    }
}

// The sweep points of one species: the cartesian product of the sweeps that apply to it, each
// checked to make a valid species whose every swept path is a key the species reads.
void expandSweepPoints(SpeciesEntry& entry, const std::vector<SweepAxis>& sweeps, bool meshed) {
    std::vector<const SweepAxis*> axes;
    for (const SweepAxis& a : sweeps) {
        if (a.plots.empty() &&
            (a.species.empty() || std::find(a.species.begin(), a.species.end(),
                                            entry.species.name) != a.species.end())) {
            for (const SweepAxis* b : axes) {
                if (b->path == a.path) {
                    throw SpecError(a.where, "sweep.path",
                                    "\"" + a.path + "\" is already swept (at " + b->where.str() +
                                        ") for species \"" + entry.species.name + "\"");
                }
            }
            axes.push_back(&a);
        }
    }
    size_t total = 1;
    for (auto* a : axes) {
        total *= a->values.size();
        if (total > 1000000) throw SpecError(a->where, "sweep", "over 10⁶ sweep points");
    }
    for (size_t k = 0; k < total; ++k) {
        SweepPoint pt;
        auto ov = std::make_shared<Overrides>();
        size_t rest = k;
        for (auto* a : axes) {
            size_t v = rest % a->values.size();
            rest /= a->values.size();
            Override o;
            o.holder = a->values[v];
            o.where = a->where;
            (*ov)[a->path] = std::move(o);
            pt.values[a->path] = a->labels[v];
            pt.key += (pt.key.empty() ? "" : ";") + a->path + "=" + a->labels[v];
            if (!a->sameSeed) {
                pt.seedKey += (pt.seedKey.empty() ? "" : ";") + a->path + "=" + a->labels[v];
            }
        }
        try {
            validateSpecies(entry.species, ov.get(), &entry.budget, meshed);
        } catch (const SpecError& err) {
            // A sweep value's own error is already at the sweep, in the dataset file.
            if (err.where().file != entry.species.path) throw;
            failInSpeciesFile(entry, err);
        }
        for (const auto& [path, o] : *ov) {
            if (!o.used) {
                throw SpecError(o.where, "sweep.path",
                                "\"" + path + "\" is not a parameter of species \"" +
                                    entry.species.name + "\" (" + entry.species.path + ")");
            }
        }
        pt.overrides = ov;
        entry.points.push_back(std::move(pt));
    }
}

// Σ count × sweep points ≤ kMaxInstances, summed in 128 bits (each count ≤ kMaxInstances, at
// most 10⁶ points each); the error points at the count that crosses it.
void checkInstanceTotal(const DatasetSpec& d) {
    unsigned __int128 total = 0;
    for (const SpeciesEntry& e : d.species) {
        total += static_cast<unsigned __int128>(e.count) * e.points.size();
        if (total > static_cast<unsigned __int128>(kMaxInstances)) {
            std::string digits;
            for (unsigned __int128 v = total; v > 0; v /= 10) {
                digits.insert(digits.begin(), static_cast<char>('0' + static_cast<int>(v % 10)));
            }
            throw SpecError(e.countWhere, e.keyPath + ".count",
                            "expected at most 9e+15 instances in the dataset (Σ count × sweep "
                            "points: the largest dataset supported), got " +
                                digits);
        }
    }
}

// Ids are unique: "<name>-p<point>-<index>" of a swept species is never the id
// "<other>-<index>" of an unswept species named "<name>-p<point>" (both with instances).
void checkIdsUnique(const DatasetSpec& d) {
    for (const SpeciesEntry& x : d.species) {
        if (x.count == 0 || x.points.size() > 1 || !x.points[0].key.empty()) continue;
        for (const SpeciesEntry& y : d.species) {
            if (y.count == 0 || (y.points.size() == 1 && y.points[0].key.empty())) continue;
            const std::string& n = x.species.name;
            const std::string prefix = y.species.name + "-p";
            if (n.size() <= prefix.size() || n.compare(0, prefix.size(), prefix) != 0) continue;
            for (size_t pi = 0; pi < y.points.size(); ++pi) {
                if (instanceId(y.species.name, true, static_cast<int>(pi), 0) != n + "-00000") {
                    continue;
                }
                throw SpecError(x.fileWhere, x.keyPath + ".file",
                                "expected a species name that no instance id of another species "
                                "starts with, got \"" +
                                    n + "\": \"" + n + "-00000\" is also sweep point " +
                                    std::to_string(pi) + " of species \"" + y.species.name +
                                    "\" (rename one)");
            }
        }
    }
}

// The last plot's name is unique, and none of its instance ids ("<plot>-<index>") is a species
// instance id: a plot is not named like a species, nor like a swept species' sweep point
// ("<species>-p001"). `p` is its [[plot]] table, for the error's place.
void checkPlotName(const DatasetSpec& d, const Params& p) {
    const PlotSpec& plot = d.plots.back();
    for (size_t k = 0; k + 1 < d.plots.size(); ++k) {
        if (d.plots[k].name == plot.name) {
            p.fail("name", "expected a name no other [[plot]] has, got \"" + plot.name +
                               "\" again (also " + d.plots[k].keyPath + ")");
        }
    }
    for (const SpeciesEntry& e : d.species) {
        if (e.species.name == plot.name) {
            p.fail("name", "expected a name that is not a species of the dataset, got \"" +
                               plot.name + "\" (its instance ids would be the species' ids)");
        }
        for (size_t pi = 0; pi < e.points.size() && e.points.size() > 1; ++pi) {
            if (instanceId(e.species.name, true, static_cast<int>(pi), 0) ==
                plotInstanceId(plot.name, 0)) {
                p.fail("name", "expected a name no instance id of species \"" + e.species.name +
                                   "\" starts with, got \"" + plot.name + "\" (its sweep point " +
                                   std::to_string(pi) + ")");
            }
        }
    }
}

// A plot's sweep points: the cartesian product of the axes naming it, each point the plot read
// again from the dataset with the axes' values over its keys (overrides at "plot[k].<path>"),
// named "<plot>-p<point>". Every axis path must be a key the plot reads.
constexpr size_t kMaxPlotSweepPoints = 10000;

void expandPlotSweeps(DatasetSpec& d, std::vector<Params>& plots, DrawContext& draw, bool meshed,
                      std::string& fingerprintBytes) {
    std::set<std::string> named;
    PlotFileCache files;  // each species file and DEM read once for every plot and sweep point
    for (size_t k = 0; k < plots.size(); ++k) {
        PlotSpec base = readPlot(plots[k], d.budget, meshed, &fingerprintBytes, &files);
        named.insert(base.name);
        std::vector<const SweepAxis*> axes;
        for (const SweepAxis& a : d.sweeps) {
            if (std::find(a.plots.begin(), a.plots.end(), base.name) == a.plots.end()) continue;
            for (const SweepAxis* b : axes) {
                if (b->path == a.path) {
                    throw SpecError(a.where, "sweep.path",
                                    "\"" + a.path + "\" is already swept (at " + b->where.str() +
                                        ") for plot \"" + base.name + "\"");
                }
            }
            axes.push_back(&a);
        }
        if (axes.empty()) {
            d.plots.push_back(std::move(base));
            checkPlotName(d, plots[k]);
            continue;
        }
        size_t total = 1;
        for (const SweepAxis* a : axes) {
            total *= a->values.size();
            if (total > kMaxPlotSweepPoints) {
                throw SpecError(a->where, "sweep", "expected at most 10⁴ sweep points per plot");
            }
        }
        const std::string prefix = plots[k].prefix() + ".";
        for (size_t point = 0; point < total; ++point) {
            Overrides ov;
            std::map<std::string, std::string> values;
            std::string seedKey;
            size_t rest = point;
            for (const SweepAxis* a : axes) {
                const size_t v = rest % a->values.size();
                rest /= a->values.size();
                Override o;
                o.holder = a->values[v];
                o.where = a->where;
                ov[prefix + a->path] = std::move(o);
                values[a->path] = a->labels[v];
                if (!a->sameSeed) {
                    seedKey += (seedKey.empty() ? "" : ";") + a->path + "=" + a->labels[v];
                }
            }
            Params again(*d.table, d.path, "", &draw, &ov);
            again.documentAs("dataset");
            std::vector<Params> tables = again.tableArray("plot");
            // (The species files and DEM are in the fingerprint already.)
            PlotSpec s = readPlot(tables[k], d.budget, meshed, nullptr, &files);
            for (const auto& [full, o] : ov) {
                if (!o.used) {
                    throw SpecError(o.where, "sweep.path",
                                    "\"" + full.substr(prefix.size()) +
                                        "\" is not a key of plot \"" + base.name + "\" (" +
                                        plots[k].prefix() + ")");
                }
            }
            char suffix[32];
            std::snprintf(suffix, sizeof suffix, "-p%03zu", point);
            s.sweptFrom = base.name;
            s.name = base.name + suffix;
            s.seedKey = std::move(seedKey);
            s.sweep = std::move(values);
            d.plots.push_back(std::move(s));
            checkPlotName(d, plots[k]);
        }
    }
    for (const SweepAxis& a : d.sweeps) {
        for (const std::string& n : a.plots) {
            if (named.count(n)) continue;
            std::string hint;
            if (auto c = closestWord(n, named)) hint = "; did you mean \"" + *c + "\"?";
            throw SpecError(a.where, "sweep.plots",
                            "no plot named \"" + n + "\" in this dataset" + hint);
        }
    }
}

}  // namespace

DatasetSpec loadDataset(const std::string& path, KeyLog* keyLog) {
    DatasetSpec d;
    d.path = path;
    d.table = std::make_shared<const toml::table>(parseTomlFile(path));
    DrawContext draw;
    draw.draw = false;  // a dataset's numbers are plain values
    draw.keyLog = keyLog;
    Params p(*d.table, path, "", &draw);
    p.documentAs("dataset");
    d.name = p.string("name", fs::path(path).stem().string());
    // The name is the default output directory (out/<name>): keep it a plain name.
    if (!isFileSafeName(d.name)) {
        p.fail("name",
               "expected 1–64 letters, digits, '-' or '_' (it is used as the "
               "output directory name), got \"" +
                   d.name + "\"");
    }
    d.description = p.string("description", "");
    d.seed = static_cast<uint64_t>(p.integer("seed", 0, Range::closed(0, 9.2e18)));
    std::string fingerprintBytes = fileBytes(path);
    for (Params& s : p.tableArray("sweep")) d.sweeps.push_back(parseSweep(s));
    readSpeciesEntries(p, d, fingerprintBytes);
    checkSweptSpecies(d);
    if (auto b = p.optionalTable("budget")) d.budget = readBudget(*b, true);
    std::optional<Params> scanTable = p.optionalTable("scan");
    if (scanTable) readScan(*scanTable, d.outputs.scan);
    d.outputs.qsm = d.outputs.scan.enabled;  // [outputs] qsm overrides it
    if (auto o = p.optionalTable("outputs")) readOutputs(*o, d.outputs);
    if (auto v = p.optionalTable("views")) {
        readViews(*v, d.outputs.views, d.outputs.render, d.outputs.colour);
        checkViewPixels(*v, d.outputs.views, d.budget);
    }
    std::vector<Params> plots = p.tableArray("plot");  // [[plot]]: species/plot/plot_spec.h
    p.finish();
    const bool meshed =
        !d.outputs.meshFormats.empty() || d.outputs.views.count > 0 || d.outputs.scan.enabled;
    for (SpeciesEntry& entry : d.species) {
        entry.budget = d.budget;
        expandSweepPoints(entry, d.sweeps, meshed);
    }
    expandPlotSweeps(d, plots, draw, meshed, fingerprintBytes);
    if (scanTable) {
        checkStationsReachPlots(*scanTable, d);
        checkAirborneSurveys(*scanTable, d);
    }
    checkInstanceTotal(d);
    checkIdsUnique(d);
    char fingerprint[17];
    std::snprintf(fingerprint, sizeof fingerprint, "%016llx",
                  static_cast<unsigned long long>(hashString(fingerprintBytes)));
    d.fingerprint = fingerprint;
    return d;
}

uint64_t plotSeed(uint64_t datasetSeed, const PlotSpec& plot, int64_t index) {
    // "plot:" keeps a plot's seeds apart from a species' of the same name; a sweep point's
    // seeds hash the [[plot]] name and the point's seed key (same_seed axes left out of it).
    const std::string& name = plot.sweptFrom.empty() ? plot.name : plot.sweptFrom;
    return instanceSeed(datasetSeed, "plot:" + name, plot.seedKey, index);
}

std::string instanceId(const std::string& species, bool swept, int pointIndex, int64_t index) {
    char buf[64];
    if (swept) {
        std::snprintf(buf, sizeof buf, "-p%03d-%05lld", pointIndex, static_cast<long long>(index));
    } else {
        std::snprintf(buf, sizeof buf, "-%05lld", static_cast<long long>(index));
    }
    return species + buf;
}

namespace {

bool isSwept(const SpeciesEntry& e) { return e.points.size() > 1 || !e.points[0].key.empty(); }

// A decimal number of 1–18 digits (no sign); nullopt otherwise. Canonical form (padding) is
// checked by the caller, which formats the id again.
std::optional<int64_t> parseDigits(std::string_view s) {
    if (s.empty() || s.size() > 18) return std::nullopt;
    int64_t v = 0;
    for (char c : s) {
        if (c < '0' || c > '9') return std::nullopt;
        v = v * 10 + (c - '0');
    }
    return v;
}

}  // namespace

DatasetInstances::DatasetInstances(const DatasetSpec& spec) : spec_(&spec) {
    start_.reserve(spec.species.size() + 1);
    start_.push_back(0);
    for (size_t s = 0; s < spec.species.size(); ++s) {
        const SpeciesEntry& e = spec.species[s];
        // loadDataset keeps the sum ≤ kMaxInstances; a hand-made spec may not.
        const auto points = static_cast<int64_t>(e.points.size());
        if (e.count < 0 || (e.count > 0 && points > (kMaxInstances - start_.back()) / e.count)) {
            throw std::length_error("DatasetInstances: over kMaxInstances instances");
        }
        start_.push_back(start_.back() + e.count * points);
        byName_.emplace(e.species.name, s);
    }
    // Plots follow the species, each plot instance one position (no sweep points).
    for (size_t k = 0; k < spec.plots.size(); ++k) {
        const PlotSpec& p = spec.plots[k];
        if (p.count < 0 || p.count > kMaxInstances - start_.back()) {
            throw std::length_error("DatasetInstances: over kMaxInstances instances");
        }
        start_.push_back(start_.back() + p.count);
        byName_.emplace(p.name, spec.species.size() + k);
    }
}

InstanceJob DatasetInstances::operator[](int64_t position) const {
    if (position < 0 || position >= size()) {
        throw std::out_of_range("DatasetInstances: position " + std::to_string(position) + " of " +
                                std::to_string(size()));
    }
    // The last entry starting at or before `position` (entries without instances start where
    // the next one does, so this is the non-empty one that holds it).
    const size_t s = static_cast<size_t>(std::upper_bound(start_.begin(), start_.end(), position) -
                                         start_.begin() - 1);
    if (s >= spec_->species.size()) {
        const PlotSpec& p = spec_->plots[s - spec_->species.size()];
        InstanceJob j;
        j.plot = &p;
        j.datasetBudget = &spec_->budget;
        j.index = position - start_[s];
        j.seed = plotSeed(spec_->seed, p, j.index);
        j.id = plotInstanceId(p.name, j.index);
        j.position = position;
        return j;
    }
    const SpeciesEntry& e = spec_->species[s];
    const int64_t r = position - start_[s];
    InstanceJob j;
    j.entry = &e;
    j.pointIndex = static_cast<int>(r / e.count);
    j.point = &e.points[static_cast<size_t>(j.pointIndex)];
    j.index = r % e.count;
    j.seed = instanceSeed(spec_->seed, e.species.name, j.point->seedKey, j.index);
    j.id = instanceId(e.species.name, isSwept(e), j.pointIndex, j.index);
    j.position = position;
    return j;
}

std::optional<int64_t> DatasetInstances::find(std::string_view id) const {
    // The species name ends at one of the id's '-' (names may hold '-' themselves); at most one
    // split gives an id of this dataset (checkIdsUnique).
    for (size_t dash = id.find('-'); dash != std::string_view::npos;
         dash = id.find('-', dash + 1)) {
        auto it = byName_.find(id.substr(0, dash));
        if (it == byName_.end()) continue;
        if (it->second >= spec_->species.size()) {  // a plot
            const PlotSpec& p = spec_->plots[it->second - spec_->species.size()];
            const auto index = parseDigits(id.substr(dash + 1));
            if (!index || *index >= p.count || plotInstanceId(p.name, *index) != id) continue;
            return start_[it->second] + *index;
        }
        const SpeciesEntry& e = spec_->species[it->second];
        std::string_view rest = id.substr(dash + 1);
        int64_t point = 0;
        if (isSwept(e)) {
            const size_t sep = rest.find('-');
            if (rest.empty() || rest[0] != 'p' || sep == std::string_view::npos) continue;
            const auto p = parseDigits(rest.substr(1, sep - 1));
            if (!p || *p >= static_cast<int64_t>(e.points.size())) continue;
            point = *p;
            rest = rest.substr(sep + 1);
        }
        const auto index = parseDigits(rest);
        if (!index || *index >= e.count) continue;
        if (instanceId(e.species.name, isSwept(e), static_cast<int>(point), *index) != id) {
            continue;  // not in canonical form ("p1" for "p001", extra zeros)
        }
        return start_[it->second] + point * e.count + *index;
    }
    return std::nullopt;
}

std::vector<InstanceJob> expandJobs(const DatasetSpec& spec) {
    const DatasetInstances instances(spec);
    if (instances.size() > 10'000'000) {
        throw std::length_error("expandJobs: " + std::to_string(instances.size()) +
                                " instances (use DatasetInstances)");
    }
    std::vector<InstanceJob> jobs;
    jobs.reserve(static_cast<size_t>(instances.size()));
    for (int64_t i = 0; i < instances.size(); ++i) jobs.push_back(instances[i]);
    return jobs;
}

}  // namespace sylva
