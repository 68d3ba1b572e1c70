// Dense uniform grids: one list per cell (PointGrid) or one packed run per cell
// (PackedPointGrid).
#include "volumes/point_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sylva {

namespace {
// Cap on the number of cells: a huge box with a tiny cell would otherwise allocate gigabytes
// (8M cells = 32 MB of heads). Beyond it the cells grow, which only slows queries.
constexpr double kMaxCells = 8.0 * 1024 * 1024;
}  // namespace

GridCells::GridCells(const Aabb& bounds, double cellSize) {
    Vec3 size{0, 0, 0};
    if (!bounds.empty()) {
        origin_ = bounds.lo;
        size = bounds.size();
    }
    // Unbounded (or NaN) boxes get one cell per axis: still correct, just unaccelerated.
    for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(origin_[a]) || !std::isfinite(size[a])) {
            origin_[a] = 0.0;
            size[a] = 0.0;
        }
    }
    const double extent = std::max({size.x, size.y, size.z});
    // A non-positive or non-finite cell would make every coordinate map to infinity.
    if (!(cellSize > 0.0) || !std::isfinite(cellSize)) cellSize = extent > 0.0 ? extent : 1.0;
    auto cellsFor = [&](double cell) {
        double n = 1.0;
        for (int a = 0; a < 3; ++a) n *= std::max(1.0, std::ceil(size[a] / cell));
        return n;
    };
    while (cellsFor(cellSize) > kMaxCells) cellSize *= 1.25;
    inv_ = 1.0 / cellSize;
    for (int a = 0; a < 3; ++a)
        dims_[a] = static_cast<int>(std::max(1.0, std::ceil(size[a] / cellSize)));
}

PointGrid::PointGrid(const Aabb& bounds, double cellSize)
    : cells_(bounds, cellSize), head_(cells_.count(), kEnd) {
    constexpr double kFar = std::numeric_limits<double>::infinity();
    slots_.push_back({{kFar, kFar, kFar}, -1, kEnd});
}

void PointGrid::insert(int32_t id, const Vec3& p) {
    const size_t cell = cells_.indexOf(p);
    slots_.push_back({p, id, head_[cell]});
    head_[cell] = static_cast<int32_t>(slots_.size()) - 1;
}

void PointGrid::reserve(size_t n) { slots_.reserve(n + 1); }

bool PointGrid::anyWithin(const Vec3& q, double radius) const {
    const double r2 = radius * radius;
    int lo[3], hi[3];
    cells_.range(q, radius, lo, hi);
    // The middle cell first (the query's own when the radius is the cell size): when a dart
    // is rejected it is most often by a point there. The answer does not depend on the order.
    const size_t own = cells_.index((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2);
    for (int32_t s = head_[own]; s != kEnd; s = slots_[s].next)
        if (distance2(slots_[s].pos, q) < r2) return true;
    // Then a row of cells at a time, without a branch on whether a cell is empty (an empty
    // one reads the end slot, at infinity): at Poisson densities about half the cells are
    // empty, and that branch was mispredicted (perf: the slowest instructions of the query).
    // Points at infinity are never within, nor is anything of a NaN query (as before). The
    // middle cell is read again in its row: one more distance test, and no branch to skip it.
    for (int z = lo[2]; z <= hi[2]; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y) {
            const size_t row = cells_.index(0, y, z);
            bool hit = false;
            for (int x = lo[0]; x <= hi[0]; ++x) {
                const Slot& first = slots_[head_[row + x]];
                hit |= distance2(first.pos, q) < r2;
                for (int32_t s = first.next; s != kEnd; s = slots_[s].next)
                    hit |= distance2(slots_[s].pos, q) < r2;
            }
            if (hit) return true;
        }
    return false;
}

void PackedPointGrid::assign(const std::vector<Vec3>& points, double cellSize) {
    Aabb box;
    for (const Vec3& p : points) box.extend(p);
    cells_ = GridCells(box, cellSize);
    const int32_t n = static_cast<int32_t>(points.size());
    // Counting sort by cell; filling from the highest index down leaves each cell's points
    // in descending index order.
    start_.assign(cells_.count() + 1, 0);
    cellOf_.resize(n);
    for (int32_t i = 0; i < n; ++i) {
        cellOf_[i] = static_cast<int32_t>(cells_.indexOf(points[i]));
        ++start_[cellOf_[i] + 1];
    }
    for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    ids_.resize(n);
    pos_.resize(n);
    slotOf_.resize(n);
    for (int32_t i = n; i-- > 0;) {
        const int32_t s = start_[cellOf_[i]]++;
        ids_[s] = i;
        pos_[s] = points[i];
        slotOf_[i] = s;
    }
    // The fill advanced every start to the next cell's; shift back.
    for (size_t c = start_.size() - 1; c > 0; --c) start_[c] = start_[c - 1];
    start_[0] = 0;
}

void PackedPointGrid::pairsWithin(double radius, int32_t iEnd,
                                  std::vector<std::pair<int32_t, int32_t>>& out) {
    const int32_t n = static_cast<int32_t>(ids_.size());
    iEnd = std::max(0, std::min(iEnd, n));
    const double r2 = radius * radius;
    const int dx = cells_.dim(0), dy = cells_.dim(1), dz = cells_.dim(2);
    // A point is regular when the cells its own query would visit are exactly its cell and
    // the neighbours (clamped at the border): the pass over neighbouring cells finds its
    // pairs. Others (rounding at a cell border, or cells larger than the radius) query alone.
    regular_.assign(n, 0);
    for (int32_t i = 0; i < iEnd; ++i) {
        const int32_t c = cellOf_[i];
        const int own[3] = {c % dx, (c / dx) % dy, c / dx / dy};
        int lo[3], hi[3];
        cells_.range(pos_[slotOf_[i]], radius, lo, hi);
        bool same = true;
        for (int a = 0; a < 3; ++a) {
            same = same && lo[a] == std::max(own[a] - 1, 0) &&
                   hi[a] == std::min(own[a] + 1, cells_.dim(a) - 1);
        }
        regular_[i] = same;
    }
    size_t m = 0;
    // Writes (lower index, slot of the higher) and keeps it only when it counts: no branch.
    auto consider = [&](int32_t sa, int32_t sb) {
        const int32_t a = ids_[sa], b = ids_[sb];
        const bool aLow = a < b;
        const int32_t i = aLow ? a : b;
        found_[m] = {i, aLow ? sb : sa};
        m += (i < iEnd) & (regular_[i] != 0) & (distance2(pos_[sb], pos_[sa]) < r2);
    };
    for (int z = 0; z < dz; ++z)
        for (int y = 0; y < dy; ++y)
            for (int x = 0; x < dx; ++x) {
                const size_t cellA = cells_.index(x, y, z);
                const int32_t a0 = start_[cellA], a1 = start_[cellA + 1];
                if (a0 == a1) continue;
                // Pairs inside the cell, then with the 13 neighbours after it in index order.
                const size_t inside = size_t(a1 - a0) * (a1 - a0);
                if (found_.size() < m + inside) found_.resize(2 * (m + inside));
                for (int32_t sa = a0; sa < a1; ++sa)
                    for (int32_t sb = sa + 1; sb < a1; ++sb) consider(sa, sb);
                for (int oz = 0; oz <= 1; ++oz)
                    for (int oy = oz ? -1 : 0; oy <= 1; ++oy)
                        for (int ox = (oz || oy) ? -1 : 1; ox <= 1; ++ox) {
                            const int bx = x + ox, by = y + oy, bz = z + oz;
                            if (bx < 0 || bx >= dx || by < 0 || by >= dy || bz >= dz) continue;
                            const size_t cellB = cells_.index(bx, by, bz);
                            const int32_t b0 = start_[cellB], b1 = start_[cellB + 1];
                            if (b0 == b1) continue;  // an empty neighbour: no pairs
                            const size_t most = size_t(a1 - a0) * (b1 - b0);
                            if (found_.size() < m + most) found_.resize(2 * (m + most));
                            for (int32_t sa = a0; sa < a1; ++sa)
                                for (int32_t sb = b0; sb < b1; ++sb) consider(sa, sb);
                        }
            }
    // Irregular points query alone, in forEachWithin's order.
    for (int32_t i = 0; i < iEnd; ++i) {
        if (regular_[i]) continue;
        const Vec3 q = pos_[slotOf_[i]];
        cells_.forEachCell(q, radius, [&](size_t cell) {
            for (int32_t s = start_[cell]; s < start_[cell + 1]; ++s) {
                if (ids_[s] > i && distance2(pos_[s], q) < r2) {
                    if (found_.size() <= m) found_.resize(2 * m + 16);
                    found_[m++] = {i, s};
                }
            }
        });
    }
    // Group by i (counting sort), then each i's partners by slot: cells in index order and
    // descending index within a cell, which is forEachWithin's order.
    bucket_.assign(static_cast<size_t>(iEnd) + 1, 0);
    for (size_t k = 0; k < m; ++k) ++bucket_[found_[k].first + 1];
    for (int32_t i = 0; i < iEnd; ++i) bucket_[i + 1] += bucket_[i];
    out.resize(m);
    for (size_t k = 0; k < m; ++k) out[bucket_[found_[k].first]++] = found_[k];
    for (int32_t i = 0, begin = 0; i < iEnd; ++i) {
        const int32_t end = bucket_[i];  // the scatter advanced bucket_[i] to i's end
        std::sort(out.begin() + begin, out.begin() + end,
                  [](const auto& p, const auto& q) { return p.second < q.second; });
        for (int32_t k = begin; k < end; ++k) out[k].second = ids_[out[k].second];
        begin = end;
    }
}

}  // namespace sylva
