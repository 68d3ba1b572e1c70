// Dense uniform grids: one list per cell (PointGrid) or one packed run per cell
// (PackedPointGrid).
#include "volumes/point_grid.h"

#include <cmath>

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
    : cells_(bounds, cellSize), head_(cells_.count(), -1) {}

void PointGrid::insert(int32_t id, const Vec3& p) {
    const size_t cell = cells_.indexOf(p);
    slots_.push_back({p, id, head_[cell]});
    head_[cell] = static_cast<int32_t>(slots_.size()) - 1;
}

void PointGrid::reserve(size_t n) { slots_.reserve(n); }

bool PointGrid::anyWithin(const Vec3& q, double radius) const {
    const double r2 = radius * radius;
    auto near = [&](size_t cell) {
        for (int32_t s = head_[cell]; s >= 0; s = slots_[s].next)
            if (distance2(slots_[s].pos, q) < r2) return true;
        return false;
    };
    // The query's own cell first: when a dart is rejected it is most often by a point there.
    const size_t own = cells_.indexOf(q);
    if (near(own)) return true;
    int lo[3], hi[3];
    cells_.range(q, radius, lo, hi);
    for (int z = lo[2]; z <= hi[2]; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y) {
            const size_t row = cells_.index(0, y, z);
            for (int x = lo[0]; x <= hi[0]; ++x) {
                const size_t cell = row + x;
                if (cell != own && near(cell)) return true;
            }
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
    for (int32_t i = n; i-- > 0;) {
        const int32_t s = start_[cellOf_[i]]++;
        ids_[s] = i;
        pos_[s] = points[i];
    }
    // The fill advanced every start to the next cell's; shift back.
    for (size_t c = start_.size() - 1; c > 0; --c) start_[c] = start_[c - 1];
    start_[0] = 0;
}

}  // namespace sylva
