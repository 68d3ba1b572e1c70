// Leaves at the terminal twigs, for methods that do not place their own (the iterated-graph
// method): count per tip, size distribution, random orientation or turned toward a sun
// direction (as the canopy paper orients its leaves), and a colour class by height.
#pragma once

#include "core/budget.h"
#include "core/rng.h"
#include "species/model/season.h"
#include "species/model/tree.h"

namespace sylva {

// How a leaf's card faces. kRandom: a uniformly random normal (the spherical distribution of
// inclinations); kSun: turned toward a sun direction. The rest are de Wit's (1965) leaf
// inclination distributions, the leaf normal's angle θ from the vertical having the density
// f(θ) on [0, π/2], azimuth uniform — planophile (2/π)(1 + cos 2θ), mostly horizontal leaves,
// mean 26.8°; erectophile (2/π)(1 − cos 2θ), mostly vertical, 63.2°; plagiophile
// (2/π)(1 − cos 4θ), mostly oblique, 45°; extremophile (2/π)(1 + cos 4θ), horizontal or
// vertical, 45°; uniform 2/π, 45°; spherical sin θ, 57.3°. Pisek et al. 2013 (Agric. For.
// Meteorol. 169: 186–194) measured 58 temperate and boreal broadleaf trees and found most
// planophile or plagiophile, few spherical.
enum class LeafOrientation {
    kRandom,
    kSun,
    kPlanophile,
    kErectophile,
    kPlagiophile,
    kExtremophile,
    kUniform,
    kSpherical
};

// A de Wit orientation (kPlanophile … kSpherical).
bool isInclinationDistribution(LeafOrientation o);
// A unit leaf normal (+y up) whose angle from the vertical follows the de Wit distribution
// `o`, azimuth uniform.
Vec3 inclinedLeafNormal(LeafOrientation o, Rng& rng);

// The leaf cards themselves, shared by every [leaves] table (these leaves and the canopy
// method's): their size, shape and orientation.
struct LeafCardOptions {
    double sizeMin = 0.08;  // card length, uniform in [sizeMin, sizeMax], metres
    double sizeMax = 0.14;
    double aspect = 0.6;                 // card width / length
    LeafShape shape = LeafShape::kCard;  // the outline on the card (species/model/leaf_shape.h)
    LeafOrientation orientation = LeafOrientation::kRandom;
    Vec3 sun{0.3, 1.0, 0.2};  // towards the sun (unit after parsing)
    double sunWeight = 0.7;   // normal = normalise(w·sun + (1 − w)·random)
};

struct LeafOptions : LeafCardOptions {
    bool enabled = false;
    int perTip = 5;             // leaves per terminal twig
    double alongTwig = 0.4;     // spread over the last this-many metres of each twig
    int colourClasses = 1;      // classes by relative height, 0 lowest (lighter higher)
    double colourJitter = 0.1;  // random shift of the height fraction before classing
};

// Appends leaves to tree.leaves at every tip (shoot nodes without children). Throws
// BudgetExceeded before placing any when tips × per_tip is over `guard`'s max_leaves.
void placeLeaves(Tree& tree, const LeafOptions& options, Rng& rng,
                 const GrowthGuard& guard = GrowthGuard::unlimited());

// The season of a tree whose method coloured its own leaves: each leaf is kept when its first
// draw from `rng` (a stream of its own, leaf by leaf) is below the palette's density, so a
// sparser season's leaves are a subset of a denser one's; unless the palette is as grown, a
// kept leaf takes the grammar's rule (Jain et al. 2021 §3.2): of k classes, entry
// ⌊h·k − 0.5 + u⌋ (clamped), h its height in the span of the shoot's nodes (0 lowest), u its
// second draw — dark low, light high, neighbours mixing between. No leaves kept when the
// palette has no classes (and is not as grown).
void applySeason(Tree& tree, const SeasonPalette& palette, const Rng& rng);

}  // namespace sylva
