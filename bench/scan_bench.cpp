// The laser scanner (issue 17, docs/scanning.md "Speed"):
//   ScanTree/<sub_rays>/<threads>: TLS, one station 12 m from a silver birch (grown once per
//     process, tubes + leaf cards) on a 60 m ground square — HELIOS++'s reference scene —
//     a 90° × 100° window at 0.1° steps (≈ 900 × 1000 pulses);
//   EmbreeRawTree/<mode>/<threads>: the same first-pass rays through the same BVH, closest hits
//     only (mode 0 rtcIntersect1, 1 rtcIntersect16, 2 rtcIntersect1M): Embree's own limit;
//   ScanPlot/<platform>/<sub_rays>/<threads>: a 1 ha, 400-tree plot (platform 0 TLS) — the 0.1 ha
//   benchmark plot
//     (bench/plot-0.1ha.toml, 40 trees grown once) instanced on a 3 × 3 + 1 tiling to 400 trees on
//     a 1 ha ground plane — scanned by TLS (one station in the middle, 0.1° steps, capped at
//     1.5 M pulses), ULS at 60 m and ALS at 500 m (platform 1, 2; capped at 1.5 M pulses);
//   ScanSceneBuild/<instanced>: the BVH of those 400 trees, instanced (40 prototypes) or with
//     every copy's triangles (the plot's meshes copied out 10 times): seconds and Embree bytes;
//   ScanRepeat: 10 scenes built, scanned and destroyed in one process: resident memory after
//     the first and after the tenth.
#include <benchmark/benchmark.h>
#include <malloc.h>
#include <sys/resource.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "pipeline/batch/dataset.h"
#include "pipeline/render/plot_render.h"
#include "pipeline/scan/scanner.h"
#include "species/geometry/leaf_mesh.h"
#include "species/geometry/tube_mesh.h"
#include "species/plot/layout.h"
#include "species/plot/plot_growth.h"
#include "species/spec/species.h"

using namespace sylva;

namespace {

// Resident memory after glibc returns its free pages (malloc_trim): what the process holds, not
// what the allocator keeps cached for later.
double residentMiB() {
    malloc_trim(0);
    std::ifstream in("/proc/self/statm");
    long pages = 0, resident = 0;
    in >> pages >> resident;
    return resident * 4096.0 / (1 << 20);
}

struct BirchScene {
    GrownTree grown;
    TreeMesh mesh;
    std::vector<int32_t> nodes;
    std::unique_ptr<ScanScene> scene;
};

const BirchScene& birch() {
    static BirchScene* b = [] {
        auto* s = new BirchScene;
        const SpeciesFile sp = loadSpecies(SYLVA_SOURCE_DIR "/species/presets/silver-birch.toml");
        s->grown = growSpecies(sp, 1, nullptr, true);
        s->mesh.wood = tubeMesh(s->grown.tree, TubeOptions{}, &s->nodes);
        s->mesh.leaves = leafMesh(s->grown.tree);
        s->scene =
            std::make_unique<ScanScene>(makeScanScene(s->grown.tree, s->mesh, s->nodes, 30.0));
        return s;
    }();
    return *b;
}

ScanOptions birchTls(int subRays) {
    ScanOptions o = defaultScanOptions(ScanPlatform::kTls);
    o.stations = {{0, 12, 1.5}};  // 12 m south of the tree, looking north
    o.horizontalFov = 90 * kScanDeg;
    o.horizontalStep = o.verticalStep = 0.1 * kScanDeg;
    o.subRays = subRays;
    return o;
}

void ScanTree(benchmark::State& state) {
    const BirchScene& b = birch();
    ScanOptions o = birchTls(static_cast<int>(state.range(0)));
    if (state.range(2) == 0) o.leafTransmission = 0;  // every ray traced once, as EmbreeRawTree
    tbb::task_arena arena(static_cast<int>(state.range(1)));
    uint64_t pulses = 0, points = 0;
    for (auto _ : state) {
        arena.execute([&] {
            const ScanResult r = scan(*b.scene, o, 1);
            pulses += r.pulses;
            points += r.points.size();
        });
    }
    state.counters["pulses_per_s"] =
        benchmark::Counter(double(pulses), benchmark::Counter::kIsRate);
    state.counters["points_per_pulse"] = double(points) / double(pulses);
    state.counters["triangles"] = double(b.scene->triangles());
}
BENCHMARK(ScanTree)
    ->ArgNames({"sub_rays", "threads", "transmission"})
    ->Args({1, 1, 1})
    ->Args({19, 1, 1})
    ->Args({19, 1, 0})
    ->Args({1, 2, 1})
    ->Args({19, 2, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

void EmbreeRawTree(benchmark::State& state) {
    const BirchScene& b = birch();
    const ScanOptions o = birchTls(19);
    static const std::vector<ScanRay> rays = scanRays(*b.scene, o, 1, 0, surveyPulses(*b.scene, o));
    const auto mode = static_cast<RayMode>(state.range(0));
    tbb::task_arena arena(static_cast<int>(state.range(1)));
    uint64_t n = 0;
    for (auto _ : state) {
        arena.execute([&] { benchmark::DoNotOptimize(traceRays(*b.scene, rays, mode)); });
        n += rays.size();
    }
    state.counters["rays_per_s"] = benchmark::Counter(double(n), benchmark::Counter::kIsRate);
    state.counters["pulses_per_s"] =
        benchmark::Counter(double(n) / 19.0, benchmark::Counter::kIsRate);
}
BENCHMARK(EmbreeRawTree)
    ->ArgNames({"mode", "threads"})
    ->Args({0, 1})
    ->Args({1, 1})
    ->Args({2, 1})
    ->Args({1, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

// --- the hectare --------------------------------------------------------------------------------

struct PlotMeshes {
    DatasetSpec spec;
    GrownPlot plot;
    PlotScene scene;
};

const PlotMeshes& tenthHectare() {
    static PlotMeshes* p = [] {
        auto* m = new PlotMeshes;
        m->spec = loadDataset(SYLVA_SOURCE_DIR "/bench/plot-0.1ha.toml");
        const PlotSpec& ps = m->spec.plots[0];
        m->plot = growPlot(ps, layoutPlot(ps, 1), nullptr, true);
        m->scene = makePlotScene(m->plot, TubeOptions{}, true, false);
        return m;
    }();
    return *p;
}

// The 0.1 ha plot's 40 trees tiled to 400 on a flat hectare: 10 copies at offsets of one tile
// (the plot's width) — a 3 × 3 block and one more — each copy its own tree ids.
ScanScene hectare(bool instanced) {
    const PlotMeshes& m = tenthHectare();
    const double w = m.spec.plots[0].area.width;
    std::vector<Vec3> offsets;
    for (int i = 0; i < 10; ++i) {
        offsets.push_back({(i % 3 - 1) * w, 0, (i < 9 ? i / 3 - 1 : 2) * w});
    }
    ScanScene s;
    std::vector<int> protos;
    std::vector<Tree> flattened;  // the plot's trees with their bases at terrain 0
    for (size_t k = 0; k < m.scene.trees.size(); ++k) {
        ScanTreeInput in;
        in.tree = &m.plot.trees[k].grown.tree;
        in.mesh = &m.scene.trees[k].mesh;
        in.woodNodes = &m.scene.trees[k].woodNodes;
        in.leafOutlines = m.scene.leafOutlines;
        in.species = static_cast<uint16_t>(m.plot.trees[k].stem.species);
        if (instanced) {
            protos.push_back(s.addPrototype(in));
        }
    }
    for (size_t c = 0; c < offsets.size(); ++c) {
        for (size_t k = 0; k < m.scene.trees.size(); ++k) {
            const int32_t id = static_cast<int32_t>(c * m.scene.trees.size() + k + 1);
            if (instanced) {
                s.addInstance(protos[k], offsets[c], 0.0, id);
                continue;
            }
            TreeMesh moved = m.scene.trees[k].mesh;
            for (Mesh* mesh : {&moved.wood, &moved.leaves}) {
                for (size_t i = 0; i < mesh->positions.size(); i += 3) {
                    mesh->positions[i] += static_cast<float>(offsets[c].x);
                    mesh->positions[i + 2] += static_cast<float>(offsets[c].z);
                }
            }
            ScanTreeInput in;
            in.tree = &m.plot.trees[k].grown.tree;
            in.mesh = &moved;
            in.woodNodes = &m.scene.trees[k].woodNodes;
            in.leafOutlines = m.scene.leafOutlines;
            in.treeId = id;
            s.addTree(in);
        }
    }
    Mesh ground;
    const float h = static_cast<float>(2 * w);
    ground.positions = {-h, 0, -h, h, 0, -h, h, 0, h, -h, 0, h};
    ground.indices = {0, 2, 1, 0, 3, 2};
    s.addMesh(ground, kScanTerrain);
    s.commit();
    Aabb area;
    area.extend(Vec3{-50, 0, -50});
    area.extend(Vec3{50, 0, 50});
    s.setArea(area);
    return s;
}

const ScanScene& hectareScene() {
    static ScanScene* s = new ScanScene(hectare(true));
    return *s;
}

void ScanPlot(benchmark::State& state) {
    const ScanScene& s = hectareScene();
    const bool tls = state.range(0) == 0;
    const ScanPlatform platform = tls                   ? ScanPlatform::kTls
                                  : state.range(0) == 1 ? ScanPlatform::kUls
                                                        : ScanPlatform::kAls;
    ScanOptions o = defaultScanOptions(platform);
    if (tls) {
        o.stations = {{0, 0, 1.5}};
        o.horizontalStep = o.verticalStep = 0.1 * kScanDeg;
    }
    o.subRays = static_cast<int>(state.range(1));
    o.maxPulses = 1500000;
    tbb::task_arena arena(static_cast<int>(state.range(2)));
    uint64_t pulses = 0, points = 0;
    for (auto _ : state) {
        arena.execute([&] {
            const ScanResult r = scan(s, o, 1);
            pulses += r.pulses;
            points += r.points.size();
        });
    }
    state.counters["pulses_per_s"] =
        benchmark::Counter(double(pulses), benchmark::Counter::kIsRate);
    state.counters["points_per_pulse"] = double(points) / double(pulses);
    state.counters["triangles"] = double(s.triangles());
    state.counters["peak_rss_MiB"] = [] {
        rusage u{};
        getrusage(RUSAGE_SELF, &u);
        return u.ru_maxrss / 1024.0;
    }();
}
BENCHMARK(ScanPlot)
    ->ArgNames({"platform", "sub_rays", "threads"})
    ->Args({0, 1, 1})
    ->Args({0, 19, 1})
    ->Args({0, 19, 2})
    ->Args({1, 1, 1})
    ->Args({1, 19, 1})
    ->Args({1, 19, 2})
    ->Args({2, 1, 1})
    ->Args({2, 19, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

void ScanSceneBuild(benchmark::State& state) {
    tenthHectare();
    const bool instanced = state.range(0) != 0;
    int64_t bytes = 0, stored = 0, triangles = 0;
    for (auto _ : state) {
        const ScanScene s = hectare(instanced);
        bytes = s.embreeBytes();
        stored = s.storedTriangles();
        triangles = s.triangles();
    }
    state.counters["embree_MiB"] = double(bytes) / (1 << 20);
    state.counters["stored_triangles"] = double(stored);
    state.counters["triangles"] = double(triangles);
}
BENCHMARK(ScanSceneBuild)
    ->ArgName("instanced")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);

void ScanRepeat(benchmark::State& state) {
    tenthHectare();
    double first = 0, last = 0;
    for (auto _ : state) {
        for (int k = 0; k < 10; ++k) {
            {
                const ScanScene s = hectare(true);
                ScanOptions o = defaultScanOptions(ScanPlatform::kUls);
                o.maxPulses = 200000;
                benchmark::DoNotOptimize(scan(s, o, k).points.size());
            }
            if (k == 0) first = residentMiB();
            if (k == 4) state.counters["rss_after_5_MiB"] = residentMiB();
        }
        last = residentMiB();
    }
    state.counters["rss_after_1_MiB"] = first;
    state.counters["rss_after_10_MiB"] = last;
}
BENCHMARK(ScanRepeat)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

}  // namespace
