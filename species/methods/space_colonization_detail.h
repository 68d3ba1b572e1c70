// Internal steps of the `space-colonization` method, exposed for tests only. These are the
// functions growSpaceColonization itself calls, not copies.
#pragma once

#include <cstdint>
#include <vector>

#include "core/math.h"
#include "core/rng.h"

namespace sylva::detail {

// A bud as the competition sees it: its position and unit direction (metres, +y up).
struct PerceivingBud {
    Vec3 position;
    Vec3 direction;
};

// The baseline competition for markers (Palubicki et al. 2009 §4; Liu 2020 §3, Fig. 3b):
// for every marker, the index of the closest bud whose perception volume holds it — within
// `radius` metres of the bud and at most `angle` radians from its direction — or −1 when no
// bud perceives it. Equal distances go to the lower bud index.
std::vector<int32_t> closestPerceivingBud(const std::vector<PerceivingBud>& buds,
                                          const std::vector<Vec3>& markers, double radius,
                                          double angle, bool threaded = false);

// A Binomial(n, p) draw, exact and deterministic for a given rng. The improved variant
// draws how many of a bud's markers fall within the radius where they can matter.
int64_t binomial(Rng& rng, int64_t n, double p);

}  // namespace sylva::detail
