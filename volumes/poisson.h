// Poisson-disc sampling inside a volume (dart throwing accelerated by a uniform grid),
// Xu & Mould 2012 maketree step 1: K nodes at pairwise distance ≥ d inside V.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "core/math.h"
#include "core/rng.h"
#include "volumes/volume.h"

namespace sylva {

// Thrown when the requested count does not fit; the message says how many were placed.
class PoissonSaturated : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

struct PoissonOptions {
    int count = 0;             // K: number of points wanted
    double minDistance = 0.0;  // d: minimum pairwise distance, metres
    // Give up after this many consecutive rejected darts per wanted point still missing;
    // the search is declared saturated (no infinite loop).
    int maxConsecutiveRejections = 2000;
};

// K points, pairwise at least d apart, uniformly distributed inside `volume`. Runs in about
// O(K) expected time. Throws PoissonSaturated when K points cannot be placed.
std::vector<Vec3> poissonSample(const Volume& volume, const PoissonOptions& options, Rng& rng);
// The same points appended to `out` (which may already hold others; they are not spaced
// against).
void poissonSample(const Volume& volume, const PoissonOptions& options, Rng& rng,
                   std::vector<Vec3>& out);

// Largest count that random sequential packing typically reaches at spacing d in a volume of
// `cubicMetres` (≈ 0.7·V/d³ in 3-D) — for error messages and for choosing d from K.
double poissonCapacity(double cubicMetres, double minDistance);

}  // namespace sylva
