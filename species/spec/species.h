// A species file: name, method, crown volume and the method's parameters. It is parsed once
// into a TOML table; per instance the table is read again with that instance's draw state
// (distributions drawn, sweep overrides applied) into the method's plain options.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/params.h"
#include "species/model/look.h"
#include "species/model/season.h"
#include "species/model/tree.h"
#include "species/spec/growth_method.h"

namespace sylva {

struct SpeciesCache;

struct SpeciesFile {
    std::string path;         // as given (used in error messages)
    std::string name;         // `name`, or the file stem
    std::string method;       // `method`
    std::string description;  // `description`
    std::string habit;        // `habit`: "tree", "conifer", "shrub", "clump", "palm" or ""
    std::shared_ptr<const toml::table> table;
    // `[look]`: how its trees look in colour (the defaults when the file has none).
    std::shared_ptr<const Look> look;
    // Parsed methods of species without distributions, per sweep point: the same for every
    // instance, so a crown level set or a CSG measure is built once, not once per tree.
    std::shared_ptr<SpeciesCache> cache;
};

// The habits a species file may state in `habit`.
const std::vector<std::string>& speciesHabits();

// Reads and checks the file's top-level keys. Throws SpecError.
SpeciesFile loadSpecies(const std::string& path);

// The same species with an empty cache of its own: a caller that grows it under ever new
// overrides (`sylva fit`, one set per evaluation) drops the parsed methods it will not need
// again with the copy, instead of keeping one per override set in the shared cache.
SpeciesFile withOwnCache(SpeciesFile species);

struct GrownTree {
    Tree tree;
    Budget budget;  // the tree's budgets (defaults, the species' [budget], the dataset's)
    std::map<std::string, double> methodStats;  // method-specific counters
    std::map<std::string, double> sampled;      // parameter path -> value drawn for this tree
};

// The method for one instance: distributions drawn from `seed` (or, with draw = false, their
// centres, for validation), `overrides` applied. Every key is checked. Throws SpecError.
// `budget`: the species' [budget] table. `season`: the palette of the species' `season` (as
// grown for a method that has seasons of its own, the grammar's).
struct LeafOptions;
struct FormOptions;
std::unique_ptr<GrowthMethod> instantiateSpecies(const SpeciesFile& species, DrawContext& draw,
                                                 const Overrides* overrides,
                                                 LeafOptions* leaves = nullptr,
                                                 FormOptions* form = nullptr,
                                                 BudgetTable* budget = nullptr,
                                                 SeasonPalette* season = nullptr);

// How often growSpecies took a species' method from its cache (hits: a species without
// distributions, per sweep point) or parsed it (misses).
struct SpeciesCacheCounts {
    int64_t hits = 0;
    int64_t misses = 0;
};
SpeciesCacheCounts speciesCacheCounts(const SpeciesFile& species);

// Grows one tree of the species with the given instance seed, within its budgets: the
// defaults, then the species' [budget], then `datasetBudget` (a dataset's [budget]). A tree
// whose drawn parameters certainly exceed a budget, or that exceeds one while it grows (or
// outgrows max_growth_seconds), throws BudgetExceeded.
GrownTree growSpecies(const SpeciesFile& species, uint64_t seed, const Overrides* overrides,
                      bool threaded, const BudgetTable* datasetBudget = nullptr);

// growSpecies in steps, for trees that grow among others (species/plot/plot_growth.h):
// prepareSpecies draws the instance's method and budget exactly as growSpecies does; the
// caller grows the tree from Rng(seed) (alone: prepared.method->grow, as growSpecies; or with
// its neighbours); finishSpecies applies the form and the leaves to it, as growSpecies does.
struct PreparedTree {
    std::shared_ptr<const GrowthMethod> method;
    std::shared_ptr<const LeafOptions> leaves;
    std::shared_ptr<const FormOptions> form;
    SeasonPalette season;  // applied after the leaves (as grown: nothing changes)
    uint64_t seed = 0;
    GrownTree out;  // budget and sampled parameters so far (methodStats: the grower's)
};
PreparedTree prepareSpecies(const SpeciesFile& species, uint64_t seed, const Overrides* overrides,
                            const BudgetTable* datasetBudget = nullptr);
GrownTree finishSpecies(PreparedTree& prepared, Tree tree, const GrowthGuard& guard);

// The budgets of a species' trees: the defaults, then the species' [budget] table (as
// instantiateSpecies returns it), then a dataset's.
Budget effectiveBudget(const BudgetTable& species, const BudgetTable* dataset = nullptr);
// A SpecError at the key that dominates the first size bound of `method` over `budget` (the
// triangle bounds only when `meshed`).
void checkSizeBounds(const GrowthMethod& method, const Budget& budget, bool meshed);

// Checks every key and value of the species (with overrides) without growing, and that its
// parameters do not certainly exceed a budget (SpecError at the key that dominates; the
// triangle budget only when `meshed`: a dataset that makes meshes or views). Returns the
// budgets its trees are held to.
Budget validateSpecies(const SpeciesFile& species, const Overrides* overrides,
                       const BudgetTable* datasetBudget = nullptr, bool meshed = false);

}  // namespace sylva
