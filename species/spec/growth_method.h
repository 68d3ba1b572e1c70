// Growth methods, created by name from a species file (after pbrt-v4's Create functions).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/budget.h"
#include "core/params.h"
#include "core/rng.h"
#include "species/model/tree.h"
#include "volumes/volume.h"

namespace sylva {

struct SpaceColonizationOptions;

// What a tree growing in a plot knows of its neighbours (species/plot/plot_growth.h), in the
// tree's own frame: its root at the origin, metres at the scale the species grows.
struct Neighbourhood {
    // Crown shyness: the crown keeps inside every half-space (iterated-graph, canopy).
    std::vector<HalfSpace> clip;
    // Crown shyness up to the lower of two crowns' tops (grammar): a branch stops at, or
    // rising grows up along, each bound's plane (GrammarOptions::shyBounds).
    std::vector<ShyBound> bounds;
    // Light/shade tropism (grammar): horizontal, away from the neighbours' crowns; its length
    // is the strength, added to every shoot stem's direction before it is normalised.
    Vec3 away{0, 0, 0};
};

class GrowthMethod {
  public:
    virtual ~GrowthMethod() = default;
    // Grows one tree from rng. `threaded`: the method may split its own work across TBB
    // workers; results never depend on it. Method-specific counters go into `stats`. The
    // growth loops hold what they build to `guard`'s budget and deadline (BudgetExceeded).
    virtual Tree grow(Rng& rng, bool threaded, std::map<std::string, double>& stats,
                      const GrowthGuard& guard) const = 0;
    // Grows the tree among neighbours; a method that makes no use of them grows as grow().
    virtual Tree growAmong(Rng& rng, bool threaded, std::map<std::string, double>& stats,
                           const GrowthGuard& guard, const Neighbourhood& neighbours) const {
        (void)neighbours;
        return grow(rng, threaded, stats, guard);
    }
    // A space-colonization method's options (a plot grows those trees together in one marker
    // set, species/methods/space_colonization.h), else nullptr.
    virtual const SpaceColonizationOptions* spaceColonization() const { return nullptr; }
    // The method's named volumes, as parsed for this instance ("crown", ...), for
    // `sylva volume`; a method without volumes returns none.
    virtual std::vector<std::pair<std::string, VolumePtr>> volumes() const { return {}; }
    // True when the method reads the species' [leaves] table itself (its own keys) and
    // places its leaves; the shared [leaves] reader (species/geometry/leaves.h) is then skipped.
    virtual bool placesOwnLeaves() const { return false; }
    // True when the method reads the species' season itself and places its leaves by it (the
    // grammar); otherwise the species' `season` and [seasons] are applied to its grown leaves.
    virtual bool hasOwnSeasons() const { return false; }

    // Lower bounds of the sizes of this species' trees, with the keys that make them: the
    // reader states them from the parameters (core/budget.h), before anything grows.
    SizeEstimate sizes;
};

// Reads the method's parameters from the species table (its own keys only) and returns the
// method; an unknown name is an error naming the file and line of `method` and the known
// names. The methods are one table in growth_method.cpp.
std::unique_ptr<GrowthMethod> makeGrowthMethod(const std::string& name, Params& species);

// The names of every growth method, in the table's order.
std::vector<std::string> growthMethodNames();

// Each method's factory, one per file in species/methods/ (<method>_spec.cpp).
std::unique_ptr<GrowthMethod> makeIteratedGraphMethod(Params& species);
std::unique_ptr<GrowthMethod> makeSpaceColonizationMethod(Params& species);
std::unique_ptr<GrowthMethod> makeGrammarMethod(Params& species);
std::unique_ptr<GrowthMethod> makeCanopyMethod(Params& species);

}  // namespace sylva
