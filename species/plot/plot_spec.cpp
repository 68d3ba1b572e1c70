#include "species/plot/plot_spec.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "species/plot/inventory.h"
#include "species/plot/plot_growth.h"
#include "species/plot/point_process.h"
#include "species/plot/terrain.h"
#include "volumes/image_file.h"

namespace sylva {

namespace fs = std::filesystem;

double expectedStems(const PlotSpecies& s, const PlotArea& area) {
    return s.count >= 0 ? static_cast<double>(s.count) : s.density * area.area() * 1e-4;
}

std::string plotInstanceId(const std::string& plotName, int64_t index) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "-%05lld", static_cast<long long>(index));
    return plotName + buf;
}

namespace {

std::string number(double v) { return formatNumber(v, 4); }

// A key that only applies to some kinds (of terrain, process or shape) is an error elsewhere:
// it would be silently ignored.
void onlyFor(Params& p, const char* key, bool applies, const std::string& which,
             const std::string& actual) {
    if (p.has(key) && !applies) {
        p.fail(key, "expected only with " + which + " (this one is " + actual + ")");
    }
}

// Copies a number or distribution node into holder["v"].
toml::table holderOf(const toml::node& n) {
    toml::table holder;
    if (auto i = n.as_integer())
        holder.insert("v", i->get());
    else if (auto f = n.as_floating_point())
        holder.insert("v", f->get());
    else if (auto t = n.as_table())
        holder.insert("v", *t);
    return holder;
}

void readTerrain(Params& t, PlotSpec& s) {
    using K = TerrainOptions::Kind;
    TerrainOptions& o = s.terrain;
    o.kind = t.choice(
        "kind", K::kFlat,
        {{"flat", K::kFlat}, {"slope", K::kSlope}, {"noise", K::kNoise}, {"dem", K::kDem}});
    const std::string kind = "kind = \"" +
                             std::string(o.kind == K::kFlat    ? "flat"
                                         : o.kind == K::kSlope ? "slope"
                                         : o.kind == K::kNoise ? "noise"
                                                               : "dem") +
                             "\"";
    onlyFor(t, "slope_deg", o.kind == K::kSlope, "kind = \"slope\"", kind);
    onlyFor(t, "aspect_deg", o.kind == K::kSlope, "kind = \"slope\"", kind);
    for (const char* k : {"amplitude", "wavelength", "octaves"}) {
        onlyFor(t, k, o.kind == K::kNoise, "kind = \"noise\"", kind);
    }
    for (const char* k : {"file", "metres_per_pixel", "height_scale", "height_offset"}) {
        onlyFor(t, k, o.kind == K::kDem, "kind = \"dem\"", kind);
    }
    o.cell = t.number("cell", o.cell, Range::closed(0.05, 100));
    if (o.kind == K::kSlope) {
        o.slopeRad = t.degrees("slope_deg", 0.0, Range::closed(0, 80));
        o.aspectRad = t.degrees("aspect_deg", 0.0, Range::closed(0, 360));
    } else if (o.kind == K::kNoise) {
        o.amplitude = t.number("amplitude", 2.0, Range::closed(0, 1000));
        o.wavelength = t.number("wavelength", o.wavelength, Range::leftOpen(0, 100000));
        o.octaves = static_cast<int>(t.integer("octaves", o.octaves, Range::closed(1, 8)));
    } else if (o.kind == K::kDem) {
        o.demPath = t.filePath("file");
        o.metresPerPixel = t.number("metres_per_pixel", o.metresPerPixel, Range::leftOpen(0, 1e4));
        o.heightScale = t.number("height_scale", o.heightScale, Range::closed(-1e4, 1e4));
        o.heightOffset = t.number("height_offset", o.heightOffset, Range::closed(-1e5, 1e5));
    }
}

// The DEM is readable, single-channel and covers the heightfield grid.
void checkDem(Params& t, const PlotSpec& s, std::string* fingerprintBytes, PlotFileCache* cache) {
    const TerrainOptions& o = s.terrain;
    PlotFileCache::Dem img;
    if (cache && cache->dems.count(o.demPath)) {
        img = cache->dems.at(o.demPath);
    } else {
        try {
            const ImageFile read = readImageFile(o.demPath);
            img = {read.width, read.height, read.channels};
        } catch (const ImageError& e) {
            t.fail("file", std::string("expected a single-channel DEM image: ") + e.what());
        }
        if (cache) cache->dems[o.demPath] = img;
    }
    if (img.channels != 1) {
        t.fail("file", "expected a single-channel DEM (grey heights), got " +
                           std::to_string(img.channels) + " channels in " + o.demPath);
    }
    const TerrainGrid g = terrainGrid(s.area, s.margin, o.cell);
    const DemPixels need = demPixelsNeeded(g, o.cell, o.metresPerPixel);
    if (img.width < need.width || img.height < need.height) {
        const double spanX = static_cast<double>(g.nx - 1) * o.cell;
        const double spanZ = static_cast<double>(g.nz - 1) * o.cell;
        t.fail("file", "expected a DEM covering the plot and its margin, " + number(spanX) + " × " +
                           number(spanZ) + " m: at least " + std::to_string(need.width) + " × " +
                           std::to_string(need.height) +
                           " pixels at metres_per_pixel = " + number(o.metresPerPixel) + ", got " +
                           std::to_string(img.width) + " × " + std::to_string(img.height) +
                           " pixels (" + number((img.width - 1) * o.metresPerPixel) + " × " +
                           number((img.height - 1) * o.metresPerPixel) + " m)");
    }
    if (fingerprintBytes) *fingerprintBytes += fileBytes(o.demPath);
}

void readStems(Params& t, PlotSpec& s) {
    using K = PointProcessOptions::Kind;
    PointProcessOptions& o = s.process;
    o.kind = t.choice("process", K::kPoisson,
                      {{"poisson", K::kPoisson},
                       {"hard-core", K::kHardCore},
                       {"strauss", K::kStrauss},
                       {"thomas", K::kThomas},
                       {"rows", K::kRows}});
    const std::string kind = "process = \"" +
                             std::string(o.kind == K::kPoisson    ? "poisson"
                                         : o.kind == K::kHardCore ? "hard-core"
                                         : o.kind == K::kStrauss  ? "strauss"
                                         : o.kind == K::kThomas   ? "thomas"
                                                                  : "rows") +
                             "\"";
    const bool inhibition = o.kind == K::kHardCore || o.kind == K::kStrauss;
    onlyFor(t, "min_spacing", inhibition, "process = \"hard-core\" or \"strauss\"", kind);
    onlyFor(t, "interaction", o.kind == K::kStrauss, "process = \"strauss\"", kind);
    onlyFor(t, "parent_density", o.kind == K::kThomas, "process = \"thomas\"", kind);
    onlyFor(t, "cluster_sigma", o.kind == K::kThomas, "process = \"thomas\"", kind);
    for (const char* k : {"row_spacing", "stem_spacing", "row_azimuth_deg", "jitter"}) {
        onlyFor(t, k, o.kind == K::kRows, "process = \"rows\"", kind);
    }
    if (inhibition) o.minSpacing = t.number("min_spacing", Range::leftOpen(0, 1000));
    if (o.kind == K::kStrauss) o.interaction = t.number("interaction", 0.5, Range::closed(0, 1));
    if (o.kind == K::kThomas) {
        o.parentDensity = t.number("parent_density", 25.0, Range::leftOpen(0, 1e6));
        o.clusterSigma = t.number("cluster_sigma", 3.0, Range::leftOpen(0, 1000));
        // Parents are drawn over the area grown by 4σ: at most kMaxPlotStems of them (more
        // clusters than stems make no clusters).
        const double w = 2 * s.area.halfX() + 8 * o.clusterSigma;
        const double d = 2 * s.area.halfZ() + 8 * o.clusterSigma;
        const double parents = o.parentDensity * 1e-4 * w * d;
        if (parents > static_cast<double>(kMaxPlotStems)) {
            t.fail("parent_density",
                   "expected at most " + std::to_string(kMaxPlotStems) +
                       " cluster centres over the plot grown by 4 × cluster_sigma (" + number(w) +
                       " × " + number(d) + " m), got " + number(parents) + " expected");
        }
    }
    if (o.kind == K::kRows) {
        o.rowSpacing = t.number("row_spacing", Range::leftOpen(0, 1000));
        o.stemSpacing = t.number("stem_spacing", Range::leftOpen(0, 1000));
        o.rowAzimuthRad = t.degrees("row_azimuth_deg", 0.0, Range::closed(0, 360));
        o.jitter = t.number("jitter", 0.0, Range::closed(0, 100));
    }
}

PlotSpecies readSpecies(Params& e, bool understory, const BudgetTable& budget, bool meshed,
                        std::string* fingerprintBytes, PlotFileCache* cache) {
    PlotSpecies ps;
    ps.understory = understory;
    ps.keyPath = e.prefix();
    ps.where = e.whereTable();
    const std::string file = e.string("file");
    const fs::path base = fs::path(e.file()).parent_path();
    const fs::path resolved = fs::path(file).is_absolute() ? fs::path(file) : base / file;
    std::error_code ec;
    if (!fs::is_regular_file(resolved, ec)) {
        e.fail("file", "species file not found: " + resolved.string());
    }
    const std::string path = resolved.lexically_normal().string();
    if (cache && cache->species.count(path)) {
        ps.species = cache->species.at(path);
    } else {
        try {
            ps.species = loadSpecies(path);
            validateSpecies(ps.species, nullptr, &budget, meshed);
        } catch (const SpecError& err) {
            // One line, at the dataset key that names the file, then the error's own place.
            throw SpecError(e.where("file"), e.path("file"), std::string("in ") + err.what());
        }
        if (cache) cache->species[path] = ps.species;
    }
    if (fingerprintBytes) *fingerprintBytes += fileBytes(ps.species.path);
    if (e.has("density") == e.has("count")) {
        if (e.has("count"))
            e.fail("count", "expected either density (stems/ha) or count, not both");
        e.failHere("expected density (stems per hectare) or count (stems per plot)");
    }
    if (e.has("count")) {
        ps.count = e.integer("count", Range::closed(0, static_cast<double>(kMaxPlotStems)));
    } else {
        ps.density = e.number("density", Range::closed(0, 1e6));
    }
    if (const toml::node* h = e.raw("height")) {
        e.numberOrDistribution("height", Range::leftOpen(0, 200));  // checks it and its bounds
        ps.height = holderOf(*h);
        ps.hasHeight = true;
    }
    if (const toml::node* h = e.raw("slenderness")) {
        e.numberOrDistribution("slenderness", Range::closed(10, 300));
        ps.slenderness = holderOf(*h);
        ps.hasSlenderness = true;
    }
    ps.lai = e.has("lai") ? e.number("lai", Range::leftOpen(0, kMaxPlotLai)) : -1.0;
    ps.crownShyness = e.number("crown_shyness", ps.crownShyness, Range::closed(0, 1));
    ps.maxOverlap = e.number("max_overlap", ps.maxOverlap, Range::closed(0, 1));
    e.finish();
    return ps;
}

}  // namespace

// An LAI target the grown leaves cannot reach, refused at its key before anything grows (the
// plot's lai and the species' own exclude each other, above). Growth decides what it reaches
// (reachLai, plot_growth.cpp), so it is estimated: one tree of each species grown alone (seed 1),
// scaled to its height's centre as the plot scales it (leaf area with the square), times the
// stems expected, gives the plot's leaf area; a target that would need more than kLaiMargin
// times the area growth allows (kMaxLeafScale², leaves scaled 4×) or less than 1/kLaiMargin² of
// what it keeps (kMinLeavesKept) is refused. The margins cover the estimate's error (trees in a
// stand grow fewer leaves than alone, so the upper side errs toward letting a spec through);
// between them growth decides, as before.
constexpr double kLaiMargin = 4;

void checkLaiReachable(Params& p, const PlotSpec& s, const std::vector<Params*>& entries,
                       const BudgetTable& budget, PlotFileCache* cache) {
    bool any = s.lai > 0;
    for (const PlotSpecies& ps : s.species) any |= ps.lai >= 0;
    if (!any) return;
    // Leaf area (m²) each species' expected stems carry, estimated.
    std::vector<double> leafArea(s.species.size(), 0.0);
    for (size_t k = 0; k < s.species.size(); ++k) {
        const PlotSpecies& ps = s.species[k];
        if (s.lai <= 0 && ps.lai < 0) continue;  // in no target
        PlotFileCache::Grown alone;
        if (cache && cache->grown.count(ps.species.path)) {
            alone = cache->grown.at(ps.species.path);
        } else {
            try {
                const GrownTree g = growSpecies(ps.species, 1, nullptr, false, &budget);
                alone.leafArea = treeLeafArea(g.tree);
                alone.height = g.tree.nodes.empty()
                                   ? 0.0
                                   : measureTree(g.tree, g.tree.nodes[0].position).height;
            } catch (const BudgetExceeded&) {
                return;  // too large to grow here: growth decides (and budgets it)
            }
            if (cache) cache->grown[ps.species.path] = alone;
        }
        double scale = 1;
        if (ps.hasHeight && alone.height > 0) {
            DrawContext centre;
            centre.draw = false;
            Params h(ps.height, p.file(), "", &centre);
            scale = h.numberOrDistribution("v", Range::leftOpen(0, 200)) / alone.height;
        }
        leafArea[k] = alone.leafArea * scale * scale * expectedStems(ps, s.area);
    }
    const double area = s.area.area();
    auto check = [&](Params& at, double target, double grown, const std::string& which) {
        const double r = grown > 0 ? target * area / grown : INFINITY;
        if (r <= kLaiMargin * kMaxLeafScale * kMaxLeafScale &&
            r >= kMinLeavesKept / (kLaiMargin * kLaiMargin)) {
            return;
        }
        at.fail("lai", grown > 0
                           ? "expected a leaf area index the grown leaves can reach: one tree of " +
                                 which + " grown alone, scaled to its height, gives about " +
                                 number(grown / area) + " over the stems expected, so " +
                                 number(target) + " needs ×" + number(r) +
                                 " of their area (growth keeps at least " + number(kMinLeavesKept) +
                                 " and scales at most ×" + number(kMaxLeafScale * kMaxLeafScale) +
                                 "), got " + number(target)
                           : "expected species with leaves to reach it, got " + number(target) +
                                 " for " + which + " growing no leaves");
    };
    if (s.lai > 0) {
        double all = 0;
        for (double a : leafArea) all += a;
        check(p, s.lai, all, "each species");
        return;
    }
    for (size_t k = 0; k < s.species.size(); ++k) {
        if (s.species[k].lai >= 0) {
            check(*entries[k], s.species[k].lai, leafArea[k], s.species[k].keyPath);
        }
    }
}

PlotSpec readPlot(Params& p, const BudgetTable& budget, bool meshed, std::string* fingerprintBytes,
                  PlotFileCache* cache) {
    DocumentAs doc(p, "plot");
    // A plot's numbers are plain but for its species' height and slenderness (docs/plots.md).
    p.plainNumbersOnly();
    PlotSpec s;
    s.keyPath = p.prefix();
    s.where = p.whereTable();
    s.name = p.string("name");
    if (!isFileSafeName(s.name)) {
        p.fail("name",
               "expected 1–64 letters, digits, '-' or '_' (it names the plot's instances and "
               "their directories), got \"" +
                   s.name + "\"");
    }
    s.count = p.integer("count", 1, Range::closed(0, static_cast<double>(kMaxPlotCount)));
    using S = PlotArea::Shape;
    s.area.shape =
        p.choice("shape", S::kRectangle, {{"rectangle", S::kRectangle}, {"circle", S::kCircle}});
    const bool circle = s.area.shape == S::kCircle;
    const std::string shape = circle ? "shape = \"circle\"" : "shape = \"rectangle\"";
    onlyFor(p, "width", !circle, "shape = \"rectangle\"", shape);
    onlyFor(p, "depth", !circle, "shape = \"rectangle\"", shape);
    onlyFor(p, "radius", circle, "shape = \"circle\"", shape);
    if (circle) {
        s.area.radius = p.number("radius", 25.0, Range::closed(kMinPlotSide / 2, kMaxPlotSide / 2));
    } else {
        s.area.width = p.number("width", s.area.width, Range::closed(kMinPlotSide, kMaxPlotSide));
        s.area.depth = p.number("depth", s.area.depth, Range::closed(kMinPlotSide, kMaxPlotSide));
    }
    const char* sizeKey = circle ? "radius" : "width";
    s.margin = p.number("margin", s.margin, Range::closed(0, 1000));
    s.lai = p.has("lai") ? p.number("lai", Range::leftOpen(0, kMaxPlotLai)) : -1.0;
    s.neighbours = p.boolean("neighbours", s.neighbours);

    std::optional<Params> terrain = p.optionalTable("terrain");
    if (terrain) readTerrain(*terrain, s);
    const TerrainGrid grid = terrainGrid(s.area, s.margin, s.terrain.cell);
    if (grid.samples() > kMaxTerrainSamples) {
        const std::string msg = "expected a terrain heightfield of at most " +
                                std::to_string(kMaxTerrainSamples) + " samples (4096²), got " +
                                std::to_string(grid.nx) + " × " + std::to_string(grid.nz) +
                                " (the plot and its margin at cell = " + number(s.terrain.cell) +
                                " m): set a larger [plot.terrain] cell";
        if (terrain) terrain->fail("cell", msg);
        p.fail(sizeKey, msg);
    }
    if (terrain) {
        if (s.terrain.kind == TerrainOptions::Kind::kDem)
            checkDem(*terrain, s, fingerprintBytes, cache);
        terrain->finish();
    }

    std::optional<Params> stems = p.optionalTable("stems");
    if (stems) {
        readStems(*stems, s);
        stems->finish();
    }

    std::vector<Params> canopy = p.tableArray("species");
    std::vector<Params> understory = p.tableArray("understory");
    std::vector<Params*> entries;
    for (Params& e : canopy) {
        s.species.push_back(readSpecies(e, false, budget, meshed, fingerprintBytes, cache));
        entries.push_back(&e);
    }
    for (Params& e : understory) {
        s.species.push_back(readSpecies(e, true, budget, meshed, fingerprintBytes, cache));
        entries.push_back(&e);
    }
    if (s.species.empty()) {
        p.failHere("expected at least one [[plot.species]] (or [[plot.understory]]) entry");
    }
    if (auto g = p.optionalTable("ground_cover")) {
        s.groundCover.density = g->number("density", Range::closed(0, 1000));
        if (s.groundCover.density * s.area.area() > kMaxGroundCards) {
            g->fail("density", "expected at most " + number(kMaxGroundCards) +
                                   " ground-cover cards per plot, got " +
                                   number(s.groundCover.density * s.area.area()) + " (" +
                                   number(s.groundCover.density) + " per m² on " +
                                   number(s.area.area()) + " m²)");
        }
        s.groundCover.height = g->number("height", s.groundCover.height, Range::leftOpen(0, 10));
        s.groundCover.width = g->number("width", s.groundCover.width, Range::leftOpen(0, 10));
        g->finish();
    }
    p.finish();

    // Leaf area: the plot's target or the species' shares, not both; the shares at most 15.
    double laiSum = 0;
    for (size_t k = 0; k < s.species.size(); ++k) {
        if (s.species[k].lai < 0) continue;
        if (s.lai >= 0) {
            entries[k]->fail("lai", "expected either the plot's lai (at " + p.where("lai").str() +
                                        ") or a lai per species, not both");
        }
        laiSum += s.species[k].lai;
        if (laiSum > kMaxPlotLai) {
            entries[k]->fail("lai", "expected the species' lai to sum to at most " +
                                        number(kMaxPlotLai) + " m²/m², got " + number(laiSum));
        }
    }

    // Stems: at most kMaxPlotStems expected per plot.
    double total = 0, canopyStems = 0;
    for (size_t k = 0; k < s.species.size(); ++k) {
        const double n = expectedStems(s.species[k], s.area);
        total += n;
        if (!s.species[k].understory) canopyStems += std::round(n);
        if (total > static_cast<double>(kMaxPlotStems)) {
            entries[k]->fail(s.species[k].count >= 0 ? "count" : "density",
                             "expected at most " + std::to_string(kMaxPlotStems) +
                                 " stems per plot (all species), got " + number(total) +
                                 " expected on " + number(s.area.area()) + " m²");
        }
    }

    // The canopy stems fit the process.
    using K = PointProcessOptions::Kind;
    const PointProcessOptions& o = s.process;
    if (o.kind == K::kHardCore || (o.kind == K::kStrauss && o.interaction == 0)) {
        const int64_t capacity = hardCoreCapacity(o.minSpacing, s.area);
        if (canopyStems > static_cast<double>(capacity)) {
            const double coverage =
                canopyStems * kPi * o.minSpacing * o.minSpacing / 4 / s.area.area();
            const double largest =
                std::sqrt(kMaxHardCoreCoverage * s.area.area() * 4 / (kPi * canopyStems));
            stems->fail("min_spacing",
                        "expected a spacing that fits the stems: " + number(canopyStems) +
                            " stems " + number(o.minSpacing) + " m apart cover " +
                            number(100 * coverage) + " % of the plot's " + number(s.area.area()) +
                            " m² with disks of that diameter (random "
                            "sequential packing jams at 54.7 %; at most " +
                            number(100 * kMaxHardCoreCoverage) + " %): at most " +
                            std::to_string(capacity) +
                            " stems at this spacing, or a spacing of "
                            "at most " +
                            number(largest) + " m");
        }
    }
    if (o.kind == K::kRows) {
        const double lattice = rowLatticeSize(o, s.area);
        if (lattice > kMaxRowLattice) {
            stems->fail("row_spacing", "expected rows of at most " + number(kMaxRowLattice) +
                                           " lattice places over the plot, got " + number(lattice) +
                                           ": wider spacings or a smaller plot");
        }
        const size_t places = rowSites(o, s.area).size();
        if (canopyStems > static_cast<double>(places)) {
            stems->fail("row_spacing",
                        "expected rows that hold the stems: rows " + number(o.rowSpacing) +
                            " m apart with stems every " + number(o.stemSpacing) + " m have " +
                            std::to_string(places) + " places in this plot, the species ask for " +
                            number(canopyStems));
        }
    }
    checkLaiReachable(p, s, entries, budget, cache);
    return s;
}

}  // namespace sylva
