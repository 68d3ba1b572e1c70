// Tree statistics; the crown hull uses CGAL (robust predicates, inexact constructions).
#include "species/model/tree_stats.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Exact_rational.h>
#include <CGAL/Mpzf.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/convex_hull_3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "species/model/realism_metrics.h"
#include "species/model/tree_metrics.h"

namespace sylva {

namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
// The points that may be vertices of the hull (Akl & Toussaint's throw-away, in 3D): the
// extreme points along 26 directions span an inner polytope, and every point inside it by a
// margin far above rounding (1e-9 of the extent) is no vertex of the hull, so the hull of the
// rest is the hull of all, to the bit. Skeletons are dense inside the crown and canopy nodes
// lie on lattices, whose ties send the hull's predicates to exact arithmetic: dropping the
// interior first cut a norway-maple's hull from 45 % of its CPU time to 4 %.
std::vector<Point> dropInterior(const std::vector<Point>& pts) {
    std::vector<Point> extremes;
    for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dz = -1; dz <= 1; ++dz) {
                if (dx == 0 && dy == 0 && dz == 0) continue;
                size_t best = 0;
                double top = -std::numeric_limits<double>::infinity();
                for (size_t i = 0; i < pts.size(); ++i) {
                    const double v = dx * pts[i].x() + dy * pts[i].y() + dz * pts[i].z();
                    if (v > top) top = v, best = i;
                }
                extremes.push_back(pts[best]);
            }
    Mesh inner;
    CGAL::convex_hull_3(extremes.begin(), extremes.end(), inner);
    if (inner.number_of_faces() < 4 || !CGAL::is_closed(inner)) return pts;
    // The planes n·p ≤ d of the inner polytope's faces, n pointing away from its centroid.
    double extent = 0.0, cx = 0.0, cy = 0.0, cz = 0.0;
    for (const Point& p : extremes) {
        extent = std::max({extent, std::abs(p.x()), std::abs(p.y()), std::abs(p.z())});
        cx += p.x() / extremes.size(), cy += p.y() / extremes.size(), cz += p.z() / extremes.size();
    }
    struct Plane {
        double nx, ny, nz, d;
    };
    std::vector<Plane> planes;
    for (auto f : inner.faces()) {
        auto h = inner.halfedge(f);
        const Point& a = inner.point(inner.source(h));
        const Point& b = inner.point(inner.target(h));
        const Point& c = inner.point(inner.target(inner.next(h)));
        const double ux = b.x() - a.x(), uy = b.y() - a.y(), uz = b.z() - a.z();
        const double vx = c.x() - a.x(), vy = c.y() - a.y(), vz = c.z() - a.z();
        Plane pl{uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx, 0.0};
        const double len = std::sqrt(pl.nx * pl.nx + pl.ny * pl.ny + pl.nz * pl.nz);
        if (!(len > 0)) return pts;
        pl.nx /= len, pl.ny /= len, pl.nz /= len;
        pl.d = pl.nx * a.x() + pl.ny * a.y() + pl.nz * a.z();
        if (pl.nx * cx + pl.ny * cy + pl.nz * cz > pl.d) pl = {-pl.nx, -pl.ny, -pl.nz, -pl.d};
        planes.push_back(pl);
    }
    const double margin = 1e-9 * std::max(extent, 1.0);
    std::vector<Point> kept;
    for (const Point& p : pts) {
        bool inside = true;
        for (const Plane& pl : planes) {
            if (pl.nx * p.x() + pl.ny * p.y() + pl.nz * p.z() - pl.d > -margin) {
                inside = false;
                break;
            }
        }
        if (!inside) kept.push_back(p);
    }
    return kept;
}

}  // namespace

double convexHullVolume(const std::vector<Vec3>& points) {
    std::vector<Point> pts;
    pts.reserve(points.size());
    for (const Vec3& p : points) {
        if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) {
            pts.emplace_back(p.x, p.y, p.z);
        }
    }
    if (pts.size() < 4) return 0.0;

    // convex_hull_3 emits a non-closed (or empty) mesh for lower-dimensional input, on which
    // volume() would be meaningless, so first check with exact predicates that the points
    // span 3D: find two distinct points, a third off their line, a fourth off their plane.
    size_t i1 = 1;
    while (i1 < pts.size() && pts[i1] == pts[0]) ++i1;
    if (i1 == pts.size()) return 0.0;
    size_t i2 = i1 + 1;
    while (i2 < pts.size() && CGAL::collinear(pts[0], pts[i1], pts[i2])) ++i2;
    if (i2 >= pts.size()) return 0.0;
    size_t i3 = i2 + 1;
    while (i3 < pts.size() && CGAL::coplanar(pts[0], pts[i1], pts[i2], pts[i3])) ++i3;
    if (i3 >= pts.size()) return 0.0;

    Mesh hull;
    const std::vector<Point> candidates = dropInterior(pts);
    CGAL::convex_hull_3(candidates.begin(), candidates.end(), hull);
    if (hull.number_of_faces() < 4 || !CGAL::is_closed(hull)) return 0.0;
    // Sum the tetrahedra exactly: the hull's face order and the triangulation of coplanar
    // facets depend on the heap state, and a floating-point sum would differ in the last bits
    // between runs; the exact volume of the hull polytope does not. The sum only adds,
    // subtracts and multiplies doubles, so it runs in CGAL's Mpzf (exact binary floating
    // point, no fractions to reduce: the rational type's canonicalisation was most of this
    // function's time); the exact total becomes a rational once, for the rounding to double
    // the rational sum always had (mpq_get_d).
    using Z = CGAL::Mpzf;
    const Point& o = hull.point(*hull.vertices().begin());
    const Z ox(o.x()), oy(o.y()), oz(o.z());
    auto rel = [&](const Point& p) -> std::array<Z, 3> {
        return {Z(p.x()) - ox, Z(p.y()) - oy, Z(p.z()) - oz};
    };
    Z vol6 = 0;
    for (auto f : hull.faces()) {
        auto h = hull.halfedge(f);
        auto [ax, ay, az] = rel(hull.point(hull.target(h)));
        auto [bx, by, bz] = rel(hull.point(hull.target(hull.next(h))));
        auto [cx, cy, cz] = rel(hull.point(hull.source(h)));
        vol6 += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
    }
    const CGAL::Exact_rational exact = static_cast<CGAL::Exact_rational>(vol6);
    return std::abs(CGAL::to_double(exact)) / 6.0;
}

TreeStats computeStats(const Tree& tree) {
    TreeStats s;
    const auto& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());
    s.nodes = n;
    if (n == 0) {
        addShapeMetrics(tree, s);
        addRealismMetrics(tree, s);
        return s;
    }
    ChildIndex children(tree);  // also validates the parent invariant

    Aabb shootBox;
    double minRootY = 0.0;
    bool anyRoot = false;
    std::vector<Vec3> shootPoints;
    shootPoints.reserve(n);
    for (int32_t i = 0; i < n; ++i) {
        const SkeletonNode& node = nodes[i];
        s.highestOrder = std::max<int64_t>(s.highestOrder, node.order);
        if (node.part == kRootPart) {
            minRootY = anyRoot ? std::min(minRootY, node.position.y) : node.position.y;
            anyRoot = true;
        } else {
            shootBox.extend(node.position);
            shootPoints.push_back(node.position);
        }
        if (i > 0) {
            ++s.segments;
            s.totalLength += distance(nodes[node.parent].position, node.position);
            if (children.count(i) == 0) ++s.endpoints;
        }
    }
    s.segmentsPerOrder.assign(static_cast<size_t>(s.highestOrder) + 1, 0);
    for (int32_t i = 1; i < n; ++i) ++s.segmentsPerOrder[std::max(0, nodes[i].order)];

    if (!shootBox.empty()) {
        s.height = shootBox.hi.y;
        s.crownWidth = std::max(shootBox.size().x, shootBox.size().z);
    }
    s.rootDepth = anyRoot ? std::max(0.0, -minRootY) : 0.0;
    s.crownHullVolume = convexHullVolume(shootPoints);
    addShapeMetrics(tree, s);
    addRealismMetrics(tree, s);
    return s;
}

}  // namespace sylva
