#include "pipeline/build/dataset.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace sylva {

namespace fs = std::filesystem;

uint64_t instanceSeed(uint64_t datasetSeed, const std::string& species, const std::string& pointKey,
                      int64_t index) {
    uint64_t h = hashCombine(datasetSeed, hashString(species));
    h = hashCombine(h, hashString(pointKey));
    return hashCombine(h, static_cast<uint64_t>(index));
}

bool isDatasetFile(const toml::table& t) {
    return t.contains("species") && t["species"].is_array();
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

std::string fileBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

SweepAxis parseSweep(Params& p) {
    SweepAxis a;
    a.where = p.whereTable();
    a.path = p.string("path");
    a.species = p.stringArray("species");
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
        // llround beyond int64 gives an unspecified value (-9.2·10¹⁸ on x86): the error would
        // then quote a number the user never wrote.
        for (const char* key : {"from", "to"}) {
            if (integer && !(std::abs(key[0] == 'f' ? from : to) < 9.2e18)) {
                r.fail(key, "expected a number within ±9.2·10¹⁸ (integer = true)");
            }
        }
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

// [[species]]: each file loaded and checked once, names unique; their bytes join the
// fingerprint.
void readSpeciesEntries(Params& p, DatasetSpec& d, std::string& fingerprintBytes) {
    std::vector<Params> entries = p.tableArray("species");
    if (entries.empty()) p.fail("species", "expected at least one [[species]] entry");
    std::set<std::string> names;
    fs::path base = fs::path(d.path).parent_path();
    for (Params& e : entries) {
        SpeciesEntry entry;
        std::string file = e.string("file");
        fs::path resolved = fs::path(file).is_absolute() ? fs::path(file) : base / file;
        if (!fs::is_regular_file(resolved)) {
            e.fail("file", "species file not found: " + resolved.string());
        }
        entry.species = loadSpecies(resolved.lexically_normal().string());
        entry.count = e.integer("count", Range::closed(0, 1e9));
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
    out.speciesSheet =
        static_cast<int>(o.integer("species_sheet", out.speciesSheet, Range::closed(0, 10000)));
    o.finish();
}

// [views]; defaults come from ViewOptions, except `count`: a [views] table without it asks
// for kDefaultViewCount views (no table: none).
constexpr int kDefaultViewCount = 8;
void readViews(Params& v, ViewOptions& vo, RenderOptions& ro) {
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
        auto w = a && a->size() == 2 ? a->get(0)->value<int64_t>() : std::nullopt;
        auto h = a && a->size() == 2 ? a->get(1)->value<int64_t>() : std::nullopt;
        if (!w || !h || *w < 8 || *h < 8 || *w > 16384 || *h > 16384) {
            v.fail("resolution", "expected [width, height] in whole pixels, 8 to 16384");
        }
        vo.width = static_cast<int>(*w);
        vo.height = static_cast<int>(*h);
    }
    vo.margin = v.number("margin", vo.margin, Range::closed(0.5, 10));
    vo.depth = v.boolean("depth", vo.depth);
    vo.depthPng = v.boolean("depth_png", vo.depthPng);
    vo.labels = v.boolean("labels", vo.labels);
    vo.pointCloud = v.boolean("point_cloud", vo.pointCloud);
    if (vo.pointCloud && !vo.depth) v.fail("point_cloud", "needs depth = true");
    vo.contactSheet = v.boolean("contact_sheet", vo.contactSheet);
    ro.minWidthPx = v.number("min_width_px", ro.minWidthPx, Range::closed(0, 64));
    v.finish();
}

// The sweep points of one species: the cartesian product of the sweeps that apply to it, each
// checked to make a valid species whose every swept path is a key the species reads.
void expandSweepPoints(SpeciesEntry& entry, const std::vector<SweepAxis>& sweeps) {
    std::vector<const SweepAxis*> axes;
    for (const SweepAxis& a : sweeps) {
        if (a.species.empty() ||
            std::find(a.species.begin(), a.species.end(), entry.species.name) != a.species.end()) {
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
        validateSpecies(entry.species, ov.get());
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
    if (auto o = p.optionalTable("outputs")) readOutputs(*o, d.outputs);
    if (auto v = p.optionalTable("views")) readViews(*v, d.outputs.views, d.outputs.render);
    p.finish();
    for (SpeciesEntry& entry : d.species) expandSweepPoints(entry, d.sweeps);
    char fingerprint[17];
    std::snprintf(fingerprint, sizeof fingerprint, "%016llx",
                  static_cast<unsigned long long>(hashString(fingerprintBytes)));
    d.fingerprint = fingerprint;
    return d;
}

std::vector<InstanceJob> expandJobs(const DatasetSpec& spec) {
    std::vector<InstanceJob> jobs;
    for (const SpeciesEntry& e : spec.species) {
        const bool swept = e.points.size() > 1 || !e.points[0].key.empty();
        for (size_t pi = 0; pi < e.points.size(); ++pi) {
            for (int64_t k = 0; k < e.count; ++k) {
                InstanceJob j;
                j.entry = &e;
                j.point = &e.points[pi];
                j.pointIndex = static_cast<int>(pi);
                j.index = k;
                j.seed = instanceSeed(spec.seed, e.species.name, e.points[pi].seedKey, k);
                char buf[64];
                if (swept) {
                    std::snprintf(buf, sizeof buf, "-p%03zu-%05lld", pi, static_cast<long long>(k));
                } else {
                    std::snprintf(buf, sizeof buf, "-%05lld", static_cast<long long>(k));
                }
                j.id = e.species.name + buf;
                jobs.push_back(std::move(j));
            }
        }
    }
    return jobs;
}

}  // namespace sylva
