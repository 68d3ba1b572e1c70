// sylva benchmarks (Google Benchmark). Run through scripts/bench.
//  - Table1Tree: one iterated-graph tree at the scale of Xu & Mould 2012 Table 1
//    (~350k graph nodes, ~34k endpoints), on 1 thread and on all cores.
//  - DemoBuild: the whole demo dataset (1,000 trees, files written), trees per second.
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>

#include <filesystem>

#include "pipeline/build.h"
#include "pipeline/dataset.h"
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

static void DemoBuild(benchmark::State& state) {
    const int threads =
        state.range(0) > 0 ? static_cast<int>(state.range(0)) : tbb::info::default_concurrency();
    DatasetSpec spec = loadDataset(SYLVA_SOURCE_DIR "/datasets/demo.toml");
    fs::path out = fs::temp_directory_path() / ("sylva-bench-demo-" + std::to_string(getpid()));
    int64_t trees = 0;
    for (auto _ : state) {
        state.PauseTiming();
        fs::remove_all(out);
        state.ResumeTiming();
        BuildOptions o;
        o.out = out;
        o.threads = threads;
        o.progress = false;
        trees += buildDataset(spec, o).built;
    }
    fs::remove_all(out);
    state.counters["threads"] = threads;
    state.counters["trees_per_second"] =
        benchmark::Counter(static_cast<double>(trees), benchmark::Counter::kIsRate);
    state.counters["peak_rss_MiB"] = peakRssMiB();
}
BENCHMARK(DemoBuild)->Arg(1)->Arg(0)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

BENCHMARK_MAIN();
