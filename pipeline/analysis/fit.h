// `sylva fit SPECIES.toml`: calibrates a species' parameters against measured trees. The
// species file's [fit] table names a reference file (quantile tables of architecture
// distributions, as `sylva stats --reference` reads them), the parameters to fit with their
// bounds, and a budget; the objective is the weighted mean KS distance D between the pooled
// distributions of `trees` trees grown with the candidate values (as dataset sweeps override
// them) and the reference's tables, pooled and measured exactly as `sylva stats --reference`
// does (dataset_stats.h). pagmo2's CMA-ES minimises it. The same tree seeds serve every
// evaluation (common random numbers), so the objective is a deterministic function of the
// parameters and the whole fit is byte-identical for a spec and seed, whatever the threads.
// docs/fit.md describes every key and output.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/errors.h"
#include "core/params.h"
#include "pipeline/analysis/dataset_stats.h"

namespace sylva {

// One fitted parameter: a number of the species file, an element of a distribution, or an
// element of an array of numbers.
struct FitParameter {
    std::string path;           // as written in [fit]: "form.pipe_exponent", "x.normal[0]",
                                // "geometry.a->m.tilt_deg[1]"
    double lo = 0, hi = 0;      // bounds = [lo, hi], lo < hi, in the key's own unit
    double initial = 0;         // the file's own value (inside the bounds)
    bool integer = false;       // an integer key (the species refuses a float): values rounded
    std::string overrideKey;    // the species parameter it overrides: path without ".normal[i]"
                                // or "[i]"
    int element = -1;           // the distribution or array element, or -1 for a plain number
    bool arrayElement = false;  // an element of an array of numbers (not of a distribution)
    SourcePos value;            // where the file's value starts (the number replaced in place)
    SourcePos where;            // the [[fit.parameter]] entry's `path`, for errors
};

// The [fit] table of a species file, with the species file's path.
struct FitSpec {
    std::string speciesPath;          // as given
    std::string speciesName;          // the species' `name`
    std::filesystem::path reference;  // `reference`, resolved against the species file
    // `allometry`: per-species allometry (species/reference/baad-allometry.json), resolved
    // against the species file; needed when `distributions` lists kAllometryDistributions.
    std::filesystem::path allometry;
    int trees = 16;                          // `trees`: trees per evaluation, ≥ 4
    int64_t evaluations = 600;               // `evaluations`: the budget of objective evaluations
    uint64_t seed = 1;                       // `seed`: tree seeds and CMA-ES
    std::vector<std::string> distributions;  // `distributions`: reference distribution names
    SourcePos distributionsWhere;            // where they are (the [fit] table when absent)
    std::vector<double> weights;             // `weights`: one per distribution (default 1)
    std::vector<FitParameter> parameters;    // [[fit.parameter]]
};

// Distributions a fit may take from an allometry file rather than the reference: one value per
// tree, crown depth ÷ height (TreeStats crownHeight / height) and crown diameter ÷ height (the
// mean of the crown's two horizontal extents / height), as baad-allometry.json defines them.
inline const std::vector<std::string> kAllometryDistributions = {"crown_depth_ratio",
                                                                 "crown_diameter_ratio"};

// The quantile table of an allometry distribution of a species: the species block of its entry
// in the allometry file, else its genus block; p 0, 0.05, 0.25, 0.5, 0.75, 0.95, 1 through the
// block's min, p5, p25, p50, p75, p95, max. Throws InputError "FILE: …" when the file or the
// entry is missing or malformed, or neither block measured that distribution.
QuantileTable allometryTable(const std::filesystem::path& file, const std::string& species,
                             const std::string& distribution);

// Reads and checks the [fit] table of a species file (and the species file itself: every
// fitted path must be a number or a distribution element in the file that the species reads,
// and the species must validate at both ends of every bound). Throws SpecError at the key.
// With a KeyLog, every key asked is recorded under "species.fit" (docs/fit.md).
// referenceOverride (--reference) replaces `reference`, which then need not name a file.
FitSpec readFitSpec(const std::string& speciesPath, KeyLog* keyLog = nullptr,
                    const std::optional<std::filesystem::path>& referenceOverride = {});

// The CMA-ES population for `dimension` parameters: 4 + ⌊3 ln n⌋ (Hansen's default), at least
// 5 (pagmo's cmaes needs 5).
int cmaesPopulation(size_t dimension);

// --- the optimiser, on any objective --------------------------------------------------------

struct CmaesOptions {
    int64_t evaluations = 600;  // budget: the initial population, then whole generations
    uint64_t seed = 1;          // CMA-ES's own random numbers and the initial population
    double sigma0 = 0.3;        // initial step, as a fraction of each bound's width
    // The first individual of the initial population (inside the bounds); the other
    // population − 1 are uniform in the bounds. Empty: all uniform.
    std::vector<double> x0;
};

struct CmaesGeneration {
    int generation = 0;         // 0: the initial population
    int64_t evaluations = 0;    // evaluations so far
    double best = 0;            // the best objective so far
    std::vector<double> bestX;  // its parameters
};

struct CmaesResult {
    std::vector<double> bestX;
    double best = 0;
    int64_t evaluations = 0;
    bool converged = false;  // CMA-ES stopped before the budget (its step fell to 0)
    std::vector<CmaesGeneration> generations;
};

// Minimises f over the box [lo, hi] with pagmo2's CMA-ES (force_bounds: candidates are clipped
// to the box; no early stop on ftol or xtol), one generation at a time so the budget and progress
// are exact: evaluations = population × (1 + generations) ≤ options.evaluations. f is called
// serially, in a fixed order; with a deterministic f the result depends on the seed only.
// onGeneration (optional) is called after the initial population and after every generation.
// Throws std::invalid_argument when the budget is below two populations or the box is empty.
CmaesResult minimiseCmaes(const std::function<double(const std::vector<double>&)>& f,
                          const std::vector<double>& lo, const std::vector<double>& hi,
                          const CmaesOptions& options,
                          const std::function<void(const CmaesGeneration&)>& onGeneration = {});

// --- the fit --------------------------------------------------------------------------------

struct FitOptions {
    std::filesystem::path out;  // the fitted species file (default: out/fit/<species>.toml)
    // Command-line overrides of the [fit] keys.
    std::optional<uint64_t> seed;
    std::optional<int64_t> evaluations;
    std::optional<std::filesystem::path> reference;
    // Reuse the evaluations of an existing <out>.fit.jsonl of the same spec and seed (looked up
    // by their exact parameter values). false: start afresh.
    bool resume = true;
    bool progress = true;  // a line per generation on stderr
};

// One evaluation: the trees grown with parameter values x.
struct FitEvaluation {
    std::vector<double> x;
    double objective = 1.0;  // weighted mean of d; 1 when a tree failed
    // KS D per listed distribution, in FitSpec::distributions order; none when the trees had no
    // value of it (counted as 1 in the objective) or a tree failed.
    std::vector<std::optional<double>> d;
    std::string error;  // a tree's BudgetExceeded or SpecError message; "" when all grew
};

// The seeds of a fit's trees: tree i of every evaluation is grown from element i (derived from
// the fit seed alone, so every evaluation grows the same trees but for the parameters).
std::vector<uint64_t> fitTreeSeeds(uint64_t seed, int trees);

// The objective of a fit spec: grows spec.trees trees (in parallel, one TBB task each) with
// the values x and returns their distances to the reference. Deterministic in x.
class FitObjective {
  public:
    explicit FitObjective(const FitSpec& spec);
    ~FitObjective();
    FitEvaluation evaluate(const std::vector<double>& x) const;
    const FitSpec& spec() const;
    // The reference's name and tree count ("trees" of the file, else the most of any table).
    const std::string& referenceName() const;
    size_t referenceTrees() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

struct FitResult {
    std::filesystem::path out, log, report, plot;
    FitEvaluation before, after;  // the file's own values; the best found
    int64_t evaluations = 0;      // made (in the log)
    int64_t reused = 0;           // of them, taken from an existing log
    int generations = 0;
    bool converged = false;
    double seconds = 0;
};

// Runs a fit and writes the fitted species file (atomically, with its provenance comment),
// <out>.fit.jsonl (one line per evaluation, appended as it goes), <out>.fit.md and
// <out>.fit.svg. Throws SpecError / InputError on bad input before writing anything.
FitResult runFit(const std::string& speciesPath, const FitOptions& options);

// The text of the species file with the fitted values written in place of the file's own (each
// number replaced at its source position; comments and layout kept). Exposed for tests.
std::string replaceFittedValues(const std::string& text, const std::vector<FitParameter>& params,
                                const std::vector<double>& values);

// Shortest decimal text that reads back as exactly v (a TOML float: always with '.' or 'e').
std::string roundTripNumber(double v);

}  // namespace sylva
