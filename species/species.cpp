#include "species/species.h"

#include <filesystem>

namespace sylva {

SpeciesFile loadSpecies(const std::string& path) {
    SpeciesFile s;
    s.path = path;
    s.table = std::make_shared<const toml::table>(parseTomlFile(path));
    DrawContext draw;
    draw.draw = false;
    Params p(*s.table, path, "", &draw);
    s.name = p.string("name", std::filesystem::path(path).stem().string());
    if (!isFileSafeName(s.name)) {
        p.fail("name", "expected 1–64 letters, digits, '-' or '_' (it names files), got \"" +
                           s.name + "\"");
    }
    s.method = p.string("method");
    s.description = p.string("description", "");
    return s;
}

std::unique_ptr<GrowthMethod> instantiateSpecies(const SpeciesFile& species, DrawContext& draw,
                                                 const Overrides* overrides) {
    Params p(*species.table, species.path, "", &draw, overrides);
    p.string("name", "");
    p.string("description", "");
    std::string method = p.string("method");
    std::unique_ptr<GrowthMethod> m = makeGrowthMethod(method, p);
    p.finish();
    return m;
}

GrownTree growSpecies(const SpeciesFile& species, uint64_t seed, const Overrides* overrides,
                      bool threaded) {
    DrawContext draw;
    draw.seed = hashCombine(seed, 0x9a7a);  // parameter draws: their own stream
    std::unique_ptr<GrowthMethod> method = instantiateSpecies(species, draw, overrides);
    GrownTree out;
    Rng rng(seed);
    out.tree = method->grow(rng, threaded, out.methodStats);
    out.sampled = std::move(draw.sampled);
    return out;
}

void validateSpecies(const SpeciesFile& species, const Overrides* overrides) {
    DrawContext draw;
    draw.draw = false;
    instantiateSpecies(species, draw, overrides);
}

}  // namespace sylva
