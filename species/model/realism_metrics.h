// Measures of how plausible a tree is as a real one (issue 13's realism gates; definitions in
// docs/metrics.md): growth below the ground, stems leaving the base, the lean of the leader,
// and how far leaves are from the wood that should carry them.
#pragma once

#include <vector>

#include "species/model/tree.h"
#include "species/model/tree_stats.h"

namespace sylva {

// Fills s.lowestShootY, s.belowGroundFraction, s.stemsAtBase, s.leaderLeanDeg and
// s.leafWoodDistanceP95 (NaN where undefined); computeStats calls it.
void addRealismMetrics(const Tree& tree, TreeStats& s);

// Distance (metres, ≥ 0) from each point to the nearest wood surface of the tree: the tapered
// capsules of its segments (radius linear along each segment, spheres at the nodes); 0 inside
// the wood. Every segment counts, shoot and root. Empty tree: +infinity. `near` (optional, one
// per point) names a node near each point (a leaf's carrier; −1 or 0: none): its segment's
// distance bounds the search, which makes it faster and changes no result.
std::vector<double> woodDistances(const Tree& tree, const std::vector<Vec3>& points,
                                  const std::vector<int32_t>& near = {});

}  // namespace sylva
