// sylva benchmarks (Google Benchmark). Run through scripts/bench.
//  - Table1Tree: one iterated-graph tree at the scale of Xu & Mould 2012 Table 1
//    (~350k graph nodes, ~34k endpoints), on 1 thread and on all cores.
//  - MeshTree / WatertightTree / RenderView: per-tree meshing and per-view rendering.
//  - WriteViewFile: one view's silhouette PNG, label PNG and depth EXR, per file.
//  - DatasetBuild: the whole demo dataset (1,000 trees with meshes and 8 views, files
//    written) and an ez-tree-sized one, trees per second.
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>

#include <filesystem>

#include "pipeline/build.h"
#include "pipeline/dataset.h"
#include "pipeline/mesh_writers.h"
#include "pipeline/views.h"
#include "species/mesh.h"
#include "species/species.h"

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
    SpeciesFile species = loadSpecies(SYLVA_SOURCE_DIR "/species/presets/xm-a.toml");
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

// One 256×256 view with depth and labels (the demo's views), per view.
static void RenderView(benchmark::State& state) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    GrownTree g = demoTree();
    ViewOptions vo;
    vo.count = 8;
    vo.elevationsDeg = {10, 35};
    Rng rng(1);
    std::vector<Camera> cams = makeCameras(g.tree, vo, rng);
    size_t k = 0;
    for (auto _ : state) {
        ViewImage v = renderView(g.tree, cams[k++ % cams.size()], true, true);
        benchmark::DoNotOptimize(v.silhouette.data());
    }
}
BENCHMARK(RenderView)->Unit(benchmark::kMillisecond);

// Writing one view's files to a RAM disk (/dev/shm when present): the silhouette PNG, the
// label PNG and the depth EXR (Arg 0, 1, 2), per file.
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
            default:
                writeDepthExr(out.string() + ".exr", v.width, v.height, v.depth);
                break;
        }
    }
    fs::remove(out.string() + ".png");
    fs::remove(out.string() + ".exr");
}
BENCHMARK(WriteViewFile)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

// A whole dataset built and written: trees per second on 1 core and on all cores.
static void DatasetBuild(benchmark::State& state, const char* specPath) {
    const int threads =
        state.range(0) > 0 ? static_cast<int>(state.range(0)) : tbb::info::default_concurrency();
    DatasetSpec spec = loadDataset(std::string(SYLVA_SOURCE_DIR "/") + specPath);
    fs::path out = fs::temp_directory_path() / ("sylva-bench-build-" + std::to_string(getpid()));
    int64_t trees = 0;
    double bytes = 0;
    for (auto _ : state) {
        state.PauseTiming();
        fs::remove_all(out);
        state.ResumeTiming();
        BuildOptions o;
        o.out = out;
        o.threads = threads;
        o.progress = false;
        trees += buildDataset(spec, o).built;
        state.PauseTiming();
        for (const auto& f : fs::recursive_directory_iterator(out)) {
            if (f.is_regular_file()) bytes += static_cast<double>(f.file_size());
        }
        state.ResumeTiming();
    }
    fs::remove_all(out);
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

BENCHMARK_MAIN();
