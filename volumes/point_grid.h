// Uniform grids over a box for fixed-radius neighbour queries in O(1) expected time.
// Used by Poisson sampling and by graph linking (not O(K²)).
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "core/math.h"

namespace sylva {

// The cells both grids use: edge `cellSize` metres, covering `bounds` (points outside are
// clamped to the border cells, so queries stay correct, only slower).
class GridCells {
  public:
    GridCells() = default;
    GridCells(const Aabb& bounds, double cellSize);

    size_t count() const { return static_cast<size_t>(dims_[0]) * dims_[1] * dims_[2]; }
    int dim(int axis) const { return dims_[axis]; }
    int coord(double v, int axis) const {
        // Clamp before the cast: far-away (or NaN) coordinates must not overflow int. Within
        // the clamps t ≥ 1, where truncation is floor (and cheaper than std::floor).
        const double t = (v - origin_[axis]) * inv_;
        if (!(t >= 1.0)) return 0;
        return t >= dims_[axis] - 1 ? dims_[axis] - 1 : static_cast<int>(t);
    }
    size_t index(int x, int y, int z) const {
        return (static_cast<size_t>(z) * dims_[1] + y) * dims_[0] + x;
    }
    size_t indexOf(const Vec3& p) const {
        return index(coord(p.x, 0), coord(p.y, 1), coord(p.z, 2));
    }
    // The cells (inclusive) the box q ± radius touches, per axis.
    void range(const Vec3& q, double radius, int lo[3], int hi[3]) const {
        for (int a = 0; a < 3; ++a) {
            lo[a] = coord(q[a] - radius, a);
            hi[a] = coord(q[a] + radius, a);
        }
    }
    // Calls f(cell index) for every cell the box q ± radius touches, z slowest, x fastest.
    template <class F>
    void forEachCell(const Vec3& q, double radius, F&& f) const {
        int lo[3], hi[3];
        range(q, radius, lo, hi);
        const size_t sy = static_cast<size_t>(dims_[0]), sz = sy * dims_[1];
        for (int z = lo[2]; z <= hi[2]; ++z)
            for (int y = lo[1]; y <= hi[1]; ++y) {
                const size_t row = z * sz + y * sy;
                for (int x = lo[0]; x <= hi[0]; ++x) f(row + x);
            }
    }

  private:
    Vec3 origin_;
    double inv_ = 1.0;
    int dims_[3] = {1, 1, 1};
};

// Points added one at a time (dart throwing): one singly linked list per cell.
class PointGrid {
  public:
    PointGrid(const Aabb& bounds, double cellSize);

    // Adds point p with caller-chosen index `id` (ids need not be dense).
    void insert(int32_t id, const Vec3& p);
    // Pre-allocates room for n points (avoids regrowth when the count is known).
    void reserve(size_t n);
    size_t size() const { return slots_.size() - 1; }

    // Calls f(id, position) for every stored point with |q - p| < radius, cell by cell (z
    // slowest), the latest insertion first within a cell.
    template <class F>
    void forEachWithin(const Vec3& q, double radius, F&& f) const {
        const double r2 = radius * radius;
        cells_.forEachCell(q, radius, [&](size_t cell) {
            for (int32_t s = head_[cell]; s != kEnd; s = slots_[s].next) {
                if (distance2(slots_[s].pos, q) < r2) f(slots_[s].id, slots_[s].pos);
            }
        });
    }
    // True if any stored point lies within `radius` of q (early exit).
    bool anyWithin(const Vec3& q, double radius) const;

  private:
    struct Slot {
        Vec3 pos;
        int32_t id;
        int32_t next;  // next slot in the same cell, kEnd at the end
    };
    // Slot 0 ends every list: a point at infinity, which no query is within. anyWithin reads
    // it for an empty cell instead of branching on emptiness.
    static constexpr int32_t kEnd = 0;
    GridCells cells_;
    std::vector<int32_t> head_;  // first slot per cell, kEnd if empty
    std::vector<Slot> slots_;
};

// A fixed point set (a graph's nodes), indexed 0..n-1, sorted by cell so that each cell's
// points lie together. Visits points in the order a PointGrid with the same cells would had
// they been inserted in index order: cell by cell, each cell's points by descending index.
// `assign` reuses the storage of the previous set.
class PackedPointGrid {
  public:
    // Cells of edge `cellSize` metres over the bounding box of `points`.
    void assign(const std::vector<Vec3>& points, double cellSize);
    size_t size() const { return ids_.size(); }

    // Calls f(id, position) for every point with |q - p| < radius: the box query over the
    // ball's box (a row of cells one packed run), in its order — the order cell by cell.
    template <class F>
    void forEachWithin(const Vec3& q, double radius, F&& f) const {
        const double r2 = radius * radius;
        const Vec3 pad{radius, radius, radius};
        forEachInBox(q - pad, q + pad, [&](int32_t id, const Vec3& p) {
            if (distance2(p, q) < r2) f(id, p);
        });
    }
    // Calls f(id, position) for every point in the cells the box [lo, hi] touches (a superset
    // of the points inside it): cell by cell, z slowest, each row of cells one packed run.
    template <class F>
    void forEachInBox(const Vec3& lo, const Vec3& hi, F&& f) const {
        if (ids_.empty()) return;
        int l[3], h[3];
        for (int a = 0; a < 3; ++a) {
            l[a] = cells_.coord(lo[a], a);
            h[a] = cells_.coord(hi[a], a);
        }
        for (int z = l[2]; z <= h[2]; ++z)
            for (int y = l[1]; y <= h[1]; ++y) {
                const size_t row = cells_.index(0, y, z);
                for (int32_t s = start_[row + l[0]], end = start_[row + h[0] + 1]; s < end; ++s) {
                    f(ids_[s], pos_[s]);
                }
            }
    }
    // Every pair (i, j) with i < j, i < iEnd and |p_i − p_j| < radius, as (i, j) in `out`:
    // by i ascending and, for each i, in the order forEachWithin(p_i, radius) visits the j —
    // what calling it for each i would list, found with one pass over pairs of neighbouring
    // cells (each pair measured once) when radius is the cell size.
    void pairsWithin(double radius, int32_t iEnd, std::vector<std::pair<int32_t, int32_t>>& out);

  private:
    GridCells cells_;
    std::vector<int32_t> start_;   // first slot per cell; size cells + 1
    std::vector<int32_t> ids_;     // per slot
    std::vector<Vec3> pos_;        // per slot
    std::vector<int32_t> cellOf_;  // per point
    std::vector<int32_t> slotOf_;  // per point
    // pairsWithin's buffers
    std::vector<uint8_t> regular_;
    std::vector<std::pair<int32_t, int32_t>> found_;  // (i, slot of j)
    std::vector<int32_t> bucket_;
};

}  // namespace sylva
