// Growing a plot's trees together (issue 16, part B): every stem of a layout grown by its
// species' method in a shared environment, placed at its base on the terrain, scaled to its
// drawn height, its leaves scaled to the plot's leaf area index; and the statistics that show
// the neighbours shaped the crowns. docs/plots.md, "Growing together".
//
// Frame: plot-local metres, +y up (plot.h).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/budget.h"
#include "species/plot/plot.h"

namespace sylva {

// The bounds of the one factor that scales a species' (or the plot's) leaves to reach an LAI
// target: a target needing leaves scaled beyond them is refused (SpecError at its `lai`).
constexpr double kMinLeafScale = 0.25;
constexpr double kMaxLeafScale = 4.0;
// The least share of a species' grown leaf area an LAI target may keep by thinning: a target
// below it is refused (SpecError at its `lai`).
constexpr double kMinLeavesKept = 0.01;

// Close neighbours: trees whose bases are nearer than this many times the sum of their crown
// radii shape each other (clip planes, tropism).
constexpr double kNeighbourReach = 1.25;
// The grammar method's light/shade tropism at full strength (a neighbour crown touching this
// one): the length of the horizontal vector added to each branch's unit horizontal direction
// (half of it to the trunk's unit direction; GrammarOptions::lightTropism).
constexpr double kShadeTropism = 0.2;
// How far above the lower of two crowns' predicted tops their crown-shyness plane still holds,
// a fraction of the shorter tree's height (its leaves stand above its highest node).
constexpr double kShyAbove = 0.05;
// How many times grammar trees are grown again with their neighbours' tops as grown (a tree
// among neighbours may grow taller than alone, and its planes must hold up to its real top).
constexpr int kShyRegrowths = 3;

// Grows every stem of `layout` (PlotStem::species indexes spec.species) and places it: the
// root node at the stem's base on the terrain, the tree vertical, scaled uniformly about its
// base so its height (highest shoot node above the root) is targetHeight when that is > 0 —
// node radii and leaf sizes with it (a grammar tree grown within shyness bounds keeps the
// scale they were set at instead, and may be shorter). With spec.neighbours (the default)
// the trees know their neighbours, and every crown keeps a crown-shyness gap: between each
// close pair a vertical plane, the distance between the stems shared in proportion to their
// predicted crown radii, each side moved back by half the gap — crown_shyness (the larger of
// the two species') × the larger of the two crowns' radii toward each other (each its share,
// at most its radius) — and never past half its share:
//  - space colonization: the plot's space-colonization trees compete for one shared marker
//    set per group of trees linked through close neighbours (growSpaceColonizationTogether;
//    Palubicki et al. 2009), each grown at its target scale (internode, bole, crown), then
//    brought back to the species' scale for its form and leaves like any tree of it; its
//    markers are drawn, and its buds perceive, only on its side of its planes up to the
//    lower crown's top (ShyBound; ColonizingTree::territory), and the placed tree is cut at
//    them;
//  - iterated graph and canopy: the crown volume is clipped at the planes (at every height);
//  - grammar: a light/shade tropism away from the neighbours' crowns, the sum over close
//    neighbours of the unit vectors from them weighted by crown radius / distance
//    (GrammarOptions::lightTropism), and its branches stop at (or, rising, grow up along) the
//    planes up to the lower crown's top (GrammarOptions::shyBounds).
// Without neighbours each tree grows alone, exactly as growSpecies grows it. Then the LAI
// (spec.lai, per-species lai), per species: a target below the grown leaf area thins the
// leaves — each kept or dropped by a draw keyed by the tree's seed and the leaf's index, the
// lower leaves of a crown (the shaded ones) dropped first, so the expected kept area is the
// target — and then every kept leaf of the species is scaled (size about its attachment, so
// its area by factor²) by one factor so that the leaf area over the plot area is the target;
// a target above it only scales. PlotTree::leafScale, PlotTree::leavesGrown and
// GrownPlot::lai are set. Throws SpecError (at the `lai` key) for a target that keeps less
// than kMinLeavesKept of the grown area, needs leaves scaled outside [kMinLeafScale,
// kMaxLeafScale], or species that have no leaves; BudgetExceeded from a tree's budgets.
// Growth runs in parallel (TBB) when `threaded`; the result is identical either way. The whole
// plot has the dataset's max_plot_seconds (core/budget.h), checked before each tree's steps:
// BudgetExceeded past it. `progress`, when set, is called from any of the growth threads after
// each tree's step: phase "growing" (its method ran; a tree regrown among its neighbours counts
// again, so `done` may pass `total`) or "finishing" (form, leaves, placement).
using PlotProgress = std::function<void(const char* phase, int64_t done, int64_t total)>;
GrownPlot growPlot(const PlotSpec& spec, PlotLayout layout, const BudgetTable* datasetBudget,
                   bool threaded, const PlotProgress& progress = {});

// One side's leaf area of a tree, m² (Σ leafArea over its leaves).
double treeLeafArea(const Tree& tree);

// The plot's leaf area index: Σ leaf area of every tree / the plot's area.
double plotLai(const GrownPlot& plot);

// --- statistics -------------------------------------------------------------------------------

// A tree's crown as seen from above: its horizontal points are its leaves' centres and its
// branch tips (skeleton endpoints of the shoot; nodes if it has no leaves).
struct CrownShape {
    Vec2 base;                // x, z of the stem base
    Vec2 centroid;            // mean x, z of the crown points
    double radius = 0;        // largest horizontal distance of a crown point from the base, metres
    double low = 0, top = 0;  // lowest and highest crown point (y, plot metres)
    std::vector<Vec2> hull;   // convex hull of the crown points (counter-clockwise in x, z)
};
CrownShape crownShape(const PlotTree& tree);

// Per tree: the crown-centre offset (centroid − base, x z) and the neighbour vector (Σ unit
// vectors from each neighbour whose base lies within 2 of this tree's crown radii to this
// tree; zero without neighbours).
struct CrownAsymmetry {
    int32_t id = 0;
    Vec2 offset;
    Vec2 neighbours;
    double radius = 0;
};
std::vector<CrownAsymmetry> crownAsymmetry(const GrownPlot& plot);

// The plot's correlation between crown offsets and neighbour vectors: the mean cosine of the
// angle between them over the trees where both are non-zero (offset > 1 mm); positive when
// crowns grow away from their close neighbours. 0 when no tree qualifies.
double crownNeighbourCosine(const std::vector<CrownAsymmetry>& trees);

// Crown overlap of a pair, counted only where the crowns share space: in the layer of height
// both occupy (from the higher of the two crowns' lowest points to the lower of their highest,
// CrownShape::low/top), the fraction of the smaller crown's projected area there (the convex
// hull of its crown points in the layer, rasterised on `cell`-metre cells) that the other's
// covers too. A tree standing wholly under another's crown (a suppressed tree, in foresters'
// crown classes) shares no layer with it: its pair is `overtopped`, not overlapped.
struct CrownOverlap {
    int32_t a = 0, b = 0;     // tree ids, a < b
    double fraction = 0;      // in the shared layer; 0 without one (or < 3 points of a crown in it)
    double projected = 0;     // the whole crowns seen from above (heights ignored), as fraction
    bool overtopped = false;  // projections meet but the crowns share no layer
};
// Every pair whose hulls' bounding boxes meet, in id order. cell ≤ 0: 1/50 of the smallest
// crown radius, at least 2 cm.
std::vector<CrownOverlap> crownOverlaps(const GrownPlot& plot, double cell = 0);
// The largest `fraction` (shared layer) of the pairs; 0 without pairs.
double maxCrownOverlap(const std::vector<CrownOverlap>& overlaps);

}  // namespace sylva
