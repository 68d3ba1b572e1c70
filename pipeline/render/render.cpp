// CPU renderer of one view: skeleton segments as tapered capsules (drawn directly, no mesh,
// so sub-pixel twigs survive) and leaves as the triangles of their outlines, z-buffered; plus
// silhouette statistics.
//
// Segments. Each is a tapered capsule: the union of the spheres of radius r(t) (linear
// between the node radii) about the axis points. A pixel is covered when its centre's ray
// meets the capsule, or when the projected axis passes within kMinRadiusPx of the centre.
// That minimum is just over half a pixel diagonal (√½), so every pixel holding a point of
// the projected axis is drawn: sub-pixel twigs become unbroken 1–2 px lines, as in the
// paper's black-on-white figures, and every node lands on a silhouette pixel. Only pixels
// within a conservative screen bound of the axis (the projected sphere ellipses) are tested.
//
// Segment depth (metres along the view axis, always > 0): the front of the capsule along the
// pixel-centre ray, computed exactly (closed form, see capsuleFront), but never deeper than
// the nearest axis point within kMinRadiusPx of the pixel centre; for pixels covered only by
// the minimum width, that axis depth. (So a pixel's depth is never behind a skeleton point
// inside it, and back-projected points stay within radius + a pixel of the skeleton.)
// Capsules thinner than the minimum width everywhere skip the ray test and use the axis.
//
// Leaves: each leaf is the triangles of its shape's outline (species/model/leaf_shape.h; the
// card: two triangles), from the same points as the mesh's leaves (leafPoints), covering the
// pixels whose centres are inside them (edges inclusive; no minimum width, so leaves seen
// exactly edge-on, and needles thinner than a pixel between pixel centres, vanish), with
// perspective-correct depth (1/z linear in screen space; z linear for orthographic).
// Geometry in front of the near plane (depth 1e-4 m) is clipped.
//
// Visibility: nearest depth (compared as float) wins; equal depths go to the lower label,
// then to the lower primitive index (segments in child-node order, then leaf triangles).
//
// Parallelism: the image is split into bands of kBandRows rows; primitives are binned (in
// index order) by the bands their clipped screen box overlaps; each band is owned by one task
// and draws its primitives in index order, so the result does not depend on thread count.
#include "pipeline/render/render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "species/model/leaf_shape.h"

namespace sylva {

namespace {

constexpr double kMinRadiusPx = 0.7072;  // just over √½: the pixel holding any axis point
constexpr double kNear = 1e-4;           // metres; geometry closer than this is clipped
constexpr float kMinDepth = 1e-6f;       // drawn depths stay > 0 (0 means background)
constexpr int kBandRows = 16;
constexpr double kSpanMargin = 1e-6;  // pixels: a triangle's row span is widened by this

// World → camera space, camera space → pixels.
struct View {
    Vec3 right, up, back, eye;
    double f, cx, cy;
    bool ortho;
    int width, height;

    explicit View(const Camera& c)
        : right{c.cameraToWorld[0][0], c.cameraToWorld[1][0], c.cameraToWorld[2][0]},
          up{c.cameraToWorld[0][1], c.cameraToWorld[1][1], c.cameraToWorld[2][1]},
          back{c.cameraToWorld[0][2], c.cameraToWorld[1][2], c.cameraToWorld[2][2]},
          eye{c.cameraToWorld[0][3], c.cameraToWorld[1][3], c.cameraToWorld[2][3]},
          f(c.fx()),
          cx(c.cx()),
          cy(c.cy()),
          ortho(c.orthographic),
          width(c.width),
          height(c.height) {}

    Vec3 toCamera(const Vec3& p) const {
        const Vec3 d = p - eye;
        return {dot(d, right), dot(d, up), dot(d, back)};
    }
    // Camera-space point (depth −z > 0) → pixel coordinates.
    void toPixel(const Vec3& c, double& px, double& py) const {
        const double s = ortho ? f : f / -c.z;
        px = cx + s * c.x;
        py = cy - s * c.y;
    }
    // The ray through a pixel position, in camera space: origin o, direction d with d.z = −1
    // (so a ray point's depth is its ray parameter).
    void ray(double px, double py, Vec3& o, Vec3& d) const {
        const double u = (px - cx) / f, v = (cy - py) / f;
        if (ortho) {
            o = {u, v, 0.0};
            d = {0.0, 0.0, -1.0};
        } else {
            o = {0.0, 0.0, 0.0};
            d = {u, v, -1.0};
        }
    }
};

struct Box {
    int x0, x1, y0, y1;  // inclusive pixel ranges; empty when x0 > x1 or y0 > y1
};

// Index of the first / last pixel whose centre i + 0.5 is ≥ v / ≤ v, clamped to [−1, n]
// (n pixels) before converting, so far-off coordinates cannot overflow an int.
// Clamping before rounding gives the same integer (the bounds are integers) and lets the
// rounding be a truncation plus a step: std::ceil / std::floor are library calls on baseline
// x86-64 and were 3% of a build's time.
int firstCentreAtOrAfter(double v, int n) {
    const double c = std::clamp(v - 0.5, -1.0, static_cast<double>(n));
    const int i = static_cast<int>(c);  // rounds toward zero
    return i < c ? i + 1 : i;
}
int lastCentreAtOrBefore(double v, int n) {
    const double c = std::clamp(v - 0.5, -1.0, static_cast<double>(n));
    const int i = static_cast<int>(c);
    return i > c ? i - 1 : i;
}

// Pixels whose centres fall in the continuous box, clipped to the image.
bool pixelBox(double lox, double hix, double loy, double hiy, int w, int h, Box& box) {
    if (!(lox <= hix && loy <= hiy)) return false;  // also rejects NaN
    if (hix < 0.0 || hiy < 0.0 || lox > w || loy > h) return false;
    box.x0 = std::max(0, firstCentreAtOrAfter(lox, w));
    box.x1 = std::min(w - 1, lastCentreAtOrBefore(hix, w));
    box.y0 = std::max(0, firstCentreAtOrAfter(loy, h));
    box.y1 = std::min(h - 1, lastCentreAtOrBefore(hiy, h));
    return box.x0 <= box.x1 && box.y0 <= box.y1;
}

struct Segment {
    Vec3 a, e;            // camera-space axis: a + t e, t in [0, 1]
    double ee;            // e·e
    double ra, rb;        // world radii at the ends
    double da, db;        // axis depths at the ends (≥ kNear)
    double invDa, invDb;  // their reciprocals
    double invLen2;       // 1 / squared screen length, 0 for a point
    bool aNearer;         // da ≤ db
    bool ortho;
    double ax, ay, bx, by;  // screen endpoints
    double reach;           // no covered pixel centre is farther from the screen axis
    float zmin;             // no pixel of the segment is nearer than this
    uint8_t label;
    Box box;
};

struct Triangle {
    double x[3], y[3];  // screen vertices
    double z[3];        // depth (orthographic) or 1/depth (perspective) per vertex
    double area;        // signed, twice the screen area
    float zmin;
    Box box;
};

// True when the triangle's box holds at most four pixel centres and each is clearly outside
// it (a barycentric weight below −1e-9), so drawing it would change no pixel: most leaf
// triangles of shaped leaves are smaller than a pixel, and skipping them keeps the scene small.
// Centres within the margin are left to drawTriangle's exact test.
bool missesEveryCentre(const Triangle& t) {
    if ((t.box.x1 - t.box.x0 + 1) * (t.box.y1 - t.box.y0 + 1) > 4) return false;
    const double inv = 1.0 / t.area;
    for (int y = t.box.y0; y <= t.box.y1; ++y) {
        for (int x = t.box.x0; x <= t.box.x1; ++x) {
            const double pxc = x + 0.5, pyc = y + 0.5;
            bool outside = false;
            for (int j = 0; j < 3 && !outside; ++j) {
                const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
                outside = ((t.x[j2] - t.x[j1]) * (pyc - t.y[j1]) -
                           (t.y[j2] - t.y[j1]) * (pxc - t.x[j1])) *
                              inv <
                          -1e-9;
            }
            if (!outside) return false;
        }
    }
    return true;
}

// Camera-space polygon clipped to depth ≥ kNear (Sutherland–Hodgman against one plane).
int clipNear(const Vec3* in, int n, Vec3* out) {
    int m = 0;
    for (int i = 0; i < n; ++i) {
        const Vec3& p = in[i];
        const Vec3& q = in[(i + 1) % n];
        const double dp = -p.z - kNear, dq = -q.z - kNear;
        if (dp >= 0) out[m++] = p;
        if ((dp >= 0) != (dq >= 0)) out[m++] = p + (q - p) * (dp / (dp - dq));
    }
    return m;
}

struct Scene {
    std::vector<Segment> segments;
    std::vector<Triangle> triangles;
    // Per band: primitive ids in index order; ids ≥ segments.size() are triangles.
    std::vector<std::vector<int32_t>> bins;
};

void addToBins(Scene& scene, const Box& box, int32_t id) {
    for (int band = box.y0 / kBandRows; band <= box.y1 / kBandRows; ++band) {
        scene.bins[band].push_back(id);
    }
}

// How far from the projected axis the projected capsule can reach, in pixels. Orthographic:
// the radius in pixels. Perspective: a sphere of radius r at depth z, seen at angle θ from the
// optical axis under the angular radius α = asin(r / distance), projects to an ellipse
// reaching (f r / z) / cos(θ + α) from its projected centre; f r / z is linear in screen space
// along the segment, θ is largest at an end and α at most asin(max r / eye-segment distance).
double screenReach(const View& view, const Segment& s, double da, double db) {
    if (view.ortho) return std::max(s.ra, s.rb) * view.f;
    const double rz = std::max(s.ra / da, s.rb / db) * view.f;
    if (rz == 0.0) return 0.0;
    // θ: the larger end angle, via ρ² = squared pixel distance from the principal point.
    auto rho2 = [&](double px, double py) {
        return (px - view.cx) * (px - view.cx) + (py - view.cy) * (py - view.cy);
    };
    const double r2 = std::max(rho2(s.ax, s.ay), rho2(s.bx, s.by));
    const double hyp = std::sqrt(view.f * view.f + r2);
    const double cosT = view.f / hyp, sinT = std::sqrt(r2) / hyp;
    // α: from the distance between the eye (the origin) and the axis segment.
    const double t = s.ee > 0 ? std::clamp(-dot(s.a, s.e) / s.ee, 0.0, 1.0) : 0.0;
    const double dist = length(s.a + s.e * t);
    const double rmax = std::max(s.ra, s.rb);
    if (!(dist > rmax)) return 1e9;  // the eye is inside: everything
    const double sinA = rmax / dist, cosA = std::sqrt(1.0 - sinA * sinA);
    const double cosSum = cosT * cosA - sinT * sinA;  // cos(θ + α)
    if (!(cosSum > 1e-3)) return 1e9;
    return rz / cosSum * (1.0 + 1e-9);
}

Scene buildScene(const Tree& tree, const View& view) {
    Scene scene;
    const int bands = (view.height + kBandRows - 1) / kBandRows;
    scene.bins.resize(bands);
    const auto& nodes = tree.nodes;

    std::vector<Vec3> cam(nodes.size());
    for (size_t i = 0; i < nodes.size(); ++i) cam[i] = view.toCamera(nodes[i].position);

    scene.segments.reserve(nodes.size());
    for (size_t i = 1; i < nodes.size(); ++i) {
        const int32_t p = nodes[i].parent;
        if (p < 0 || static_cast<size_t>(p) >= nodes.size()) continue;
        Segment s;
        s.a = cam[p];
        Vec3 b = cam[i];
        s.ra = std::max(0.0, nodes[p].radius);
        s.rb = std::max(0.0, nodes[i].radius);
        double da = -s.a.z, db = -b.z;
        if (!(da >= kNear || db >= kNear)) continue;  // wholly behind (or NaN)
        if (da < kNear) {
            const double t = (kNear - da) / (db - da);
            s.a = s.a + (b - s.a) * t;
            s.ra += (s.rb - s.ra) * t;
            da = kNear;
        } else if (db < kNear) {
            const double t = (kNear - db) / (da - db);
            b = b + (s.a - b) * t;
            s.rb += (s.ra - s.rb) * t;
            db = kNear;
        }
        s.e = b - s.a;
        s.ee = dot(s.e, s.e);
        s.da = da;
        s.db = db;
        s.invDa = 1.0 / da;
        s.invDb = 1.0 / db;
        s.aNearer = da <= db;
        s.ortho = view.ortho;
        view.toPixel(s.a, s.ax, s.ay);
        view.toPixel(b, s.bx, s.by);
        {
            const double dx = s.bx - s.ax, dy = s.by - s.ay, len2 = dx * dx + dy * dy;
            s.invLen2 = len2 > 1e-18 ? 1.0 / len2 : 0.0;
        }
        s.reach = std::max(kMinRadiusPx, screenReach(view, s, da, db));
        s.zmin = static_cast<float>(std::min(da - s.ra, db - s.rb));
        s.label = segmentLabel(nodes[i]);
        const double reach = s.reach;
        if (!pixelBox(std::min(s.ax, s.bx) - reach, std::max(s.ax, s.bx) + reach,
                      std::min(s.ay, s.by) - reach, std::max(s.ay, s.by) + reach, view.width,
                      view.height, s.box)) {
            continue;
        }
        const int32_t id = static_cast<int32_t>(scene.segments.size());
        scene.segments.push_back(s);
        addToBins(scene, s.box, id);
    }

    // Leaf triangles get ids after every segment; their bin entries are appended after the
    // segments', so each bin stays in index order.
    const int32_t firstTri = static_cast<int32_t>(scene.segments.size());
    // A projected triangle corner: screen position, depth and the interpolated depth term.
    struct Corner {
        double x, y, depth, z;
    };
    auto project = [&](const Vec3& c) {
        Corner k;
        view.toPixel(c, k.x, k.y);
        k.depth = -c.z;
        k.z = view.ortho ? k.depth : 1.0 / k.depth;
        return k;
    };
    auto addTriangle = [&](const Corner& a, const Corner& b, const Corner& c) {
        Triangle t;
        const Corner* v[3] = {&a, &b, &c};
        double lox = 1e300, hix = -1e300, loy = 1e300, hiy = -1e300, zmin = 1e300;
        for (int j = 0; j < 3; ++j) {
            t.x[j] = v[j]->x;
            t.y[j] = v[j]->y;
            t.z[j] = v[j]->z;
            zmin = std::min(zmin, v[j]->depth);
            lox = std::min(lox, t.x[j]);
            hix = std::max(hix, t.x[j]);
            loy = std::min(loy, t.y[j]);
            hiy = std::max(hiy, t.y[j]);
        }
        t.area = (t.x[1] - t.x[0]) * (t.y[2] - t.y[0]) - (t.y[1] - t.y[0]) * (t.x[2] - t.x[0]);
        t.zmin = static_cast<float>(zmin);
        if (!(t.area != 0.0) || !pixelBox(lox, hix, loy, hiy, view.width, view.height, t.box)) {
            return;
        }
        if (missesEveryCentre(t)) return;  // a sub-pixel leaf triangle between pixel centres
        const int32_t id = firstTri + static_cast<int32_t>(scene.triangles.size());
        scene.triangles.push_back(t);
        addToBins(scene, t.box, id);
    };
    // Each leaf's outline triangles, from the same points as its mesh (leafPoints).
    std::vector<Vec3> world, inCamera;
    std::vector<Corner> corners;
    for (const Leaf& leaf : tree.leaves) {
        const LeafOutline& outline = leafOutline(leaf.shape);
        leafPoints(leaf, leafFrame(leaf), outline, world);
        inCamera.resize(world.size());
        bool inFront = true;
        for (size_t i = 0; i < world.size(); ++i) {
            inCamera[i] = view.toCamera(world[i]);
            inFront = inFront && -inCamera[i].z - kNear >= 0;
        }
        const std::vector<uint32_t>& tri = outline.triangles;
        if (inFront) {  // the usual case: no clipping, each point projected once
            corners.resize(inCamera.size());
            for (size_t i = 0; i < inCamera.size(); ++i) corners[i] = project(inCamera[i]);
            for (size_t k = 0; k < tri.size(); k += 3) {
                addTriangle(corners[tri[k]], corners[tri[k + 1]], corners[tri[k + 2]]);
            }
            continue;
        }
        for (size_t k = 0; k < tri.size(); k += 3) {
            const Vec3 t3[3] = {inCamera[tri[k]], inCamera[tri[k + 1]], inCamera[tri[k + 2]]};
            Vec3 poly[4];
            const int n = clipNear(t3, 3, poly);
            for (int j = 1; j + 1 < n; ++j) {  // fan
                addTriangle(project(poly[0]), project(poly[j]), project(poly[j + 1]));
            }
        }
    }
    return scene;
}

// The z-buffer test and write. Equal depths go to the lower label; a full tie keeps the
// earlier primitive (bands draw in index order).
inline void plot(float* zbuf, uint8_t* lbuf, size_t k, double depth, uint8_t label) {
    const float z = std::max(kMinDepth, static_cast<float>(depth));
    if (z < zbuf[k] || (z == zbuf[k] && label < lbuf[k])) {
        zbuf[k] = z;
        lbuf[k] = label;
    }
}

// Depth of the axis at the nearest point of the stretch of the screen-space axis within
// `radius` pixels of a pixel centre p inside it; tRaw: the unclamped screen parameter of the
// point of the axis line closest to p, pa2 = |p − screen a|².
double nearestAxisDepth(const Segment& s, double tRaw, double pa2, double radius) {
    double u = s.aNearer ? 0.0 : 1.0;  // depth is monotonic along the axis: the nearer end …
    if (s.invLen2 > 0) {               // … of the stretch
        const double half =
            std::sqrt(std::max(0.0, tRaw * tRaw - (pa2 - radius * radius) * s.invLen2));
        u = s.aNearer ? std::max(0.0, tRaw - half) : std::min(1.0, tRaw + half);
    }
    // Perspective: 1/depth is linear in screen space; orthographic: depth is.
    return s.ortho ? s.da + u * (s.db - s.da) : 1.0 / (s.invDa + u * (s.invDb - s.invDa));
}

// Front of the tapered capsule (the union of the spheres of radius r(t) about a + t e) along
// the ray o + σ d (d.z = −1, so σ is the depth), or +∞ if the ray misses it. The ray meets
// sphere t where q(t) = dist²(ray, centre(t)) − r(t)² ≤ 0 (q quadratic in t), entering it at
// f(t) = σ(t) − sqrt(−q(t))/|d| with σ(t) linear. The front is the least f over that set.
// Where q reaches 0 inside [0, 1], f has an infinite slope pointing inwards, so the least f
// is at t = 0 or 1 (the end caps) or where f' = 0, a quadratic's roots in closed form.
// Exact up to rounding.
double capsuleFront(const Segment& s, const Vec3& o, const Vec3& d) {
    const Vec3 g = s.a - o;
    const double c = dot(d, d), invC = 1.0 / c, invLen = std::sqrt(invC);
    const double dg = dot(d, g), de = dot(d, s.e), dr = s.rb - s.ra;
    const double alpha = s.ee - de * de * invC - dr * dr;
    const double beta = dot(g, s.e) - dg * de * invC - s.ra * dr;
    const double gamma = dot(g, g) - dg * dg * invC - s.ra * s.ra;
    double front = std::numeric_limits<double>::infinity();
    auto consider = [&](double t) {
        if (!(t >= 0.0 && t <= 1.0)) return;
        const double q = (alpha * t + 2.0 * beta) * t + gamma;
        if (q <= 0.0) front = std::min(front, (dg + t * de) * invC - std::sqrt(-q) * invLen);
    };
    consider(0.0);
    consider(1.0);
    const double tiny = 1e-12 * (s.ee + s.ra * s.ra);
    if (de * de > 1e-24 * c * s.ee) {
        // f'(t) = 0  ⇔  sqrt(−q) = −(α t + β) c / (de |d|)  ⇒  (squared, m = c / de²)
        // α(1 + mα) t² + 2β(1 + mα) t + γ + mβ² = 0. Squaring may add a spurious root; it
        // is still a point of the capsule, so taking the least f stays exact.
        const double m = c / (de * de);
        const double qa = alpha * (1.0 + m * alpha), qb = beta * (1.0 + m * alpha);
        const double qc = gamma + m * beta * beta;
        if (std::abs(qa) > tiny) {
            const double disc = qb * qb - qa * qc;
            if (disc >= 0.0) {
                const double root = std::sqrt(disc);
                consider((-qb - root) / qa);
                consider((-qb + root) / qa);
            }
        } else if (std::abs(qb) > tiny) {
            consider(-qc / (2.0 * qb));
        }
    } else if (std::abs(alpha) > tiny) {
        consider(-beta / alpha);  // σ is constant: the deepest point inside
    }
    return front;
}

void drawSegment(const Segment& s, const View& view, int row0, int row1, float* zbuf,
                 uint8_t* lbuf) {
    const double dx = s.bx - s.ax, dy = s.by - s.ay;
    const double reach = s.reach;
    const bool thin = reach <= kMinRadiusPx;  // the projected capsule is sub-pixel
    const int w = view.width;
    for (int y = std::max(s.box.y0, row0); y <= std::min(s.box.y1, row1 - 1); ++y) {
        const double pyc = y + 0.5;
        // Only the part of the axis within `reach` rows of this one can cover it.
        int xa = s.box.x0, xb = s.box.x1;
        if (std::abs(dy) > 1e-12) {
            const double ta = std::clamp((pyc - reach - s.ay) / dy, 0.0, 1.0);
            const double tb = std::clamp((pyc + reach - s.ay) / dy, 0.0, 1.0);
            const double xta = s.ax + ta * dx, xtb = s.ax + tb * dx;
            xa = std::max(xa, firstCentreAtOrAfter(std::min(xta, xtb) - reach, w));
            xb = std::min(xb, lastCentreAtOrBefore(std::max(xta, xtb) + reach, w));
        }
        const size_t rowOff = static_cast<size_t>(y) * w;
        for (int x = xa; x <= xb; ++x) {
            const size_t k = rowOff + x;
            if (zbuf[k] < s.zmin) continue;  // something strictly nearer already
            const double pxc = x + 0.5;
            const double pax = pxc - s.ax, pay = pyc - s.ay;
            const double tRaw = (pax * dx + pay * dy) * s.invLen2;
            const double t = std::clamp(tRaw, 0.0, 1.0);
            const double ex = pxc - (s.ax + t * dx), ey = pyc - (s.ay + t * dy);
            const double dist2 = ex * ex + ey * ey;
            if (dist2 > reach * reach) continue;
            // Covered if the pixel-centre ray meets the capsule, or the projected axis passes
            // within kMinRadiusPx of the centre (the pixel holds a skeleton point). Depth: the
            // capsule's front along the ray, but no deeper than the nearest axis point in the
            // pixel.
            if (thin) {
                // Sub-pixel capsule: whatever the ray meets lies within the minimum width;
                // the axis depth stands for the surface (they differ by < r).
                plot(zbuf, lbuf, k, nearestAxisDepth(s, tRaw, pax * pax + pay * pay, kMinRadiusPx),
                     s.label);
                continue;
            }
            Vec3 o, d;
            view.ray(pxc, pyc, o, d);
            double depth = capsuleFront(s, o, d);
            if (dist2 <= kMinRadiusPx * kMinRadiusPx) {
                // (No axis point is nearer than the nearer end.)
                if (!(depth <= std::min(s.da, s.db))) {
                    depth = std::min(
                        depth, nearestAxisDepth(s, tRaw, pax * pax + pay * pay, kMinRadiusPx));
                }
            } else if (!std::isfinite(depth)) {
                continue;
            }
            plot(zbuf, lbuf, k, depth, s.label);
        }
    }
}

void drawTriangle(const Triangle& t, const View& view, int row0, int row1, float* zbuf,
                  uint8_t* lbuf) {
    const double inv = 1.0 / t.area;
    const int w = view.width;
    for (int y = std::max(t.box.y0, row0); y <= std::min(t.box.y1, row1 - 1); ++y) {
        const double pyc = y + 0.5;
        const size_t rowOff = static_cast<size_t>(y) * w;
        // The row's span: each barycentric weight is linear in x along the row, so the
        // inside is an interval; widened by a hair so the exact test below, unchanged, still
        // decides every pixel (slivers such as needles no longer scan their whole box).
        double lo = t.box.x0 + 0.5, hi = t.box.x1 + 0.5;
        for (int j = 0; j < 3; ++j) {
            const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
            // bc[j] = (a − b (x − x[j1])) · inv ≥ 0
            const double a = (t.x[j2] - t.x[j1]) * (pyc - t.y[j1]) * inv;
            const double b = (t.y[j2] - t.y[j1]) * inv;
            if (b > 0) {
                hi = std::min(hi, t.x[j1] + a / b + kSpanMargin);
            } else if (b < 0) {
                lo = std::max(lo, t.x[j1] + a / b - kSpanMargin);
            } else if (a < -kSpanMargin) {
                lo = hi + 1;  // parallel to the row and outside: no pixel
            }
        }
        if (!(lo <= hi)) continue;
        const int xa = std::max(t.box.x0, firstCentreAtOrAfter(lo, w));
        const int xb = std::min(t.box.x1, lastCentreAtOrBefore(hi, w));
        for (int x = xa; x <= xb; ++x) {
            const size_t k = rowOff + x;
            if (zbuf[k] < t.zmin) continue;
            const double pxc = x + 0.5;
            double bc[3];
            bool inside = true;
            for (int j = 0; j < 3 && inside; ++j) {
                const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
                // Barycentric weight of vertex j: the sub-triangle opposite it.
                bc[j] = ((t.x[j2] - t.x[j1]) * (pyc - t.y[j1]) -
                         (t.y[j2] - t.y[j1]) * (pxc - t.x[j1])) *
                        inv;
                inside = bc[j] >= 0.0;
            }
            if (!inside) continue;
            const double zi = bc[0] * t.z[0] + bc[1] * t.z[1] + bc[2] * t.z[2];
            plot(zbuf, lbuf, k, view.ortho ? zi : 1.0 / zi, kLabelLeaf);
        }
    }
}

}  // namespace

ViewImage renderView(const Tree& tree, const Camera& camera, bool wantDepth, bool wantLabels) {
    if (camera.width <= 0 || camera.height <= 0) {
        throw std::invalid_argument("renderView: image size must be positive");
    }
    const View view(camera);
    const int w = camera.width, h = camera.height;
    const size_t n = static_cast<size_t>(w) * h;
    std::vector<float> zbuf(n, std::numeric_limits<float>::infinity());
    std::vector<uint8_t> lbuf(n, kLabelBackground);

    if (view.f > 0 && std::isfinite(view.f)) {
        const Scene scene = buildScene(tree, view);
        const int32_t firstTri = static_cast<int32_t>(scene.segments.size());
        const int bands = static_cast<int>(scene.bins.size());
        tbb::parallel_for(tbb::blocked_range<int>(0, bands), [&](const tbb::blocked_range<int>& r) {
            for (int band = r.begin(); band != r.end(); ++band) {
                const int row0 = band * kBandRows, row1 = std::min(h, row0 + kBandRows);
                for (int32_t id : scene.bins[band]) {
                    if (id < firstTri) {
                        drawSegment(scene.segments[id], view, row0, row1, zbuf.data(), lbuf.data());
                    } else {
                        drawTriangle(scene.triangles[id - firstTri], view, row0, row1, zbuf.data(),
                                     lbuf.data());
                    }
                }
            }
        });
    }

    ViewImage out;
    out.width = w;
    out.height = h;
    // One pass: the silhouette from the drawn pixels, background depth ∞ → 0.
    out.silhouette.resize(n);
    constexpr float kInf = std::numeric_limits<float>::infinity();
    uint8_t* sil = out.silhouette.data();  // plain pointers: the loop vectorises
    float* z = zbuf.data();
    for (size_t k = 0; k < n; ++k) {
        const bool drawn = z[k] != kInf;
        sil[k] = drawn ? 255 : 0;
        z[k] = drawn ? z[k] : 0.0f;
    }
    if (wantDepth) out.depth = std::move(zbuf);
    if (wantLabels) out.labels = std::move(lbuf);
    return out;
}

double silhouetteCoverage(const ViewImage& view) {
    if (view.silhouette.empty()) return 0.0;
    size_t tree = 0;
    for (uint8_t v : view.silhouette) tree += v != 0;
    return static_cast<double>(tree) / view.silhouette.size();
}

Rgb labelColour(uint8_t label) {
    static constexpr Rgb kOrders[] = {
        {214, 120, 34}, {49, 116, 178}, {150, 75, 160}, {0, 158, 150}, {200, 60, 110}};
    if (label == kLabelBackground) return {255, 255, 255};
    if (label == kLabelLeaf) return {60, 170, 70};
    if (label == kLabelRoot) return {150, 30, 30};
    if (label == woodLabel(0)) return {92, 51, 23};
    return kOrders[(label - 2) % 5];
}

std::vector<uint8_t> colourLabels(const std::vector<uint8_t>& labels) {
    std::vector<uint8_t> rgb(3 * labels.size());
    for (size_t k = 0; k < labels.size(); ++k) {
        const Rgb c = labelColour(labels[k]);
        rgb[3 * k] = c.r;
        rgb[3 * k + 1] = c.g;
        rgb[3 * k + 2] = c.b;
    }
    return rgb;
}

double leafPixelFraction(const std::vector<ViewImage>& views) {
    size_t leaf = 0, tree = 0;
    for (const ViewImage& v : views) {
        for (uint8_t l : v.labels) {
            leaf += l == kLabelLeaf;
            tree += l != kLabelBackground;
        }
    }
    return tree > 0 ? static_cast<double>(leaf) / static_cast<double>(tree)
                    : std::numeric_limits<double>::quiet_NaN();
}

double boxCountingDimension(const ViewImage& view) {
    const int w = view.width, h = view.height;
    if (w <= 0 || h <= 0 || view.silhouette.size() != static_cast<size_t>(w) * h) return 0.0;
    // Box sizes 2, 4, 8, … up to min(w, h)/4, at least three of them; boxes tile the image
    // from its top-left corner (partial boxes at the right and bottom edges count).
    std::vector<int> sizes;
    for (int s = 2; s <= std::min(w, h) / 4 || sizes.size() < 3; s *= 2) sizes.push_back(s);
    // A pyramid of occupancy maps: boxes of size 2 from the pixels, then each size from the
    // one below by OR-ing 2×2 boxes (ceil(ceil(w/s)/2) = ceil(w/2s), so partial boxes match).
    std::vector<double> lx, ly;
    int bw = (w + 1) / 2, bh = (h + 1) / 2;
    std::vector<uint8_t> hit(static_cast<size_t>(bw) * bh, 0);
    for (int y = 0; y < h; ++y) {
        const uint8_t* row = view.silhouette.data() + static_cast<size_t>(y) * w;
        uint8_t* hrow = hit.data() + static_cast<size_t>(y / 2) * bw;
        const int pairs = w / 2;  // pixel pairs, so the loop vectorises
        for (int i = 0; i < pairs; ++i) {
            hrow[i] |= static_cast<uint8_t>((row[2 * i] | row[2 * i + 1]) != 0);
        }
        if (w & 1) hrow[pairs] |= static_cast<uint8_t>(row[w - 1] != 0);
    }
    for (size_t level = 0; level < sizes.size(); ++level) {
        if (level > 0) {
            const int nw = (bw + 1) / 2, nh = (bh + 1) / 2;
            std::vector<uint8_t> next(static_cast<size_t>(nw) * nh, 0);
            for (int y = 0; y < bh; ++y) {
                const uint8_t* row = hit.data() + static_cast<size_t>(y) * bw;
                uint8_t* nrow = next.data() + static_cast<size_t>(y / 2) * nw;
                for (int i = 0; i < bw / 2; ++i) nrow[i] |= row[2 * i] | row[2 * i + 1];
                if (bw & 1) nrow[bw / 2] |= row[bw - 1];
            }
            hit.swap(next);
            bw = nw;
            bh = nh;
        }
        size_t count = 0;
        for (uint8_t v : hit) count += v;
        if (count == 0) return 0.0;  // empty image
        lx.push_back(std::log(1.0 / sizes[level]));
        ly.push_back(std::log(static_cast<double>(count)));
    }
    // Least-squares slope of log N against log 1/s.
    const double m = static_cast<double>(lx.size());
    double sx = 0, sy = 0;
    for (size_t i = 0; i < lx.size(); ++i) {
        sx += lx[i];
        sy += ly[i];
    }
    const double mx = sx / m, my = sy / m;
    double sxy = 0, sxx = 0;
    for (size_t i = 0; i < lx.size(); ++i) {
        sxy += (lx[i] - mx) * (ly[i] - my);
        sxx += (lx[i] - mx) * (lx[i] - mx);
    }
    return sxx > 0 ? sxy / sxx : 0.0;
}

}  // namespace sylva
