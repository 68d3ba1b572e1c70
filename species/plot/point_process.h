// Spatial point processes for stem positions, and the statistics that check them.
#pragma once

#include <cstdint>
#include <vector>

#include "core/math.h"
#include "core/rng.h"
#include "species/plot/plot.h"

namespace sylva {

// Every process below draws from the Rng it is given and nothing else (the caller derives it
// with a stable key, so the same seed gives the same points on any thread count). Points are
// (x, z) in plot-local metres as Vec2(x, z), inside the area.

// A uniform point in the area (a circle by rejection from its bounding square).
Vec2 uniformInArea(const PlotArea& area, Rng& rng);

// A Poisson-distributed count with this mean (≥ 0), exactly: Knuth's product of uniforms over
// pieces of mean ≤ 16 (the sum of independent Poisson counts is Poisson), about mean + 1
// uniforms per draw — plots have at most 10⁵ stems.
int64_t poissonCount(double mean, Rng& rng);

// Poisson (binomial) process with exactly n points: each uniform in the area, independent.
std::vector<Vec2> poissonPoints(int64_t n, const PlotArea& area, Rng& rng);

// The largest coverage n·π·d²/4 / area a hard-core pattern with spacing d may ask for. Random
// sequential adsorption of disks (diameter d) jams at a coverage of about 0.547 (Feder 1980;
// Hinrichsen, Feder & Jøssang 1986); near it each placed point costs ever more darts, so sylva
// refuses counts above 0.40 (where about 1 dart in 50 still lands) at the spec.
constexpr double kMaxHardCoreCoverage = 0.40;
// The most points of spacing d the area takes under that bound.
int64_t hardCoreCapacity(double minSpacing, const PlotArea& area);

// Matérn (1960/1986) hard-core process as simple sequential inhibition (Diggle 1983): darts
// uniform in the area, each kept when no kept point is closer than minSpacing, until n are kept
// (a grid of cells of the spacing makes each dart O(1)). After 2000·n + 10⁵ darts without
// finishing it starts over on a derived stream, at most 8 times, then throws
// std::runtime_error (at most the coverage bound above it does not happen in practice).
std::vector<Vec2> hardCorePoints(int64_t n, double minSpacing, const PlotArea& area, Rng& rng);

// Strauss (1975) process with exactly n points, interaction radius r and γ ∈ [0, 1]: density ∝
// γ^(pairs closer than r). Metropolis–Hastings (Geyer & Møller 1994, fixed n): from a Poisson
// pattern, kStraussSweeps · n moves, each a uniformly chosen point proposed at a uniform place
// and accepted with probability min(1, γ^(s' − s)), s and s' its neighbours within r before
// and after. γ = 1 is Poisson, γ = 0 a hard core.
constexpr int kStraussSweeps = 100;
std::vector<Vec2> straussPoints(int64_t n, double r, double gamma, const PlotArea& area, Rng& rng);

// Thomas (1949) cluster process with exactly n points: parents Poisson at parentDensity per
// hectare over the area grown by 4σ on every side (at least one parent), each point a
// uniformly chosen parent plus an isotropic Gaussian offset of sd σ, redrawn (parent and offset)
// until it falls inside the area (after 1000 tries: uniform in the area).
std::vector<Vec2> thomasPoints(int64_t n, double parentDensityPerHa, double sigma,
                               const PlotArea& area, Rng& rng);

// Rows: the lattice of row_spacing × stem_spacing through the plot centre, turned so rows run
// along rowAzimuthRad (0° along −z, 90° along +x); the places inside the area, row by row.
std::vector<Vec2> rowSites(const PointProcessOptions& options, const PlotArea& area);
// The lattice places rowSites examines (those in the square of the area's half-diagonal), a
// bound on its work: the spec reader refuses more than kMaxRowLattice.
double rowLatticeSize(const PointProcessOptions& options, const PlotArea& area);
constexpr double kMaxRowLattice = 4e6;
// n of the row places (all when n equals their number; otherwise a uniform random subset, kept
// in row order: missing trees), each moved by an isotropic Gaussian of sd `jitter` (redrawn
// up to 16 times to stay inside the area, else not moved). Throws std::invalid_argument when
// n is more than the places.
std::vector<Vec2> rowPoints(int64_t n, const PointProcessOptions& options, const PlotArea& area,
                            Rng& rng);

// n points of `options`' process (Poisson: binomial with exactly n).
std::vector<Vec2> drawPoints(int64_t n, const PointProcessOptions& options, const PlotArea& area,
                             Rng& rng);

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
