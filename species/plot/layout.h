// One plot instance's layout: its terrain and the stems standing on it (where, which species,
// how tall, with what seed), drawn from the plot's seed alone.
#pragma once

#include <cstdint>

#include "species/plot/plot.h"

namespace sylva {

// The layout of one instance of `spec` (plotSeed: the instance's seed).
//  - terrain: makeTerrain(spec.terrain, spec.area, spec.margin, plotSeed);
//  - canopy stems: each canopy species' count (its `count`, or for a density: a Poisson count
//    of mean density × area under the poisson process, round(density × area) under the
//    others), their total drawn together by spec.process, the species assigned to the points by
//    a keyed shuffle of the species labels;
//  - understory stems: each understory species by its own Poisson process (count as above);
//  - every stem: base = (x, terrain height there, z); id 1 … N in order (canopy first);
//    seed = hash(plot seed, "tree", id); targetHeight drawn from its species' `height` with
//    the stem's seed (0: as grown).
//  - ground cover: a Poisson count of density × area cards at uniform places, each leaning
//    20–70° towards a uniform azimuth, its base on the terrain (layout.cpp groundCover).
// Streams (derived from plotSeed by these keys, so nothing depends on thread count or on the
// other streams' use): "terrain/noise", "canopy/count/<k>", "canopy/points",
// "canopy/species", "understory/<k>/count", "understory/<k>/points", "ground-cover".
PlotLayout layoutPlot(const PlotSpec& spec, uint64_t plotSeed);

// The seed of tree `id` of a plot instance.
uint64_t plotTreeSeed(uint64_t plotSeed, int32_t id);

}  // namespace sylva
