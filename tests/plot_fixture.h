// Hand-made forest plots for the tests of plot outputs (inventory, scene meshes, views, the
// plot writer), built without the layout and growth stages: trees are hand-built skeletons or
// library species grown alone, stood at their bases on a Terrain made directly.
#pragma once

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "species/plot/plot.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace sylva::test {

// A tilted plane y = sx·x + sz·z over [−half, half]² (1 m cells).
inline Terrain planeTerrain(double half, double sx, double sz) {
    const int n = static_cast<int>(2 * half) + 1;
    std::vector<float> h(static_cast<size_t>(n) * n);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            h[size_t(j) * n + i] = static_cast<float>(sx * (i - half) + sz * (j - half));
    return Terrain(-half, -half, 1.0, n, n, std::move(h));
}

// A small hand-built tree with its base at the origin: a trunk of `height` metres in 0.5 m
// steps tapering from `radius` to a third of it, four first-order branches of `crown` metres
// (azimuths `turn` + 0°, 90°, 180°, 270°) from 0.55·height up, each with three leaf cards, and
// a taproot 0.7 m down.
inline Tree handTree(double height, double radius, double crown, double turn) {
    Tree t;
    const int steps = std::max(2, static_cast<int>(std::round(height / 0.5)));
    int32_t prev = addNode(t, -1, {0, 0, 0}, radius, 0);
    std::vector<int32_t> trunk{prev};
    addNode(t, 0, {0.1, -0.7, 0.05}, 0.6 * radius, 0, kRootPart);  // a taproot under the ground
    for (int k = 1; k <= steps; ++k) {
        const double y = height * k / steps;
        prev = addNode(t, prev, {0, y, 0}, radius * (1.0 - 0.667 * k / steps), 0);
        trunk.push_back(prev);
    }
    for (int b = 0; b < 4; ++b) {
        const double a = turn + b * kPi / 2;
        const int32_t at = trunk[static_cast<size_t>(std::round((0.55 + 0.1 * b) * steps))];
        const Vec3 from = t.nodes[at].position;
        const Vec3 dir{std::sin(a), 0.35, -std::cos(a)};
        int32_t p = at;
        for (int s = 1; s <= 3; ++s) {
            p = addNode(t, p, from + dir * (crown * s / 3.0), 0.25 * radius * (1.2 - 0.3 * s), 1);
            Leaf leaf;
            leaf.position = t.nodes[p].position + Vec3{0, 0.1, 0};
            leaf.normal = normalize(Vec3{0.2, 1, 0.1});
            leaf.tangent = normalize(cross(leaf.normal, Vec3{0, 0, 1}));
            leaf.size = 0.45;
            leaf.aspect = 0.6;
            leaf.node = p;
            t.leaves.push_back(leaf);
        }
    }
    return t;
}

// The tree moved by `offset` (nodes and leaves).
inline Tree moved(Tree t, const Vec3& offset) {
    for (SkeletonNode& n : t.nodes) n.position = n.position + offset;
    for (Leaf& l : t.leaves) l.position = l.position + offset;
    return t;
}

// A plot of hand-built trees at the given (x, z) positions on a gentle slope, with a few
// ground-cover cards. `spec` must outlive the plot (its area: width × depth).
inline GrownPlot handPlot(PlotSpec& spec, const std::vector<Vec2>& xz, double width = 20,
                          double depth = 20) {
    spec.name = "hand";
    spec.area.width = width;
    spec.area.depth = depth;
    GrownPlot plot;
    plot.spec = &spec;
    plot.seed = 0x1234;
    plot.layout.terrain = planeTerrain(0.5 * std::max(width, depth) + 4, 0.08, -0.05);
    for (size_t k = 0; k < xz.size(); ++k) {
        PlotStem stem;
        stem.id = static_cast<int32_t>(k + 1);
        stem.species = static_cast<int32_t>(k % 2);
        stem.base = {xz[k].x, plot.layout.terrain.height(xz[k].x, xz[k].y), xz[k].y};
        PlotTree tree;
        tree.stem = stem;
        tree.grown.tree =
            moved(handTree(5.0 + k % 3, 0.12 + 0.02 * (k % 2), 2.0, 0.4 * k), stem.base);
        plot.trees.push_back(std::move(tree));
        plot.layout.stems.push_back(stem);
    }
    for (int g = 0; g < 6; ++g) {
        Leaf card;
        const double x = -0.5 * width + 2 + 3 * g, z = 0.3 * depth - g;
        card.position = {x, plot.layout.terrain.height(x, z) + 0.15, z};
        card.normal = {0, 0, 1};
        card.tangent = {0, 1, 0};
        card.size = 0.3;
        card.aspect = 0.5;
        plot.groundCover.push_back(card);
    }
    return plot;
}

// A plot of library species grown alone (growSpecies, seeds 1, 2, …), stood at `xz` on a gentle
// slope: species[k % species.size()] for tree k. The species files must outlive the plot.
inline GrownPlot presetPlot(PlotSpec& spec, const std::vector<std::string>& species,
                            const std::vector<Vec2>& xz, double width, double depth) {
    spec.name = "presets";
    spec.area.width = width;
    spec.area.depth = depth;
    spec.species.clear();
    for (const std::string& name : species) {
        PlotSpecies s;
        s.species =
            loadSpecies(std::string(SYLVA_SOURCE_DIR) + "/species/presets/" + name + ".toml");
        spec.species.push_back(std::move(s));
    }
    GrownPlot plot;
    plot.spec = &spec;
    plot.seed = 0xabcd;
    plot.layout.terrain = planeTerrain(0.5 * std::max(width, depth) + 8, 0.05, 0.03);
    for (size_t k = 0; k < xz.size(); ++k) {
        PlotStem stem;
        stem.id = static_cast<int32_t>(k + 1);
        stem.species = static_cast<int32_t>(k % species.size());
        stem.base = {xz[k].x, plot.layout.terrain.height(xz[k].x, xz[k].y), xz[k].y};
        stem.seed = 1 + k;
        PlotTree tree;
        tree.stem = stem;
        tree.grown = growSpecies(spec.species[stem.species].species, stem.seed, nullptr, true);
        tree.grown.tree = moved(std::move(tree.grown.tree), stem.base);
        plot.trees.push_back(std::move(tree));
        plot.layout.stems.push_back(stem);
    }
    return plot;
}

}  // namespace sylva::test
