// sylva benchmarks (Google Benchmark). Run through scripts/bench.
//  - Table1Tree: one iterated-graph tree at the scale of Xu & Mould 2012 Table 1
//    (~350k graph nodes, ~34k endpoints), on 1 thread and on all cores.
//  - MeshTree / WatertightTree / RenderView: per-tree meshing and per-view rendering.
//  - LeafShapeMesh / LeafShapeRender: a leafy tree's leaf mesh and one view, cards vs each
//    leaf shape.
//  - WriteViewFile: one view's silhouette PNG, label PNG and depth EXR, per file.
//  - DatasetBuild: the whole demo dataset (1,000 trees with meshes and 8 views, files
//    written) and an ez-tree-sized one, trees per second.
//  - VolumeBuild / InsideTest: what a crown volume costs per tree — building each kind from
//    its spec, and inside() queries per second (analytic primitives, CSG, level set, and the
//    sketched and envelope kinds from their presets).
//  - Colonization/<variant>/<internodes>: the space-colonization method's baseline
//    (Palubicki 2009) and improved (Liu 2020 §3) variants growing to 2k, 10k and 50k
//    internodes in the same crown with the same marker budget, one thread (Liu 2020 Fig. 17).
//  - ContinuousLimbs/<case>: the iterated-graph continuous-limb options (issue 13) on a tree
//    at Table 1 scale, one thread: growth with the paper's costs and with each option, and
//    the merging and smoothing passes alone on the grown skeleton.
//  - SpeciesTree/<species>: every shipped species (found at run time), time per
//    tree with its mesh and 8 views at 256² as in datasets/species-gallery.toml, one thread,
//    no file writes; GalleryBuild: the whole gallery built and written, all cores, trees/s.
//  - InstanceLookup / InstanceFind / ValidateHuge / ResumeScan: huge datasets (issue 15) —
//    instance i from i and its inverse, validating 4 × 10³…10¹⁵ instances, resume's manifest
//    scan against parsing each line into a document.
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <vector>

#include "pipeline/batch/build.h"
#include "pipeline/batch/dataset.h"
#include "pipeline/batch/instance.h"
#include "pipeline/batch/instance_set.h"
#include "pipeline/batch/resume.h"
#include "pipeline/formats/mesh_writers.h"
#include "pipeline/formats/view_writers.h"
#include "pipeline/render/camera.h"
#include "pipeline/render/colour_render.h"
#include "pipeline/render/render.h"
#include "species/geometry/leaf_mesh.h"
#include "species/geometry/tube_mesh.h"
#include "species/geometry/watertight.h"
#include "species/methods/iterated_graph.h"
#include "species/methods/space_colonization.h"
#include "species/model/leaf_shape.h"
#include "species/spec/species.h"
#include "species/spec/volume_spec.h"
#include "volumes/poisson.h"

namespace fs = std::filesystem;
using namespace sylva;

static double peakRssMiB() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_maxrss / 1024.0;
}

static void Table1Tree(benchmark::State& state) {
    const int threads =
        state.range(0) > 0 ? static_cast<int>(state.range(0)) : tbb::info::default_concurrency();
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    SpeciesFile species = loadSpecies(SYLVA_SOURCE_DIR "/bench/table1.toml");
    uint64_t seed = 1;
    GrownTree g;
    for (auto _ : state) {
        g = growSpecies(species, seed++, nullptr, threads > 1);
        benchmark::DoNotOptimize(g.tree.nodes.data());
    }
    state.counters["threads"] = threads;
    state.counters["graph_nodes"] = g.methodStats["graph_nodes"];
    state.counters["graph_endpoints"] = g.methodStats["graph_endpoints"];
    state.counters["skeleton_nodes"] = static_cast<double>(g.tree.nodes.size());
    state.counters["peak_rss_MiB"] = peakRssMiB();
}
BENCHMARK(Table1Tree)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->MinTime(3.0);

// Per tree: tubes + leaf cards for a demo-sized tree (xm-a, ~2.5k nodes, 4 leaves per tip).
static GrownTree demoTree() {
    SpeciesFile species = loadSpecies(SYLVA_SOURCE_DIR "/species/papers/xu-mould-2012/xm-a.toml");
    return growSpecies(species, 1, nullptr, false);
}

static void MeshTree(benchmark::State& state) {
    GrownTree g = demoTree();
    TubeOptions tubes;
    tubes.maxSides = 12;
    tubes.edgeLength = 0.04;
    TreeMesh m;
    for (auto _ : state) {
        m.wood = tubeMesh(g.tree, tubes);
        m.leaves = leafMesh(g.tree);
        benchmark::DoNotOptimize(m.wood.indices.data());
    }
    state.counters["wood_triangles"] = static_cast<double>(m.wood.triangleCount());
    state.counters["leaf_triangles"] = static_cast<double>(m.leaves.triangleCount());
    state.counters["ply_bytes"] = static_cast<double>(meshPly(m).size());
}
BENCHMARK(MeshTree)->Unit(benchmark::kMillisecond);

static void WatertightTree(benchmark::State& state) {
    GrownTree g = demoTree();
    WatertightOptions w;
    w.voxelSize = 0.03;
    Mesh m;
    for (auto _ : state) {
        m = watertightMesh(g.tree, w);
        benchmark::DoNotOptimize(m.indices.data());
    }
    state.counters["triangles"] = static_cast<double>(m.triangleCount());
}
BENCHMARK(WatertightTree)->Unit(benchmark::kMillisecond);

// The branch tubes a view draws, made once per tree as the build's mesh stage does (the demo's
// level of detail: 3–12 sides, 4 cm edges).
struct Tubes {
    Mesh wood;
    std::vector<int32_t> nodes;
    explicit Tubes(const Tree& tree) {
        TubeOptions t;
        t.maxSides = 12;
        t.edgeLength = 0.04;
        wood = tubeMesh(tree, t, &nodes);
    }
};

// One 256×256 view with depth and labels (the demo's views), per view, the tubes made
// beforehand (once per tree: MeshTree). Arg: [views] min_width_px (0: the mesh only, the
// default; 1.415: skeleton lines at least √2 px wide on top).
static void RenderView(benchmark::State& state) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    GrownTree g = demoTree();
    const Tubes tubes(g.tree);
    RenderOptions ro;
    ro.minWidthPx = state.range(0) / 1000.0;
    ViewOptions vo;
    vo.count = 8;
    vo.elevationsDeg = {10, 35};
    Rng rng(1);
    std::vector<Camera> cams = makeCameras(g.tree, vo, rng);
    size_t k = 0;
    for (auto _ : state) {
        ViewImage v =
            renderView(g.tree, tubes.wood, tubes.nodes, cams[k++ % cams.size()], true, true, ro);
        benchmark::DoNotOptimize(v.silhouette.data());
    }
    state.counters["wood_triangles"] = static_cast<double>(tubes.wood.triangleCount());
}
BENCHMARK(RenderView)->Arg(0)->Arg(1415)->Unit(benchmark::kMillisecond);

// 8 cameras round a tree at 512 × 512, the first at azimuth 0.
static std::vector<Camera> eightViews512(const Tree& tree) {
    ViewOptions vo;
    vo.count = 8;
    vo.width = vo.height = 512;
    vo.randomAzimuth = false;
    Rng rng(1);
    return makeCameras(tree, vo, rng);
}

// One 512×512 view with depth and labels of the large Table 1 tree (bench/table1.toml), per
// view, on 1 thread (Arg 1) and on every core (Arg 0): the renderer's banded parallelism. The
// tubes are made beforehand, once per tree, as in RenderView.
static void RenderViewLarge(benchmark::State& state) {
    std::optional<tbb::global_control> limit;
    if (state.range(0) > 0) {
        limit.emplace(tbb::global_control::max_allowed_parallelism, state.range(0));
    }
    static const Tree tree =
        growSpecies(loadSpecies(SYLVA_SOURCE_DIR "/bench/table1.toml"), 1, nullptr, true).tree;
    const std::vector<Camera> cams = eightViews512(tree);
    static const Tubes tubes(tree);
    size_t k = 0;
    for (auto _ : state) {
        ViewImage v =
            renderView(tree, tubes.wood, tubes.nodes, cams[k++ % cams.size()], true, true);
        benchmark::DoNotOptimize(v.silhouette.data());
    }
    state.counters["segments"] = static_cast<double>(tree.nodes.size() - 1);
    state.counters["wood_triangles"] = static_cast<double>(tubes.wood.triangleCount());
}
BENCHMARK(RenderViewLarge)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);

// Colour views against label views: a library tree (pedunculate-oak, seed 1) seen by 8 cameras
// at 512×512 on one thread. Args (colour, samples, sky rays): colour 0, the 8 label views
// (silhouette, depth, labels: renderView); 1, the same 8 views and their colour pictures at
// `samples` per pixel and `sky rays` per pixel (the Embree scene built once per tree, then 8
// colour renders: colour_render.h) — the cost of colour is the ratio.
static void ColourViews(benchmark::State& state) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    static const SpeciesFile species =
        loadSpecies(SYLVA_SOURCE_DIR "/species/presets/pedunculate-oak.toml");
    static const Tree tree = growSpecies(species, 1, nullptr, false).tree;
    static const Tubes tubes(tree);
    static const Mesh leaves = leafMesh(tree);
    const std::vector<Camera> cams = eightViews512(tree);
    ColourOptions co;
    co.enabled = true;
    co.samples = static_cast<int>(state.range(1));
    co.aoRays = static_cast<int>(state.range(2));
    const bool colour = state.range(0) != 0;
    for (auto _ : state) {
        std::vector<ViewImage> views;
        for (const Camera& c : cams)
            views.push_back(renderView(tree, tubes.wood, tubes.nodes, c, true, true));
        if (colour) {
            const ColourScene scene(tree, tubes.wood, leaves, *species.look, 1);
            for (size_t k = 0; k < cams.size(); ++k) {
                ColourImage img = scene.render(cams[k], views[k], co, Rng(1).derive(k));
                benchmark::DoNotOptimize(img.rgba.data());
            }
        }
        benchmark::DoNotOptimize(views.data());
    }
    state.SetLabel(colour ? "label + colour views" : "label views");
    state.counters["triangles"] =
        static_cast<double>(tubes.wood.triangleCount() + leaves.triangleCount() / 2);
}
BENCHMARK(ColourViews)
    ->Args({0, 4, 4})
    ->Args({1, 4, 4})
    ->Args({1, 4, 2})
    ->Args({1, 4, 0})
    ->Args({1, 1, 4})
    ->Unit(benchmark::kMillisecond);

// Leaf shapes: Jain 2021's guava (species/papers/jain-2021/grammar-guava.toml, seed 1, about
// 4,900 particle leaves) with every leaf given one shape (Arg: LeafShape, 0 card … 6 frond;
// the label names it): its leaf mesh per tree, and one 512×512 view with depth and labels on
// one thread (the views cycle through 8 cameras around the tree).
static Tree guavaWithShape(LeafShape shape) {
    static const Tree guava =
        growSpecies(loadSpecies(SYLVA_SOURCE_DIR "/species/papers/jain-2021/grammar-guava.toml"), 1,
                    nullptr, false)
            .tree;
    Tree t = guava;
    for (Leaf& leaf : t.leaves) leaf.shape = shape;
    return t;
}

static void LeafShapeMesh(benchmark::State& state) {
    const LeafShape shape = static_cast<LeafShape>(state.range(0));
    const Tree tree = guavaWithShape(shape);
    Mesh m;
    for (auto _ : state) {
        m = leafMesh(tree);
        benchmark::DoNotOptimize(m.indices.data());
    }
    state.SetLabel(leafShapeWords()[state.range(0)].first);
    state.counters["leaves"] = static_cast<double>(tree.leaves.size());
    state.counters["leaf_triangles"] = static_cast<double>(m.triangleCount());
}
BENCHMARK(LeafShapeMesh)->DenseRange(0, 6)->Unit(benchmark::kMillisecond);

static void LeafShapeRender(benchmark::State& state) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    const LeafShape shape = static_cast<LeafShape>(state.range(0));
    const Tree tree = guavaWithShape(shape);
    ViewOptions vo;
    vo.count = 8;
    vo.width = vo.height = 512;
    vo.randomAzimuth = false;
    Rng rng(1);
    const std::vector<Camera> cams = makeCameras(tree, vo, rng);
    const Tubes tubes(tree);
    size_t k = 0;
    for (auto _ : state) {
        ViewImage v =
            renderView(tree, tubes.wood, tubes.nodes, cams[k++ % cams.size()], true, true);
        benchmark::DoNotOptimize(v.silhouette.data());
    }
    std::vector<ViewImage> views;
    for (const Camera& c : cams) {
        views.push_back(renderView(tree, tubes.wood, tubes.nodes, c, false, true));
    }
    state.SetLabel(leafShapeWords()[state.range(0)].first);
    state.counters["leaf_pixel_fraction"] = leafPixelFraction(views);
}
BENCHMARK(LeafShapeRender)->DenseRange(0, 6)->Unit(benchmark::kMillisecond);

// Writing one view's files to a RAM disk (/dev/shm when present): the silhouette PNG, the
// label PNG, the depth EXR, the 16-bit depth PNG and the depth EXR ZIP-compressed (Arg 0, 1,
// 2, 3, 4), per file.
static void WriteViewFile(benchmark::State& state) {
    GrownTree g = demoTree();
    ViewOptions vo;
    vo.count = 1;
    Rng rng(1);
    const Camera cam = makeCameras(g.tree, vo, rng).front();
    const ViewImage v = renderView(g.tree, cam, true, true);
    const fs::path dir = fs::exists("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
    const fs::path out = dir / ("sylva-bench-view-" + std::to_string(getpid()));
    for (auto _ : state) {
        switch (state.range(0)) {
            case 0:
                writeGreyPng(out.string() + ".png", v.width, v.height, v.silhouette);
                break;
            case 1:
                writeGreyPng(out.string() + ".png", v.width, v.height, v.labels);
                break;
            case 2:
                writeDepthExr(out.string() + ".exr", v.width, v.height, v.depth);
                break;
            case 4:
                writeDepthExr(out.string() + ".exr", v.width, v.height, v.depth, false, true);
                break;
            default:
                writeDepthPng(out.string() + ".png", v.width, v.height, v.depth,
                              integerDepthScale({v}));
                break;
        }
    }
    fs::remove(out.string() + ".png");
    fs::remove(out.string() + ".exr");
}
BENCHMARK(WriteViewFile)->DenseRange(0, 4)->Unit(benchmark::kMicrosecond);

// Builds `spec` into a fresh `out` on `threads` once per iteration (removing the last build
// untimed), then calls measure(summary) untimed; removes `out` at the end.
template <class Measure>
static void buildEachIteration(benchmark::State& state, const DatasetSpec& spec,
                               const fs::path& out, int threads, Measure measure) {
    for (auto _ : state) {
        state.PauseTiming();
        fs::remove_all(out);
        state.ResumeTiming();
        BuildOptions o;
        o.out = out;
        o.threads = threads;
        o.progress = false;
        const auto summary = buildDataset(spec, o);
        state.PauseTiming();
        measure(summary);
        state.ResumeTiming();
    }
    fs::remove_all(out);
}

// A whole dataset built and written: trees per second on 1 core and on all cores.
static void DatasetBuild(benchmark::State& state, const char* specPath) {
    const int threads =
        state.range(0) > 0 ? static_cast<int>(state.range(0)) : tbb::info::default_concurrency();
    DatasetSpec spec = loadDataset(std::string(SYLVA_SOURCE_DIR "/") + specPath);
    fs::path out = fs::temp_directory_path() / ("sylva-bench-build-" + std::to_string(getpid()));
    int64_t trees = 0;
    double bytes = 0;
    buildEachIteration(state, spec, out, threads, [&](const auto& summary) {
        trees += summary.built;
        for (const auto& f : fs::recursive_directory_iterator(out)) {
            if (f.is_regular_file()) bytes += static_cast<double>(f.file_size());
        }
    });
    state.counters["threads"] = threads;
    state.counters["trees_per_second"] =
        benchmark::Counter(static_cast<double>(trees), benchmark::Counter::kIsRate);
    state.counters["peak_rss_MiB"] = peakRssMiB();
    state.counters["MiB_written_per_tree"] = bytes / std::max<int64_t>(1, trees) / (1 << 20);
}
// The demo (1,000 Xu & Mould trees, ~37k wood + 9k leaf triangles each) and 300 trees the
// size of ez-tree's (~9k + 6k triangles), both with meshes and 8 views with depth and labels.
BENCHMARK_CAPTURE(DatasetBuild, demo, "datasets/demo.toml")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();
BENCHMARK_CAPTURE(DatasetBuild, ez_size, "bench/ez-size.toml")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();
// The same five species as the benchmark plots (bench/plot-singles.toml: 400 trees, 80 each),
// each tree alone: the per-tree cost a plot is compared with.
BENCHMARK_CAPTURE(DatasetBuild, plot_singles, "bench/plot-singles.toml")
    ->Arg(0)
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

// One forest plot built and written (bench/plot-<size>ha.toml: five species, one per growth
// method and a second conifer, 400 stems/ha, grown together, three views with depth, labels
// and instance ids drawn tree by tree; the 1 ha plot also meshed, its scene files streamed) on
// all cores: seconds per plot, per tree, and the process's peak
// RSS — run each size in its own process (--benchmark_filter=PlotBuild/1ha), since peak RSS
// is the process's.
static void PlotBuild(benchmark::State& state, const char* specPath) {
    DatasetSpec spec = loadDataset(std::string(SYLVA_SOURCE_DIR "/") + specPath);
    fs::path out = fs::temp_directory_path() / ("sylva-bench-plot-" + std::to_string(getpid()));
    int64_t trees = 0;
    buildEachIteration(state, spec, out, tbb::info::default_concurrency(), [&](const auto&) {
        for (const auto& d : fs::recursive_directory_iterator(out)) {
            if (d.is_directory() && d.path().parent_path().filename() == "trees") ++trees;
        }
    });
    state.counters["trees"] = static_cast<double>(trees) / static_cast<double>(state.iterations());
    state.counters["trees_per_second"] =
        benchmark::Counter(static_cast<double>(trees), benchmark::Counter::kIsRate);
    state.counters["peak_rss_MiB"] = peakRssMiB();
}
BENCHMARK_CAPTURE(PlotBuild, 0.1ha, "bench/plot-0.1ha.toml")
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();
BENCHMARK_CAPTURE(PlotBuild, 1ha, "bench/plot-1ha.toml")
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();
BENCHMARK_CAPTURE(PlotBuild, 4ha, "bench/plot-4ha.toml")
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

// --- crown volumes -----------------------------------------------------------------------------

// A volume table to parse: inline TOML (primitives) or the first table of a kind in the
// [crown] of a preset (parts of a union searched depth first), so relative files resolve.
struct VolumeSource {
    std::string file;   // for file-relative keys and messages
    toml::table owner;  // keeps the table alive
    const toml::table* table = nullptr;
    std::string prefix;
};

static std::optional<VolumeSource> inlineVolume(const char* toml) {
    VolumeSource v;
    v.file = "bench";
    v.owner = toml::parse(toml);
    v.table = v.owner["crown"].as_table();
    v.prefix = "crown";
    return v;
}

static const toml::table* findKind(const toml::table& t, const std::string& kind,
                                   std::string& prefix) {
    if (t["type"].value_or(std::string()) == kind) return &t;
    if (const toml::array* parts = t["parts"].as_array()) {
        for (size_t i = 0; i < parts->size(); ++i) {
            if (const toml::table* part = (*parts)[i].as_table()) {
                std::string sub = prefix + ".parts[" + std::to_string(i) + "]";
                if (const toml::table* found = findKind(*part, kind, sub)) {
                    prefix = sub;
                    return found;
                }
            }
        }
    }
    return nullptr;
}

// Every shipped species file (species/presets/ and species/papers/), sorted by file name.
static std::vector<fs::path> shippedSpeciesFiles() {
    std::vector<fs::path> files;
    for (const char* dir : {"/species/presets", "/species/papers"}) {
        std::error_code ec;
        for (const auto& e :
             fs::recursive_directory_iterator(SYLVA_SOURCE_DIR + std::string(dir), ec)) {
            if (e.path().extension() == ".toml") files.push_back(e.path());
        }
    }
    std::sort(files.begin(), files.end(),
              [](const fs::path& a, const fs::path& b) { return a.filename() < b.filename(); });
    return files;
}

// The first species (sorted by name) among the shipped <prefix>*.toml whose [crown] or
// [endpoints] holds a volume of type `kind`.
static std::optional<VolumeSource> presetVolume(const std::string& filePrefix,
                                                const std::string& kind) {
    for (const fs::path& f : shippedSpeciesFiles()) {
        if (f.filename().string().rfind(filePrefix, 0) != 0) continue;
        VolumeSource v;
        v.file = f.string();
        v.owner = parseTomlFile(v.file);
        for (const char* top : {"crown", "endpoints"}) {
            const toml::table* t = v.owner[top].as_table();
            std::string prefix = top;
            if (t && (v.table = findKind(*t, kind, prefix))) {
                v.prefix = prefix;
                return v;
            }
        }
    }
    return std::nullopt;
}

static VolumePtr parseSource(const VolumeSource& v, uint64_t seed,
                             const toml::table* table = nullptr) {
    DrawContext draw;
    draw.seed = seed;
    Params p(table ? *table : *v.table, v.file, v.prefix, &draw);
    return parseVolume(p);
}

using SourceFn = std::function<std::optional<VolumeSource>()>;

struct VolumeCase {
    const char* name;
    SourceFn source;
};

static const char* kSphere = "[crown]\ntype = 'sphere'\nradius = 4.0\nposition = [0, 6, 0]\n";
static const char* kEllipsoid =
    "[crown]\ntype = 'ellipsoid'\nradii = [4.0, 6.0, 3.0]\nposition = [0, 7, 0]\n";
// Xu & Mould's sub-graph sector on a trunk cylinder: a CSG union of two primitives.
static const char* kSectorCylinder =
    "[crown]\ntype = 'union'\nparts = [ { type = 'cylinder', radius = 0.4, height = 3 },\n"
    "  { type = 'sphere-sector', radius = 6, alpha_deg = 54, position = [0, 2, 0] } ]\n";
// The same union realised as a level set (voxel_size ≈ its largest extent, 9.7 m, / 128).
static const char* kLevelSet =
    "[crown]\ntype = 'union'\nvoxel_size = 0.075\nparts = [ { type = 'cylinder', radius = 0.4, "
    "height = 3 },\n  { type = 'sphere-sector', radius = 6, alpha_deg = 54, position = [0, 2, 0] "
    "} ]\n";

static const std::vector<VolumeCase>& volumeCases() {
    static const std::vector<VolumeCase> cases = {
        {"sphere", [] { return inlineVolume(kSphere); }},
        {"ellipsoid", [] { return inlineVolume(kEllipsoid); }},
        {"sector_cylinder_union", [] { return inlineVolume(kSectorCylinder); }},
        {"level_set", [] { return inlineVolume(kLevelSet); }},
        {"revolution", [] { return presetVolume("xm-sketch-", "revolution"); }},
        {"mask_revolution", [] { return presetVolume("xm-mask-", "mask-revolution"); }},
        {"visual_hull", [] { return presetVolume("xm-mask-", "visual-hull"); }},
        {"canopy_envelope", [] { return presetVolume("xm-canopy-", "canopy-envelope"); }},
        {"crown_refinement", [] { return presetVolume("xm-refined", "crown-refinement"); }},
    };
    return cases;
}

static const VolumeCase& volumeCase(const char* name) {
    for (const VolumeCase& c : volumeCases())
        if (std::string(c.name) == name) return c;
    throw std::invalid_argument(name);
}

// Parse and build one volume from its spec (one instance's draw per iteration), as a tree
// of the species would; counters: its measure, m³, and the largest bounds extent, m.
static void VolumeBuild(benchmark::State& state, const char* kind) {
    const std::optional<VolumeSource> src = volumeCase(kind).source();
    if (!src) {
        state.SkipWithError("preset not present");
        return;
    }
    // makeRevolution keeps its last 8 results in-process (a species names one sketch for its
    // crown and endpoints), so for the revolved kinds each build gets a (segments, samples)
    // pair not used in the last 80 builds (each within +8 of the spec's own): every
    // iteration is a fresh build of an almost identical crown.
    const toml::table& spec = *src->table;
    const std::string type = spec["type"].value_or(std::string());
    const bool revolved = type == "revolution" || type == "mask-revolution";
    const int64_t segments = spec["segments"].value_or(int64_t{64});
    const int64_t samples = spec["samples"].value_or(int64_t{96});
    static int64_t fresh = 0;  // across calls: Google Benchmark calls this several times
    toml::table variant = spec;
    uint64_t seed = 1;
    VolumePtr v;
    for (auto _ : state) {
        if (revolved) {
            state.PauseTiming();
            variant.insert_or_assign("segments", segments + fresh % 9);
            variant.insert_or_assign("samples", samples + (fresh / 9) % 9);
            ++fresh;
            state.ResumeTiming();
        }
        v = parseSource(*src, seed++, revolved ? &variant : nullptr);
        benchmark::DoNotOptimize(v.get());
    }
    const Vec3 e = v->bounds().size();
    state.counters["extent_m"] = std::max({e.x, e.y, e.z});
    state.counters["measure_m3"] = v->measure();
}

// inside() on random points in the volume's bounds (fixed draw, single thread).
static void InsideTest(benchmark::State& state, const char* kind) {
    const std::optional<VolumeSource> src = volumeCase(kind).source();
    if (!src) {
        state.SkipWithError("preset not present");
        return;
    }
    const VolumePtr v = parseSource(*src, 1);
    const Aabb b = v->bounds();
    Rng rng(7);
    std::vector<Vec3> points(1 << 14);
    for (Vec3& p : points)
        p = {rng.uniform(b.lo.x, b.hi.x), rng.uniform(b.lo.y, b.hi.y), rng.uniform(b.lo.z, b.hi.z)};
    size_t inside = 0, queries = 0;
    for (auto _ : state) {
        for (const Vec3& p : points) inside += v->inside(p);
        queries += points.size();
    }
    state.SetItemsProcessed(static_cast<int64_t>(queries));
    state.counters["inside_fraction"] = static_cast<double>(inside) / std::max<size_t>(1, queries);
}

#define SYLVA_VOLUME_BENCH(kind)                                                              \
    BENCHMARK_CAPTURE(VolumeBuild, kind, #kind)->Unit(benchmark::kMillisecond)->MinTime(0.5); \
    BENCHMARK_CAPTURE(InsideTest, kind, #kind)->Unit(benchmark::kMicrosecond)->MinTime(0.5)
SYLVA_VOLUME_BENCH(sphere);
SYLVA_VOLUME_BENCH(ellipsoid);
SYLVA_VOLUME_BENCH(sector_cylinder_union);
SYLVA_VOLUME_BENCH(level_set);
SYLVA_VOLUME_BENCH(revolution);
SYLVA_VOLUME_BENCH(mask_revolution);
SYLVA_VOLUME_BENCH(visual_hull);
SYLVA_VOLUME_BENCH(canopy_envelope);
SYLVA_VOLUME_BENCH(crown_refinement);

// Xu & Mould's node sampling as xm-l's first level draws it: 2,500 Poisson-disc points in a
// cone 3 m wide and 10 m high at spacing 0.7·(V/2,500)^(1/3), by dart throwing (seeds 1, 2, …
// per iteration). Items are darts; counter darts_per_point.
static void PoissonCone(benchmark::State& state) {
    const VolumePtr cone = makeCone(3.0, 10.0, 0.0);
    PoissonOptions po;
    po.count = 2500;
    po.minDistance = 0.7 * std::cbrt(cone->measure() / po.count);
    // Counting sampler: the same cone, the darts counted.
    struct Counting final : Volume {
        const Volume& v;
        mutable int64_t draws = 0;
        explicit Counting(const Volume& of) : v(of) {}
        double signedDistance(const Vec3& p) const override { return v.signedDistance(p); }
        Aabb bounds() const override { return v.bounds(); }
        std::optional<Vec3> sample(Rng& rng, int tries) const override {
            ++draws;
            return v.sample(rng, tries);
        }
        double measure() const override { return v.measure(); }
        std::string describe() const override { return v.describe(); }
    } counting(*cone);
    uint64_t seed = 1;
    std::vector<Vec3> points;
    for (auto _ : state) {
        Rng rng(seed++);
        points.clear();
        poissonSample(counting, po, rng, points);
        benchmark::DoNotOptimize(points.data());
    }
    state.SetItemsProcessed(counting.draws);
    state.counters["darts_per_point"] =
        static_cast<double>(counting.draws) / (static_cast<double>(state.iterations()) * po.count);
}
BENCHMARK(PoissonCone)->Unit(benchmark::kMillisecond)->MinTime(1.0);

// Liu 2020 Fig. 17: time per tree of Palubicki's method and the improved variant on the same
// crown and marker budget. The crown (an ellipsoid 10 × 8 × 10 m over a 1 m bole, internodes
// of 0.1 m) holds a 50k-internode tree; both variants stop at max_internodes = the argument,
// so the 2k and 10k trees are the young stages of the same growth. The budget: the baseline
// spreads 400,000 markers once; the improved variant's 40 markers per bud and iteration draw
// about as many by 50k internodes (counter markers_generated; the draws beyond max(r, 4.3σ)
// that could not matter are skipped, see space_colonization.cpp). One thread. Peak RSS is the
// process's (monotone), so run one case per process to compare memory; the counters give the
// method's own sizes (markers, internodes, iterations, height).
// Grows a tree per iteration (seeds 1, 2, …) and leaves the last one and its counters in
// `tree` and `stats`; returns the last tree's height, metres.
static double growColonizationTrees(benchmark::State& state, const SpaceColonizationOptions& o,
                                    Tree& tree, std::map<std::string, double>& stats) {
    uint64_t seed = 1;
    for (auto _ : state) {
        Rng rng(seed++);
        stats.clear();
        tree = growSpaceColonization(o, rng, &stats);
        benchmark::DoNotOptimize(tree.nodes.data());
    }
    double height = 0.0;
    for (const SkeletonNode& n : tree.nodes) height = std::max(height, n.position.y);
    return height;
}

static void Colonization(benchmark::State& state, ColonizationVariant variant) {
    SpaceColonizationOptions o;
    o.variant = variant;
    o.crown = makePlaced(makeEllipsoid({5, 4, 5}), Placement{{0, 5, 0}, {0, 1, 0}, {1, 1, 1}});
    o.internode = 0.1;
    o.trunkLength = 1.0;
    o.markers = 400000;
    o.markersPerBud = 40;
    o.maxIterations = 1000;
    o.maxInternodes = static_cast<int>(state.range(0));
    o.threaded = false;
    std::map<std::string, double> stats;
    Tree tree;
    static const double rssBefore = peakRssMiB();  // at the first Colonization case's start
    const double height = growColonizationTrees(state, o, tree, stats);
    state.counters["internodes"] = stats["internodes"];
    state.counters["iterations"] = stats["iterations"];
    state.counters["markers_generated"] = stats["markers_generated"];
    state.counters["height_m"] = height;
    state.counters["peak_rss_MiB"] = peakRssMiB();
    // What growing added to the process's peak since the first Colonization case started:
    // the method's own peak when this case runs alone in its process.
    state.counters["peak_rss_added_MiB"] = peakRssMiB() - rssBefore;
}
BENCHMARK_CAPTURE(Colonization, baseline, ColonizationVariant::kBaseline)
    ->Arg(2000)
    ->Arg(10000)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0);
BENCHMARK_CAPTURE(Colonization, improved, ColonizationVariant::kImproved)
    ->Arg(2000)
    ->Arg(10000)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0);

// What Palubicki 2009's Borchert–Honda allocation costs (issue 13): the baseline in the
// Colonization crown above (400,000 markers, internodes of 0.1 m) grown to the argument's
// internodes with allocation = none (one metamer per bud and iteration: the papers'), with
// Borchert–Honda allocation on Q = space (λ = 0.55, α = 2), and with allocation on Q = shadow
// plus shedding (a = 0.15, threshold 0.45: the library's broadleaves). One thread.
static void ColonizationAllocation(benchmark::State& state) {
    SpaceColonizationOptions o;
    o.crown = makePlaced(makeEllipsoid({5, 4, 5}), Placement{{0, 5, 0}, {0, 1, 0}, {1, 1, 1}});
    o.internode = 0.1;
    o.trunkLength = 1.0;
    o.markers = 400000;
    o.maxIterations = 1000;
    o.maxInternodes = static_cast<int>(state.range(1));
    const int64_t mode = state.range(0);
    if (mode >= 1) {
        o.allocation = Allocation::kBorchertHonda;
        o.apicalControl = 0.55;
        o.resourceCoefficient = 2.0;
    }
    if (mode >= 2) {
        o.light = Light::kShadow;
        o.shadowStrength = 0.15;
        o.shedThreshold = 0.45;
    }
    std::map<std::string, double> stats;
    Tree tree;
    const double height = growColonizationTrees(state, o, tree, stats);
    state.counters["internodes"] = stats["internodes"];
    state.counters["iterations"] = stats["iterations"];
    state.counters["shed_internodes"] = stats["shed_internodes"];
    state.counters["height_m"] = height;
}
BENCHMARK(ColonizationAllocation)
    ->ArgNames({"mode", "internodes"})
    ->Args({0, 10000})
    ->Args({1, 10000})
    ->Args({2, 10000})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0);

// --- the species library (issue 6) -------------------------------------------------------------

// What one gallery tree costs: grow + mesh (tubes + leaf cards) + 8 views at 256² with depth
// and labels, the stages of `sylva build` (pipeline/batch/instance.h) with the outputs of
// datasets/species-gallery.toml, but no file writes (they cost the same for every species and
// are measured by WriteViewFile and GalleryBuild). One thread, so the figure is per core; a
// new instance seed every iteration, as a build draws them. Registered per preset by main().
static OutputOptions galleryOutputs() {
    OutputOptions o;
    o.meshFormats = {"ply"};
    o.tubes.minSides = 3;
    o.tubes.maxSides = 12;
    o.tubes.edgeLength = 0.04;
    o.views.count = 8;
    o.views.elevationsDeg = {10, 35};
    o.views.depth = true;
    o.views.labels = true;
    return o;
}

static void SpeciesTree(benchmark::State& state, const std::string& file) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    SpeciesEntry entry;
    try {
        entry.species = loadSpecies(file);
        validateSpecies(entry.species, nullptr);
    } catch (const std::exception& e) {
        state.SkipWithError(e.what());
        return;
    }
    entry.count = 1;
    entry.points.emplace_back();  // no sweep
    const OutputOptions outputs = galleryOutputs();
    InstanceJob job;
    job.entry = &entry;
    job.point = &entry.points.front();
    job.seed = 1;
    double nodes = 0, leaves = 0, triangles = 0, growMs = 0, meshMs = 0, renderMs = 0;
    int64_t trees = 0;
    for (auto _ : state) {
        InstanceWork w;
        w.job = job;
        growStage(w);
        meshStage(w, outputs, fs::path());
        renderStage(w, outputs);
        benchmark::DoNotOptimize(w.views.data());
        nodes += static_cast<double>(w.grown.tree.nodes.size());
        leaves += static_cast<double>(w.grown.tree.leaves.size());
        triangles +=
            static_cast<double>(w.mesh.wood.triangleCount() + w.mesh.leaves.triangleCount());
        growMs += w.growMs;
        meshMs += w.meshMs;
        renderMs += w.renderMs;
        ++trees;
        ++job.seed;
    }
    const double n = static_cast<double>(std::max<int64_t>(1, trees));
    state.counters["nodes"] = nodes / n;
    state.counters["leaves"] = leaves / n;
    state.counters["triangles"] = triangles / n;
    state.counters["grow_ms"] = growMs / n;
    state.counters["mesh_ms"] = meshMs / n;
    state.counters["render_ms"] = renderMs / n;
}

// What leaf support costs: the paper's canopy-maple with twigs grown to every leaf (compare
// SpeciesTree/canopy-maple).
BENCHMARK_CAPTURE(SpeciesTree, canopy_maple_twigs,
                  std::string(SYLVA_SOURCE_DIR "/bench/canopy-maple-twigs.toml"))
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0);

// One SpeciesTree benchmark per shipped species file, in name order.
static void registerSpeciesTrees() {
    for (const fs::path& f : shippedSpeciesFiles()) {
        const std::string name = "SpeciesTree/" + f.stem().string();
        benchmark::RegisterBenchmark(name.c_str(), SpeciesTree, f.string())
            ->Unit(benchmark::kMillisecond)
            ->MinTime(1.0);
    }
}

// The whole gallery (a few trees of every preset, meshes, 8 views, contact sheets, files
// written to the temp directory) on all cores: trees per second.
static void GalleryBuild(benchmark::State& state) {
    const char* spec = "datasets/species-gallery.toml";
    try {  // a species that does not load is reported, not a crash of the whole run
        loadDataset(std::string(SYLVA_SOURCE_DIR "/") + spec);
    } catch (const std::exception& e) {
        state.SkipWithError(e.what());
        return;
    }
    DatasetBuild(state, spec);
}
BENCHMARK(GalleryBuild)->Arg(0)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// Continuous limbs (issue 13): what the options cost on a tree at Table 1 scale
// (bench/table1.toml's volumes and levels, built here so the passes can run on their own),
// one thread. Cases: grow with the paper's costs (`paper`), with the radial weight on the same
// graph (`radial`), with the denser linking the library uses (`radial_link3`), with everything
// the umbrella-thorn preset turns on (`all`: trunk, radial weight 3 on link factor 3, merging
// 0.5 m × 0.6^k, 8 smoothing passes); and the passes alone on the paper's grown skeleton
// (`merge`, `smooth`: the copy of the tree is not timed).
static IteratedGraphOptions table1Options() {
    IteratedGraphOptions o;
    o.crown.volume = makeUnion(
        {makeCylinder(0.5, 3.0), makePlaced(makeHemisphere(6.0), Placement{{0, 3.0, 0}})});
    o.crown.endpointVolume = makePlaced(makeHemisphere(6.0), Placement{{0, 3.0, 0}});
    o.crown.subgraphRadius = 3.0;
    o.crown.shrink = 0.6;
    const int nodes[] = {5000, 1500, 400, 100}, ends[] = {15, 15, 10, 14};
    for (int k = 0; k < 4; ++k) {
        IteratedGraphLevel l;
        l.nodes = nodes[k];
        l.endpoints = ends[k];
        if (k == 0) l.endpointShell = 2.0;
        if (k > 0) l.alpha = 60.0 * kPi / 180;
        o.crown.levels.push_back(l);
    }
    return o;
}

static void ContinuousLimbs(benchmark::State& state, const char* which) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    const std::string c = which;
    IteratedGraphOptions o = table1Options();
    if (c == "radial" || c == "radial_link3" || c == "all") o.radialWeight = 3.0;
    if (c == "radial_link3" || c == "all") o.linkFactor = 3.0;
    if (c == "all") {
        o.trunk.height = 3.0;
        o.merge.distance = 0.5;
        o.merge.shrink = 0.6;
        o.smoothing.iterations = 8;
    }
    const bool pass = c == "merge" || c == "smooth";
    Rng rng(1);
    const Tree grown = pass ? growIteratedGraph(o, rng, false) : Tree{};
    MergeOptions m;
    m.distance = 0.5;
    m.shrink = 0.6;
    uint64_t seed = 1;
    double nodesIn = 0, nodesOut = 0;
    int64_t runs = 0;
    for (auto _ : state) {
        Tree t;
        if (pass) {
            state.PauseTiming();
            t = grown;
            state.ResumeTiming();
            if (c == "merge") mergeParallelPaths(t, m);
            if (c == "smooth") smoothAxes(t, 8);
            nodesIn += static_cast<double>(grown.nodes.size());
        } else {
            Rng r(seed++);
            t = growIteratedGraph(o, r, false);
        }
        nodesOut += static_cast<double>(t.nodes.size());
        ++runs;
        benchmark::DoNotOptimize(t.nodes.data());
    }
    const double n = static_cast<double>(std::max<int64_t>(1, runs));
    if (pass) state.counters["nodes_in"] = nodesIn / n;
    state.counters["nodes"] = nodesOut / n;
}
BENCHMARK_CAPTURE(ContinuousLimbs, paper, "paper")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ContinuousLimbs, radial, "radial")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ContinuousLimbs, radial_link3, "radial_link3")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ContinuousLimbs, all, "all")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ContinuousLimbs, merge, "merge")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ContinuousLimbs, smooth, "smooth")->Unit(benchmark::kMillisecond);

// --- huge datasets (issue 15) ------------------------------------------------------------------

// A dataset spec in the temp directory: `species` entries (copies of tests/data/tiny.toml under
// their own names), `count` instances each, every entry swept over 4 points; skeletons only.
static fs::path hugeDatasetSpec(int species, int64_t count) {
    const fs::path dir =
        fs::temp_directory_path() / ("sylva-bench-huge-" + std::to_string(getpid()));
    fs::create_directories(dir);
    std::string tiny;
    {
        std::ifstream in(SYLVA_SOURCE_DIR "/tests/data/tiny.toml");
        tiny.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    std::string spec = "name = \"huge\"\nseed = 15\n";
    for (int s = 0; s < species; ++s) {
        const std::string name = "tiny-" + std::to_string(s);
        std::string text = tiny;
        text.replace(text.find("name = \"tiny\""), 13, "name = \"" + name + "\"");
        std::ofstream(dir / (name + ".toml")) << text;
        spec +=
            "[[species]]\nfile = \"" + name + ".toml\"\ncount = " + std::to_string(count) + "\n";
    }
    spec += "[[sweep]]\npath = \"levels[1].endpoints\"\nvalues = [2, 3, 4, 5]\n";
    const fs::path file =
        dir / ("huge-" + std::to_string(species) + "-" + std::to_string(count) + ".toml");
    std::ofstream(file) << spec;
    return file;
}

// Instance i from i: DatasetInstances::operator[] (binary search over the species' prefix sums,
// the id formatted, the seed hashed) at random positions of a dataset of Arg species entries ×
// 4 sweep points × 10⁹.
static void InstanceLookup(benchmark::State& state) {
    const int species = static_cast<int>(state.range(0));
    const DatasetSpec spec = loadDataset(hugeDatasetSpec(species, 1'000'000'000).string());
    const DatasetInstances instances(spec);
    Rng rng(7);
    for (auto _ : state) {
        const auto i =
            static_cast<int64_t>(rng.uniform(0, 1) * static_cast<double>(instances.size()));
        InstanceJob job = instances[std::min(i, instances.size() - 1)];
        benchmark::DoNotOptimize(job);
    }
    state.counters["instances"] = static_cast<double>(instances.size());
}
BENCHMARK(InstanceLookup)->Arg(1)->Arg(64)->Unit(benchmark::kNanosecond);

// The inverse, DatasetInstances::find(id), which resume's manifest scan calls once per line.
static void InstanceFind(benchmark::State& state) {
    const int species = static_cast<int>(state.range(0));
    const DatasetSpec spec = loadDataset(hugeDatasetSpec(species, 1'000'000'000).string());
    const DatasetInstances instances(spec);
    Rng rng(7);
    std::vector<std::string> ids;
    for (int k = 0; k < 1024; ++k) {
        const auto i =
            static_cast<int64_t>(rng.uniform(0, 1) * static_cast<double>(instances.size()));
        ids.push_back(instances[std::min(i, instances.size() - 1)].id);
    }
    size_t k = 0;
    for (auto _ : state) benchmark::DoNotOptimize(instances.find(ids[k++ & 1023]));
}
BENCHMARK(InstanceFind)->Arg(1)->Arg(64)->Unit(benchmark::kNanosecond);

// What `sylva validate` does with a dataset of 4 × 10^Arg instances (one species, 4 sweep
// points): load and check the spec and every sweep point, count the instances. The count does
// not enter the cost.
static void ValidateHuge(benchmark::State& state) {
    int64_t count = 1;
    for (int64_t k = 0; k < state.range(0); ++k) count *= 10;
    const std::string file = hugeDatasetSpec(1, count).string();
    int64_t n = 0;
    for (auto _ : state) {
        const DatasetSpec spec = loadDataset(file);
        n = DatasetInstances(spec).size();
        benchmark::DoNotOptimize(n);
    }
    state.counters["instances"] = static_cast<double>(n);
    state.counters["peak_rss_MiB"] = peakRssMiB();
}
BENCHMARK(ValidateHuge)->Arg(3)->Arg(9)->Arg(15)->Unit(benchmark::kMillisecond);

// Resume's manifest scan (recordedInstances): 20,000 lines like a build's — a real record of
// tests/data/tiny_dataset.toml (4 views, every output), renumbered through a 10⁹-instance
// dataset — read into runs of positions. Arg(1): the same lines parsed into json documents and
// their ids looked up, as resume read them before issue 15.
static void ResumeScan(benchmark::State& state) {
    const bool dom = state.range(0) == 1;
    const fs::path dir =
        fs::temp_directory_path() / ("sylva-bench-resume-" + std::to_string(getpid()));
    fs::remove_all(dir);
    // One real record: the first instance of the tiny dataset, built.
    DatasetSpec tiny = loadDataset(SYLVA_SOURCE_DIR "/tests/data/tiny_dataset.toml");
    BuildOptions o;
    o.out = dir / "tiny";
    o.shardIndex = 0;
    o.shardCount = 24;
    o.progress = false;
    buildDataset(tiny, o);
    std::string line;
    std::getline(std::ifstream(o.out / manifestName(0, 24)), line);
    auto record = nlohmann::json::parse(line);
    // The same record under the ids of a 10⁹-instance dataset of the tiny species.
    const DatasetSpec spec = loadDataset(hugeDatasetSpec(1, 1'000'000'000).string());
    const DatasetInstances instances(spec);
    const fs::path manifest = dir / "manifest.jsonl";
    const int lines = 20000;
    {
        std::ofstream out(manifest, std::ios::binary);
        for (int k = 0; k < lines; ++k) {
            record["id"] = instances[k].id;
            out << record.dump() << '\n';
        }
    }
    const double bytes = static_cast<double>(fs::file_size(manifest));
    for (auto _ : state) {
        if (dom) {
            InstanceSet done;
            std::ifstream in(manifest, std::ios::binary);
            for (std::string l; std::getline(in, l);) {
                auto j = nlohmann::json::parse(l, nullptr, false);
                if (j.is_discarded() || !j.contains("id")) continue;
                if (auto p = instances.find(j["id"].get<std::string>())) done.insert(*p);
            }
            benchmark::DoNotOptimize(done.size());
        } else {
            benchmark::DoNotOptimize(recordedInstances(manifest, instances).size());
        }
    }
    fs::remove_all(dir);
    state.counters["lines_per_second"] =
        benchmark::Counter(static_cast<double>(lines) * static_cast<double>(state.iterations()),
                           benchmark::Counter::kIsRate);
    state.counters["MB_per_second"] = benchmark::Counter(
        bytes * static_cast<double>(state.iterations()) / 1e6, benchmark::Counter::kIsRate);
    state.counters["bytes_per_line"] = bytes / lines;
}
BENCHMARK(ResumeScan)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// BENCHMARK_MAIN(), plus the per-preset benchmarks registered before the run.
int main(int argc, char** argv) {
    registerSpeciesTrees();
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
