#include "species/spec/growth_method.h"

namespace sylva {

std::unique_ptr<GrowthMethod> makeGrowthMethod(const std::string& name, Params& species) {
    if (name == "iterated-graph") return makeIteratedGraphMethod(species);
    if (name == "space-colonization") return makeSpaceColonizationMethod(species);
    if (name == "grammar") return makeGrammarMethod(species);
    if (name == "canopy") return makeCanopyMethod(species);
    std::string hint;
    if (auto s = closestWord(name, {"iterated-graph", "space-colonization", "grammar", "canopy"})) {
        hint = "; did you mean \"" + *s + "\"?";
    }
    species.fail("method",
                 "unknown growth method \"" + name +
                     "\" (known: \"iterated-graph\", \"space-colonization\", \"grammar\", "
                     "\"canopy\")" +
                     hint);
}

}  // namespace sylva
