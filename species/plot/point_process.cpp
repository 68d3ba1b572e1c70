#include "species/plot/point_process.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace sylva {

std::vector<double> nearestNeighbourDistances(const std::vector<Vec2>& points) {
    const size_t n = points.size();
    std::vector<double> out(n, std::numeric_limits<double>::infinity());
    if (n < 2) return out;
    double minX = points[0].x, maxX = minX, minY = points[0].y, maxY = minY;
    for (const Vec2& p : points) {
        minX = std::min(minX, p.x), maxX = std::max(maxX, p.x);
        minY = std::min(minY, p.y), maxY = std::max(maxY, p.y);
    }
    // Cells of about one point each: a ring search stops once the ring is farther than the
    // best distance found.
    const double extent = std::max({maxX - minX, maxY - minY, 1e-9});
    const double cell = std::max(extent / std::sqrt(static_cast<double>(n)), 1e-9);
    auto key = [&](int64_t i, int64_t j) { return (i << 32) ^ (j & 0xffffffff); };
    std::unordered_map<int64_t, std::vector<int32_t>> grid;
    auto cellOf = [&](const Vec2& p) {
        return std::pair<int64_t, int64_t>(static_cast<int64_t>((p.x - minX) / cell),
                                           static_cast<int64_t>((p.y - minY) / cell));
    };
    for (size_t k = 0; k < n; ++k) {
        auto [i, j] = cellOf(points[k]);
        grid[key(i, j)].push_back(static_cast<int32_t>(k));
    }
    for (size_t k = 0; k < n; ++k) {
        auto [ci, cj] = cellOf(points[k]);
        double best = std::numeric_limits<double>::infinity();
        for (int64_t r = 0;; ++r) {
            if ((r - 1) * cell > best) break;
            for (int64_t i = ci - r; i <= ci + r; ++i) {
                for (int64_t j = cj - r; j <= cj + r; ++j) {
                    if (std::max(std::abs(i - ci), std::abs(j - cj)) != r) continue;
                    auto it = grid.find(key(i, j));
                    if (it == grid.end()) continue;
                    for (int32_t m : it->second) {
                        if (static_cast<size_t>(m) == k) continue;
                        const double dx = points[m].x - points[k].x;
                        const double dy = points[m].y - points[k].y;
                        best = std::min(best, std::sqrt(dx * dx + dy * dy));
                    }
                }
            }
            if (r > static_cast<int64_t>(n) + 2) break;
        }
        out[k] = best;
    }
    return out;
}

double clarkEvans(const std::vector<Vec2>& points, const PlotArea& area) {
    const size_t n = points.size();
    if (n < 2 || !(area.area() > 0)) return std::numeric_limits<double>::quiet_NaN();
    double sum = 0;
    for (double d : nearestNeighbourDistances(points)) sum += d;
    const double observed = sum / n;
    const double lambda = n / area.area();
    const double perimeter = area.shape == PlotArea::Shape::kCircle ? 2 * kPi * area.radius
                                                                    : 2 * (area.width + area.depth);
    const double expected =
        0.5 / std::sqrt(lambda) +
        (0.0514 + 0.041 / std::sqrt(static_cast<double>(n))) * perimeter / static_cast<double>(n);
    return observed / expected;
}

}  // namespace sylva
