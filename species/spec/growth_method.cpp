#include "species/spec/growth_method.h"

#include <set>

namespace sylva {

namespace {

// Every growth method, by the name a species file gives in `method` (after pbrt-v4's
// Create functions). Adding a method is its files in species/methods/ and one line here.
struct MethodEntry {
    const char* name;
    std::unique_ptr<GrowthMethod> (*make)(Params& species);
};
constexpr MethodEntry kMethods[] = {
    {"iterated-graph", makeIteratedGraphMethod},          // Xu & Mould 2012
    {"space-colonization", makeSpaceColonizationMethod},  // Runions 2007, Liu 2020
    {"grammar", makeGrammarMethod},                       // Jain et al. 2021
    {"canopy", makeCanopyMethod},                         // Shesh et al.
};

}  // namespace

std::vector<std::string> growthMethodNames() {
    std::vector<std::string> names;
    for (const MethodEntry& m : kMethods) names.emplace_back(m.name);
    return names;
}

std::unique_ptr<GrowthMethod> makeGrowthMethod(const std::string& name, Params& species) {
    for (const MethodEntry& m : kMethods) {
        if (name == m.name) return m.make(species);
    }
    std::string known;
    for (const MethodEntry& m : kMethods) {
        known += std::string(known.empty() ? "" : ", ") + "\"" + m.name + "\"";
    }
    std::string hint;
    const std::vector<std::string> names = growthMethodNames();
    if (auto s = closestWord(name, std::set<std::string>(names.begin(), names.end()))) {
        hint = "; did you mean \"" + *s + "\"?";
    }
    species.fail("method", "unknown growth method \"" + name + "\" (known: " + known + ")" + hint);
}

}  // namespace sylva
