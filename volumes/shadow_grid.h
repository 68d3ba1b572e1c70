// Palubicki et al. 2009's shadow propagation (§4): shade cast downward in a pyramid of voxels,
// the light a bud or a shoot tip receives. Used by space colonization's allocation and shedding
// and by the form stage's shade shedding.
#pragma once

#include <cstdint>
#include <vector>

#include "core/math.h"

namespace sylva {

// Palubicki 2009 §4's shadow propagation on a voxel grid of edge `voxel` metres over `box`:
// a node at voxel (i, j, k) adds strength·decay^(−q) to the voxels (i + p, j − q, k + p'),
// |p|, |p'| ≤ q, for q = 0 … depth — a pyramid of shade below it. The light exposure at a
// point is max(1 − s + strength, 0), s the shade of its voxel (full light is 1; the node's own
// share at q = 0 is given back so that a lone node sees full light). Outside the box: no
// shade is stored, exposure 1.
class ShadowGrid {
  public:
    ShadowGrid(const Aabb& box, double voxel, double strength, double decay, int depth);
    void cast(const Vec3& p, double sign);  // +1 adds a node's shade, −1 removes it
    double exposure(const Vec3& p) const;

  private:
    bool index(const Vec3& p, int64_t& i, int64_t& j, int64_t& k) const;
    Vec3 lo_;
    double inv_, strength_, decay_;
    int depth_;
    int64_t nx_, ny_, nz_;
    std::vector<double> shade_;
};

}  // namespace sylva
