// Shape metrics of a tree skeleton: Horton–Strahler orders, bifurcation ratios, fork angles,
// the radius exponent at forks, tortuosity, crown shape and leaf area (definitions in
// docs/metrics.md).
#pragma once

#include <vector>

#include "species/model/tree.h"
#include "species/model/tree_stats.h"

namespace sylva {

// Fills the shape metrics of s (strahlerOrder .. leafArea) from the tree; computeStats calls
// it.
void addShapeMetrics(const Tree& tree, TreeStats& s);

// The n in [0.5, 6] with parentRadius^n = sum childRadii^n, by bisection; NaN unless
// parentRadius > 0, at least two children and 0 < child < parentRadius for every child. Roots
// outside the interval are clamped to its ends.
double radiusExponent(double parentRadius, const std::vector<double>& childRadii);

// Quantile q in [0, 1] of the values with linear interpolation between order statistics
// (numpy's default); NaN for no values. Sorts a copy.
double quantile(std::vector<double> values, double q);

}  // namespace sylva
