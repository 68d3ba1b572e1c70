// Spatial point processes for stem positions, and the statistics that check them.
#pragma once

#include <vector>

#include "core/math.h"
#include "species/plot/plot.h"

namespace sylva {

// Clark & Evans (1954) aggregation index R = mean nearest-neighbour distance / its expectation
// under complete spatial randomness, 0.5 / √λ (λ = n / area), with Donnelly's (1978) edge
// correction of the expectation for a rectangle (0.5 / √λ + (0.0514 + 0.041 / √n) · P / n,
// P the perimeter; for a circle its circumference). R ≈ 1 for a Poisson pattern, < 1
// clustered, > 1 regular (at most 2.1491, a hexagonal lattice). NaN for fewer than 2 points.
// Points are (x, z) in plot-local metres.
double clarkEvans(const std::vector<Vec2>& points, const PlotArea& area);

// Nearest-neighbour distance of every point (metres); +∞ for a lone point. O(n log n) with a
// uniform grid.
std::vector<double> nearestNeighbourDistances(const std::vector<Vec2>& points);

}  // namespace sylva
