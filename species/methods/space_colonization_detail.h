// Internal steps of the `space-colonization` method, exposed for tests only. These are the
// functions growSpaceColonization itself calls, not copies.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/math.h"
#include "core/rng.h"
#include "volumes/volume.h"

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

// What each bud perceives of `markers` after those flagged in `dead` died: (marker index,
// squared distance) in the order growth sums them; `compacted`: with the marker grid packed
// anew from the living markers first, as growth does once the dead are most of it (the lists
// must not change). `gridSize` (optional): the markers the grid then holds.
std::vector<std::vector<std::pair<int32_t, double>>> perceivedMarkers(
    const std::vector<PerceivingBud>& buds, const std::vector<Vec3>& markers,
    const std::vector<char>& dead, double radius, double angle, bool compacted,
    size_t* gridSize = nullptr);

// A Binomial(n, p) draw, exact and deterministic for a given rng. The improved variant
// draws how many of a bud's markers fall within the radius where they can matter.
int64_t binomial(Rng& rng, int64_t n, double p);

// One bud as the resource allocation sees it: the skeleton node it sits on, whether it is a
// lateral bud of that node (else the terminal bud, continuing the node's axis) and its light
// Q (Palubicki 2009 §4).
struct AllocationBud {
    int32_t node = 0;
    bool lateral = false;
    double q = 0.0;        // the bud's share in the splits
    double vigour = -1.0;  // what it adds to the base's resource; < 0: q
};

// The extended Borchert–Honda model (Palubicki 2009 §4) on a skeleton given by `parent`
// (parent[i] < i, −1 for the root 0) and `lateralNode` (1 where node i starts a lateral axis
// off its parent, 0 where it continues the parent's axis):
//  - shedding (when shedThreshold > 0): a lateral branch (the subtree of a lateral node)
//    whose mean light — Σ nodeLight over its nodes / its node (internode) count — is below
//    shedThreshold has starved[i] raised by one (else reset to 0); at shedDelay it is cut off
//    with its subtree (shed = 1 on every node removed, which then counts for nothing below);
//  - basipetal: Q of a node = Σ Q of its buds and of its child nodes (nodeQ);
//  - acropetal: the root receives α·Q_base — times V/Q, the unshed buds' summed vigour over
//    their summed Q, when some bud's vigour differs from its Q (the tree's light then sets the
//    resource and the buds' Q only where it goes); at every node the resource v splits between
//    the main side (continuing child or terminal bud, Q_m) and the lateral side (lateral children
//    and buds, Q_l = Σ of theirs) by v_m = v·λQ_m / (λQ_m + (1−λ)Q_l) and
//    v_l = v·(1−λ)Q_l / (λQ_m + (1−λ)Q_l), each lateral taking v_l in proportion to its Q;
//    budResource[b] is what bud b receives (0 on shed nodes).
// `nodeLight` (one value per node) and `starved` (resized by the caller to the node count)
// are read only when shedThreshold > 0.
struct AllocationResult {
    std::vector<double> nodeQ;
    std::vector<double> nodeResource;  // resource entering each node (through its internode)
    std::vector<double> budResource;
    std::vector<uint8_t> shed;
};
AllocationResult borchertHonda(const std::vector<int32_t>& parent,
                               const std::vector<uint8_t>& lateralNode,
                               const std::vector<AllocationBud>& buds,
                               const std::vector<double>& nodeLight, double lambda, double alpha,
                               double shedThreshold, int shedDelay, std::vector<int32_t>& starved);

// A lateral-axis bud's Q under space-limited vigour (SpaceColonizationOptions::spaceMarkers):
// light · min(1, won / spaceMarkers), or light itself when spaceMarkers is 0.
double spaceLimitedQ(double light, size_t won, double spaceMarkers);

// A deformed copy of a crown, one per tree (SpaceColonizationOptions::envelopeScaleSd,
// envelopeNoise): image(p) = s·(c + (p − c)·(1 + a·f(u))), u the unit direction of p − c, c the
// centre of the crown's bounds, f(u) = ¼ Σⱼ cos(π mⱼ (dⱼ·u) + φⱼ) ∈ [−1, 1] with random unit dⱼ,
// mⱼ ∈ [1, 2] (one or two lobes across the crown) and phases φⱼ, all from `rng`. The map
// keeps directions from c, so it inverts exactly: a point is inside when its preimage is
// inside the crown. The signed distance is the crown's at the preimage times s·(1 − a): its
// sign is exact (all that inside tests and rejection sampling need), its size approximate.
class PerturbedCrown : public Volume {
  public:
    PerturbedCrown(VolumePtr base, double scale, double noise, Rng rng);
    double signedDistance(const Vec3& q) const override;
    Aabb bounds() const override { return bounds_; }
    std::string describe() const override;
    Vec3 image(const Vec3& p) const;  // where the crown's point p goes
    Vec3 preimage(const Vec3& q) const;

  private:
    static constexpr int kWaves = 4;
    double wave(const Vec3& u) const;
    VolumePtr base_;
    double s_, a_;
    Vec3 c_;
    Vec3 d_[kWaves];
    double m_[kWaves], phi_[kWaves];
    Aabb bounds_;
};

}  // namespace sylva::detail
