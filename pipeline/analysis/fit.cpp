#include "pipeline/analysis/fit.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/atomic_file.h"
#include "core/budget.h"
#include "core/input_file.h"
#include "core/rng.h"
#include "pipeline/analysis/cmaes_module.h"
#include "pipeline/analysis/dataset_stats.h"
#include "species/model/reference_metrics.h"
#include "species/model/tree_stats.h"
#include "species/spec/species.h"

namespace fs = std::filesystem;

namespace sylva {

namespace {

// The distributions a fit compares when [fit] lists none: every one a broadleaf tree is held
// to but order-3 branch lengths (docs/metrics.md), plus the radius exponent — the reference's
// radius ratio … order-2 branch length.
const std::vector<std::string> kDefaultDistributions(kReferenceDistributionNames.begin() +
                                                         kRadiusRatio,
                                                     kReferenceDistributionNames.begin() +
                                                         kBranchLengthOrder2 + 1);

int distributionIndex(const std::string& name) {
    for (int k = 0; k < kReferenceDistributions; ++k) {
        if (name == kReferenceDistributionNames[k]) return k;
    }
    return -1;
}

// The override that sets the fitted values x on the species: a number for a plain key, the
// whole distribution table (the other element kept) for a distribution element, the whole array
// (the other elements kept) for an element of an array of numbers.
Overrides makeOverrides(const FitSpec& spec, const toml::table& table,
                        const std::vector<double>& x) {
    Overrides ov;
    for (size_t i = 0; i < spec.parameters.size(); ++i) {
        const FitParameter& p = spec.parameters[i];
        Override& o = ov[p.overrideKey];
        o.where = p.where;
        if (p.element < 0) {
            if (p.integer) {
                o.holder.insert_or_assign("v", static_cast<int64_t>(std::llround(x[i])));
            } else {
                o.holder.insert_or_assign("v", x[i]);
            }
            continue;
        }
        if (p.arrayElement) {
            if (!o.holder.contains("v")) {
                o.holder.insert_or_assign("v", *table.at_path(p.overrideKey).as_array());
            }
            toml::array& array = *o.holder.get_as<toml::array>("v");
            array.replace(array.cbegin() + p.element, x[i]);
            continue;
        }
        if (!o.holder.contains("v")) {
            o.holder.insert_or_assign("v", *table.at_path(p.overrideKey).as_table());
        }
        toml::table& dist = *o.holder.get_as<toml::table>("v");
        auto [kind, node] = *dist.begin();
        const toml::array& old = *node.as_array();
        toml::array fresh;
        for (size_t e = 0; e < old.size(); ++e) {
            if (static_cast<int>(e) == p.element) {
                fresh.push_back(x[i]);
            } else {
                fresh.push_back(old.get(e)->value<double>().value_or(0.0));
            }
        }
        const std::string k(kind.str());
        dist.insert_or_assign(k, std::move(fresh));
    }
    return ov;
}

// The values x written as the species file would hold them (integers rounded).
std::vector<double> asWritten(const FitSpec& spec, std::vector<double> x) {
    for (size_t i = 0; i < x.size(); ++i) {
        if (spec.parameters[i].integer) x[i] = std::round(x[i]);
    }
    return x;
}

std::string num4(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4f", v);
    return buf;
}

std::string optNum4(const std::optional<double>& v) { return v ? num4(*v) : "-"; }

}  // namespace

QuantileTable allometryTable(const fs::path& file, const std::string& species,
                             const std::string& distribution) {
    constexpr uint64_t kMaxAllometryBytes = uint64_t(16) << 20;
    const nlohmann::json j = nlohmann::json::parse(
        readInputFile(file, kMaxAllometryBytes, "allometry file"), nullptr, false);
    auto fail = [&](const std::string& what) { throw InputError(file.string() + ": " + what); };
    if (j.is_discarded() || !j.is_object()) fail("not a JSON object");
    const auto all = j.find("species");
    if (all == j.end() || !all->is_object()) fail("no \"species\" object");
    const auto entry = all->find(species);
    if (entry == all->end() || !entry->is_object())
        fail("no entry for species \"" + species + "\"");
    for (const char* level : {"species", "genus"}) {
        const auto block = entry->find(level);
        if (block == entry->end() || !block->is_object()) continue;
        const auto d = block->find(distribution);
        if (d == block->end()) continue;
        QuantileTable t;
        t.p = {0, 0.05, 0.25, 0.5, 0.75, 0.95, 1};
        for (const char* k : {"min", "p5", "p25", "p50", "p75", "p95", "max"}) {
            const auto v = d->is_object() ? d->find(k) : d->end();
            if (v == d->end() || !v->is_number() || !std::isfinite(v->get<double>())) {
                fail("\"" + species + "\" " + level + " " + distribution +
                     ": expected a number \"" + k + "\"");
            }
            t.q.push_back(v->get<double>());
            if (t.q.size() > 1 && t.q.back() < t.q[t.q.size() - 2]) {
                fail("\"" + species + "\" " + level + " " + distribution +
                     ": quantiles decrease at \"" + k + "\"");
            }
        }
        return t;
    }
    throw InputError(file.string() + ": \"" + species + "\" has no " + distribution +
                     " (neither its species nor its genus)");
}

int cmaesPopulation(size_t dimension) {
    const int lambda =
        4 + static_cast<int>(std::floor(3.0 * std::log(static_cast<double>(dimension))));
    return std::max(5, lambda);
}

// --- the [fit] table --------------------------------------------------------------------------

FitSpec readFitSpec(const std::string& speciesPath, KeyLog* keyLog,
                    const std::optional<fs::path>& referenceOverride) {
    const SpeciesFile species = loadSpecies(speciesPath);
    FitSpec spec;
    spec.speciesPath = speciesPath;
    spec.speciesName = species.name;
    DrawContext draw;
    draw.draw = false;
    draw.keyLog = keyLog;
    Params top(*species.table, speciesPath, "", &draw);
    top.documentAs("species");
    if (!top.has("fit")) {
        top.failHere(
            "expected a [fit] table (the reference, the parameters and their bounds; "
            "docs/fit.md)");
    }
    Params f = top.table("fit");
    if (referenceOverride) {
        f.string("reference", "");
        spec.reference = *referenceOverride;
    } else {
        spec.reference = f.filePath("reference");
    }
    spec.trees = static_cast<int>(f.integer("trees", spec.trees, Range::closed(4, 100000)));
    spec.evaluations = f.integer("evaluations", spec.evaluations, Range::closed(1, 1e8));
    spec.seed = static_cast<uint64_t>(f.integer("seed", 1, Range::closed(0, 9.2e18)));

    spec.distributionsWhere = f.where("distributions");
    if (f.has("distributions")) {
        spec.distributions = f.stringArray("distributions");
        if (spec.distributions.empty()) {
            f.fail("distributions", "expected at least one distribution name");
        }
        std::set<std::string> known, seen;
        for (const char* k : kReferenceDistributionNames) known.insert(k);
        for (const std::string& k : kAllometryDistributions) known.insert(k);
        for (const std::string& d : spec.distributions) {
            if (!known.count(d)) {
                std::string hint;
                if (auto w = closestWord(d, known)) hint = "; did you mean \"" + *w + "\"?";
                std::string list;
                for (const char* k : kReferenceDistributionNames) {
                    list += (list.empty() ? "" : ", ") + std::string(k);
                }
                for (const std::string& k : kAllometryDistributions) list += ", " + k;
                f.fail("distributions",
                       "unknown distribution \"" + d + "\"" + hint + " (known: " + list + ")");
            }
            if (!seen.insert(d).second) {
                f.fail("distributions", "\"" + d + "\" is listed twice");
            }
        }
    } else {
        spec.distributions = kDefaultDistributions;
    }
    if (f.has("allometry")) spec.allometry = f.filePath("allometry");
    for (const std::string& d : spec.distributions) {
        const bool allometric =
            std::find(kAllometryDistributions.begin(), kAllometryDistributions.end(), d) !=
            kAllometryDistributions.end();
        if (!allometric) continue;
        if (spec.allometry.empty()) {
            f.fail("distributions", "\"" + d +
                                        "\" comes from an allometry file: set `allometry` (e.g. "
                                        "\"../reference/baad-allometry.json\")");
        }
        try {
            allometryTable(spec.allometry, spec.speciesName, d);
        } catch (const InputError& e) {
            f.fail("allometry", e.what());
        }
    }
    spec.weights.assign(spec.distributions.size(), 1.0);
    if (const toml::node* w = f.raw("weights")) {
        const toml::array* a = w->as_array();
        if (!a || a->size() != spec.distributions.size()) {
            f.fail("weights", "expected an array of " + std::to_string(spec.distributions.size()) +
                                  " numbers, one per distribution");
        }
        double sum = 0;
        for (size_t i = 0; i < a->size(); ++i) {
            const std::optional<double> v = a->get(i)->value<double>();
            if (!v || !std::isfinite(*v) || *v < 0 || *v > kMaxSpecMagnitude) {
                f.fail("weights", "expected numbers ≥ 0 (at most 1e9), one per distribution");
            }
            spec.weights[i] = *v;
            sum += *v;
        }
        if (!(sum > 0)) f.fail("weights", "expected at least one weight > 0");
    }

    std::vector<Params> entries = f.tableArray("parameter");
    if (entries.empty()) {
        f.fail("parameter", "expected at least one [[fit.parameter]] with a path and bounds");
    }
    static const std::regex kElement(R"(^(.+)\.(normal|uniform)\[([01])\]$)");
    static const std::regex kArrayElement(R"(^(.+)\[([0-9]{1,3})\]$)");
    std::set<std::string> paths;
    for (Params& e : entries) {
        FitParameter p;
        p.path = e.string("path");
        p.where = e.where("path");
        if (!e.has("bounds")) e.fail("bounds", "required [lo, hi] missing");
        const auto [lo, hi] = e.interval("bounds", {0.0, 0.0}, Range::any());
        if (!(lo < hi)) e.fail("bounds", "expected lo < hi in [lo, hi]");
        p.lo = lo;
        p.hi = hi;
        e.finish();
        if (!paths.insert(p.path).second) e.fail("path", "\"" + p.path + "\" is fitted twice");

        const toml::node* node = species.table->at_path(p.path).node();
        if (!node) {
            e.fail("path", "\"" + p.path + "\" is not set in " + speciesPath +
                               " (a fitted value must be written in the species file)");
        }
        std::smatch m;
        if (std::regex_match(p.path, m, kElement)) {
            const toml::table* dist = species.table->at_path(m[1].str()).as_table();
            if (!dist || dist->size() != 1) {
                e.fail("path", "\"" + m[1].str() + "\" is not a distribution");
            }
            p.overrideKey = m[1].str();
            p.element = std::stoi(m[3].str());
        } else if (std::regex_match(p.path, m, kArrayElement)) {
            // An element of an array of numbers (a grammar's `tilt_deg = [40, 55]`).
            const toml::array* array = species.table->at_path(m[1].str()).as_array();
            if (!array || array->empty() ||
                !std::all_of(array->begin(), array->end(),
                             [](const toml::node& n) { return n.is_number(); })) {
                e.fail("path", "\"" + m[1].str() + "\" is not an array of numbers");
            }
            p.overrideKey = m[1].str();
            p.element = std::stoi(m[2].str());
            p.arrayElement = true;
        } else {
            p.overrideKey = p.path;
        }
        if (node->is_table()) {
            e.fail("path", "\"" + p.path + "\" is a distribution; fit one of its numbers (\"" +
                               p.path + ".normal[0]\", \"" + p.path + ".uniform[1]\", …)");
        }
        if (!node->is_number()) {
            e.fail("path", "\"" + p.path + "\" is not a number in " + speciesPath);
        }
        p.initial = *node->value<double>();
        const toml::source_region& src = node->source();
        p.value = {speciesPath, static_cast<int>(src.begin.line),
                   static_cast<int>(src.begin.column)};
        if (p.initial < p.lo || p.initial > p.hi) {
            e.fail("bounds", "the file's value " + formatNumber(p.initial) + " of \"" + p.path +
                                 "\" lies outside the bounds");
        }
        spec.parameters.push_back(std::move(p));
    }
    f.finish();

    const int population = cmaesPopulation(spec.parameters.size());
    if (spec.evaluations < 2 * population) {
        f.fail("evaluations", "expected at least " + std::to_string(2 * population) +
                                  " (two CMA-ES populations of " + std::to_string(population) +
                                  " for " + std::to_string(spec.parameters.size()) +
                                  " parameters)");
    }

    // An integer in the file may be a real-valued key written without a decimal point
    // (`branch_angle_deg = 35`) or an integer key (`nodes = 300`): the species reader tells,
    // refusing the value as a float only for the latter.
    for (FitParameter& p : spec.parameters) {
        const toml::node* node = species.table->at_path(p.path).node();
        if (p.element >= 0 || !node->is_integer()) continue;
        Overrides probe;
        probe[p.overrideKey].holder.insert_or_assign("v", p.initial);
        probe[p.overrideKey].where = p.where;
        try {
            validateSpecies(species, &probe);
        } catch (const SpecError& err) {
            p.integer = std::string(err.what()).find("expected an integer") != std::string::npos;
            if (!p.integer) throw;
        }
    }
    // Every fitted key is one the species reads, and the species is valid at both ends of
    // every bound (an error there is at the parameter's path).
    std::vector<double> x;
    for (const FitParameter& p : spec.parameters) x.push_back(p.initial);
    for (int corner = 0; corner < 3; ++corner) {
        std::vector<double> at = x;
        for (size_t i = 0; i < at.size() && corner > 0; ++i) {
            at[i] = corner == 1 ? spec.parameters[i].lo : spec.parameters[i].hi;
        }
        const Overrides ov = makeOverrides(spec, *species.table, at);
        validateSpecies(species, &ov);
        for (const auto& [key, o] : ov) {
            if (!o.used) {
                throw SpecError(
                    o.where, "fit.parameter.path",
                    "\"" + key + "\" is not a parameter species \"" + species.name + "\" reads");
            }
        }
    }
    return spec;
}

// --- the optimiser ----------------------------------------------------------------------------

CmaesResult minimiseCmaes(const std::function<double(const std::vector<double>&)>& f,
                          const std::vector<double>& lo, const std::vector<double>& hi,
                          const CmaesOptions& options,
                          const std::function<void(const CmaesGeneration&)>& onGeneration) {
    const size_t dim = lo.size();
    if (dim == 0 || hi.size() != dim) throw std::invalid_argument("cmaes: empty or uneven box");
    for (size_t i = 0; i < dim; ++i) {
        if (!(lo[i] < hi[i])) throw std::invalid_argument("cmaes: bounds with lo >= hi");
    }
    const int lambda = cmaesPopulation(dim);
    if (options.evaluations < 2 * lambda) {
        throw std::invalid_argument("cmaes: a budget of " + std::to_string(options.evaluations) +
                                    " evaluations is below two populations of " +
                                    std::to_string(lambda));
    }
    const unsigned seed32 = static_cast<unsigned>(hashCombine(options.seed, hashString("cmaes")));
    Rng initial = Rng(options.seed).derive("cmaes-initial-population");
    std::vector<std::vector<double>> population(lambda, std::vector<double>(dim));
    for (int i = 0; i < lambda; ++i) {
        for (size_t j = 0; j < dim; ++j) {
            population[i][j] = (i == 0 && options.x0.size() == dim)
                                   ? std::clamp(options.x0[j], lo[j], hi[j])
                                   : initial.uniform(lo[j], hi[j]);
        }
    }
    CmaesResult r;
    int generation = 0;
    auto step = [&](int64_t made, const std::vector<double>& x, double fx) {
        r.evaluations += made;
        if (r.bestX.empty() || fx < r.best) {
            r.best = fx;
            r.bestX = x;
        }
        CmaesGeneration g;
        g.generation = generation++;
        g.evaluations = r.evaluations;
        g.best = r.best;
        g.bestX = r.bestX;
        r.generations.push_back(g);
        if (onGeneration) onGeneration(g);
    };
    const int64_t generations = (options.evaluations - lambda) / lambda;
    r.converged =
        cmaesModule().run(f, lo, hi, population, options.sigma0, seed32, generations, step);
    return r;
}

// --- the objective ----------------------------------------------------------------------------

struct FitObjective::Impl {
    FitSpec spec;
    SpeciesFile species;
    Reference reference;
    std::vector<QuantileTable> allometry;      // the allometry distributions' tables
    std::vector<const QuantileTable*> tables;  // per listed distribution
    std::vector<int> kinds;                    // their ReferenceDistribution, or −1 − (index in
                             // kAllometryDistributions) for an allometry distribution
    std::vector<uint64_t> seeds;  // the trees' seeds (common random numbers)
};

// One tree's value of an allometry distribution (kAllometryDistributions[index]); none when the
// tree has no crown or no height.
static std::optional<double> allometryValue(const Tree& tree, size_t index) {
    const TreeStats s = computeStats(tree);
    const double v =
        index == 0 ? s.crownHeight / s.height : 0.5 * (s.crownWidthMajor + s.crownDepth) / s.height;
    if (!std::isfinite(v)) return std::nullopt;
    return v;
}

FitObjective::FitObjective(const FitSpec& spec) : impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    m.spec = spec;
    m.species = loadSpecies(spec.speciesPath);
    m.reference = readReference(spec.reference);
    m.allometry.reserve(spec.distributions.size());  // (pointers into it are kept)
    for (const std::string& d : spec.distributions) {
        const auto a = std::find(kAllometryDistributions.begin(), kAllometryDistributions.end(), d);
        if (a != kAllometryDistributions.end()) {
            m.allometry.push_back(allometryTable(spec.allometry, spec.speciesName, d));
            m.tables.push_back(&m.allometry.back());
            m.kinds.push_back(-1 - static_cast<int>(a - kAllometryDistributions.begin()));
            continue;
        }
        auto it = m.reference.distributions.find(d);
        if (it == m.reference.distributions.end()) {
            throw SpecError(
                spec.distributionsWhere, "fit.distributions",
                "\"" + d + "\" is not in the reference file " + spec.reference.string());
        }
        m.tables.push_back(&it->second.table);
        m.kinds.push_back(distributionIndex(d));
    }
    m.seeds = fitTreeSeeds(spec.seed, spec.trees);
}

std::vector<uint64_t> fitTreeSeeds(uint64_t seed, int trees) {
    const Rng base = Rng(seed).derive("fit-trees");
    std::vector<uint64_t> seeds;
    for (int i = 0; i < trees; ++i) seeds.push_back(base.derive(static_cast<uint64_t>(i)).seed());
    return seeds;
}

FitObjective::~FitObjective() = default;

const FitSpec& FitObjective::spec() const { return impl_->spec; }
const std::string& FitObjective::referenceName() const { return impl_->reference.name; }
size_t FitObjective::referenceTrees() const {
    if (impl_->reference.trees) return impl_->reference.trees;
    size_t most = 0;
    for (const auto& [name, d] : impl_->reference.distributions) most = std::max(most, d.trees);
    return most;
}

FitEvaluation FitObjective::evaluate(const std::vector<double>& x) const {
    const Impl& m = *impl_;
    FitEvaluation e;
    e.x = x;
    e.d.assign(m.spec.distributions.size(), std::nullopt);
    const Overrides ov = makeOverrides(m.spec, *m.species.table, x);
    // A cache of its own: these overrides are never asked for again.
    const SpeciesFile species = withOwnCache(m.species);
    const size_t n = m.seeds.size();
    std::vector<ReferenceValues> values(n);
    std::vector<std::array<std::optional<double>, 2>> allometric(n);
    const bool anyAllometry = !m.allometry.empty();
    std::vector<std::string> errors(n);
    tbb::parallel_for(size_t(0), n, [&](size_t i) {
        try {
            const GrownTree g = growSpecies(species, m.seeds[i], &ov, false);
            values[i] = skeletonReferenceValues(g.tree);
            if (anyAllometry) {
                for (size_t a = 0; a < kAllometryDistributions.size(); ++a) {
                    allometric[i][a] = allometryValue(g.tree, a);
                }
            }
        } catch (const BudgetExceeded& err) {
            errors[i] = err.what();
        } catch (const SpecError& err) {
            errors[i] = err.what();
        }
    });
    for (size_t i = 0; i < n; ++i) {
        if (!errors[i].empty()) {
            e.error = "tree " + std::to_string(i) + ": " + errors[i];
            e.objective = 1.0;
            return e;
        }
    }
    ReferenceValues pool;
    for (const ReferenceValues& v : values) poolReferenceValues(pool, v);
    double sum = 0, weights = 0;
    for (size_t k = 0; k < m.tables.size(); ++k) {
        if (m.kinds[k] < 0) {  // an allometry distribution: one value per tree
            const auto a = static_cast<size_t>(-1 - m.kinds[k]);
            std::vector<double> v;
            for (const auto& tree : allometric) {
                if (tree[a]) v.push_back(*tree[a]);
            }
            e.d[k] = referenceDistance(std::move(v), *m.tables[k]);
        } else {
            e.d[k] = referenceDistance(pool[m.kinds[k]], *m.tables[k]);
        }
        sum += m.spec.weights[k] * e.d[k].value_or(1.0);
        weights += m.spec.weights[k];
    }
    e.objective = sum / weights;
    return e;
}

// --- the fitted file ----------------------------------------------------------------------

std::string roundTripNumber(double v) {
    char buf[64];
    // Plain decimals where they are short (20.0, 0.56, 2.6125), else the shortest %g.
    if (std::fabs(v) >= 1e-4 && std::fabs(v) < 1e15) {
        for (int d = 0; d <= 17; ++d) {
            std::snprintf(buf, sizeof buf, "%.*f", d, v);
            if (std::strtod(buf, nullptr) == v) {
                std::string s = buf;
                return s.find('.') == std::string::npos ? s + ".0" : s;
            }
        }
    }
    for (int p = 1; p <= 17; ++p) {
        std::snprintf(buf, sizeof buf, "%.*g", p, v);
        if (std::strtod(buf, nullptr) == v) break;
    }
    std::string s = buf;
    if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
    return s;
}

std::string replaceFittedValues(const std::string& text, const std::vector<FitParameter>& params,
                                const std::vector<double>& values) {
    // Byte offsets of the lines' starts.
    std::vector<size_t> lineStart = {0};
    for (size_t i = 0; i < text.size(); ++i) {
        if (text[i] == '\n') lineStart.push_back(i + 1);
    }
    struct Edit {
        size_t begin, end;
        std::string with;
    };
    std::vector<Edit> edits;
    for (size_t i = 0; i < params.size(); ++i) {
        const FitParameter& p = params[i];
        if (p.value.line < 1 || static_cast<size_t>(p.value.line) > lineStart.size()) {
            throw std::invalid_argument("fit: no line " + std::to_string(p.value.line));
        }
        // toml++ counts columns in code points.
        size_t at = lineStart[p.value.line - 1];
        for (int c = 1; c < p.value.column && at < text.size(); ++c) {
            ++at;
            while (at < text.size() && (static_cast<unsigned char>(text[at]) & 0xC0) == 0x80) ++at;
        }
        size_t end = at;
        while (end < text.size() &&
               (std::isalnum(static_cast<unsigned char>(text[end])) ||
                std::string_view("+-._").find(text[end]) != std::string_view::npos)) {
            ++end;
        }
        if (end == at) throw std::invalid_argument("fit: no number at " + p.value.str());
        const std::string with =
            p.integer ? std::to_string(std::llround(values[i])) : roundTripNumber(values[i]);
        edits.push_back({at, end, with});
    }
    std::sort(edits.begin(), edits.end(),
              [](const Edit& a, const Edit& b) { return a.begin > b.begin; });
    std::string out = text;
    for (const Edit& e : edits) out.replace(e.begin, e.end - e.begin, e.with);
    return out;
}

namespace {

const char* kProvenanceBegin = "# --- sylva fit ";
const char* kProvenanceEnd = "# --- end of sylva fit ---";

// The species file's text without a provenance block a previous fit put at its top.
std::string withoutProvenance(const std::string& text) {
    if (text.rfind(kProvenanceBegin, 0) != 0) return text;
    const size_t end = text.find(std::string(kProvenanceEnd) + "\n");
    if (end == std::string::npos) return text;
    return text.substr(end + std::string(kProvenanceEnd).size() + 1);
}

// --- the evaluation log -----------------------------------------------------------------------

nlohmann::ordered_json evaluationJson(const FitSpec& spec, int64_t index, const FitEvaluation& e) {
    nlohmann::ordered_json j;
    j["evaluation"] = index;
    nlohmann::ordered_json x = nlohmann::ordered_json::object();
    for (size_t i = 0; i < spec.parameters.size(); ++i) x[spec.parameters[i].path] = e.x[i];
    j["x"] = x;
    j["objective"] = e.objective;
    nlohmann::ordered_json d = nlohmann::ordered_json::object();
    for (size_t k = 0; k < spec.distributions.size(); ++k) {
        d[spec.distributions[k]] = e.d[k] ? nlohmann::ordered_json(*e.d[k]) : nullptr;
    }
    j["d"] = d;
    if (!e.error.empty()) j["error"] = e.error;
    return j;
}

// An evaluation read back from a log line (nlohmann writes doubles so that they read back
// exactly); none when the line is not one of this spec's.
std::optional<FitEvaluation> parseEvaluation(const FitSpec& spec, const std::string& line) {
    const nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("x") || !j.contains("objective") ||
        !j.contains("d")) {
        return std::nullopt;
    }
    FitEvaluation e;
    try {
        for (const FitParameter& p : spec.parameters)
            e.x.push_back(j["x"].at(p.path).get<double>());
        e.objective = j["objective"].get<double>();
        for (const std::string& name : spec.distributions) {
            const nlohmann::json& d = j["d"].at(name);
            e.d.push_back(d.is_null() ? std::nullopt : std::optional<double>(d.get<double>()));
        }
        if (j.contains("error")) e.error = j["error"].get<std::string>();
    } catch (const nlohmann::json::exception&) {
        return std::nullopt;
    }
    return e;
}

// The log's first line: what an evaluation's value depends on (the species and reference
// files' bytes, the trees and their seed, the parameters fitted, the distributions and their
// weights). A log with another first line is not reused.
std::string logHeader(const FitSpec& spec, const FitObjective& objective) {
    uint64_t h = hashString(fileBytes(spec.speciesPath));
    h = hashCombine(h, hashString(fileBytes(spec.reference.string())));
    if (!spec.allometry.empty()) h = hashCombine(h, hashString(fileBytes(spec.allometry.string())));
    char hex[20];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
    nlohmann::ordered_json j;
    j["sylva_fit"] = 1;
    j["species"] = spec.speciesName;
    j["files"] = hex;
    j["reference"] = objective.referenceName();
    j["seed"] = spec.seed;
    j["trees"] = spec.trees;
    nlohmann::ordered_json params = nlohmann::ordered_json::array();
    for (const FitParameter& p : spec.parameters) params.push_back(p.path);
    j["parameters"] = params;
    j["distributions"] = spec.distributions;
    j["weights"] = spec.weights;
    return j.dump();
}

// --- the report ---------------------------------------------------------------------------

std::string parameterLine(const FitSpec& spec, const std::vector<double>& before,
                          const std::vector<double>& after) {
    std::string s;
    for (size_t i = 0; i < spec.parameters.size(); ++i) {
        const FitParameter& p = spec.parameters[i];
        s += "#   " + p.path + ": " + roundTripNumber(before[i]) + " -> " +
             (p.integer ? std::to_string(std::llround(after[i])) : roundTripNumber(after[i])) +
             "  (bounds [" + roundTripNumber(p.lo) + ", " + roundTripNumber(p.hi) + "])\n";
    }
    return s;
}

std::string objectiveWords(const FitSpec& spec) {
    std::string s;
    for (size_t k = 0; k < spec.distributions.size(); ++k) {
        s += (k ? ", " : "") + spec.distributions[k] + " (" + formatNumber(spec.weights[k]) + ")";
    }
    return s;
}

std::string provenance(const FitSpec& spec, const FitObjective& objective, const FitResult& r) {
    std::ostringstream o;
    o << kProvenanceBegin << "---\n";
    o << "# Fitted by `sylva fit` (pagmo2 CMA-ES) from "
      << fs::path(spec.speciesPath).filename().string() << ": " << r.evaluations
      << " evaluations of " << spec.trees << " trees each, seed " << spec.seed << ", "
      << r.generations << " generations" << (r.converged ? " (converged)" : "") << ".\n";
    o << "# Reference: " << spec.reference.filename().string() << " (\""
      << objective.referenceName() << "\", " << objective.referenceTrees() << " measured trees).\n";
    if (!spec.allometry.empty()) {
        o << "# Allometry: " << spec.allometry.filename().string() << " (species \""
          << spec.speciesName << "\"; crown ratios, one value per tree).\n";
    }
    o << "# Objective: weighted mean of the KS distance D (as sylva stats --reference) of the "
         "trees'\n#   pooled values to the reference, over "
      << objectiveWords(spec)
      << ";\n#   a distribution without values counts 1, a tree that "
         "fails makes the objective 1.\n";
    o << "# Parameters (the file's value -> fitted):\n"
      << parameterLine(spec, r.before.x, r.after.x);
    o << "# D            before   after\n";
    for (size_t k = 0; k < spec.distributions.size(); ++k) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "#   %-22s %7s %7s\n", spec.distributions[k].c_str(),
                      optNum4(r.before.d[k]).c_str(), optNum4(r.after.d[k]).c_str());
        o << buf;
    }
    o << "#   objective              " << num4(r.before.objective) << "  "
      << num4(r.after.objective) << "\n";
    o << kProvenanceEnd << "\n";
    return o.str();
}

// A small line plot of the best objective against evaluations (SVG, deterministic text).
std::string convergenceSvg(const std::vector<CmaesGeneration>& gens, double worst) {
    const double W = 480, H = 240, L = 56, R = 12, T = 16, B = 40;
    double maxE = 1, lo = 1e300, hi = -1e300;
    for (const CmaesGeneration& g : gens) {
        maxE = std::max(maxE, static_cast<double>(g.evaluations));
        lo = std::min(lo, g.best);
        hi = std::max(hi, g.best);
    }
    hi = std::max(hi, worst);
    if (!(hi > lo)) hi = lo + 0.01;
    const double pad = 0.05 * (hi - lo);
    lo -= pad;
    hi += pad;
    auto px = [&](double e) { return L + (W - L - R) * e / maxE; };
    auto py = [&](double v) { return T + (H - T - B) * (hi - v) / (hi - lo); };
    char buf[256];
    std::ostringstream o;
    std::snprintf(buf, sizeof buf,
                  "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
                  "viewBox=\"0 0 %.0f %.0f\" font-family=\"sans-serif\" font-size=\"11\">\n",
                  W, H, W, H);
    o << buf << "<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n";
    std::snprintf(buf, sizeof buf,
                  "<path d=\"M%.1f %.1fV%.1fH%.1f\" fill=\"none\" stroke=\"#444\"/>\n", L, T, H - B,
                  W - R);
    o << buf;
    for (int t = 0; t <= 4; ++t) {
        const double v = lo + (hi - lo) * t / 4;
        std::snprintf(buf, sizeof buf,
                      "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\">%.3f</text>\n", L - 4,
                      py(v) + 4, v);
        o << buf;
        const double e = maxE * t / 4;
        std::snprintf(buf, sizeof buf,
                      "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">%.0f</text>\n", px(e),
                      H - B + 14, e);
        o << buf;
    }
    std::snprintf(buf, sizeof buf,
                  "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">evaluations</text>\n",
                  (L + W - R) / 2, H - 6);
    o << buf;
    std::snprintf(buf, sizeof buf,
                  "<text x=\"12\" y=\"%.1f\" transform=\"rotate(-90 12 %.1f)\" "
                  "text-anchor=\"middle\">best objective</text>\n",
                  (T + H - B) / 2, (T + H - B) / 2);
    o << buf;
    o << "<polyline fill=\"none\" stroke=\"#1b6e3a\" stroke-width=\"2\" points=\"";
    for (size_t i = 0; i < gens.size(); ++i) {
        std::snprintf(buf, sizeof buf, "%s%.1f,%.1f", i ? " " : "",
                      px(static_cast<double>(gens[i].evaluations)), py(gens[i].best));
        o << buf;
    }
    o << "\"/>\n</svg>\n";
    return o.str();
}

std::string reportMarkdown(const FitSpec& spec, const FitObjective& objective, const FitResult& r,
                           const std::vector<CmaesGeneration>& gens,
                           const std::map<int64_t, FitEvaluation>& bestByGeneration) {
    std::ostringstream o;
    o << "# sylva fit: " << spec.speciesName << "\n\n";
    o << "Species file `" << fs::path(spec.speciesPath).filename().string() << "`, reference `"
      << spec.reference.filename().string() << "` (\"" << objective.referenceName() << "\", "
      << objective.referenceTrees() << " measured trees)"
      << (spec.allometry.empty() ? std::string()
                                 : ", allometry `" + spec.allometry.filename().string() + "`")
      << ", " << spec.trees << " trees per evaluation, seed " << spec.seed << ", " << r.evaluations
      << " evaluations in " << r.generations << " generations"
      << (r.converged ? " (CMA-ES converged before the budget)" : "") << ".\n\n";
    o << "Objective: the weighted mean of KS D over " << objectiveWords(spec)
      << "; a distribution without values counts 1, a tree that fails makes it 1.\n\n";
    o << "## Before and after\n\n| | before (the file) | after (fitted) |\n|---|---:|---:|\n";
    for (size_t i = 0; i < spec.parameters.size(); ++i) {
        o << "| `" << spec.parameters[i].path << "` | " << roundTripNumber(r.before.x[i]) << " | "
          << roundTripNumber(asWritten(spec, r.after.x)[i]) << " |\n";
    }
    for (size_t k = 0; k < spec.distributions.size(); ++k) {
        o << "| D " << spec.distributions[k] << " | " << optNum4(r.before.d[k]) << " | "
          << optNum4(r.after.d[k]) << " |\n";
    }
    o << "| **objective** | " << num4(r.before.objective) << " | " << num4(r.after.objective)
      << " |\n\n";
    o << "## Convergence\n\n![best objective against evaluations](" << r.plot.filename().string()
      << ")\n\n";
    o << "| generation | evaluations | best objective |";
    for (const std::string& d : spec.distributions) o << " " << d << " |";
    o << "\n|---:|---:|---:|";
    for (size_t k = 0; k < spec.distributions.size(); ++k) o << "---:|";
    o << "\n";
    for (const CmaesGeneration& g : gens) {
        const FitEvaluation& best = bestByGeneration.at(g.generation);
        o << "| " << g.generation << " | " << g.evaluations << " | " << num4(g.best) << " |";
        for (size_t k = 0; k < spec.distributions.size(); ++k)
            o << " " << optNum4(best.d[k]) << " |";
        o << "\n";
    }
    return o.str();
}

}  // namespace

// --- the command --------------------------------------------------------------------------

FitResult runFit(const std::string& speciesPath, const FitOptions& options) {
    const auto start = std::chrono::steady_clock::now();
    if (options.reference) {
        std::error_code ec;
        if (!fs::is_regular_file(*options.reference, ec)) {
            throw InputError("--reference: file not found: " + options.reference->string());
        }
    }
    FitSpec spec = readFitSpec(speciesPath, nullptr, options.reference);
    if (options.seed) spec.seed = *options.seed;
    if (options.evaluations) {
        const int population = cmaesPopulation(spec.parameters.size());
        if (*options.evaluations < 2 * population) {
            throw InputError("--evaluations: expected at least " + std::to_string(2 * population) +
                             " (two CMA-ES populations of " + std::to_string(population) +
                             "), got " + std::to_string(*options.evaluations));
        }
        spec.evaluations = *options.evaluations;
    }
    const FitObjective objective(spec);  // reads the reference: bad input throws here
    cmaesModule();  // a missing optimiser fails here, before any file is written

    FitResult r;
    r.out =
        options.out.empty() ? fs::path("out") / "fit" / (spec.speciesName + ".toml") : options.out;
    r.log = r.out.string() + ".fit.jsonl";
    r.report = r.out.string() + ".fit.md";
    r.plot = r.out.string() + ".fit.svg";
    const std::string originalText = fileBytes(speciesPath);

    // The log: reuse the evaluations of a log of the same spec and seed.
    const std::string header = logHeader(spec, objective);
    std::vector<std::string> logged;  // the log's evaluation lines
    // Evaluations by their exact parameter values, and whether they came from the log.
    std::map<std::vector<double>, std::pair<FitEvaluation, bool>> known;
    std::error_code ec;
    if (options.resume && fs::exists(r.log, ec)) {
        std::vector<std::string> lines = AppendLog::readCompleteLines(r.log);
        if (!lines.empty() && lines[0] == header) {
            for (size_t i = 1; i < lines.size(); ++i) {
                std::optional<FitEvaluation> e = parseEvaluation(spec, lines[i]);
                if (!e) break;
                known.emplace(e->x, std::make_pair(*e, true));
                logged.push_back(lines[i]);
            }
        } else if (options.progress) {
            std::fprintf(stderr, "sylva: fit: %s is of another spec or seed; starting afresh\n",
                         r.log.string().c_str());
        }
    }
    // The log as it will be (its reused prefix), then appended to line by line.
    auto rewriteLog = [&](size_t keep) {
        std::string text = header + "\n";
        for (size_t i = 0; i < keep; ++i) text += logged[i] + "\n";
        writeFileAtomic(r.log, text);
        logged.resize(keep);
    };
    if (logged.empty()) rewriteLog(0);
    auto appender = std::make_unique<AppendLog>(r.log);

    std::vector<FitEvaluation> evaluations;
    int64_t computed = 0;
    std::function<double(const std::vector<double>&)> f = [&](const std::vector<double>& x) {
        const int64_t index = static_cast<int64_t>(evaluations.size());
        FitEvaluation e;
        auto it = known.find(x);
        if (it != known.end()) {
            e = it->second.first;
            r.reused += it->second.second;
        } else {
            e = objective.evaluate(x);
            ++computed;
            known.emplace(x, std::make_pair(e, false));  // a candidate clipped to a bound again
        }
        const std::string line = evaluationJson(spec, index, e).dump();
        if (static_cast<size_t>(index) < logged.size()) {
            if (logged[index] != line) {  // the log went another way from here: cut it
                appender.reset();
                rewriteLog(static_cast<size_t>(index));
                appender = std::make_unique<AppendLog>(r.log);
                appender->append(line);
                logged.push_back(line);
            }
        } else {
            appender->append(line);
            logged.push_back(line);
        }
        evaluations.push_back(std::move(e));
        return evaluations.back().objective;
    };

    std::vector<double> lo, hi, x0;
    for (const FitParameter& p : spec.parameters) {
        lo.push_back(p.lo);
        hi.push_back(p.hi);
        x0.push_back(p.initial);
    }
    CmaesOptions co;
    co.evaluations = spec.evaluations;
    co.seed = spec.seed;
    co.x0 = x0;
    // The best evaluation after each generation (the first of the lowest objective).
    std::map<int64_t, FitEvaluation> bestByGeneration;
    size_t bestIndex = 0;
    size_t scanned = 0;
    const int64_t totalGenerations =
        (spec.evaluations - cmaesPopulation(lo.size())) / cmaesPopulation(lo.size());
    auto onGeneration = [&](const CmaesGeneration& g) {
        for (; scanned < evaluations.size(); ++scanned) {
            if (evaluations[scanned].objective < evaluations[bestIndex].objective) {
                bestIndex = scanned;
            }
        }
        bestByGeneration[g.generation] = evaluations[bestIndex];
        if (!options.progress) return;
        const auto now = std::chrono::steady_clock::now();
        const double s = std::chrono::duration<double>(now - start).count();
        std::fprintf(stderr,
                     "sylva: fit: %s: generation %d/%lld, %lld evaluations (%lld from the log), "
                     "best %.4f, %.2f evaluations/s\n",
                     spec.speciesName.c_str(), g.generation,
                     static_cast<long long>(totalGenerations),
                     static_cast<long long>(g.evaluations), static_cast<long long>(r.reused),
                     g.best, s > 0 ? static_cast<double>(computed) / s : 0.0);
    };
    const CmaesResult cr = minimiseCmaes(f, lo, hi, co, onGeneration);
    if (logged.size() > evaluations.size()) {  // a longer run's log: keep what this run made
        appender.reset();
        rewriteLog(evaluations.size());
    }
    appender.reset();

    r.evaluations = static_cast<int64_t>(evaluations.size());
    r.generations = static_cast<int>(cr.generations.size()) - 1;
    r.converged = cr.converged;
    r.before = evaluations.front();  // the file's own values: the first individual
    r.after = evaluations[bestIndex];
    r.after.x = asWritten(spec, r.after.x);

    // The fitted file: the provenance block, then the file's text (without the block of an
    // earlier fit, whose lines shift the parameters' positions) with the values replaced.
    const std::string body = withoutProvenance(originalText);
    const int shift = static_cast<int>(std::count(originalText.begin(), originalText.end(), '\n') -
                                       std::count(body.begin(), body.end(), '\n'));
    std::vector<FitParameter> at = spec.parameters;
    for (FitParameter& p : at) p.value.line -= shift;
    writeFileAtomic(r.out,
                    provenance(spec, objective, r) + replaceFittedValues(body, at, r.after.x));
    writeFileAtomic(r.report, reportMarkdown(spec, objective, r, cr.generations, bestByGeneration));
    writeFileAtomic(r.plot, convergenceSvg(cr.generations, r.before.objective));
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return r;
}

}  // namespace sylva
