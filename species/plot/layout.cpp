#include "species/plot/layout.h"

#include <cmath>
#include <string>
#include <vector>

#include "core/rng.h"
#include "species/plot/point_process.h"
#include "species/plot/terrain.h"

namespace sylva {

uint64_t plotTreeSeed(uint64_t plotSeed, int32_t id) {
    return hashCombine(hashCombine(plotSeed, hashString("tree")), static_cast<uint64_t>(id));
}

namespace {

int64_t stemCount(const PlotSpecies& s, const PlotArea& area, bool poisson, Rng rng) {
    if (s.count >= 0) return s.count;
    const double mean = s.density * area.area() * 1e-4;
    return poisson ? poissonCount(mean, rng) : static_cast<int64_t>(std::llround(mean));
}

// A stem's draw of a species' per-stem number (`holder`["v"], the species' `key`), from the
// stem's seed; each key its own stream (keyed by the key path, as every draw). 0 when absent.
double drawPerStem(const PlotSpecies& s, bool present, const toml::table& holder, const char* key,
                   const Range& range, uint64_t seed) {
    if (!present) return 0.0;
    DrawContext draw;
    draw.seed = seed;
    draw.draw = true;
    Params p(holder, s.where.file, s.keyPath + "." + key, &draw);
    return p.number("v", range);
}

// Ground cover ([plot.ground_cover]): a Poisson count of density × area cards, each at a
// uniform place in the plot, a blade of grass or forb leaning 20–70° from vertical towards a
// uniform azimuth (so both an airborne and a terrestrial scanner see it), its length uniform in
// [height / 2, height] and its width `width`, its base on the terrain.
std::vector<Leaf> groundCover(const PlotSpec& spec, const Terrain& terrain, Rng rng) {
    std::vector<Leaf> cards;
    const GroundCoverOptions& g = spec.groundCover;
    if (!(g.density > 0)) return cards;
    const int64_t n = poissonCount(g.density * spec.area.area(), rng);
    const std::vector<Vec2> at = poissonPoints(n, spec.area, rng);
    cards.reserve(at.size());
    for (const Vec2& p : at) {
        const double lean = rng.uniform(20.0, 70.0) * kPi / 180;
        const double azimuth = rng.uniform(0.0, 2 * kPi);
        const double length = rng.uniform(0.5, 1.0) * g.height;
        const Vec3 towards{std::cos(azimuth), 0, std::sin(azimuth)};
        Leaf card;
        card.tangent = normalize(Vec3{0, std::cos(lean), 0} + towards * std::sin(lean));
        card.normal = normalize(cross(Vec3{-towards.z, 0, towards.x}, card.tangent));
        card.size = length;
        card.aspect = g.width / length;
        card.shape = LeafShape::kCard;
        card.position = Vec3{p.x, terrain.height(p.x, p.y), p.y} + card.tangent * (length / 2);
        cards.push_back(card);
    }
    return cards;
}

}  // namespace

PlotLayout layoutPlot(const PlotSpec& spec, uint64_t plotSeed) {
    PlotLayout layout;
    layout.terrain = makeTerrain(spec.terrain, spec.area, spec.margin, plotSeed);
    const Rng root(plotSeed);
    const bool poisson = spec.process.kind == PointProcessOptions::Kind::kPoisson;

    auto addStem = [&](int32_t species, const Vec2& p) {
        PlotStem stem;
        stem.id = static_cast<int32_t>(layout.stems.size()) + 1;
        stem.species = species;
        stem.base = Vec3(p.x, layout.terrain.height(p.x, p.y), p.y);
        stem.seed = plotTreeSeed(plotSeed, stem.id);
        const PlotSpecies& s = spec.species[size_t(species)];
        stem.targetHeight =
            drawPerStem(s, s.hasHeight, s.height, "height", Range::leftOpen(0, 200), stem.seed);
        stem.slenderness = drawPerStem(s, s.hasSlenderness, s.slenderness, "slenderness",
                                       Range::closed(10, 300), stem.seed);
        layout.stems.push_back(stem);
    };

    // Canopy: one pattern for all canopy species, the species shuffled onto its points.
    std::vector<int32_t> labels;
    for (size_t k = 0; k < spec.species.size(); ++k) {
        if (spec.species[k].understory) continue;
        const int64_t n = stemCount(spec.species[k], spec.area, poisson,
                                    root.derive("canopy/count/" + std::to_string(k)));
        labels.insert(labels.end(), static_cast<size_t>(n), static_cast<int32_t>(k));
    }
    Rng pointRng = root.derive("canopy/points");
    const std::vector<Vec2> points =
        drawPoints(static_cast<int64_t>(labels.size()), spec.process, spec.area, pointRng);
    Rng shuffle = root.derive("canopy/species");
    for (size_t k = labels.size(); k > 1; --k) {
        std::swap(labels[k - 1], labels[static_cast<size_t>(shuffle.below(k))]);
    }
    layout.stems.reserve(labels.size());
    for (size_t k = 0; k < labels.size(); ++k) addStem(labels[k], points[k]);

    // Understory: each species its own Poisson process.
    for (size_t k = 0; k < spec.species.size(); ++k) {
        if (!spec.species[k].understory) continue;
        const std::string key = "understory/" + std::to_string(k);
        const int64_t n = stemCount(spec.species[k], spec.area, true, root.derive(key + "/count"));
        Rng rng = root.derive(key + "/points");
        for (const Vec2& p : poissonPoints(n, spec.area, rng)) {
            addStem(static_cast<int32_t>(k), p);
        }
    }
    layout.groundCover = groundCover(spec, layout.terrain, root.derive("ground-cover"));
    return layout;
}

}  // namespace sylva
