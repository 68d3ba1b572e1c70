// Plot layouts (issue 16): PlotLayout/<process> — layoutPlot of a 1 ha plot (100 × 100 m, 5 m
// margin) with 400 canopy stems of 2 species and 200 understory stems, on smooth-noise terrain
// at 0.5 m cells (44,521 samples), one thread: terrain, point pattern, species and heights.
// Terrain/<kind> — the heightfield alone.
#include <benchmark/benchmark.h>

#include <string>

#include "pipeline/batch/dataset.h"
#include "species/plot/layout.h"
#include "species/plot/terrain.h"

using namespace sylva;

namespace {

PlotSpec hectare(PointProcessOptions::Kind process) {
    const DatasetSpec d =
        loadDataset(std::string(SYLVA_SOURCE_DIR) + "/tests/data/plot/plots.toml");
    PlotSpec s = d.plots[0];  // mixed-slope: 2 canopy species and an understory
    s.area.width = s.area.depth = 100;
    s.margin = 5;
    s.species[0].count = 300;
    s.species[1].count = 100;
    s.species[2].count = 200;
    s.terrain.kind = TerrainOptions::Kind::kNoise;
    s.terrain.amplitude = 3;
    s.terrain.wavelength = 40;
    s.terrain.octaves = 3;
    s.terrain.cell = 0.5;
    s.process = PointProcessOptions{};
    s.process.kind = process;
    s.process.minSpacing = 3;
    s.process.interaction = 0.2;
    s.process.parentDensity = 25;
    s.process.clusterSigma = 3;
    s.process.rowSpacing = 4;
    s.process.stemSpacing = 5;
    s.process.rowAzimuthRad = 0.3;
    s.process.jitter = 0.2;
    return s;
}

void PlotLayoutBench(benchmark::State& state) {
    const auto kind = static_cast<PointProcessOptions::Kind>(state.range(0));
    const PlotSpec spec = hectare(kind);
    uint64_t seed = 1;
    size_t stems = 0;
    for (auto _ : state) {
        const PlotLayout l = layoutPlot(spec, seed++);
        stems = l.stems.size();
        benchmark::DoNotOptimize(l.stems.data());
    }
    state.counters["stems"] = static_cast<double>(stems);
}
BENCHMARK(PlotLayoutBench)
    ->Name("PlotLayout")
    ->ArgName("process")
    ->DenseRange(0, 4)
    ->Unit(benchmark::kMillisecond);

void TerrainBench(benchmark::State& state) {
    PlotSpec spec = hectare(PointProcessOptions::Kind::kPoisson);
    spec.terrain.kind = static_cast<TerrainOptions::Kind>(state.range(0));
    spec.terrain.slopeRad = 0.2;
    for (auto _ : state) {
        const Terrain t = makeTerrain(spec.terrain, spec.area, spec.margin, 7);
        benchmark::DoNotOptimize(t.heights().data());
    }
}
BENCHMARK(TerrainBench)
    ->Name("Terrain")
    ->ArgName("kind")
    ->DenseRange(0, 2)
    ->Unit(benchmark::kMillisecond);

}  // namespace
