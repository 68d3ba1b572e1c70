// Uniform hash grid over a box for fixed-radius neighbour queries in O(1) expected time.
// Used by Poisson sampling and by graph linking (not O(K²)).
#pragma once

#include <cstdint>
#include <vector>

#include "volumes/math.h"

namespace sylva {

class PointGrid {
  public:
    // Cells of edge `cellSize` metres covering `bounds` (points outside are clamped to the
    // border cells, so queries stay correct, only slower).
    PointGrid(const Aabb& bounds, double cellSize);

    // Adds point p with caller-chosen index `id` (ids need not be dense).
    void insert(int32_t id, const Vec3& p);
    // Pre-allocates room for n points (avoids regrowth when the count is known).
    void reserve(size_t n);
    size_t size() const { return ids_.size(); }

    // Calls f(id, position) for every stored point with |q - p| < radius.
    template <class F>
    void forEachWithin(const Vec3& q, double radius, F&& f) const {
        const double r2 = radius * radius;
        int lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = cellCoord(q[a] - radius, a);
            hi[a] = cellCoord(q[a] + radius, a);
        }
        for (int z = lo[2]; z <= hi[2]; ++z)
            for (int y = lo[1]; y <= hi[1]; ++y)
                for (int x = lo[0]; x <= hi[0]; ++x) {
                    for (int32_t s = head_[cellIndex(x, y, z)]; s >= 0; s = next_[s]) {
                        if (distance2(pos_[s], q) < r2) f(ids_[s], pos_[s]);
                    }
                }
    }
    // True if any stored point lies within `radius` of q (early exit).
    bool anyWithin(const Vec3& q, double radius) const;

  private:
    int cellCoord(double v, int axis) const {
        // Clamp before the cast: far-away (or NaN) coordinates must not overflow int.
        double c = std::floor((v - origin_[axis]) * inv_);
        if (!(c > 0.0)) return 0;
        return c >= dims_[axis] - 1 ? dims_[axis] - 1 : static_cast<int>(c);
    }
    size_t cellIndex(int x, int y, int z) const {
        return (static_cast<size_t>(z) * dims_[1] + y) * dims_[0] + x;
    }

    Vec3 origin_;
    double inv_ = 1.0;
    int dims_[3] = {1, 1, 1};
    std::vector<int32_t> head_;  // first slot per cell, -1 if empty
    std::vector<int32_t> next_;  // next slot in the same cell
    std::vector<Vec3> pos_;      // per slot
    std::vector<int32_t> ids_;   // per slot
};

}  // namespace sylva
