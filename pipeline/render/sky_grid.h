// How much of the sky a point among a tree's leaves and branches sees, from a grid of the
// occluding area: the light-transport half of a crown's ambient occlusion, computed once per
// scene and shared by all its views, in place of sky rays that cross the whole crown.
//
// The leaves and wood are turned into an extinction coefficient per cell (Beer–Lambert, the
// turbid-medium model of canopy optics: Ross 1981, Nilson 1971): σ = Ω · Σ G·A / V, with A a
// surface's area, G its mean projection (½ for a flat leaf of random orientation, ¼ for a closed
// tube's surface) and Ω the clumping index. Then, for each of a fixed set of directions spread
// over the sphere, the transmittance from every cell to the edge of the grid along it, by one
// sweep per direction: each cell's is its step's attenuation times the transmittance where the
// step lands, interpolated in the neighbouring slice across the direction's major axis (a
// discrete-ordinates sweep; shadow propagation on a voxel grid as Palubicki 2009 §4 does for
// growth, but along many directions and with Beer–Lambert attenuation). Interpolating between
// cells blurs the paths (numerical diffusion): through a uniform slab the transmittance is
// within 3 % along a grid axis and up to ≈ 10 % too high across the axes (SkyGrid tests) —
// enough for sky light, which the near rays refine (colour_render.cpp).
//
//   SkyGrid grid(lo, hi, 48, 0.8);
//   grid.addArea(centroid, 0.5 * leafArea);  // every occluder
//   grid.finish();
//   grid.transmittance(p, t);                // t[k]: towards directions()[k], 1 = open sky
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/math.h"

namespace sylva {

class SkyGrid {
  public:
    static constexpr int kDirections = 32;

    // A grid over the box [lo, hi] (grown by a cell each side) with `cells` cubic cells along its
    // longest side; `clumping` Ω in (0, 1]: 1 for leaves spread at random, below for clumped
    // foliage (more light gets through than the leaf area alone says).
    SkyGrid(const Vec3& lo, const Vec3& hi, int cells, double clumping);

    // Occluding area (m², already × G) at `p`, spread over the 8 nearest cell centres.
    void addArea(const Vec3& p, double projectedArea);
    // The sweeps; after it, transmittance() may be called (from any thread).
    void finish();

    // Unit directions, spread evenly over the sphere (a Fibonacci lattice).
    const std::array<Vec3, kDirections>& directions() const { return directions_; }
    // The transmittance from `p` to the grid's edge towards each direction, trilinear in the
    // cells; 1 outside the grid.
    void transmittance(const Vec3& p, float* t) const;

    double cellSize() const { return h_; }
    // The extinction coefficient (1/m) at the cell holding `p` (0 outside the grid).
    double extinction(const Vec3& p) const;

  private:
    size_t cell(int i, int j, int k) const { return (size_t(k) * ny_ + j) * nx_ + i; }
    void sweep(int direction);

    std::array<Vec3, kDirections> directions_;
    Vec3 origin_;  // the corner of cell (0, 0, 0)
    double h_ = 1.0;
    double clumping_ = 1.0;
    int nx_ = 1, ny_ = 1, nz_ = 1;
    std::vector<float> area_;      // per cell: projected area, then σ (1/m) after finish()
    std::vector<uint16_t> trans_;  // per cell, per direction: transmittance × 65535
};

}  // namespace sylva
