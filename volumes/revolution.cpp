// Surfaces of revolution of a sketched stroke (Xu & Mould 2012 §3.3.1, Figure 8): stroke
// cleaning, the revolved CGAL Surface_mesh with its Polygon Mesh Processing checks, the
// OpenVDB level set of that mesh, and the SVG / image stroke readers.
#include "volumes/revolution.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>

#include "core/errors.h"
#include "core/input_file.h"
#include "volumes/image_file.h"
#include "volumes/level_set_grid.h"

namespace sylva {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;

std::string format(const char* fmt, ...) {
    char buf[512];
    va_list args;
    va_start(args, fmt);
    std::vsnprintf(buf, sizeof buf, fmt, args);
    va_end(args);
    return buf;
}

[[noreturn]] void fail(const std::string& message) { throw StrokeError(message); }

// Limits on a drawn SVG stroke, far above any drawing (the shipped umbrella.svg: 1 kB, 60
// points), so a hostile file fails at once instead of filling memory.
constexpr size_t kMaxSvgBytes = size_t(16) << 20;  // 16 MiB
constexpr size_t kMaxSvgPoints = 100000;           // after flattening curves
constexpr double kMaxSvgCoordinate = 1e9;          // SVG user units

// Largest extent of the points' bounding box (the length scale for tolerances).
double extent(const std::vector<Vec2>& pts) {
    if (pts.empty()) return 0.0;
    Vec2 lo = pts[0], hi = pts[0];
    for (const Vec2& p : pts) {
        lo = {std::min(lo.x, p.x), std::min(lo.y, p.y)};
        hi = {std::max(hi.x, p.x), std::max(hi.y, p.y)};
    }
    return std::max(hi.x - lo.x, hi.y - lo.y);
}

// --- cleaning ---------------------------------------------------------------------------------

std::vector<Vec2> resample(const std::vector<Vec2>& pts, int samples) {
    std::vector<double> along(pts.size(), 0.0);
    for (size_t i = 1; i < pts.size(); ++i) along[i] = along[i - 1] + length(pts[i] - pts[i - 1]);
    const double total = along.back();
    std::vector<Vec2> out;
    out.reserve(samples);
    size_t seg = 0;
    for (int k = 0; k < samples; ++k) {
        const double s = total * k / (samples - 1);
        while (seg + 2 < pts.size() && along[seg + 1] < s) ++seg;
        const double len = along[seg + 1] - along[seg];
        const double t = len > 0 ? std::clamp((s - along[seg]) / len, 0.0, 1.0) : 0.0;
        out.push_back(pts[seg] + (pts[seg + 1] - pts[seg]) * t);
    }
    out.front() = pts.front();  // exact ends, whatever the rounding of the arc lengths
    out.back() = pts.back();
    return out;
}

void smooth(std::vector<Vec2>& pts, int passes) {
    std::vector<Vec2> next = pts;
    for (int pass = 0; pass < passes; ++pass) {
        for (size_t i = 1; i + 1 < pts.size(); ++i)
            next[i] = pts[i - 1] * 0.25 + pts[i] * 0.5 + pts[i + 1] * 0.25;
        pts.swap(next);
    }
}

// Where the closed segments a–b and c–d meet (touching counts), if they do; `eps` is the
// area tolerance of the orientation tests.
std::optional<Vec2> segmentsMeet(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d,
                                 double eps) {
    auto orient = [&](const Vec2& p, const Vec2& q, const Vec2& r) {
        const double o = cross(q - p, r - p);
        return std::abs(o) <= eps ? 0 : (o > 0 ? 1 : -1);
    };
    const int o1 = orient(a, b, c), o2 = orient(a, b, d);
    const int o3 = orient(c, d, a), o4 = orient(c, d, b);
    if (o1 == 0 && o2 == 0) {
        // Collinear: overlap of the projections on the longer direction.
        const Vec2 dir = b - a;
        const double l2 = dot(dir, dir);
        if (l2 == 0) return std::nullopt;
        double t0 = dot(c - a, dir) / l2, t1 = dot(d - a, dir) / l2;
        if (t0 > t1) std::swap(t0, t1);
        const double lo = std::max(0.0, t0), hi = std::min(1.0, t1);
        if (lo > hi + 1e-12) return std::nullopt;
        return a + dir * (0.5 * (lo + hi));
    }
    if (o1 * o2 > 0 || o3 * o4 > 0) return std::nullopt;
    // They meet: the crossing of the two lines (or the touching end point).
    const Vec2 r = b - a, s = d - c;
    const double den = cross(r, s);
    if (std::abs(den) < 1e-300) return a;
    const double t = std::clamp(cross(c - a, s) / den, 0.0, 1.0);
    return a + r * t;
}

// Polygon area (positive counter-clockwise) and ∫∫ x dA of the closed polygon.
void polygonMoments(const std::vector<Vec2>& poly, double* area, double* firstMomentX) {
    double a = 0, mx = 0;
    for (size_t i = 0; i < poly.size(); ++i) {
        const Vec2& p = poly[i];
        const Vec2& q = poly[(i + 1) % poly.size()];
        const double c = cross(p, q);
        a += c;
        mx += (p.x + q.x) * c;
    }
    *area = 0.5 * a;
    *firstMomentX = mx / 6.0;
}

}  // namespace

std::vector<Vec2> cleanStroke(const std::vector<Vec2>& stroke, const StrokeCleaning& options) {
    if (options.samples < 4) throw std::invalid_argument("cleanStroke: samples must be >= 4");
    if (options.smoothing < 0) throw std::invalid_argument("cleanStroke: smoothing must be >= 0");
    if (!(options.closeTolerance >= 0) || !std::isfinite(options.closeTolerance))
        throw std::invalid_argument("cleanStroke: closeTolerance must be finite and >= 0");
    if (stroke.empty()) fail("the stroke is empty");
    for (size_t i = 0; i < stroke.size(); ++i) {
        if (!std::isfinite(stroke[i].x) || !std::isfinite(stroke[i].y))
            fail(format("point %zu of the stroke is not a finite number", i + 1));
    }
    const double scale = extent(stroke);
    const double eps = 1e-9 * std::max(scale, 1e-300);

    // The wrong side of the axis; a rounding error's worth of negative x is put on the axis.
    std::vector<Vec2> pts;
    for (size_t i = 0; i < stroke.size(); ++i) {
        Vec2 p = stroke[i];
        if (p.x < -eps) {
            fail(
                format("the stroke crosses the axis: point %zu at (%.2f, %.2f) m has x < 0 "
                       "(x is the distance from the axis)",
                       i + 1, p.x, p.y));
        }
        p.x = std::max(p.x, 0.0);
        if (pts.empty() || length(p - pts.back()) > eps) pts.push_back(p);
    }
    if (pts.size() < 2) {
        fail(format("the stroke has fewer than two distinct points (%zu given)", stroke.size()));
    }
    // A run of points along the axis at an end adds nothing but a segment on the axis.
    while (pts.size() > 2 && pts[0].x <= eps && pts[1].x <= eps) pts.erase(pts.begin());
    while (pts.size() > 2 && pts.back().x <= eps && pts[pts.size() - 2].x <= eps) pts.pop_back();

    double maxR = 0;
    for (const Vec2& p : pts) maxR = std::max(maxR, p.x);
    if (maxR <= eps) fail("the stroke lies on the axis and encloses no volume");

    // Both ends must come close to the axis. The farther end is reported.
    {
        const bool firstIsTop = pts.front().y > pts.back().y;
        const bool level = pts.front().y == pts.back().y;
        const Vec2* ends[2] = {&pts.front(), &pts.back()};
        const char* names[2] = {level ? "first" : (firstIsTop ? "top" : "bottom"),
                                level ? "last" : (firstIsTop ? "bottom" : "top")};
        const int far = ends[0]->x >= ends[1]->x ? 0 : 1;
        const double allowed = options.closeTolerance * maxR;
        if (ends[far]->x > allowed + eps) {
            fail(
                format("the stroke never reaches the axis: its %s end is %.3g m from it (at "
                       "most %.3g m, %g of the widest radius %.3g m)",
                       names[far], ends[far]->x, allowed, options.closeTolerance, maxR));
        }
    }

    pts = resample(pts, options.samples);
    smooth(pts, options.smoothing);

    // Close both ends to the axis with horizontal segments.
    if (pts.front().x > eps) {
        pts.insert(pts.begin(), Vec2{0.0, pts.front().y});
    } else {
        pts.front().x = 0.0;
    }
    if (pts.back().x > eps) {
        pts.push_back({0.0, pts.back().y});
    } else {
        pts.back().x = 0.0;
    }
    if (std::abs(pts.front().y - pts.back().y) <= 1e-6 * scale) {
        fail(
            format("both ends of the stroke meet the axis at the same height (%.2f m): the "
                   "solid would pinch to a point there",
                   pts.front().y));
    }

    // The closed polygon (profile, then the axis from its last point back to its first) must
    // be simple. Segment i joins pts[i] and pts[i + 1]; segment n − 1 is the axis.
    const size_t n = pts.size();
    const double areaEps = 1e-12 * scale * scale;
    auto seg = [&](size_t i) { return std::make_pair(pts[i], pts[(i + 1) % n]); };
    for (size_t i = 0; i < n; ++i) {
        const auto [a, b] = seg(i);
        // Adjacent segments meet at their shared point; they overlap only when folding back.
        const auto [c, d] = seg((i + 1) % n);
        if (std::abs(cross(b - a, d - c)) <= areaEps && dot(b - a, d - c) < 0) {
            fail(format("the stroke doubles back on itself near (%.2f, %.2f) m", b.x, b.y));
        }
        for (size_t j = i + 2; j < n; ++j) {
            if (i == 0 && j == n - 1) continue;  // adjacent through the closing point
            const auto [e, f] = seg(j);
            if (auto at = segmentsMeet(a, b, e, f, areaEps)) {
                if (j == n - 1) {
                    fail(
                        format("the stroke touches the axis between its ends near (%.2f, "
                               "%.2f) m",
                               at->x, at->y));
                }
                fail(format("the stroke crosses itself near (%.2f, %.2f) m", at->x, at->y));
            }
        }
    }

    double area = 0, momentX = 0;
    polygonMoments(pts, &area, &momentX);
    if (std::abs(area) <= 1e-9 * scale * scale) fail("the stroke encloses no area");
    // Counter-clockwise in (x, y): from the lower axis point out and up to the upper one.
    if (area < 0) std::reverse(pts.begin(), pts.end());
    return pts;
}

TriangleSoup revolveProfile(const std::vector<Vec2>& profile, int segments) {
    if (segments < 3) throw std::invalid_argument("revolveProfile: segments must be >= 3");
    const size_t n = profile.size();
    if (n < 3) fail("the profile needs at least three points");
    const double eps = 1e-9 * std::max(extent(profile), 1e-300);
    if (std::abs(profile.front().x) > eps || std::abs(profile.back().x) > eps)
        fail("the profile does not begin and end on the axis (clean the stroke first)");
    for (size_t i = 1; i + 1 < n; ++i) {
        if (!(profile[i].x > eps)) {
            fail(format("the profile touches the axis between its ends near (%.2f, %.2f) m",
                        profile[i].x, profile[i].y));
        }
    }

    // Vertices: the first pole, `segments` per interior profile point, the last pole.
    Mesh mesh;
    std::vector<Mesh::Vertex_index> v;
    v.reserve((n - 2) * segments + 2);
    v.push_back(mesh.add_vertex({0.0, profile.front().y, 0.0}));
    for (size_t i = 1; i + 1 < n; ++i) {
        for (int j = 0; j < segments; ++j) {
            const double th = 2.0 * kPi * j / segments;
            v.push_back(mesh.add_vertex(
                {profile[i].x * std::cos(th), profile[i].y, profile[i].x * std::sin(th)}));
        }
    }
    v.push_back(mesh.add_vertex({0.0, profile.back().y, 0.0}));
    const auto ring = [&](size_t i, int j) {  // profile point i (1 … n−2), step j
        return v[1 + (i - 1) * segments + (j % segments)];
    };
    bool ok = true;
    auto face = [&](Mesh::Vertex_index a, Mesh::Vertex_index b, Mesh::Vertex_index c) {
        if (mesh.add_face(a, b, c) == Mesh::null_face()) ok = false;
    };
    // Winding for a counter-clockwise profile (bottom pole first): outward normals.
    for (int j = 0; j < segments; ++j) face(v.front(), ring(1, j), ring(1, j + 1));
    for (size_t i = 1; i + 2 < n; ++i) {
        for (int j = 0; j < segments; ++j) {
            face(ring(i, j), ring(i + 1, j), ring(i, j + 1));
            face(ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
        }
    }
    for (int j = 0; j < segments; ++j) face(ring(n - 2, j), v.back(), ring(n - 2, j + 1));
    if (!ok) fail("the revolved profile is not a manifold surface");

    if (!CGAL::is_closed(mesh)) fail("the revolved surface is not closed");
    if (!CGAL::is_triangle_mesh(mesh)) fail("the revolved surface is not a triangle mesh");
    if (PMP::does_self_intersect(mesh))
        fail("the revolved surface intersects itself (the profile crosses itself)");
    if (!PMP::is_outward_oriented(mesh)) {
        PMP::reverse_face_orientations(mesh);
        if (!PMP::is_outward_oriented(mesh))
            fail("the revolved surface cannot be oriented outwards");
    }

    TriangleSoup soup;
    soup.points.reserve(mesh.number_of_vertices());
    for (Mesh::Vertex_index vi : mesh.vertices()) {
        const auto& p = mesh.point(vi);
        soup.points.push_back({p.x(), p.y(), p.z()});
    }
    soup.triangles.reserve(mesh.number_of_faces());
    for (Mesh::Face_index f : mesh.faces()) {
        std::array<uint32_t, 3> t{};
        int k = 0;
        for (Mesh::Vertex_index vi : CGAL::vertices_around_face(mesh.halfedge(f), mesh))
            t[k++] = static_cast<uint32_t>(vi.idx());
        soup.triangles.push_back(t);
    }
    return soup;
}

namespace {

// The revolved mesh as a narrow-band level set (MeshToVolume). Inside tests are exact to
// about a voxel; distances are trilinear within ±3 voxels of the surface and ±3 voxels beyond
// (sign right).
VolumePtr revolvedLevelSet(const std::vector<Vec2>& profile, double voxel, int segments) {
    const TriangleSoup soup = revolveProfile(profile, segments);
    std::vector<float> points;
    points.reserve(3 * soup.points.size());
    Aabb bounds;
    for (const Vec3& p : soup.points) {
        points.insert(points.end(), {float(p.x), float(p.y), float(p.z)});
        bounds.extend(p);
    }
    std::vector<uint32_t> triangles;
    triangles.reserve(3 * soup.triangles.size());
    for (const auto& t : soup.triangles)
        triangles.insert(triangles.end(), {uint32_t(t[0]), uint32_t(t[1]), uint32_t(t[2])});
    VdbGridPtr grid = vdbModule().meshToLevelSet(voxel, points, triangles, 3.0f);
    // The realised surface can sit up to a voxel outside the mesh's bounds.
    const Vec3 pad{voxel, voxel, voxel};
    bounds.lo -= pad;
    bounds.hi += pad;
    // Measure, closed form (Pappus' theorem) for the faceted solid the level set realises, not
    // a voxel count: the profile polygon revolved has volume 2π·∫∫x dA; the mesh's
    // cross-sections are regular n-gons inscribed in those circles, n·sin(2π/n)/(2π) of their
    // area. The voxelised inside differs from it by about a voxel layer of surface.
    double area = 0, momentX = 0;
    polygonMoments(profile, &area, &momentX);
    const double n = segments;
    const double measure =
        2.0 * kPi * std::abs(momentX) * (n * std::sin(2.0 * kPi / n) / (2.0 * kPi));
    return std::make_shared<GridVolume>(
        std::move(grid), voxel, bounds, measure,
        format("revolution of a %zu-point profile (level set, voxel %.3g m)", profile.size(),
               voxel));
}

}  // namespace

VolumePtr makeRevolution(const std::vector<Vec2>& profile, double voxelSize, int segments) {
    if (!(voxelSize > 0.0) || !std::isfinite(voxelSize))
        throw std::invalid_argument("makeRevolution: voxelSize must be finite and > 0");
    // The result is a pure function of its arguments and immutable, so the last few are
    // kept: a species names the same sketch for its crown and its endpoints, and is parsed
    // again for every validation and every tree that is not cached.
    struct Entry {
        std::vector<Vec2> profile;
        double voxel;
        int segments;
        VolumePtr volume;
    };
    constexpr size_t kKept = 8;
    static std::mutex mutex;
    static std::vector<Entry> kept;  // most recently used last
    {
        std::lock_guard<std::mutex> lock(mutex);
        for (size_t i = 0; i < kept.size(); ++i) {
            if (kept[i].voxel == voxelSize && kept[i].segments == segments &&
                kept[i].profile == profile) {
                std::rotate(kept.begin() + i, kept.begin() + i + 1, kept.end());
                return kept.back().volume;
            }
        }
    }
    VolumePtr v = revolvedLevelSet(profile, voxelSize, segments);
    std::lock_guard<std::mutex> lock(mutex);
    if (kept.size() == kKept) kept.erase(kept.begin());
    kept.push_back({profile, voxelSize, segments, v});
    return v;
}

// --- SVG paths --------------------------------------------------------------------------------
namespace {

// Tokenizer for SVG path data: command letters and numbers ("-1.5e-3", ".5.5" = .5 .5).
class PathLexer {
  public:
    explicit PathLexer(const std::string& d) : d_(d) {}

    void skipSeparators() {
        while (i_ < d_.size() &&
               (std::isspace(static_cast<unsigned char>(d_[i_])) || d_[i_] == ','))
            ++i_;
    }
    bool atEnd() {
        skipSeparators();
        return i_ >= d_.size();
    }
    // The next token is a command letter (without consuming it).
    std::optional<char> peekCommand() {
        skipSeparators();
        if (i_ < d_.size() && std::isalpha(static_cast<unsigned char>(d_[i_])) && d_[i_] != 'e' &&
            d_[i_] != 'E')
            return d_[i_];
        return std::nullopt;
    }
    char command() { return d_[i_++]; }
    bool peekNumber() {
        skipSeparators();
        if (i_ >= d_.size()) return false;
        const char c = d_[i_];
        return std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '+' || c == '.';
    }
    double number() {
        skipSeparators();
        const size_t start = i_;
        size_t j = i_;
        if (j < d_.size() && (d_[j] == '+' || d_[j] == '-')) ++j;
        size_t digits = 0;
        while (j < d_.size() && std::isdigit(static_cast<unsigned char>(d_[j]))) ++j, ++digits;
        if (j < d_.size() && d_[j] == '.') {
            ++j;
            while (j < d_.size() && std::isdigit(static_cast<unsigned char>(d_[j]))) ++j, ++digits;
        }
        if (digits == 0) badToken(start);
        if (j < d_.size() && (d_[j] == 'e' || d_[j] == 'E')) {
            size_t k = j + 1;
            if (k < d_.size() && (d_[k] == '+' || d_[k] == '-')) ++k;
            size_t expDigits = 0;
            while (k < d_.size() && std::isdigit(static_cast<unsigned char>(d_[k])))
                ++k, ++expDigits;
            if (expDigits == 0) badToken(start);
            j = k;
        }
        i_ = j;
        const double v = std::strtod(d_.substr(start, j - start).c_str(), nullptr);
        if (!std::isfinite(v)) badToken(start);
        if (std::abs(v) > kMaxSvgCoordinate) {
            fail(
                format("SVG path coordinate %g (character %zu of the d attribute) is over %g in "
                       "magnitude",
                       v, start + 1, kMaxSvgCoordinate));
        }
        return v;
    }
    [[noreturn]] void badToken(size_t at) const {
        if (at >= d_.size()) fail("bad SVG path data: it ends in the middle of a command");
        size_t end = at;
        while (end < d_.size() && end - at < 12 &&
               !std::isspace(static_cast<unsigned char>(d_[end])))
            ++end;
        fail(format("bad SVG path data at \"%s\" (character %zu of the d attribute)",
                    d_.substr(at, std::max<size_t>(end - at, 1)).c_str(), at + 1));
    }
    size_t position() const { return i_; }

  private:
    const std::string& d_;
    size_t i_ = 0;
};

// Flattens path data into a polyline in SVG user units (y down).
std::vector<Vec2> flattenPath(const std::string& d) {
    constexpr int kCurveSteps = 16;
    PathLexer lex(d);
    std::vector<Vec2> out;
    Vec2 cur{0, 0}, start{0, 0};
    Vec2 lastCubicCtrl{0, 0}, lastQuadCtrl{0, 0};
    char prev = 0;  // previous command (upper case), for S/T reflection
    char cmd = 0;
    bool started = false;
    auto emit = [&](const Vec2& p) {
        if (out.empty() || !(out.back() == p)) out.push_back(p);
        if (out.size() > kMaxSvgPoints) {
            fail(format("the SVG path has over %zu points (a curve counts %d); simplify it",
                        kMaxSvgPoints, kCurveSteps));
        }
    };
    while (!lex.atEnd()) {
        if (auto c = lex.peekCommand()) {
            cmd = lex.command();
        } else if (cmd == 0) {
            lex.badToken(lex.position());
        } else if (cmd == 'M') {
            cmd = 'L';  // implicit repeats after a moveto are linetos
        } else if (cmd == 'm') {
            cmd = 'l';
        } else if (cmd == 'Z' || cmd == 'z') {
            lex.badToken(lex.position());
        }
        const bool rel = std::islower(static_cast<unsigned char>(cmd));
        const char up = static_cast<char>(std::toupper(static_cast<unsigned char>(cmd)));
        if (!started && up != 'M') fail("the SVG path data does not begin with a moveto (M)");
        auto point = [&]() {
            const double x = lex.number();
            if (!lex.peekNumber()) lex.badToken(lex.position());
            const double y = lex.number();
            return rel ? Vec2{cur.x + x, cur.y + y} : Vec2{x, y};
        };
        switch (up) {
            case 'M': {
                const Vec2 p = point();
                if (started && !out.empty() && length(p - cur) > 1e-9 * (1 + extent(out))) {
                    fail(
                        "the SVG path has more than one piece (a second moveto); draw the "
                        "stroke as one connected path");
                }
                cur = start = p;
                started = true;
                emit(cur);
                break;
            }
            case 'L':
                cur = point();
                emit(cur);
                break;
            case 'H': {
                const double x = lex.number();
                cur.x = rel ? cur.x + x : x;
                emit(cur);
                break;
            }
            case 'V': {
                const double y = lex.number();
                cur.y = rel ? cur.y + y : y;
                emit(cur);
                break;
            }
            case 'C':
            case 'S': {
                Vec2 c1;
                if (up == 'C') {
                    c1 = point();
                } else {
                    c1 = (prev == 'C' || prev == 'S') ? cur * 2.0 - lastCubicCtrl : cur;
                }
                const Vec2 c2 = point();
                const Vec2 p = point();
                const Vec2 p0 = cur;
                for (int k = 1; k <= kCurveSteps; ++k) {
                    const double t = double(k) / kCurveSteps, s = 1 - t;
                    emit(p0 * (s * s * s) + c1 * (3 * s * s * t) + c2 * (3 * s * t * t) +
                         p * (t * t * t));
                }
                lastCubicCtrl = c2;
                cur = p;
                break;
            }
            case 'Q':
            case 'T': {
                const Vec2 c1 =
                    up == 'Q' ? point()
                              : ((prev == 'Q' || prev == 'T') ? cur * 2.0 - lastQuadCtrl : cur);
                const Vec2 p = point();
                const Vec2 p0 = cur;
                for (int k = 1; k <= kCurveSteps; ++k) {
                    const double t = double(k) / kCurveSteps, s = 1 - t;
                    emit(p0 * (s * s) + c1 * (2 * s * t) + p * (t * t));
                }
                lastQuadCtrl = c1;
                cur = p;
                break;
            }
            case 'Z':
                cur = start;
                emit(cur);
                break;
            case 'A':
                fail("SVG arc commands (A/a) are not supported; convert arcs to curves");
            default:
                lex.badToken(lex.position() - 1);
        }
        prev = up;
    }
    if (out.empty()) fail("the SVG path data is empty");
    return out;
}

// The value of attribute `name` in the tag text (between '<path' and '>').
std::optional<std::string> attribute(const std::string& tag, const std::string& name) {
    size_t pos = 0;
    while ((pos = tag.find(name, pos)) != std::string::npos) {
        const bool boundary = pos == 0 || std::isspace(static_cast<unsigned char>(tag[pos - 1]));
        size_t j = pos + name.size();
        while (j < tag.size() && std::isspace(static_cast<unsigned char>(tag[j]))) ++j;
        if (boundary && j < tag.size() && tag[j] == '=') {
            ++j;
            while (j < tag.size() && std::isspace(static_cast<unsigned char>(tag[j]))) ++j;
            if (j < tag.size() && (tag[j] == '"' || tag[j] == '\'')) {
                const size_t end = tag.find(tag[j], j + 1);
                if (end != std::string::npos) return tag.substr(j + 1, end - j - 1);
            }
        }
        pos += name.size();
    }
    return std::nullopt;
}

// Drops XML comments so that a commented-out <path> is not read (in one pass: erasing each
// comment in place is quadratic in a file of many comments).
std::string withoutComments(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    size_t from = 0, a;
    while ((a = s.find("<!--", from)) != std::string::npos) {
        out.append(s, from, a - from);
        const size_t b = s.find("-->", a + 4);
        if (b == std::string::npos) return out;
        from = b + 3;
    }
    out.append(s, from, std::string::npos);
    return out;
}

// Raw points (x from the axis, y up, any units) → metres: lowest point at 0, height `height`.
std::vector<Vec2> scaleToHeight(std::vector<Vec2> pts, double height, const char* what) {
    double lo = pts[0].y, hi = pts[0].y;
    for (const Vec2& p : pts) lo = std::min(lo, p.y), hi = std::max(hi, p.y);
    if (!(hi - lo > 0)) fail(format("the %s has no height (all its points at one level)", what));
    const double s = height / (hi - lo);
    for (Vec2& p : pts) p = {p.x * s, (p.y - lo) * s};
    return pts;
}

}  // namespace

std::vector<Vec2> readSvgStroke(const std::string& path, double axisX, double height) {
    if (!(height > 0) || !std::isfinite(height))
        throw std::invalid_argument("readSvgStroke: height must be finite and > 0");
    // A regular file (a FIFO would block, a device never end) of at most kMaxSvgBytes.
    std::optional<InputFile> in;
    try {
        in.emplace(path);
    } catch (const InputError& e) {
        fail("cannot read the SVG file " + path + " (" + e.what() + ")");
    }
    const auto tooLarge = [&](uint64_t bytes) {
        fail(
            format("the SVG file %s has %llu bytes; at most %zu (a drawn stroke needs a few "
                   "kilobytes)",
                   path.c_str(), static_cast<unsigned long long>(bytes), kMaxSvgBytes));
    };
    if (in->size() > kMaxSvgBytes) tooLarge(in->size());
    std::string bytes;
    try {
        bytes = in->readAll(kMaxSvgBytes, "SVG file");
    } catch (const InputError&) {
        tooLarge(kMaxSvgBytes + 1);  // it grew while read
    }
    const std::string text = withoutComments(bytes);
    size_t at = 0;
    std::string tag;
    while ((at = text.find("<path", at)) != std::string::npos) {
        const size_t after = at + 5;
        if (after < text.size() && (std::isspace(static_cast<unsigned char>(text[after])) ||
                                    text[after] == '/' || text[after] == '>')) {
            const size_t end = text.find('>', after);
            tag = text.substr(after, end == std::string::npos ? std::string::npos : end - after);
            break;
        }
        at = after;
    }
    if (at == std::string::npos) fail("no <path> element in the SVG file " + path);
    const std::optional<std::string> d = attribute(tag, "d");
    if (!d) fail("the first <path> of the SVG file " + path + " has no d attribute");

    const std::vector<Vec2> raw = flattenPath(*d);
    const double tol = 1e-9 * (1 + extent(raw));
    bool left = false, right = false;
    for (const Vec2& p : raw) {
        left |= p.x < axisX - tol;
        right |= p.x > axisX + tol;
    }
    if (left && right) {
        fail(format("the SVG path crosses the axis x = %g (it has points on both sides)", axisX));
    }
    std::vector<Vec2> pts;
    pts.reserve(raw.size());
    for (const Vec2& p : raw) pts.push_back({std::abs(p.x - axisX), -p.y});  // y up
    return scaleToHeight(std::move(pts), height, "SVG path");
}

// --- images -------------------------------------------------------------------------------------

std::vector<Vec2> traceStrokeImage(const std::string& path, double axisColumn, double height) {
    if (!(height > 0) || !std::isfinite(height))
        throw std::invalid_argument("traceStrokeImage: height must be finite and > 0");
    // Checked before decoding (volumes/image_file.h); colour as stored, not premultiplied.
    ImageFile img;
    try {
        img = readImageFile(path);
    } catch (const ImageError& e) {
        fail(e.what());
    }
    const int w = img.width, h = img.height, nc = img.channels;
    const std::vector<float>& px = img.pixels;

    // Opaque-on-transparent when there is an alpha channel that is not opaque everywhere;
    // otherwise dark-on-light by luminance.
    int alpha = img.alphaChannel;
    if (alpha < 0 && (nc == 2 || nc == 4)) alpha = nc - 1;
    bool useAlpha = false;
    if (alpha >= 0) {
        for (size_t i = 0; i < size_t(w) * h && !useAlpha; ++i)
            useAlpha = px[i * nc + alpha] <= 0.5f;
    }
    auto isStroke = [&](size_t i) {
        const float* c = &px[i * nc];
        if (useAlpha) return c[alpha] > 0.5f;
        const float lum = nc >= 3 ? 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2] : c[0];
        return lum < 0.5f;
    };

    std::vector<Vec2> pts;  // (pixels from the axis, rows up from the image bottom)
    for (int row = 0; row < h; ++row) {
        double best = -1;
        for (int col = 0; col < w; ++col) {
            if (isStroke(size_t(row) * w + col)) best = std::max(best, std::abs(col - axisColumn));
        }
        if (best >= 0) pts.push_back({best, double(h - 1 - row)});
    }
    if (pts.empty())
        fail("no stroke pixels in the image " + path +
             " (dark on light, or opaque "
             "on transparent)");
    if (pts.size() < 2) fail("the stroke in the image " + path + " spans a single row");
    return scaleToHeight(std::move(pts), height, "stroke in the image");
}

}  // namespace sylva
