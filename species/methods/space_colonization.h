// The `space-colonization` growth method: buds compete for marker points in the space
// available for growth (Runions et al. 2007; Palubicki et al. 2009), in two variants:
//  - baseline (Palubicki 2009): markers spread uniformly through the crown volume once; each
//    bud has a spherical occupancy zone ρ (markers inside it are removed) and a conical
//    perception volume (half-angle θ, radius r); a marker perceived by several buds goes to
//    the closest; a bud with markers grows a metamer along the normalised mean direction.
//  - improved (Liu et al. 2020 §3): each live bud generates its own markers within κ·r every
//    iteration, weighted ω = exp(−d²/2σ²)/(√(2π)σ); a bud's direction is
//    norm(v_opt + Σ ωᵢ v_m(i) + λ v_g) over the markers of *other* buds in its perception
//    volume, v_g = (0, −1, 0).
// Guides (Liu 2020 §4.3): persistent markers from brush strokes (each with the stroke's
// direction and a weight by its distance to the stroke, adding ω·v_stroke) or from a
// silhouette mask (plain markers around the masked pixels).
//
// Trees rather than brooms (off by default, so the papers' presets grow as published):
//  - Borchert–Honda resource allocation (Palubicki 2009 §4, the extended BH model) with
//    apical control λ: a bud's light Q is accumulated basipetally, the resource α·Q_base
//    distributed acropetally, and a bud given v grows ⌊v⌋ metamers in one iteration;
//  - shedding of branches whose light does not pay for their size (Palubicki 2009);
//  - a per-instance perturbed copy of the crown (size and a low-frequency radial noise);
//  - excurrent conifers: a leader held vertical, whorls of laterals on it, a bound on order.
//
// Frame: +y up, metres, radians. The root is the origin. Lengths ρ, r, κ·r are given in
// units of the internode length.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/budget.h"
#include "core/rng.h"
#include "species/model/tree.h"
#include "volumes/volume.h"

namespace sylva {

enum class ColonizationVariant { kBaseline, kImproved };

// How a bud's growth per iteration is decided: one metamer whenever it has space (Runions
// 2007; the papers' presets), or the extended Borchert–Honda model (Palubicki 2009 §4).
enum class Allocation { kNone, kBorchertHonda };

// What a bud's Q is under allocation: space (1 when it won markers; Palubicki 2009 §4's
// space-colonization case) or light from shadow propagation (§4, its other environment).
enum class Light { kSpace, kShadow };

// A persistent marker placed by a guide. `direction` is the stroke direction at the marker
// (unit) for brush markers and zero for silhouette markers; `weight` is ω from the distance
// to the stroke (0 for silhouette markers).
struct GuideMarker {
    Vec3 position;
    Vec3 direction{0, 0, 0};
    double weight = 0.0;
};

struct SpaceColonizationOptions {
    ColonizationVariant variant = ColonizationVariant::kBaseline;
    VolumePtr crown;          // where markers may be (baseline: required)
    double internode = 0.1;   // internode (metamer) length, metres: the unit of ρ, r
    double occupancy = 2.0;   // ρ, internodes (Palubicki 2009 / Liu 2020 default)
    double perception = 4.0;  // r, internodes
    double perceptionAngle = 75.0 * kPi / 180.0;  // θ, half-angle of the perception cone
    int markers = 20000;                          // baseline: markers in the crown
    // improved: markers each live bud generates per iteration. A bud in free space expects
    // N·(1/κ)³·(1−cos θ)/2 of its own in its perception volume (64 → 0.88: it grows in ~58 %
    // of iterations); more markers make denser crowns, fewer sparser ones.
    int markersPerBud = 64;
    double kappa = 3.0;               // improved: markers within κ·r of their bud (2…4)
    double sigma = 1.0;               // improved: ω's σ, internodes
    double gravityWeight = 0.0;       // λ (improved; the baseline's tropism below)
    std::vector<GuideMarker> guides;  // persistent guide markers (both variants)

    // Tree form.
    double branchAngle = 45.0 * kPi / 180.0;   // lateral bud direction from its internode
    double phyllotaxis = 137.5 * kPi / 180.0;  // divergence between successive lateral buds
    Vec3 tropism{0, 0, 0};  // added to every growth direction (e.g. (0, −0.1, 0))
    // The tropism of axes of order ≥ 2 (branchlets: e.g. a spruce's hanging ones, Picea's
    // "comb" habit), when set; else `tropism` for every order.
    std::optional<Vec3> branchletTropism;
    // The angle of lateral buds on axes of order ≥ 1 (so of the order ≥ 2 axes), when set;
    // else branchAngle for every order: e.g. level whorl branches at 85° from the stem
    // carrying sprays whose shoots leave them forward at 60°.
    std::optional<double> branchletAngle;  // radians
    // ξ: the bud's own direction times ξ is added to v_opt (both variants) — a direction
    // memory that smooths the zig-zag of few markers (cf. Palubicki 2009, where a new
    // metamer's direction weighs the bud's default orientation against the optimal one).
    double budDirectionWeight = 0.0;
    double trunkLength = 0.0;   // metres grown straight up before branching starts
    double pipeExponent = 2.5;  // n in rⁿ = Σ childrenⁿ (da Vinci 2, Murray 3)
    double tipRadius = 0.004;   // metres, radius of every terminal internode

    // Resource allocation (Palubicki 2009 §4; baseline variant only). Q of a bud is 1 when it
    // won markers this iteration, else 0; the base receives v = α·Q_base; at every node the
    // resource splits between the continuing axis (Q_m) and the laterals (Q_l) by
    // v_m = v·λQ_m / (λQ_m + (1−λ)Q_l), v_l = v·(1−λ)Q_l / (λQ_m + (1−λ)Q_l); a bud given v
    // grows a shoot of ⌊v⌋ metamers, each re-aimed at the markers its bud won that remain.
    Allocation allocation = Allocation::kNone;
    double apicalControl = 0.5;        // λ in (0, 1): 0.5 even, > 0.5 favours main axes
    double resourceCoefficient = 2.0;  // α, metamers per unit of Q reaching the base
    // Q under light = kShadow: a bud that won markers has Q = its exposure, max(1 − s + a, 0)
    // with s the shade of its voxel (edge = internode), every node casting a·b^(−q) into the
    // (2q + 1)² voxels q layers below it, q = 0 … depth (Palubicki 2009 §4, shadow
    // propagation).
    Light light = Light::kSpace;
    double shadowStrength = 0.1;  // a, fraction of full light one node shades at its voxel
    double shadowDecay = 2.0;     // b > 1, per voxel layer
    int shadowDepth = 6;          // voxel layers
    // Shedding (Palubicki 2009 §4; allocation with light = kShadow): a lateral branch whose
    // mean exposure over its nodes stays below shedThreshold for shedDelay iterations in a
    // row is cut off. 0 = never.
    double shedThreshold = 0.0;  // fraction of full light
    int shedDelay = 3;           // iterations
    // Space-limited vigour (allocation; a realism addition, not Palubicki 2009's rule): a
    // lateral-axis bud that won m markers shares in the splits with Q × min(1, m /
    // spaceMarkers), so a bud at the edge of a nearly used-up region gets little; the order-0
    // bud keeps its Q, and the base's resource stays α·ΣQ (the tree's light). 0 = off (the
    // paper's Q: any won marker counts fully).
    double spaceMarkers = 0.0;  // markers
    // Shoot zigzag (a realism addition): every metamer of a lateral axis grows along its
    // direction turned by an angle ~ N(0, turnSd) about a random axis across it (keyed by bud,
    // iteration and metamer), so axes wander as sympodial shoots do. 0 = off.
    double turnSd = 0.0;  // radians
    // Held heading (a realism addition): a lateral axis grows within this angle of the
    // direction its bud was set at; a metamer aimed further off is turned back onto the cone's
    // edge. A plagiotropic branch keeps its heading instead of following a crown's rim
    // round the stem. 0 = off.
    double axisTurnMax = 0.0;  // radians
    // Held limbs (a realism addition): every axis of order ≥ 2 also grows within this angle of
    // the direction its limb — its order-1 ancestor — was set at, so a limb's sprays stay on
    // its side of the stem instead of chaining, order after order, round it. 0 = off.
    double limbTurnMax = 0.0;  // radians
    // Flat sprays (a realism addition): a lateral axis sets its own laterals in the horizontal
    // plane, to its left or right (the side nearer the phyllotaxis azimuth), as the
    // plagiotropic branches of firs and spruces do; off: all round the axis.
    bool flatSprays = false;

    // Per-instance crown: markers (and the improved variant's bound) come from a deformed
    // copy of `crown`, drawn per tree: scaled about the root by s ~ N(1, scaleSd) (clamped to
    // [0.5, 1.5]) and, about the crown's centre, radially by 1 + noise·f(u), f ∈ [−1, 1] a
    // sum of four random low-frequency waves over the direction u. 0 = the crown as given.
    double envelopeScaleSd = 0.0;  // fraction (σ of s)
    double envelopeNoise = 0.0;    // fraction of the radius, [0, 0.9]

    // Excurrent form. leaderWeight: the order-0 axis grows along norm(g + w·ŷ) (g its
    // direction as for any bud), so w ≫ 1 holds the leader vertical; with w > 0 the order-0
    // bud also wins every marker it perceives (apical dominance: baseline competition), and
    // grows on straight up without markers while the crown continues r above it. whorlLaterals k >
    // 0: the order-0 axis carries laterals only at the top node of each iteration's shoot (the
    // annual increment), k of them 360°/k apart at branchAngle, each whorl turned by
    // phyllotaxis from the one below. maxOrder: no lateral buds beyond this branch order.
    double leaderWeight = 0.0;
    int whorlLaterals = 0;
    int maxOrder = 1000;

    // Limits.
    int maxIterations = 200;
    int maxInternodes = 20000;

    // Split the per-bud work of each iteration across TBB workers; the tree is identical
    // either way (every parallel step is a pure function of the iteration's start state).
    bool threaded = false;
};

// Grows one tree. Deterministic for a given rng, whatever the thread count. Counters
// (iterations, internodes, markers generated/removed, live buds) go into `stats`. Markers
// (before they are drawn) and internodes are held to `guard`'s budgets, and its deadline is
// checked every iteration (BudgetExceeded).
Tree growSpaceColonization(const SpaceColonizationOptions& options, Rng& rng,
                           std::map<std::string, double>* stats = nullptr,
                           const GrowthGuard& guard = GrowthGuard::unlimited());

// One tree of a plot's space-colonization trees, grown together.
struct ColonizingTree {
    SpaceColonizationOptions options;
    Vec3 origin;  // where its root stands in the shared space (plot metres)
    Rng rng;      // the tree's own stream, as growSpaceColonization would get it
    const GrowthGuard* guard = nullptr;  // nullptr: unlimited
    // Crown shyness (plot metres): its buds perceive only the markers that keep every bound, so
    // it grows no branch into a neighbour's side of the layer their crowns share, and markers
    // in the gap between two bounds are nobody's. Empty: every marker.
    std::vector<ShyBound> territory;
    std::map<std::string, double> stats;
    Tree tree;  // out: in the tree's own frame (root at the origin)
};

// Several trees in one environment (Palubicki et al. 2009 §4): the crowns' markers (each
// tree's own crown about its origin, drawn from its own stream) form one shared set, every
// node's occupancy zone removes markers whatever its tree, and a marker perceived by several
// buds goes to the closest bud of any tree (ties to the earlier tree, then the lower bud), so
// trees take space from each other. Each iteration: perception per tree (in parallel when
// `threaded`), the competition over all buds, then each tree grows in tree order; it ends when
// no tree grew (or each met its own limits). Trees of the improved variant (whose markers are
// per bud, not shared) grow alone. A single baseline tree grows exactly as
// growSpaceColonization would, up to the move of the origin. Deterministic whatever the thread
// count.
void growSpaceColonizationTogether(std::vector<ColonizingTree>& trees, bool threaded);

}  // namespace sylva
