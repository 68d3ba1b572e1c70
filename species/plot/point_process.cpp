#include "species/plot/point_process.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace sylva {

namespace {

struct Box {
    double minX, minZ, maxX, maxZ;
};

Box boundingBox(const PlotArea& a) { return {-a.halfX(), -a.halfZ(), a.halfX(), a.halfZ()}; }

// Points in square cells over a box, for "who is within r" queries with r ≤ cell (the 3 × 3
// cells around a point). Cells hold point indices; a point can move (remove, insert).
class PointGrid {
  public:
    PointGrid(const Box& box, double cell) : box_(box), cell_(cell) {
        nx_ = std::max<int64_t>(1, static_cast<int64_t>(std::ceil((box.maxX - box.minX) / cell)));
        nz_ = std::max<int64_t>(1, static_cast<int64_t>(std::ceil((box.maxZ - box.minZ) / cell)));
        cells_.resize(static_cast<size_t>(nx_ * nz_));
    }
    void insert(int32_t id, const Vec2& p) { cells_[index(p)].push_back(id); }
    void remove(int32_t id, const Vec2& p) {
        auto& c = cells_[index(p)];
        c.erase(std::find(c.begin(), c.end(), id));
    }
    template <class F>
    void neighbours(const Vec2& p, F&& f) const {
        const int64_t ci = column(p.x), cj = row(p.y);
        for (int64_t j = std::max<int64_t>(cj - 1, 0); j <= std::min(cj + 1, nz_ - 1); ++j) {
            for (int64_t i = std::max<int64_t>(ci - 1, 0); i <= std::min(ci + 1, nx_ - 1); ++i) {
                for (int32_t id : cells_[static_cast<size_t>(j * nx_ + i)]) f(id);
            }
        }
    }

  private:
    int64_t column(double x) const {
        return std::clamp<int64_t>(static_cast<int64_t>((x - box_.minX) / cell_), 0, nx_ - 1);
    }
    int64_t row(double z) const {
        return std::clamp<int64_t>(static_cast<int64_t>((z - box_.minZ) / cell_), 0, nz_ - 1);
    }
    size_t index(const Vec2& p) const { return static_cast<size_t>(row(p.y) * nx_ + column(p.x)); }
    Box box_;
    double cell_;
    int64_t nx_ = 1, nz_ = 1;
    std::vector<std::vector<int32_t>> cells_;
};

// A cell at least `r` wide and about one point per cell for n points (so a tiny r does not
// make a huge grid).
double gridCell(double r, int64_t n, const PlotArea& area) {
    return std::max(r, std::sqrt(area.area() / static_cast<double>(std::max<int64_t>(n, 1))));
}

double distanceSquared(const Vec2& a, const Vec2& b) {
    const double dx = a.x - b.x, dz = a.y - b.y;
    return dx * dx + dz * dz;
}

}  // namespace

Vec2 uniformInArea(const PlotArea& area, Rng& rng) {
    const Box b = boundingBox(area);
    for (;;) {
        const Vec2 p(rng.uniform(b.minX, b.maxX), rng.uniform(b.minZ, b.maxZ));
        if (area.shape != PlotArea::Shape::kCircle || area.contains(p.x, p.y)) return p;
    }
}

int64_t poissonCount(double mean, Rng& rng) {
    if (!(mean > 0)) return 0;
    int64_t total = 0;
    double rest = mean;
    while (rest > 0) {
        const double piece = std::min(rest, 16.0);
        rest -= piece;
        const double limit = std::exp(-piece);
        double product = rng.uniform();
        while (product > limit) {
            ++total;
            product *= rng.uniform();
        }
    }
    return total;
}

std::vector<Vec2> poissonPoints(int64_t n, const PlotArea& area, Rng& rng) {
    std::vector<Vec2> out;
    out.reserve(static_cast<size_t>(std::max<int64_t>(n, 0)));
    for (int64_t k = 0; k < n; ++k) out.push_back(uniformInArea(area, rng));
    return out;
}

int64_t hardCoreCapacity(double minSpacing, const PlotArea& area) {
    const double disk = kPi * minSpacing * minSpacing / 4;
    return static_cast<int64_t>(std::floor(kMaxHardCoreCoverage * area.area() / disk + 1e-9));
}

std::vector<Vec2> hardCorePoints(int64_t n, double minSpacing, const PlotArea& area, Rng& rng) {
    if (n <= 0) return {};
    const double d2 = minSpacing * minSpacing;
    const int64_t maxDarts = 2000 * n + 100000;
    for (int attempt = 0; attempt < 8; ++attempt) {
        Rng r = attempt == 0 ? rng : rng.derive("restart " + std::to_string(attempt));
        PointGrid grid(boundingBox(area), gridCell(minSpacing, n, area));
        std::vector<Vec2> pts;
        pts.reserve(static_cast<size_t>(n));
        for (int64_t dart = 0; dart < maxDarts && static_cast<int64_t>(pts.size()) < n; ++dart) {
            const Vec2 p = uniformInArea(area, r);
            bool free = true;
            grid.neighbours(p, [&](int32_t id) {
                if (distanceSquared(pts[static_cast<size_t>(id)], p) < d2) free = false;
            });
            if (!free) continue;
            grid.insert(static_cast<int32_t>(pts.size()), p);
            pts.push_back(p);
        }
        if (static_cast<int64_t>(pts.size()) == n) return pts;
    }
    throw std::runtime_error("hardCorePoints: " + std::to_string(n) + " points at spacing " +
                             std::to_string(minSpacing) + " m do not fit the plot");
}

std::vector<Vec2> straussPoints(int64_t n, double r, double gamma, const PlotArea& area, Rng& rng) {
    std::vector<Vec2> pts = poissonPoints(n, area, rng);
    if (n < 2 || gamma >= 1 || !(r > 0)) return pts;
    const double r2 = r * r;
    PointGrid grid(boundingBox(area), gridCell(r, n, area));
    for (int32_t k = 0; k < static_cast<int32_t>(n); ++k) grid.insert(k, pts[size_t(k)]);
    auto closeTo = [&](const Vec2& p, int32_t self) {
        int64_t s = 0;
        grid.neighbours(p, [&](int32_t id) {
            if (id != self && distanceSquared(pts[size_t(id)], p) < r2) ++s;
        });
        return s;
    };
    const int64_t moves = static_cast<int64_t>(kStraussSweeps) * n;
    for (int64_t m = 0; m < moves; ++m) {
        const auto k = static_cast<int32_t>(rng.below(static_cast<uint64_t>(n)));
        const Vec2 proposal = uniformInArea(area, rng);
        const double u = rng.uniform();  // drawn on every move: the stream does not branch
        const int64_t delta = closeTo(proposal, k) - closeTo(pts[size_t(k)], k);
        const bool accept =
            delta <= 0 || (gamma > 0 && u < std::pow(gamma, static_cast<double>(delta)));
        if (!accept) continue;
        grid.remove(k, pts[size_t(k)]);
        pts[size_t(k)] = proposal;
        grid.insert(k, proposal);
    }
    return pts;
}

std::vector<Vec2> thomasPoints(int64_t n, double parentDensityPerHa, double sigma,
                               const PlotArea& area, Rng& rng) {
    if (n <= 0) return {};
    const Box b = boundingBox(area);
    const double grow = 4 * sigma;
    const Box window{b.minX - grow, b.minZ - grow, b.maxX + grow, b.maxZ + grow};
    const double windowArea = (window.maxX - window.minX) * (window.maxZ - window.minZ);
    const int64_t parentCount =
        std::max<int64_t>(1, poissonCount(parentDensityPerHa * 1e-4 * windowArea, rng));
    std::vector<Vec2> parents;
    parents.reserve(static_cast<size_t>(parentCount));
    for (int64_t k = 0; k < parentCount; ++k) {
        parents.emplace_back(rng.uniform(window.minX, window.maxX),
                             rng.uniform(window.minZ, window.maxZ));
    }
    std::vector<Vec2> pts;
    pts.reserve(static_cast<size_t>(n));
    for (int64_t k = 0; k < n; ++k) {
        bool placed = false;
        for (int tries = 0; tries < 1000 && !placed; ++tries) {
            const Vec2& c = parents[rng.below(static_cast<uint64_t>(parentCount))];
            const double dx = rng.normal() * sigma, dz = rng.normal() * sigma;
            const Vec2 p(c.x + dx, c.y + dz);
            if (area.contains(p.x, p.y)) pts.push_back(p), placed = true;
        }
        if (!placed) pts.push_back(uniformInArea(area, rng));
    }
    return pts;
}

namespace {

// Row direction u (along a row) and v (across rows) in (x, z).
void rowAxes(double azimuth, Vec2& u, Vec2& v) {
    u = Vec2(std::sin(azimuth), -std::cos(azimuth));
    v = Vec2(std::cos(azimuth), std::sin(azimuth));
}

}  // namespace

double rowLatticeSize(const PointProcessOptions& o, const PlotArea& area) {
    const Box b = boundingBox(area);
    const double reach = std::hypot(b.maxX - b.minX, b.maxZ - b.minZ) * 0.5;
    return (2 * std::ceil(reach / o.rowSpacing) + 1) * (2 * std::ceil(reach / o.stemSpacing) + 1);
}

std::vector<Vec2> rowSites(const PointProcessOptions& o, const PlotArea& area) {
    const Box b = boundingBox(area);
    const double reach = std::hypot(b.maxX - b.minX, b.maxZ - b.minZ) * 0.5;
    Vec2 u, v;
    rowAxes(o.rowAzimuthRad, u, v);
    const auto rows = static_cast<int64_t>(std::ceil(reach / o.rowSpacing));
    const auto stems = static_cast<int64_t>(std::ceil(reach / o.stemSpacing));
    std::vector<Vec2> out;
    for (int64_t j = -rows; j <= rows; ++j) {
        for (int64_t i = -stems; i <= stems; ++i) {
            const double a = static_cast<double>(i) * o.stemSpacing;
            const double c = static_cast<double>(j) * o.rowSpacing;
            const Vec2 p(a * u.x + c * v.x, a * u.y + c * v.y);
            if (area.contains(p.x, p.y)) out.push_back(p);
        }
    }
    return out;
}

std::vector<Vec2> rowPoints(int64_t n, const PointProcessOptions& o, const PlotArea& area,
                            Rng& rng) {
    std::vector<Vec2> sites = rowSites(o, area);
    if (n > static_cast<int64_t>(sites.size())) {
        throw std::invalid_argument("rowPoints: " + std::to_string(n) + " stems, " +
                                    std::to_string(sites.size()) + " row places");
    }
    // A uniform subset of n places (partial Fisher–Yates over their indices), in row order.
    std::vector<size_t> index(sites.size());
    std::iota(index.begin(), index.end(), size_t(0));
    for (size_t k = 0; k < static_cast<size_t>(n); ++k) {
        const size_t pick = k + static_cast<size_t>(rng.below(sites.size() - k));
        std::swap(index[k], index[pick]);
    }
    index.resize(static_cast<size_t>(n));
    std::sort(index.begin(), index.end());
    std::vector<Vec2> out;
    out.reserve(index.size());
    for (size_t k : index) {
        Vec2 p = sites[k];
        if (o.jitter > 0) {
            for (int t = 0; t < 16; ++t) {
                const Vec2 q(p.x + rng.normal() * o.jitter, p.y + rng.normal() * o.jitter);
                if (area.contains(q.x, q.y)) {
                    p = q;
                    break;
                }
            }
        }
        out.push_back(p);
    }
    return out;
}

std::vector<Vec2> drawPoints(int64_t n, const PointProcessOptions& o, const PlotArea& area,
                             Rng& rng) {
    switch (o.kind) {
        case PointProcessOptions::Kind::kPoisson:
            return poissonPoints(n, area, rng);
        case PointProcessOptions::Kind::kHardCore:
            return hardCorePoints(n, o.minSpacing, area, rng);
        case PointProcessOptions::Kind::kStrauss:
            return straussPoints(n, o.minSpacing, o.interaction, area, rng);
        case PointProcessOptions::Kind::kThomas:
            return thomasPoints(n, o.parentDensity, o.clusterSigma, area, rng);
        case PointProcessOptions::Kind::kRows:
            return rowPoints(n, o, area, rng);
    }
    return {};
}

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
