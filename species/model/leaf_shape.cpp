// Leaf outlines. Each shape is drawn in its own natural proportions (lengths relative to the
// leaf's length, with the leaf base at x = 0 and its midrib on y = 0), triangulated by ear
// clipping, then fitted to the unit card (x scaled to [−0.5, 0.5], y by 0.5 / max |y|); the
// fit is a positive scaling, so the triangles stay counter-clockwise and cover the fitted
// parts exactly.
//
// Why ear clipping: lobed, palmate (with its petiole), compound and frond outlines are not
// star-shaped about any one point (sinuses and leaflets hide parts of the edge from every
// interior point), so a fan would overlap itself; ear clipping triangulates any simple polygon.
// It is O(n²)–O(n³) per polygon but runs once per shape (no polygon has more than 30 points).
//
// Proportions (the botanical sources are cited at each shape):
//   simple    ovate-lanceolate blade, widest below the middle, acute base, acuminate tip
//   lobed     obovate oak blade with five rounded lobes a side, sinuses halfway to the midrib
//   palmate   five-lobed maple blade (basal lobes smaller) on a short petiole
//   compound  imparipinnate leaf: petiole and rachis, five pairs of leaflets and a terminal one
//   needles   a tuft of seven needles fanning from a short shoot (pine fascicles)
//   frond     palm frond: a tapering rachis with 28 pairs of narrow pinnae, longest mid-frond
#include "species/model/leaf_shape.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

namespace sylva {

namespace {

double orient(const Vec2& a, const Vec2& b, const Vec2& c) { return cross(b - a, c - a); }

double shoelace(const Vec2* p, size_t n) {
    double s = 0;
    for (size_t i = 0; i < n; ++i) s += cross(p[i], p[(i + 1) % n]);
    return 0.5 * s;
}

// p inside or on the boundary of the counter-clockwise triangle abc.
bool inTriangle(const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c) {
    return orient(a, b, p) >= 0 && orient(b, c, p) >= 0 && orient(c, a, p) >= 0;
}

// A unimodal profile t^a (1 − t)^b on [0, 1], scaled to 1 at its peak t* = a / (a + b).
// Its integral over [0, 1] is B(a + 1, b + 1) / (t*^a (1 − t*)^b).
struct BetaProfile {
    double a, b;
    double peak() const { return a / (a + b); }
    double raw(double t) const { return std::pow(t, a) * std::pow(1.0 - t, b); }
    double operator()(double t) const { return raw(t) / raw(peak()); }
};

// n stations in (0, 1), denser towards both ends (Chebyshev points), plus `extra` (kept in
// order, not duplicated).
std::vector<double> stations(int n, std::vector<double> extra = {}) {
    std::vector<double> t;
    for (int k = 1; k <= n; ++k) t.push_back(0.5 * (1.0 - std::cos(kPi * k / (n + 1))));
    for (double e : extra) t.push_back(e);
    std::sort(t.begin(), t.end());
    t.erase(std::unique(t.begin(), t.end(), [](double x, double y) { return y - x < 1e-9; }),
            t.end());
    return t;
}

// A blade along the axis from `base` in the unit direction `dir`, `length` long: at the
// stations t ∈ (0, 1) of each side (0: right of the axis, 1: left) the half-width is
// halfWidth · w(t, side); pointed at the base and the tip. Counter-clockwise.
std::vector<Vec2> blade(const Vec2& base, const Vec2& dir, double length, double halfWidth,
                        const std::function<double(double, int)>& w,
                        const std::vector<double>& right, const std::vector<double>& left) {
    const Vec2 l{-dir.y, dir.x};
    std::vector<Vec2> poly{base};
    for (double t : right) poly.push_back(base + dir * (t * length) - l * (halfWidth * w(t, 0)));
    poly.push_back(base + dir * length);
    for (auto it = left.rbegin(); it != left.rend(); ++it) {
        poly.push_back(base + dir * (*it * length) + l * (halfWidth * w(*it, 1)));
    }
    return poly;
}

std::vector<Vec2> counterClockwise(std::vector<Vec2> poly) {
    if (shoelace(poly.data(), poly.size()) < 0) std::reverse(poly.begin(), poly.end());
    return poly;
}

// Triangulates the parts (in their natural proportions) and fits them to the unit card.
LeafOutline assemble(const std::vector<std::vector<Vec2>>& parts) {
    LeafOutline o;
    double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, yMax = 0;
    for (const auto& part : parts) {
        const uint32_t first = static_cast<uint32_t>(o.points.size());
        o.parts.push_back(first);
        for (uint32_t i : triangulatePolygon(part)) o.triangles.push_back(first + i);
        for (const Vec2& p : part) {
            o.points.push_back(p);
            x0 = std::min(x0, p.x);
            x1 = std::max(x1, p.x);
            yMax = std::max(yMax, std::abs(p.y));
        }
    }
    o.parts.push_back(static_cast<uint32_t>(o.points.size()));
    o.naturalAspect = 2 * yMax / (x1 - x0);
    const double sx = 1.0 / (x1 - x0), sy = 0.5 / yMax;
    for (Vec2& p : o.points) p = {(p.x - x0) * sx - 0.5, p.y * sy};
    for (size_t k = 0; k + 1 < o.parts.size(); ++k) {
        o.area += shoelace(o.points.data() + o.parts[k], o.parts[k + 1] - o.parts[k]);
    }
    return o;
}

// The card: the unit square, two triangles (0, 1, 2), (0, 2, 3), as leaf cards always were.
LeafOutline card() {
    LeafOutline o;
    o.points = {{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};
    o.parts = {0, 4};
    o.triangles = {0, 1, 2, 0, 2, 3};
    o.area = 1.0;
    return o;
}

// Simple: ovate to lanceolate ("widest below the middle of the blade", ovate 1.5–2 times as
// long as wide, lanceolate 3–6 times: Northern Ontario Plant Database, Leaf Shapes; aspect
// chooses between them), the base acute and the apex acuminate as in the mango ("narrow
// oblong-elliptic or lanceolate, apex gradually acuminate, base acute": Biotik, Mangifera
// indica). Profile t^0.8 (1 − t)^1.25: widest at t = 0.39, convex to an acute base, concave
// into an acuminate tip. Drawn at aspect 0.5; any aspect keeps the profile's form.
constexpr BetaProfile kSimple{0.8, 1.25};

LeafOutline simple(int res) {
    const auto t = stations(5 * res, {kSimple.peak()});
    auto w = [](double u, int) { return kSimple(u); };
    return assemble({blade({0, 0}, {1, 0}, 1.0, 0.25, w, t, t)});
}

// Lobed: Quercus robur, "obovate to oblong, … 3 to 7 pairs of rounded lobes with sinuses
// going halfway to midvein, very small ear-lobes at leaf base" (Virginia Tech Dendrology,
// English oak), 6–12 cm long and 6–8 cm wide (VicFlora). An obovate envelope t^1.2 (1 − t)^0.5
// (widest at t = 0.71, narrow base, rounded apex) times 1 − d (1 − |sin(π n (t − φ))|^½):
// n = 5 lobes a side (four sinuses, the last lobe the apex), round-topped by the square root,
// with notched sinuses reaching d = 0.5 of the way to the midrib; the two sides offset by
// φ = ±0.025 so the lobes alternate slightly. Natural aspect ≈ 0.6.
constexpr BetaProfile kOakEnvelope{1.2, 0.5};
constexpr int kOakLobes = 5;
constexpr double kOakSinus = 0.5, kOakPhase = 0.025;

LeafOutline lobed(int res) {
    const double phase[2] = {kOakPhase, -kOakPhase};
    auto w = [&](double t, int side) {
        const double s = std::sqrt(std::abs(std::sin(kPi * kOakLobes * (t - phase[side]))));
        return kOakEnvelope(t) * (1.0 - kOakSinus * (1.0 - s));
    };
    std::vector<double> side[2];
    for (int k = 0; k < 2; ++k) {
        // Breakpoints: the base, every sinus, the tip; three points inside each lobe.
        std::vector<double> cut{0.0};
        for (int j = 1; j < kOakLobes; ++j) cut.push_back(phase[k] + double(j) / kOakLobes);
        cut.push_back(1.0);
        const int inner = 2 * res;
        for (size_t j = 0; j + 1 < cut.size(); ++j) {
            if (j > 0) side[k].push_back(cut[j]);
            for (int q = 1; q <= inner; ++q) {
                side[k].push_back(cut[j] + (cut[j + 1] - cut[j]) * q / (inner + 1));
            }
        }
    }
    return assemble({blade({0, 0}, {1, 0}, 1.0, 0.3, w, side[0], side[1])});
}

// Palmate: a maple blade, "5-lobed … base cordate or with very wide sinus, lobes … acuminate"
// (Acer platanoides, Türkiye Bitkileri), as long as broad with "basal lobes smaller than the
// upper lobes" and pointed lobes (sugar maple, leaf-id.com); "the leaf veins go star-shaped
// from the leaf base" (Cappadocian maple, leaf-id.com). Five lobes radiate from the top of the
// petiole at 0°, ±60° and ±122° (θ = 0 towards the tip), each a blade of length L and
// half-width W with the profile t^0.45 (1 − t)^1.1 (broad near its base, acuminate tip):
// L, W = 1, 0.21 (middle), 0.9, 0.2 (upper laterals) and 0.55, 0.12 (basal). The outline is
// their union with a disc of radius 0.3 about the centre: star-shaped about it, so r(θ) is the
// largest of the lobes' radial functions and the disc's. Adjacent lobes meet in sinuses 0.38–
// 0.41 from the centre, about 60 % of the way in. A petiole 0.5 long and 0.024 wide (the real
// one is about as long as the blade; shortened so the blade fills most of the card). Natural
// aspect ≈ 0.87.
struct Lobe {
    double angle, length, halfWidth;  // radians, blade units, blade units
};
constexpr double kDeg = kPi / 180;
constexpr BetaProfile kMapleLobe{0.45, 1.1};
const std::array<Lobe, 5> kMapleLobes = {{{-122 * kDeg, 0.55, 0.12},
                                          {-60 * kDeg, 0.9, 0.2},
                                          {0, 1.0, 0.21},
                                          {60 * kDeg, 0.9, 0.2},
                                          {122 * kDeg, 0.55, 0.12}}};
constexpr double kMapleDisc = 0.3, kMaplePetiole = 0.5, kMaplePetioleHalfWidth = 0.012;

// Distance from the lobe's base along the ray at angle th to the lobe's outermost edge point
// (0 if the ray misses it).
double lobeRadius(const Lobe& l, double th) {
    const double phi = std::remainder(th - l.angle, 2 * kPi);
    const double c = std::cos(phi), s = std::abs(std::sin(phi));
    if (c <= 0) return 0;
    // Inside where ρ s ≤ W p(ρ c / L), for ρ c ≤ L: scan down from the far end, then bisect.
    auto inside = [&](double rho) {
        return rho * s <= l.halfWidth * kMapleLobe(rho * c / l.length);
    };
    const double far = l.length / c;
    constexpr int kScan = 400;
    for (int k = kScan; k > 0; --k) {
        double hi = far * k / kScan, lo = far * (k - 1) / kScan;
        if (!inside(lo)) continue;
        if (k == kScan && s == 0) return l.length;
        for (int it = 0; it < 60; ++it) {
            const double mid = 0.5 * (lo + hi);
            (inside(mid) ? lo : hi) = mid;
        }
        return lo;
    }
    return 0;
}

LeafOutline palmate(int res) {
    auto r = [](double th) {
        double v = kMapleDisc;
        for (const Lobe& l : kMapleLobes) v = std::max(v, lobeRadius(l, th));
        return v;
    };
    // Angles: each lobe's tip and the directions of its edge points at its own stations, the
    // middle of every sinus, and the base arc; θ within ±(π − δ), where the petiole's edges
    // meet the disc.
    const double delta = std::asin(kMaplePetioleHalfWidth / kMapleDisc);
    std::vector<double> th{-kPi + delta, kPi - delta};
    const auto t = stations(res);
    for (size_t i = 0; i < kMapleLobes.size(); ++i) {
        const Lobe& l = kMapleLobes[i];
        th.push_back(l.angle);
        for (double u : t) {
            const double off = std::atan2(l.halfWidth * kMapleLobe(u), u * l.length);
            th.push_back(l.angle - off);
            th.push_back(l.angle + off);
        }
        if (i + 1 < kMapleLobes.size()) th.push_back(0.5 * (l.angle + kMapleLobes[i + 1].angle));
    }
    const double baseLo = kMapleLobes.back().angle, baseHi = kPi - delta;
    for (int q = 1; q <= 2 * res; ++q) {
        const double a = baseLo + (baseHi - baseLo) * (0.5 + 0.5 * q / (2 * res + 1));
        th.push_back(a);
        th.push_back(-a);
    }
    std::sort(th.begin(), th.end());
    th.erase(std::unique(th.begin(), th.end(), [](double a, double b) { return b - a < 1e-9; }),
             th.end());
    std::vector<Vec2> poly;
    for (double a : th) {
        if (a < -kPi + delta || a > kPi - delta) continue;
        poly.push_back(Vec2{std::cos(a), std::sin(a)} * r(a));
    }
    // The petiole, from the disc at θ = π back to the leaf base.
    const double xb = -kMapleDisc - kMaplePetiole;
    poly.push_back({xb, kMaplePetioleHalfWidth});
    poly.push_back({xb, -kMaplePetioleHalfWidth});
    return assemble({poly});
}

// Compound: imparipinnate, Fraxinus excelsior: "pinnate with 9–15 leaflets, with a terminal
// leaflet; leaflets lanceolate, stalkless" (Flora of the Burren), leaves 20–35 cm with
// leaflets 3–12 × 0.8–3 cm, "usually 3–6 pairs of leaflets" (Woodland Trust); the neem's are
// alike, 7–15 leaflets of 4.5–7.5 × 1.5–2.5 cm on a 14–30 cm rachis (Azadirachta indica,
// NGC campus flora). Five pairs and a terminal leaflet: a petiole to the first pair at 0.22 of
// the length, pairs 0.12 apart at 55° to the rachis, leaflets 0.26 long (the lowest pair 0.8 of
// that) and 0.3 as wide as long, profile t^1 (1 − t)^1.3 (attenuate base, acuminate tip),
// sampled at a third and two thirds of its length (six points, four triangles a leaflet).
// The rachis is a quad 0.016 wide tapering to 0.008 under the terminal leaflet. Natural
// aspect ≈ 0.5.
constexpr BetaProfile kLeaflet{1.0, 1.3};
constexpr int kLeafletPairs = 5;
constexpr double kLeafletLength = 0.26, kLeafletWidth = 0.3, kLeafletAngle = 55 * kDeg;
constexpr double kFirstPair = 0.22, kPairSpacing = 0.12;

LeafOutline compound(int res) {
    const double xT = 1.0 - kLeafletLength;  // the terminal leaflet's base
    const double r0 = 0.008, r1 = 0.004;     // rachis half-widths at the base and at xT
    auto rachis = [&](double x) { return r0 + (r1 - r0) * x / xT; };
    std::vector<double> t;  // evenly spaced: two points a side give a lanceolate leaflet
    for (int k = 1; k <= 2 * res; ++k) t.push_back(double(k) / (2 * res + 1));
    auto w = [](double u, int) { return kLeaflet(u); };
    std::vector<std::vector<Vec2>> parts;
    parts.push_back({{0, -r0}, {xT, -r1}, {xT, r1}, {0, r0}});
    for (int k = 0; k < kLeafletPairs; ++k) {
        const double x = kFirstPair + kPairSpacing * k;
        const double len = kLeafletLength * (0.8 + 0.2 * k / (kLeafletPairs - 1));
        for (double s : {-1.0, 1.0}) {
            const Vec2 dir{std::cos(kLeafletAngle), s * std::sin(kLeafletAngle)};
            parts.push_back(counterClockwise(
                blade({x, s * rachis(x)}, dir, len, 0.5 * kLeafletWidth * len, w, t, t)));
        }
    }
    parts.push_back(
        blade({xT, 0}, {1, 0}, kLeafletLength, 0.5 * kLeafletWidth * kLeafletLength, w, t, t));
    return assemble(parts);
}

// Needles: a tuft of pine needles on a short shoot. Pinus sylvestris needles are "2.5–5 cm
// long and 1–2 mm broad, produced in fascicles of two" (twice as long on vigorous trees), 4–8
// cm and "up to 2 mm wide … pointed" in other descriptions; a pine's short shoots carry "2–5
// perennial needles" (Lamedon, Pinus). Seven needles (three and a half fascicles) bundled at
// a base 0.1 wide fan out to tips spread over ±0.16: each a thin kite (two triangles), 0.03 of
// its length wide at 0.4 of it (1.8 mm on a 6 cm needle), narrow into the sheath and pointed
// at the tip; outer needles 8 % shorter. Natural aspect ≈ 0.32.
constexpr int kNeedles = 7;
constexpr double kNeedleHalfWidth = 0.015, kNeedleWidest = 0.4, kNeedleBaseSpacing = 0.017,
                 kNeedleSpread = 0.16;

LeafOutline needles(int) {
    std::vector<std::vector<Vec2>> parts;
    const double c = 0.5 * (kNeedles - 1);
    for (int i = 0; i < kNeedles; ++i) {
        const double u = (i - c) / c;  // −1 … 1 across the tuft
        const Vec2 base{0, (i - c) * kNeedleBaseSpacing};
        const Vec2 tip{1.0 - 0.08 * u * u, u * kNeedleSpread};
        const Vec2 d = tip - base;
        const Vec2 dir = d * (1.0 / length(d)), l{-dir.y, dir.x};
        const Vec2 widest = base + d * kNeedleWidest;
        parts.push_back({base, widest - l * kNeedleHalfWidth, tip, widest + l * kNeedleHalfWidth});
    }
    return assemble(parts);
}

// Frond: Cocos nucifera, "pinnate leaves 4–6 m long, pinnae 60–90 cm long" (coconut palm,
// plants.swtexture.com), "leaflets … 60–100 × 2.5–5 cm, base narrow, apex tapering, acute"
// (MACFAST tree register), "80 to 100 pairs of leaflets" and a petiole of 90–150 cm (Garden
// Flora Online). A bare petiole for the first 0.22 of the length, then 28 pairs of pinnae (a
// third of the real number, to keep to tens of triangles) at 50° to the rachis, each a
// triangle 0.012 wide at the rachis (a mean width of 3 cm on a 5 m frond), 0.19 long
// mid-frond and 0.3 of that at both ends (ℓ = 0.19 (0.3 + 0.7 sin πu) along the leafy part,
// u ∈ (0, 1)); a rachis 0.024 wide tapering to 0.006. Natural aspect ≈ 0.3.
constexpr int kPinnaPairs = 28;
constexpr double kPetiole = 0.22, kPinnaLength = 0.19, kPinnaBase = 0.012, kPinnaAngle = 50 * kDeg;

LeafOutline frond(int) {
    const double r0 = 0.012, r1 = 0.003;  // rachis half-widths at the base and the tip
    auto rachis = [&](double x) { return r0 + (r1 - r0) * x; };
    std::vector<std::vector<Vec2>> parts;
    parts.push_back({{0, -r0}, {1, -r1}, {1, r1}, {0, r0}});
    const double spacing = (1.0 - kPetiole) / kPinnaPairs;
    for (int k = 0; k < kPinnaPairs; ++k) {
        const double u = (k + 0.5) / kPinnaPairs, x = kPetiole + spacing * (k + 0.5);
        const double len = kPinnaLength * (0.3 + 0.7 * std::sin(kPi * u));
        for (double s : {-1.0, 1.0}) {
            const double xa = x - 0.5 * kPinnaBase, xb = x + 0.5 * kPinnaBase;
            const Vec2 apex = Vec2{x, s * rachis(x)} +
                              Vec2{std::cos(kPinnaAngle), s * std::sin(kPinnaAngle)} * len;
            parts.push_back(counterClockwise({{xa, s * rachis(xa)}, apex, {xb, s * rachis(xb)}}));
        }
    }
    return assemble(parts);
}

}  // namespace

std::vector<uint32_t> triangulatePolygon(const std::vector<Vec2>& poly) {
    const size_t n = poly.size();
    if (n < 3) throw std::invalid_argument("triangulatePolygon: fewer than three points");
    std::vector<uint32_t> ring(n), tris;
    for (size_t i = 0; i < n; ++i) ring[i] = static_cast<uint32_t>(i);
    tris.reserve(3 * (n - 2));
    while (ring.size() > 3) {
        const size_t m = ring.size();
        size_t best = m;
        double bestDiagonal = std::numeric_limits<double>::infinity();
        for (size_t i = 0; i < m; ++i) {
            const uint32_t a = ring[(i + m - 1) % m], b = ring[i], c = ring[(i + 1) % m];
            if (!(orient(poly[a], poly[b], poly[c]) > 0)) continue;  // reflex or collinear
            const Vec2 ac = poly[c] - poly[a];
            const double diagonal = dot(ac, ac);
            if (!(diagonal < bestDiagonal)) continue;
            bool ear = true;
            for (size_t k = 0; ear && k < m; ++k) {
                const uint32_t v = ring[k];
                if (v != a && v != b && v != c) {
                    ear = !inTriangle(poly[v], poly[a], poly[b], poly[c]);
                }
            }
            if (ear) {
                best = i;
                bestDiagonal = diagonal;
            }
        }
        if (best == m) throw std::invalid_argument("triangulatePolygon: no ear (not simple?)");
        tris.insert(tris.end(), {ring[(best + m - 1) % m], ring[best], ring[(best + 1) % m]});
        ring.erase(ring.begin() + static_cast<std::ptrdiff_t>(best));
    }
    if (!(orient(poly[ring[0]], poly[ring[1]], poly[ring[2]]) > 0)) {
        throw std::invalid_argument("triangulatePolygon: degenerate last triangle");
    }
    tris.insert(tris.end(), ring.begin(), ring.end());
    return tris;
}

LeafOutline buildLeafOutline(LeafShape shape, int resolution) {
    const int res = std::max(1, resolution);
    switch (shape) {
        case LeafShape::kCard:
            return card();
        case LeafShape::kSimple:
            return simple(res);
        case LeafShape::kLobed:
            return lobed(res);
        case LeafShape::kPalmate:
            return palmate(res);
        case LeafShape::kCompound:
            return compound(res);
        case LeafShape::kNeedles:
            return needles(res);
        case LeafShape::kFrond:
            return frond(res);
    }
    throw std::invalid_argument("buildLeafOutline: unknown shape");
}

const std::vector<std::pair<std::string, LeafShape>>& leafShapeWords() {
    static const std::vector<std::pair<std::string, LeafShape>> words = {
        {"card", LeafShape::kCard},         {"simple", LeafShape::kSimple},
        {"lobed", LeafShape::kLobed},       {"palmate", LeafShape::kPalmate},
        {"compound", LeafShape::kCompound}, {"needles", LeafShape::kNeedles},
        {"frond", LeafShape::kFrond}};
    return words;
}

const LeafOutline& leafOutline(LeafShape shape) {
    static const std::vector<LeafOutline> outlines = [] {
        std::vector<LeafOutline> v;
        for (const auto& [word, s] : leafShapeWords()) v.push_back(buildLeafOutline(s));
        return v;
    }();
    const size_t i = static_cast<size_t>(shape);
    if (i >= outlines.size()) throw std::invalid_argument("leafOutline: unknown shape");
    return outlines[i];
}

LeafFrame leafFrame(const Leaf& leaf) {
    // Orthonormalised defensively: the card must stay flat and keep its proportions.
    LeafFrame f;
    f.normal = normalize(leaf.normal);
    const Vec3 t = leaf.tangent - f.normal * dot(leaf.tangent, f.normal);
    f.tangent = length2(t) > 1e-24 ? normalize(t) : anyPerpendicular(f.normal);
    f.across = cross(f.normal, f.tangent);
    return f;
}

void leafPoints(const Leaf& leaf, const LeafFrame& frame, const LeafOutline& outline,
                std::vector<Vec3>& out) {
    out.clear();
    const double length = leaf.size, width = leaf.size * leaf.aspect;
    for (const Vec2& p : outline.points) {
        out.push_back(leaf.position + frame.tangent * (p.x * length) +
                      frame.across * (p.y * width));
    }
}

double leafArea(const Leaf& leaf) {
    return leaf.size * leaf.size * leaf.aspect * leafOutline(leaf.shape).area;
}

}  // namespace sylva
