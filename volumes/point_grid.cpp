// Dense uniform grid of singly linked lists (one head per cell, one `next` per stored point).
#include "volumes/point_grid.h"

#include <cmath>

namespace sylva {

namespace {
// Cap on the number of cells: a huge box with a tiny cell would otherwise allocate gigabytes
// (8M cells = 32 MB of heads). Beyond it the cells grow, which only slows queries.
constexpr double kMaxCells = 8.0 * 1024 * 1024;
}  // namespace

PointGrid::PointGrid(const Aabb& bounds, double cellSize) {
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
    head_.assign(static_cast<size_t>(dims_[0]) * dims_[1] * dims_[2], -1);
}

void PointGrid::insert(int32_t id, const Vec3& p) {
    const size_t cell = cellIndex(cellCoord(p.x, 0), cellCoord(p.y, 1), cellCoord(p.z, 2));
    const int32_t slot = static_cast<int32_t>(pos_.size());
    pos_.push_back(p);
    ids_.push_back(id);
    next_.push_back(head_[cell]);
    head_[cell] = slot;
}

void PointGrid::reserve(size_t n) {
    pos_.reserve(n);
    ids_.reserve(n);
    next_.reserve(n);
}

bool PointGrid::anyWithin(const Vec3& q, double radius) const {
    const double r2 = radius * radius;
    auto near = [&](size_t cell) {
        for (int32_t s = head_[cell]; s >= 0; s = next_[s])
            if (distance2(pos_[s], q) < r2) return true;
        return false;
    };
    // The query's own cell first: when a dart is rejected it is most often by a point there.
    const size_t own = cellIndex(cellCoord(q.x, 0), cellCoord(q.y, 1), cellCoord(q.z, 2));
    if (near(own)) return true;
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = cellCoord(q[a] - radius, a);
        hi[a] = cellCoord(q[a] + radius, a);
    }
    const size_t sy = static_cast<size_t>(dims_[0]), sz = sy * dims_[1];
    for (int z = lo[2]; z <= hi[2]; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y) {
            const size_t row = z * sz + y * sy;
            for (int x = lo[0]; x <= hi[0]; ++x) {
                const size_t cell = row + x;
                if (cell != own && near(cell)) return true;
            }
        }
    return false;
}

}  // namespace sylva
