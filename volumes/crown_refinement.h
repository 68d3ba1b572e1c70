// @brief Crown refinement (Xu & Mould, journal version, as described by Wolff 2013 §3.1.1,
// Abbildung 11): well-separated points inside a crown volume, a sphere of fixed radius at each,
// each joined to the trunk top by a cone. The union of these disjoint sub-volumes replaces the
// crown for the first level; the graph's paths then run through the cones into separate
// clumps, which gives the clumped, irregular crowns of Wolff's Abbildung 12 (bottom row).
// Frame: +y up, metres.
#pragma once

#include <vector>

#include "core/math.h"
#include "core/rng.h"
#include "volumes/volume.h"

namespace sylva {

struct CrownRefinementOptions {
    Vec3 trunkTop{0, 0, 0};     // apex of every cone, metres
    int count = 8;              // N: number of spheres
    double sphereRadius = 1.0;  // R, metres
    double coneRadius = -1.0;   // radius of each cone's base disc at its sphere's centre,
                                // metres; < 0 means R/2
    double gap = 0.0;           // centres are at least 2R + gap apart, so the spheres are disjoint
    int maxConsecutiveRejections = 2000;  // Poisson dart throwing gives up after this many
};

struct RefinedCrown {
    std::vector<Vec3> centres;  // sphere centres, inside the crown, in the order drawn
    VolumePtr volume;  // union of the spheres, the cones and a hub sphere of the cone radius
                       // at the trunk top (exact part distances)
};

// Centres by Poisson-disc dart throwing inside `crown` (volumes/poisson.h) at spacing 2R + gap.
// Throws PoissonSaturated (its message gives the count placed and the capacity) when N spheres
// do not fit. A centre at the trunk top gets no cone.
RefinedCrown refineCrown(const Volume& crown, const CrownRefinementOptions& options, Rng& rng);

}  // namespace sylva
