// Visual hull of silhouette masks (Liu et al. 2020 §4.3, after Longay et al.'s TreeSketch and
// Wang et al.): the intersection of the orthographic extrusions of two or more masks seen
// horizontally from known azimuths. Frame: +y up, metres; a view at azimuth a looks along
// −(sin a, 0, cos a), its image columns run along (cos a, 0, −sin a), rows along −y.
//
// Exact in the pixel model: between consecutive row edges of all views every view shows one
// row, i.e. a set of lateral intervals, so the hull's horizontal section is the intersection of
// strips — a union of convex polygons found by clipping. The hull is kept as these prisms
// (polygon × height band): they give the exact measure and bounds, and an exact uniform draw.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "volumes/mask.h"

namespace sylva {
namespace {

constexpr double kDeg = kPi / 180.0;

// Keeps the part of a convex polygon (points in the horizontal plane, (x, z)) where
// dot(p, n) ≥ c (Sutherland–Hodgman against one line).
std::vector<Vec2> clipHalfPlane(const std::vector<Vec2>& poly, const Vec2& n, double c) {
    std::vector<Vec2> out;
    const size_t m = poly.size();
    for (size_t i = 0; i < m; ++i) {
        const Vec2& a = poly[i];
        const Vec2& b = poly[(i + 1) % m];
        const double da = dot(a, n) - c, db = dot(b, n) - c;
        if (da >= 0) out.push_back(a);
        if ((da >= 0) != (db >= 0)) out.push_back(a + (b - a) * (da / (da - db)));
    }
    return out;
}

double polygonArea(const std::vector<Vec2>& poly) {
    double a = 0.0;
    for (size_t i = 0; i < poly.size(); ++i) a += cross(poly[i], poly[(i + 1) % poly.size()]);
    return 0.5 * std::abs(a);
}

struct Interval {
    double lo, hi;  // lateral metres
};

// One view with everything its queries need, computed once.
struct View {
    Mask mask;
    double mpp = 0.0, axis = 0.0, azimuthDeg = 0.0;
    Vec2 u;                                           // lateral direction in (x, z)
    std::vector<double> sd;                           // padded signed distance, pixels
    std::vector<double> radius;                       // r_m per pixel, metres
    double outsideRadius = 0.0;                       // r_m beyond the image, metres
    std::vector<std::vector<Interval>> runs;          // per row: inside runs, lateral metres
    int lowestRow = -1, highestRow = -1;              // rows holding inside pixels
    Vec2 boxLo{1e300, 1e300}, boxHi{-1e300, -1e300};  // inside pixels' bounding box, pixels

    View(MaskView v, const MaskFalloff& falloff)
        : mask(std::move(v.mask)),
          mpp(v.metresPerPixel),
          axis(v.axisColumn),
          azimuthDeg(v.azimuthDeg) {
        const double a = v.azimuthDeg * kDeg;
        u = {std::cos(a), -std::sin(a)};
        sd = paddedSignedDistancePixels(mask);
        const std::vector<uint8_t> n = unmaskedNeighbourCounts(mask);
        radius.resize(n.size());
        for (size_t i = 0; i < n.size(); ++i) radius[i] = falloffRadius(n[i], falloff) * mpp;
        outsideRadius = falloffRadius(25, falloff) * mpp;
        runs.resize(mask.height);
        for (int y = 0; y < mask.height; ++y) {
            for (int x = 0; x < mask.width;) {
                if (!mask.at(x, y)) {
                    ++x;
                    continue;
                }
                int end = x;
                while (mask.at(end, y)) ++end;
                runs[y].push_back({(x - axis) * mpp, (end - axis) * mpp});
                boxLo = {std::min(boxLo.x, double(x)), std::min(boxLo.y, double(y))};
                boxHi = {std::max(boxHi.x, double(end)), std::max(boxHi.y, y + 1.0)};
                x = end;
            }
            if (!runs[y].empty()) {
                if (highestRow < 0) highestRow = y;  // rows run top to bottom
                lowestRow = y;
            }
        }
    }

    // (column, row) coordinates of a world point in this view's image (fractional pixels).
    Vec2 pixelOf(const Vec3& p) const {
        return {axis + (p.x * u.x + p.z * u.y) / mpp, mask.height - p.y / mpp};
    }

    bool inside(const Vec3& p) const {
        const Vec2 q = pixelOf(p);
        return mask.at(static_cast<int>(std::floor(q.x)), static_cast<int>(std::floor(q.y)));
    }

    double radiusAt(const Vec3& p) const {
        const Vec2 q = pixelOf(p);
        const int c = static_cast<int>(std::floor(q.x)), r = static_cast<int>(std::floor(q.y));
        if (c < 0 || r < 0 || c >= mask.width || r >= mask.height) return outsideRadius;
        return radius[static_cast<size_t>(r) * mask.width + c];
    }

    // The 2-D signed distance, metres. Exact at pixel centres; between them the signed
    // distance's 1-Lipschitz property bounds it from the four nearest centres c:
    // outside, s(q) ≥ max s(c) − |q − c|; inside, s(q) ≤ min s(c) + |q − c|. Beyond the
    // inside pixels' bounding box B (convex, holding the mask S), with q' the nearest point of
    // B, dist(q, S)² ≥ |q − q'|² + dist(q', S)², exact straight out of a face of B. The sign
    // comes from the pixel itself, so it is exact.
    double signedDistance(const Vec3& p) const {
        const Vec2 q = pixelOf(p);
        if (mask.at(static_cast<int>(std::floor(q.x)), static_cast<int>(std::floor(q.y)))) {
            return std::min(lipschitz(q, true), 0.0) * mpp;
        }
        double bound = 0.0;
        if (q.x >= -0.5 && q.y >= -0.5 && q.x <= mask.width + 0.5 && q.y <= mask.height + 0.5) {
            bound = std::max(lipschitz(q, false), 0.0);
        }
        const Vec2 onBox{std::clamp(q.x, boxLo.x, boxHi.x), std::clamp(q.y, boxLo.y, boxHi.y)};
        const double away = length(q - onBox);
        if (away > 0.0) {
            const double there = std::max(lipschitz(onBox, false), 0.0);
            bound = std::max(bound, std::sqrt(away * away + there * there));
        }
        return std::max(bound, 1e-9) * mpp;
    }

    // The bound from the four padded pixel centres nearest to q (image coordinates, within
    // half a pixel of the image): the least upper bound inside, the greatest lower bound out.
    double lipschitz(const Vec2& image, bool inside) const {
        const int w = mask.width + 2, h = mask.height + 2;
        const Vec2 q = image + Vec2{1.0, 1.0};  // padded coordinates
        const int i0 = std::clamp(static_cast<int>(std::floor(q.x - 0.5)), 0, w - 2);
        const int j0 = std::clamp(static_cast<int>(std::floor(q.y - 0.5)), 0, h - 2);
        double bound = inside ? 1e300 : -1e300;
        for (int j = j0; j <= j0 + 1; ++j)
            for (int i = i0; i <= i0 + 1; ++i) {
                const double s = sd[static_cast<size_t>(j) * w + i];
                const double d = length(q - Vec2{i + 0.5, j + 0.5});
                bound = inside ? std::min(bound, s + d) : std::max(bound, s - d);
            }
        return bound;
    }
};

struct Prism {
    double y0, y1;
    std::vector<Vec2> poly;       // convex, (x, z)
    std::vector<double> fanArea;  // cumulative areas of the triangles (0, i, i + 1)
};

class VisualHull final : public Volume {
  public:
    VisualHull(std::vector<MaskView> views, const MaskFalloff& falloff) : falloff_(falloff) {
        for (auto& v : views) views_.emplace_back(std::move(v), falloff);
        buildPrisms();
        char buf[48];
        description_ = "visual hull of " + std::to_string(views_.size()) + " masks (azimuths";
        for (const View& v : views_) {
            std::snprintf(buf, sizeof buf, " %g°", v.azimuthDeg);
            description_ += buf;
        }
        description_ += ")";
    }

    double signedDistance(const Vec3& p) const override {
        double s = -1e300;
        for (const View& v : views_) s = std::max(s, v.signedDistance(p));
        return s;
    }

    Aabb bounds() const override { return bounds_; }
    double measure() const override { return measure_; }
    std::string describe() const override { return description_; }

    // A uniform point from the prisms (checked against the pixel test, which owns the
    // boundary), then Liu 2020 §4.3's spread: a ball of the largest r_m among the views, 0 deep
    // inside and growing with the outside pixels in the 5×5 neighbourhood (4.8 px on a straight
    // edge, 3.8 px one pixel in, at R = 10, k = 0.4). Spread points that leave the hull are
    // drawn again: the density falls from 1 deep inside to about a third in the outermost
    // pixel, the lost border mass reappearing a few pixels further in.
    std::optional<Vec3> sample(Rng& rng, int maxTries) const override {
        if (prisms_.empty()) return std::nullopt;
        for (int t = 0; t < maxTries; ++t) {
            const Vec3 x = uniformPoint(rng);
            if (!insideAll(x)) continue;
            if (!falloff_.enabled) return x;
            double r = 0.0;
            for (const View& v : views_) r = std::max(r, v.radiusAt(x));
            if (!(r > 0.0)) return x;
            const Vec3 y = x + uniformInBall(rng, r);
            if (insideAll(y)) return y;
        }
        return std::nullopt;
    }

  private:
    bool insideAll(const Vec3& p) const {
        for (const View& v : views_) {
            if (!v.inside(p)) return false;
        }
        return true;
    }

    Vec3 uniformPoint(Rng& rng) const {
        const double pick = rng.uniform() * cumulative_.back();
        size_t k =
            std::upper_bound(cumulative_.begin(), cumulative_.end(), pick) - cumulative_.begin();
        k = std::min(k, prisms_.size() - 1);
        const Prism& pr = prisms_[k];
        const double tri = rng.uniform() * pr.fanArea.back();
        size_t i = std::upper_bound(pr.fanArea.begin(), pr.fanArea.end(), tri) - pr.fanArea.begin();
        i = std::min(i, pr.fanArea.size() - 1);
        const Vec2 a = pr.poly[0], b = pr.poly[i + 1], c = pr.poly[i + 2];
        const double r1 = std::sqrt(rng.uniform()), r2 = rng.uniform();
        const Vec2 q = a * (1 - r1) + b * (r1 * (1 - r2)) + c * (r1 * r2);
        return {q.x, rng.uniform(pr.y0, pr.y1), q.y};
    }

    // Height bands between consecutive row edges of all views (within the rows every view
    // covers), each cut into the convex pieces of the intersection of the views' strips.
    void buildPrisms() {
        double lo = -1e300, hi = 1e300, reach = 0.0;
        for (const View& v : views_) {
            if (v.lowestRow < 0) return;  // an empty mask: an empty hull
            lo = std::max(lo, (v.mask.height - v.lowestRow - 1) * v.mpp);
            hi = std::min(hi, (v.mask.height - v.highestRow) * v.mpp);
            for (const auto& row : v.runs)
                for (const Interval& iv : row)
                    reach = std::max({reach, std::abs(iv.lo), std::abs(iv.hi)});
        }
        if (!(hi > lo)) return;
        double sinMax = 0.0;
        for (size_t i = 0; i < views_.size(); ++i)
            for (size_t j = i + 1; j < views_.size(); ++j)
                sinMax = std::max(sinMax, std::abs(cross(views_[i].u, views_[j].u)));
        // Two strips of half-width `reach` at angle θ meet within 2·reach/sin θ of the axis.
        const double half = reach * (1.0 + 2.0 / sinMax);
        const std::vector<Vec2> square = {
            {-half, -half}, {half, -half}, {half, half}, {-half, half}};

        std::vector<double> edges = {lo, hi};
        for (const View& v : views_)
            for (int k = 0; k <= v.mask.height; ++k) {
                const double e = k * v.mpp;
                if (e > lo && e < hi) edges.push_back(e);
            }
        std::sort(edges.begin(), edges.end());
        edges.erase(std::unique(edges.begin(), edges.end()), edges.end());

        std::vector<const std::vector<Interval>*> rows(views_.size());
        for (size_t e = 0; e + 1 < edges.size(); ++e) {
            const double y0 = edges[e], y1 = edges[e + 1], mid = 0.5 * (y0 + y1);
            bool any = true;
            for (size_t k = 0; k < views_.size() && any; ++k) {
                const View& v = views_[k];
                const int row = static_cast<int>(std::floor(v.mask.height - mid / v.mpp));
                any = row >= 0 && row < v.mask.height && !v.runs[row].empty();
                if (any) rows[k] = &v.runs[row];
            }
            if (any) clipInto(square, 0, rows, y0, y1);
        }
        double total = 0.0;
        for (const Prism& pr : prisms_) {
            total += pr.fanArea.back() * (pr.y1 - pr.y0);
            cumulative_.push_back(total);
            for (const Vec2& q : pr.poly) {
                bounds_.extend(Vec3{q.x, pr.y0, q.y});
                bounds_.extend(Vec3{q.x, pr.y1, q.y});
            }
        }
        measure_ = total;
    }

    void clipInto(const std::vector<Vec2>& poly, size_t k,
                  const std::vector<const std::vector<Interval>*>& rows, double y0, double y1) {
        if (k == views_.size()) {
            Prism pr{y0, y1, poly, {}};
            double acc = 0.0;
            for (size_t i = 1; i + 1 < poly.size(); ++i) {
                acc += 0.5 * std::abs(cross(poly[i] - poly[0], poly[i + 1] - poly[0]));
                pr.fanArea.push_back(acc);
            }
            if (acc > 0.0) prisms_.push_back(std::move(pr));
            return;
        }
        const Vec2 u = views_[k].u;
        for (const Interval& iv : *rows[k]) {
            std::vector<Vec2> q = clipHalfPlane(poly, u, iv.lo);
            if (q.size() >= 3) q = clipHalfPlane(q, u * -1.0, -iv.hi);
            if (q.size() >= 3 && polygonArea(q) > 0.0) clipInto(q, k + 1, rows, y0, y1);
        }
    }

    std::vector<View> views_;
    MaskFalloff falloff_;
    std::vector<Prism> prisms_;
    std::vector<double> cumulative_;  // running sum of prism volumes
    Aabb bounds_;
    double measure_ = 0.0;
    std::string description_;
};

}  // namespace

VolumePtr makeVisualHull(std::vector<MaskView> views, const MaskFalloff& falloff) {
    if (views.size() < 2) {
        throw MaskError("a visual hull needs at least two views, got " +
                        std::to_string(views.size()));
    }
    for (const MaskView& v : views) {
        if (!(v.metresPerPixel > 0.0)) {
            throw std::invalid_argument("makeVisualHull: metresPerPixel must be > 0");
        }
    }
    bool crossing = false;
    for (size_t i = 0; i < views.size(); ++i) {
        for (size_t j = i + 1; j < views.size(); ++j) {
            if (std::abs(std::sin((views[i].azimuthDeg - views[j].azimuthDeg) * kDeg)) > 1e-6) {
                crossing = true;
            }
        }
    }
    if (!crossing) {
        throw MaskError(
            "all views look along one line (azimuths differ by multiples of 180°), so the hull "
            "is unbounded: add a view from another side");
    }
    return std::make_shared<VisualHull>(std::move(views), falloff);
}

}  // namespace sylva
