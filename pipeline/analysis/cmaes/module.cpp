// libsylva_cmaes.so: pagmo2's CMA-ES behind pipeline/analysis/cmaes_module.h's table.
#include <pagmo/algorithms/cmaes.hpp>
#include <pagmo/population.hpp>
#include <pagmo/problem.hpp>

#include "pipeline/analysis/cmaes_module.h"

namespace sylva {
namespace {

// pagmo's user-defined problem around a std::function (called serially by cmaes).
struct FunctionProblem {
    const std::function<double(const std::vector<double>&)>* f = nullptr;
    pagmo::vector_double lo, hi;
    pagmo::vector_double fitness(const pagmo::vector_double& x) const { return {(*f)(x)}; }
    std::pair<pagmo::vector_double, pagmo::vector_double> get_bounds() const { return {lo, hi}; }
};

bool run(const std::function<double(const std::vector<double>&)>& f, const std::vector<double>& lo,
         const std::vector<double>& hi, const std::vector<std::vector<double>>& initial,
         double sigma0, unsigned seed, int64_t generations,
         const std::function<void(int64_t, const std::vector<double>&, double)>& step) {
    FunctionProblem udp;
    udp.f = &f;
    udp.lo = lo;
    udp.hi = hi;
    pagmo::problem prob(udp);
    pagmo::population pop(prob, 0u, seed);
    for (const std::vector<double>& x : initial) pop.push_back(x);
    auto best = [&](int64_t made) {
        const auto b = pop.best_idx();
        step(made, pop.get_x()[b], pop.get_f()[b][0]);
    };
    best(static_cast<int64_t>(initial.size()));
    // ftol = xtol = 0: no early stop on a flat population. With force_bounds a generation can
    // put every candidate on the same bound, with equal objectives, which is no convergence.
    pagmo::cmaes cma(1u, -1, -1, -1, -1, sigma0, 0.0, 0.0, true, true, seed);
    for (int64_t g = 1; g <= generations; ++g) {
        const auto before = pop.get_problem().get_fevals();
        pop = cma.evolve(pop);
        const auto made = pop.get_problem().get_fevals() - before;
        if (made == 0) return true;  // CMA-ES's own stop: it returned without a generation
        best(static_cast<int64_t>(made));
    }
    return false;
}

const CmaesModule kModule = {run};

}  // namespace
}  // namespace sylva

extern "C" __attribute__((visibility("default"))) const sylva::CmaesModule* sylva_cmaes_module() {
    return &sylva::kModule;
}
