// Tree statistics; the crown hull uses CGAL (robust predicates, inexact constructions).
#include "species/model/tree_stats.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Exact_rational.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/convex_hull_3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "species/model/realism_metrics.h"
#include "species/model/tree_metrics.h"

namespace sylva {

namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
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
    CGAL::convex_hull_3(pts.begin(), pts.end(), hull);
    if (hull.number_of_faces() < 4 || !CGAL::is_closed(hull)) return 0.0;
    // Sum the tetrahedra exactly: the hull's face order and the triangulation of coplanar
    // facets depend on the heap state, and a floating-point sum would differ in the last bits
    // between runs; the exact volume of the hull polytope does not.
    using Q = CGAL::Exact_rational;
    const Point& o = hull.point(*hull.vertices().begin());
    auto rel = [&](const Point& p) -> std::array<Q, 3> {
        return {Q(p.x()) - o.x(), Q(p.y()) - o.y(), Q(p.z()) - o.z()};
    };
    Q vol6 = 0;
    for (auto f : hull.faces()) {
        auto h = hull.halfedge(f);
        auto [ax, ay, az] = rel(hull.point(hull.target(h)));
        auto [bx, by, bz] = rel(hull.point(hull.target(hull.next(h))));
        auto [cx, cy, cz] = rel(hull.point(hull.source(h)));
        vol6 += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
    }
    return std::abs(CGAL::to_double(vol6)) / 6.0;
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
