// Guides for the `space-colonization` method (Liu et al. 2020 §4.3): brush-stroke markers
// weighted by their distance to the stroke (Figs 11–13) and silhouette markers spread around
// the masked pixels with the logistic fall-off (Fig. 15). Conventions in the header.
#include "species/methods/space_colonization_guides.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "species/spec/volume_spec.h"

namespace sylva {

namespace {

// More markers than this from one guide is a unit mistake, not a crown.
constexpr double kMaxGuideMarkers = 1e7;

// Squared distance from p to segment [a, b] (b ≠ a or not).
double squaredDistanceToSegment(const Vec3& p, const Vec3& a, const Vec3& b) {
    const Vec3 ab = b - a;
    const double l2 = length2(ab);
    const double t = l2 > 0 ? std::clamp(dot(p - a, ab) / l2, 0.0, 1.0) : 0.0;
    return distance2(p, a + ab * t);
}

}  // namespace

NearestSegment nearestSegment(const std::vector<Vec3>& polyline, const Vec3& p) {
    NearestSegment best{std::sqrt(distance2(p, polyline.front())), 0};
    double bestD2 = INFINITY;
    for (size_t i = 0; i + 1 < polyline.size(); ++i) {
        if (polyline[i] == polyline[i + 1]) continue;  // no direction: its neighbours cover it
        const double d2 = squaredDistanceToSegment(p, polyline[i], polyline[i + 1]);
        if (d2 < bestD2) {
            bestD2 = d2;
            best = {std::sqrt(d2), i};
        }
    }
    return best;
}

// Liu 2020 §4.3 "weighed ... according to d_i using the normal distribution", with d in units
// of σ (see the header for why).
double strokeWeight(double d, double sigma, double weight) {
    const double u = d / sigma;
    return weight * std::exp(-0.5 * u * u) / std::sqrt(2.0 * kPi);
}

std::vector<GuideMarker> strokeMarkers(const BrushStroke& stroke, Rng& rng) {
    const std::vector<Vec3>& pts = stroke.points;
    const double r = stroke.radius;
    const double sigma = stroke.sigma > 0 ? stroke.sigma : r / 2;
    std::vector<GuideMarker> out;
    if (pts.size() < 2 || !(r > 0)) return out;

    // Capsule volumes πr²L + 4/3·πr³ of the non-degenerate segments: a candidate is drawn in
    // one capsule chosen by volume and kept only if that capsule's segment is its nearest, so
    // the kept points are uniform over the union (each point is owned by exactly one segment).
    std::vector<size_t> segs;
    std::vector<double> cumulative;
    double length = 0.0, total = 0.0;
    for (size_t i = 0; i + 1 < pts.size(); ++i) {
        const double l = distance(pts[i], pts[i + 1]);
        if (!(l > 0)) continue;
        length += l;
        total += kPi * r * r * l + 4.0 / 3.0 * kPi * r * r * r;
        segs.push_back(i);
        cumulative.push_back(total);
    }
    const long count = std::lround(stroke.density * length);
    if (segs.empty() || count <= 0) return out;
    out.reserve(static_cast<size_t>(count));

    while (static_cast<long>(out.size()) < count) {
        const double pick = rng.uniform(0.0, total);
        size_t k =
            std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin();
        if (k >= segs.size()) k = segs.size() - 1;
        const size_t s = segs[k];
        const Vec3 a = pts[s], b = pts[s + 1];
        const double l = distance(a, b);
        const Vec3 axis = (b - a) / l;
        const Vec3 u = anyPerpendicular(axis), w = cross(axis, u);
        // Uniform in the capsule: rejection from its box in the segment's frame.
        const double t = rng.uniform(-r, l + r);
        const double x = rng.uniform(-r, r), z = rng.uniform(-r, r);
        const Vec3 p = a + axis * t + u * x + w * z;
        const double along = std::clamp(t, 0.0, l);
        if (distance2(p, a + axis * along) > r * r) continue;
        const NearestSegment n = nearestSegment(pts, p);
        if (n.segment != s) continue;
        GuideMarker m;
        m.position = p;
        m.direction = axis;  // the stroke's drawing direction at the marker (Fig. 13)
        m.weight = strokeWeight(n.distance, sigma, stroke.weight);
        out.push_back(m);
    }
    return out;
}

Vec3 silhouetteToTree(const SilhouetteGuide& g, double column, double row, double depth) {
    const double a = g.azimuthDeg * kPi / 180.0;
    const Vec3 right{std::cos(a), 0.0, -std::sin(a)};
    const Vec3 toViewer{std::sin(a), 0.0, std::cos(a)};
    const double axis = g.axisColumn < 0 ? g.mask.width / 2.0 : g.axisColumn;
    const double across = (column - axis) * g.metresPerPixel;
    const double up = (g.mask.height - row) * g.metresPerPixel;
    return right * across + Vec3{0.0, up, 0.0} + toViewer * depth;
}

std::vector<GuideMarker> silhouetteMarkers(const SilhouetteGuide& g, Rng& rng) {
    const Mask& mask = g.mask;
    const std::vector<uint8_t> n = unmaskedNeighbourCounts(mask);
    const double depth = g.depth < 0 ? mask.width * g.metresPerPixel / 2 : g.depth;
    // Per row: the middle and half extent (pixels) of its masked pixels, for the round profile.
    const bool round = g.depthProfile == SilhouetteGuide::DepthProfile::kRound;
    std::vector<double> middle(mask.height, 0.0), halfExtent(mask.height, 0.0);
    double widest = 0.0;
    for (int row = 0; row < mask.height; ++row) {
        int lo = mask.width, hi = -1;
        for (int column = 0; column < mask.width; ++column) {
            if (mask.at(column, row)) {
                lo = std::min(lo, column);
                hi = column;
            }
        }
        if (hi < lo) continue;
        middle[row] = (lo + hi + 1) / 2.0;
        halfExtent[row] = (hi + 1 - lo) / 2.0;
        widest = std::max(widest, halfExtent[row]);
    }
    // The full spread across the view at a pixel centre (metres).
    auto spread = [&](int column, int row) {
        if (!round) return depth;
        const double t = (column + 0.5 - middle[row]) / halfExtent[row];
        return depth * halfExtent[row] / widest * std::sqrt(std::max(0.0, 1.0 - t * t));
    };
    std::vector<GuideMarker> out;
    out.reserve(static_cast<size_t>(g.markersPerPixel * mask.count()) + 1);
    double carry = 0.0;  // fractional markers carried from pixel to pixel
    for (int row = 0; row < mask.height; ++row) {
        for (int column = 0; column < mask.width; ++column) {
            if (!mask.at(column, row)) continue;
            carry += g.markersPerPixel;
            const int k = static_cast<int>(std::floor(carry + 1e-9));
            carry -= k;
            // Liu 2020 §4.3: r_m(x) = R·(1/(1 + e^(−k·n_x)) − 0.5) pixels, 0 deep inside.
            const double rm =
                falloffRadius(n[static_cast<size_t>(row) * mask.width + column], g.falloff);
            for (int i = 0; i < k; ++i) {
                const Vec3 ball = rm > 0 ? uniformInBall(rng, rm) : Vec3{};
                const double half = spread(column, row) / 2;
                const double across = half > 0 ? rng.uniform(-half, half) : 0.0;
                GuideMarker m;
                m.position = silhouetteToTree(g, column + 0.5 + ball.x, row + 0.5 + ball.y,
                                              across + ball.z * g.metresPerPixel);
                out.push_back(m);  // no direction, weight 0: space only
            }
        }
    }
    return out;
}

namespace {

// points = [[x, y, z], ...], at least two, finite.
std::vector<Vec3> readPolyline(Params& p, const char* key) {
    const toml::node* node = p.raw(key);
    if (!node) p.fail(key, "missing: expected an array of [x, y, z] points (metres), at least 2");
    const toml::array* a = node->as_array();
    if (!a) p.fail(key, "expected an array of [x, y, z] points (metres)");
    std::vector<Vec3> out;
    for (size_t i = 0; i < a->size(); ++i) {
        const toml::array* q = a->get(i)->as_array();
        bool ok = q && q->size() == 3;
        Vec3 v;
        for (int j = 0; ok && j < 3; ++j) {
            ok = q->get(j)->is_number();
            if (ok) v[j] = q->get(j)->value<double>().value_or(NAN);
            ok = ok && std::isfinite(v[j]) && std::abs(v[j]) <= kMaxSpecMagnitude;
        }
        if (!ok) {
            throw SpecError(sourceOf(*a->get(i), p.file()), p.path(key),
                            "item " + std::to_string(i) +
                                ": expected [x, y, z], three finite numbers (metres) of "
                                "magnitude at most 1e9");
        }
        out.push_back(v);
    }
    if (out.size() < 2) {
        p.fail(key, "a stroke needs at least 2 points, got " + std::to_string(out.size()));
    }
    return out;
}

BrushStroke readStroke(Params& s) {
    BrushStroke b;
    b.points = readPolyline(s, "points");
    b.radius = s.number("radius", Range::positive());
    b.density = s.number("density", Range::positive());
    b.sigma = s.number("sigma", b.radius / 2, Range::positive());
    b.weight = s.number("weight", b.weight, Range::nonNegative());
    double length = 0.0;
    for (size_t i = 0; i + 1 < b.points.size(); ++i) {
        length += distance(b.points[i], b.points[i + 1]);
    }
    if (!(length > 0)) s.fail("points", "the stroke has length 0 (all points coincide)");
    if (b.density * length > kMaxGuideMarkers) {
        s.fail("density", "density × stroke length is over 10⁷ markers (density is per metre)");
    }
    s.finish();
    return b;
}

SilhouetteGuide readSilhouette(Params& p) {
    SilhouetteGuide g;
    g.mask = readMaskKeys(p);
    g.metresPerPixel = readPixelScale(p, "the mask's").metresPerPixel(g.mask.height);
    g.azimuthDeg = p.number("azimuth_deg", g.azimuthDeg, Range::closed(-360, 360));
    g.axisColumn = p.number("axis_column", g.mask.width / 2.0, Range::closed(0, g.mask.width));
    g.falloff.radius = p.number("falloff_radius", g.falloff.radius, Range::nonNegative());
    g.falloff.k = p.number("falloff_k", g.falloff.k, Range::positive());
    g.markersPerPixel = p.number("markers_per_pixel", g.markersPerPixel, Range::leftOpen(0, 1000));
    g.depth = p.number("depth", g.mask.width * g.metresPerPixel / 2, Range::nonNegative());
    g.depthProfile = p.choice("depth_profile", g.depthProfile,
                              {{"slab", SilhouetteGuide::DepthProfile::kSlab},
                               {"round", SilhouetteGuide::DepthProfile::kRound}});
    if (g.markersPerPixel * g.mask.count() > kMaxGuideMarkers) {
        p.fail("markers_per_pixel", "markers_per_pixel × masked pixels is over 10⁷ markers");
    }
    p.finish();
    return g;
}

}  // namespace

std::vector<GuideMarker> parseGuides(Params& guides, Rng& rng) {
    std::vector<GuideMarker> out;
    std::vector<Params> strokes = guides.tableArray("strokes");
    for (size_t i = 0; i < strokes.size(); ++i) {
        const BrushStroke b = readStroke(strokes[i]);
        Rng r = rng.derive("strokes[" + std::to_string(i) + "]");
        std::vector<GuideMarker> m = strokeMarkers(b, r);
        out.insert(out.end(), m.begin(), m.end());
    }
    if (auto s = guides.optionalTable("silhouette")) {
        const SilhouetteGuide g = readSilhouette(*s);
        Rng r = rng.derive("silhouette");
        std::vector<GuideMarker> m = silhouetteMarkers(g, r);
        out.insert(out.end(), m.begin(), m.end());
    }
    guides.finish();
    return out;
}

}  // namespace sylva
