#include "species/spec/species.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <mutex>
#include <sstream>

#include "species/geometry/leaves.h"
#include "species/model/form.h"
#include "species/spec/budget_spec.h"
#include "species/spec/form_spec.h"
#include "species/spec/leaves_spec.h"
#include "species/spec/look_spec.h"

namespace sylva {

// A tree with one stem; a conifer (excurrent, with a leader); a shrub; a clump of many culms
// or stems; a palm.
const std::vector<std::string>& speciesHabits() {
    static const std::vector<std::string> habits = {"tree", "conifer", "shrub", "clump", "palm"};
    return habits;
}

namespace {
// `habit`, "" when the file states none.
std::string readHabit(Params& p) {
    if (!p.has("habit")) return p.string("habit", "");
    return p.choice("habit", "", speciesHabits());
}
}  // namespace

struct SpeciesCache {
    struct Entry {
        std::shared_ptr<const GrowthMethod> method;
        LeafOptions leaves;
        FormOptions form;
        BudgetTable budget;
        SeasonPalette season;
    };
    std::mutex mutex;
    std::map<std::string, Entry> entries;  // keyed by the sweep point's overrides, as text
    SpeciesCacheCounts counts;
};

SpeciesCacheCounts speciesCacheCounts(const SpeciesFile& species) {
    if (!species.cache) return {};
    std::lock_guard<std::mutex> lock(species.cache->mutex);
    return species.cache->counts;
}

namespace {
std::string overridesKey(const Overrides* overrides) {
    std::ostringstream key;
    if (overrides) {
        for (const auto& [path, o] : *overrides) key << path << '=' << o.holder << ';';
    }
    return key.str();
}
}  // namespace

SpeciesFile loadSpecies(const std::string& path) {
    SpeciesFile s;
    s.path = path;
    s.cache = std::make_shared<SpeciesCache>();
    s.table = std::make_shared<const toml::table>(parseTomlFile(path));
    DrawContext draw;
    draw.draw = false;
    Params p(*s.table, path, "", &draw);
    s.name = p.string("name", std::filesystem::path(path).stem().string());
    if (!isFileSafeName(s.name)) {
        p.fail("name", "expected 1–64 letters, digits, '-' or '_' (it names files), got \"" +
                           s.name + "\"");
    }
    if (!p.has("method") && s.table->contains("species") && (*s.table)["species"].is_array()) {
        p.fail("method",
               "required string missing: this is a dataset file (it has [[species]]), not a "
               "species file");
    }
    s.method = p.string("method");
    s.description = p.string("description", "");
    s.habit = readHabit(p);
    auto look = p.optionalTable("look");
    s.look = std::make_shared<const Look>(look ? readLook(*look) : Look{});
    return s;
}

SpeciesFile withOwnCache(SpeciesFile species) {
    species.cache = std::make_shared<SpeciesCache>();
    return species;
}

std::unique_ptr<GrowthMethod> instantiateSpecies(const SpeciesFile& species, DrawContext& draw,
                                                 const Overrides* overrides, LeafOptions* leaves,
                                                 FormOptions* form, BudgetTable* budget,
                                                 SeasonPalette* season) {
    Params p(*species.table, species.path, "", &draw, overrides);
    p.documentAs("species");
    p.string("name", "");
    p.string("description", "");
    readHabit(p);
    std::string method = p.string("method");
    std::unique_ptr<GrowthMethod> m;
    {
        DocumentAs methodKeys(p, method);  // the method's keys sit at the top level too
        m = makeGrowthMethod(method, p);
    }
    LeafOptions l = m->placesOwnLeaves() ? LeafOptions{} : readLeaves(p);
    if (leaves) *leaves = l;
    SeasonPalette palette;
    palette.asGrown = true;
    if (!m->hasOwnSeasons()) {
        // The other methods' seasons: the leaves as grown, then kept and coloured by the
        // season's palette (species/model/season.h).
        std::array<SeasonPalette, 4> palettes = grownSeasons();
        const Season chosen = readSeason(p, "season", Season::kSummer);
        readSeasonPalettes(p, palettes, true);
        palette = palettes[static_cast<int>(chosen)];
        // A season that drops leaves makes the leaves' triangle bounds too high: a leaf
        // placed is no longer certainly meshed.
        if (palette.density < 1.0 || (!palette.asGrown && palette.classes.empty())) {
            auto& bounds = m->sizes.bounds;
            bounds.erase(std::remove_if(bounds.begin(), bounds.end(),
                                        [](const SizeBound& b) {
                                            return b.kind == BudgetKind::kTriangles &&
                                                   b.keyPath.rfind("leaves.", 0) == 0;
                                        }),
                         bounds.end());
        }
    }
    if (season) *season = palette;
    const FormOptions f = readForm(p);
    if (form) *form = f;
    BudgetTable b;
    if (auto t = p.optionalTable("budget")) b = readBudget(*t, false);
    if (budget) *budget = b;
    if (auto look = p.optionalTable("look")) readLook(*look);  // checked here; loadSpecies keeps it
    // [fit]: `sylva fit`'s settings (pipeline/analysis/fit.h reads and checks them); a tree
    // never depends on them.
    if (const toml::node* fit = p.raw("fit"); fit && !fit->is_table()) {
        p.fail("fit", "expected a table (the settings of sylva fit)");
    }
    p.finish();
    return m;
}

Budget effectiveBudget(const BudgetTable& species, const BudgetTable* dataset) {
    Budget b;
    species.applyTo(b);
    if (dataset) dataset->applyTo(b);
    return b;
}

void checkSizeBounds(const GrowthMethod& method, const Budget& budget, bool meshed) {
    if (const SizeBound* over = method.sizes.over(budget, meshed)) {
        throw SpecError(over->where, over->keyPath, overBudgetMessage(*over, budget));
    }
}

PreparedTree prepareSpecies(const SpeciesFile& species, uint64_t seed, const Overrides* overrides,
                            const BudgetTable* datasetBudget) {
    std::shared_ptr<const GrowthMethod> method;
    auto leaves = std::make_shared<LeafOptions>();
    auto form = std::make_shared<FormOptions>();
    BudgetTable budget;
    SeasonPalette season;
    PreparedTree p;
    p.seed = seed;
    GrownTree& out = p.out;
    if (species.cache) {
        std::lock_guard<std::mutex> lock(species.cache->mutex);
        auto it = species.cache->entries.find(overridesKey(overrides));
        if (it != species.cache->entries.end()) {
            method = it->second.method;
            *leaves = it->second.leaves;
            *form = it->second.form;
            budget = it->second.budget;
            season = it->second.season;
            ++species.cache->counts.hits;
        } else {
            ++species.cache->counts.misses;
        }
    }
    if (!method) {
        DrawContext draw;
        draw.seed = hashCombine(seed, 0x9a7a);  // parameter draws: their own stream
        method = instantiateSpecies(species, draw, overrides, leaves.get(), form.get(), &budget,
                                    &season);
        out.sampled = std::move(draw.sampled);
        // Nothing drawn: every instance of this sweep point parses to the same method.
        if (out.sampled.empty() && !draw.perInstance && species.cache) {
            std::lock_guard<std::mutex> lock(species.cache->mutex);
            species.cache->entries.emplace(
                overridesKey(overrides),
                SpeciesCache::Entry{method, *leaves, *form, budget, season});
        }
    }
    out.budget = effectiveBudget(budget, datasetBudget);
    // This tree's drawn parameters may already make it too large (validation saw the centres).
    if (const SizeBound* over = method->sizes.over(out.budget, false)) {
        throw BudgetExceeded(over->keyPath + ": " + overBudgetMessage(*over, out.budget));
    }
    p.method = std::move(method);
    p.leaves = std::move(leaves);
    p.form = std::move(form);
    p.season = std::move(season);
    return p;
}

GrownTree finishSpecies(PreparedTree& prepared, Tree tree, const GrowthGuard& guard) {
    GrownTree out = std::move(prepared.out);
    const uint64_t seed = prepared.seed;
    out.tree = std::move(tree);
    guard.skeletonNodes(static_cast<int64_t>(out.tree.nodes.size()));
    // Before leaves: they sit on the result.
    applyForm(out.tree, *prepared.form, Rng(seed).derive("form"));
    if (out.tree.leaves.empty()) {
        Rng leafRng = Rng(seed).derive("leaves");  // its own stream: leaves never move branches
        placeLeaves(out.tree, *prepared.leaves, leafRng, guard);
    }
    applySeason(out.tree, prepared.season, Rng(seed).derive("season"));
    guard.leaves(static_cast<int64_t>(out.tree.leaves.size()));
    guard.time();
    return out;
}

GrownTree growSpecies(const SpeciesFile& species, uint64_t seed, const Overrides* overrides,
                      bool threaded, const BudgetTable* datasetBudget) {
    PreparedTree prepared = prepareSpecies(species, seed, overrides, datasetBudget);
    const GrowthGuard guard(prepared.out.budget);
    Rng rng(seed);
    Tree tree = prepared.method->grow(rng, threaded, prepared.out.methodStats, guard);
    return finishSpecies(prepared, std::move(tree), guard);
}

Budget validateSpecies(const SpeciesFile& species, const Overrides* overrides,
                       const BudgetTable* datasetBudget, bool meshed) {
    DrawContext draw;
    draw.draw = false;
    BudgetTable table;
    const std::unique_ptr<GrowthMethod> method =
        instantiateSpecies(species, draw, overrides, nullptr, nullptr, &table);
    const Budget budget = effectiveBudget(table, datasetBudget);
    checkSizeBounds(*method, budget, meshed);
    return budget;
}

}  // namespace sylva
