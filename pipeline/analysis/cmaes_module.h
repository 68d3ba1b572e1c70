// pagmo2, loaded when first needed. Its library's static initialisers (tables of the test
// problems it ships) cost every process that links it ≈ 50 ms of CPU at start — about half of
// `sylva --help` — whatever the command; only `sylva fit` (fit.h's minimiseCmaes) calls it. So
// the call lives in a module of its own, libsylva_cmaes.so (pipeline/analysis/cmaes/), built
// beside the executable and opened with dlopen the first time a fit runs (core/module.h). Copy
// it with the executable (docs/cluster.md).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

namespace sylva {

struct CmaesModule {
    // One run of pagmo2's CMA-ES over f on the box [lo, hi]: the population `initial` (each
    // evaluated in order), then at most `generations` generations, one per evolve() call with
    // the mean, step and covariance kept between calls (memory), candidates clipped to the box
    // (force_bounds), no stop on ftol or xtol, initial step `sigma0` (a fraction of the box),
    // seeded with `seed`. After the initial population and after each generation that evaluated
    // something, step(evaluations it made, the population's best x, its objective). Returns true
    // when CMA-ES stopped on its own (a generation that made no evaluation: its step fell to 0),
    // false when every generation ran.
    bool (*run)(const std::function<double(const std::vector<double>&)>& f,
                const std::vector<double>& lo, const std::vector<double>& hi,
                const std::vector<std::vector<double>>& initial, double sigma0, unsigned seed,
                int64_t generations,
                const std::function<void(int64_t, const std::vector<double>&, double)>& step);
};

// The module, opened on the first call (thread-safe); later calls return the same table.
// Opens the environment's SYLVA_CMAES_MODULE (a path) when set, else libsylva_cmaes.so beside
// the running executable. Throws std::runtime_error naming what it tried when it cannot load it.
const CmaesModule& cmaesModule();

}  // namespace sylva
