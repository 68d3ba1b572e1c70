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
// Frame: +y up, metres, radians. The root is the origin. Lengths ρ, r, κ·r are given in
// units of the internode length.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/rng.h"
#include "species/model/tree.h"
#include "volumes/volume.h"

namespace sylva {

enum class ColonizationVariant { kBaseline, kImproved };

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
    // ξ: the bud's own direction times ξ is added to v_opt (both variants) — a direction
    // memory that smooths the zig-zag of few markers (cf. Palubicki 2009, where a new
    // metamer's direction weighs the bud's default orientation against the optimal one).
    double budDirectionWeight = 0.0;
    double trunkLength = 0.0;   // metres grown straight up before branching starts
    double pipeExponent = 2.5;  // n in rⁿ = Σ childrenⁿ (da Vinci 2, Murray 3)
    double tipRadius = 0.004;   // metres, radius of every terminal internode

    // Limits.
    int maxIterations = 200;
    int maxInternodes = 20000;

    // Split the per-bud work of each iteration across TBB workers; the tree is identical
    // either way (every parallel step is a pure function of the iteration's start state).
    bool threaded = false;
};

// Grows one tree. Deterministic for a given rng, whatever the thread count. Counters
// (iterations, internodes, markers generated/removed, live buds) go into `stats`.
Tree growSpaceColonization(const SpaceColonizationOptions& options, Rng& rng,
                           std::map<std::string, double>* stats = nullptr);

}  // namespace sylva
