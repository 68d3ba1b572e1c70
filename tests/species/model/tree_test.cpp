// ChildIndex, assignBranchOrder and computeStats on small hand-built trees.
#include "species/model/tree.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Exact_rational.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/convex_hull_3.h>
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "core/rng.h"
#include "species/model/tree_stats.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

std::vector<int32_t> orders(const Tree& t) {
    std::vector<int32_t> o;
    for (const auto& n : t.nodes) o.push_back(n.order);
    return o;
}

TEST(ChildIndex, CsrChildrenInAscendingOrder) {
    Tree t;
    addNode(t, -1, {0, 0, 0});
    addNode(t, 0, {0, 1, 0});  // 1
    addNode(t, 0, {1, 0, 0});  // 2
    addNode(t, 1, {0, 2, 0});  // 3
    addNode(t, 2, {2, 0, 0});  // 4
    addNode(t, 1, {1, 2, 0});  // 5
    ChildIndex ci(t);
    ASSERT_EQ(ci.offset.size(), 7u);
    EXPECT_EQ(ci.offset, (std::vector<int32_t>{0, 2, 4, 5, 5, 5, 5}));
    EXPECT_EQ(ci.child, (std::vector<int32_t>{1, 2, 3, 5, 4}));
    EXPECT_EQ(ci.count(0), 2);
    EXPECT_EQ(ci.count(1), 2);
    EXPECT_EQ(ci.count(2), 1);
    EXPECT_EQ(ci.count(3), 0);
}

TEST(ChildIndex, EmptyAndSingleNode) {
    Tree t;
    ChildIndex e(t);
    EXPECT_EQ(e.offset, std::vector<int32_t>{0});
    EXPECT_TRUE(e.child.empty());
    addNode(t, -1, {0, 0, 0});
    ChildIndex one(t);
    EXPECT_EQ(one.offset, (std::vector<int32_t>{0, 0}));
    EXPECT_EQ(one.count(0), 0);
}

TEST(ChildIndex, RejectsParentNotSmaller) {
    Tree t;
    addNode(t, -1, {0, 0, 0});
    addNode(t, 2, {0, 1, 0});
    addNode(t, 0, {0, 2, 0});
    EXPECT_THROW(ChildIndex{t}, std::invalid_argument);
}

TEST(BranchOrder, TrunkKeepsOrderLateralsIncrement) {
    Tree t;
    addNode(t, -1, {0, 0, 0});     // 0
    addNode(t, 0, {0, 1, 0});      // 1 trunk
    addNode(t, 1, {0, 2, 0});      // 2 trunk
    addNode(t, 2, {0, 3, 0});      // 3 trunk tip
    addNode(t, 1, {0.5, 1.5, 0});  // 4 lateral at 1 (shorter than the trunk above)
    addNode(t, 4, {1, 2, 0});      // 5
    addNode(t, 5, {1.2, 2.1, 0});  // 6 continues the lateral
    addNode(t, 5, {1.1, 2.5, 0});  // 7 sub-lateral (longer than 6: 0.51 vs 0.22)
    addNode(t, 2, {0.2, 2.1, 0});  // 8 twig at 2
    for (auto& n : t.nodes) n.order = 99;
    assignBranchOrder(t);
    // 7 is longer than 6 from node 5, so 7 continues order 1 and 6 becomes order 2.
    EXPECT_EQ(orders(t), (std::vector<int32_t>{0, 0, 0, 0, 1, 1, 2, 1, 1}));
}

TEST(BranchOrder, LongerLateralTakesOverTheAxis) {
    Tree t;
    addNode(t, -1, {0, 0, 0});   // 0
    addNode(t, 0, {0, 1, 0});    // 1
    addNode(t, 1, {0, 1.5, 0});  // 2 short "leader"
    addNode(t, 1, {1, 1, 0});    // 3 long side limb
    addNode(t, 3, {3, 1, 0});    // 4
    assignBranchOrder(t);
    EXPECT_EQ(orders(t), (std::vector<int32_t>{0, 0, 1, 0, 0}));
}

TEST(BranchOrder, TiesGoToLowerIndex) {
    Tree t;
    addNode(t, -1, {0, 0, 0});
    addNode(t, 0, {0, 1, 0});   // 1
    addNode(t, 1, {1, 1, 0});   // 2 length 1
    addNode(t, 1, {-1, 1, 0});  // 3 length 1 (tie)
    addNode(t, 1, {0, 2, 0});   // 4 length 1 (tie)
    assignBranchOrder(t);
    EXPECT_EQ(orders(t), (std::vector<int32_t>{0, 0, 0, 1, 1}));
}

TEST(BranchOrder, ShootAndRootSystemsEachHaveAnOrderZeroAxis) {
    Tree t;
    addNode(t, -1, {0, 0, 0});                          // 0
    addNode(t, 0, {0, 1, 0});                           // 1 trunk (shorter than taproot)
    addNode(t, 0, {0, -3, 0}, 0.01, 0, kRootPart);      // 2 taproot
    addNode(t, 0, {0.5, -0.5, 0}, 0.01, 0, kRootPart);  // 3 lateral root
    addNode(t, 0, {0.3, 0.2, 0});                       // 4 low shoot
    addNode(t, 2, {0, -4, 0}, 0.01, 0, kRootPart);      // 5 taproot continues
    addNode(t, 2, {0.2, -3.1, 0}, 0.01, 0, kRootPart);  // 6 root off the taproot
    assignBranchOrder(t);
    EXPECT_EQ(orders(t), (std::vector<int32_t>{0, 0, 0, 1, 1, 0, 1}));
}

TEST(TreeStats, CountsAndMeasures) {
    Tree t;
    addNode(t, -1, {0, 0, 0});                        // 0
    addNode(t, 0, {0, 2, 0});                         // 1
    addNode(t, 1, {0, 4, 0});                         // 2 tip (height 4)
    addNode(t, 1, {1.5, 3, 0});                       // 3
    addNode(t, 3, {1.5, 3, -0.5});                    // 4 tip
    addNode(t, 0, {0, -1, 0}, 0.01, 0, kRootPart);    // 5
    addNode(t, 5, {0, -1.5, 0}, 0.01, 0, kRootPart);  // 6 tip (depth 1.5)
    assignBranchOrder(t);
    TreeStats s = computeStats(t);
    EXPECT_EQ(s.nodes, 7);
    EXPECT_EQ(s.segments, 6);
    EXPECT_EQ(s.endpoints, 3);
    EXPECT_DOUBLE_EQ(s.height, 4.0);
    EXPECT_DOUBLE_EQ(s.rootDepth, 1.5);
    EXPECT_DOUBLE_EQ(s.crownWidth, 1.5);  // x-extent 1.5 > z-extent 0.5
    double len = 2 + 2 + std::sqrt(1.5 * 1.5 + 1.0) + 0.5 + 1 + 0.5;
    EXPECT_NEAR(s.totalLength, len, 1e-12);
    EXPECT_EQ(s.highestOrder, 1);
    // At node 1 the limb via 3 (1.80 + 0.5 m) outlasts the leader to 2 (2 m): 2 is the lateral.
    EXPECT_EQ(orders(t), (std::vector<int32_t>{0, 0, 1, 0, 0, 0, 0}));
    EXPECT_EQ(s.segmentsPerOrder, (std::vector<int64_t>{5, 1}));
    // Shoot points: (0,0,0) (0,2,0) (0,4,0) (1.5,3,0) (1.5,3,-0.5): tetrahedral-ish hull.
    EXPECT_GT(s.crownHullVolume, 0.0);
}

TEST(TreeStats, EmptyAndNoRootSystem) {
    Tree t;
    TreeStats e = computeStats(t);
    EXPECT_EQ(e.nodes, 0);
    EXPECT_EQ(e.segments, 0);
    EXPECT_EQ(e.crownHullVolume, 0.0);
    addNode(t, -1, {0, 0, 0});
    addNode(t, 0, {0, 1, 0});
    TreeStats s = computeStats(t);
    EXPECT_EQ(s.endpoints, 1);
    EXPECT_EQ(s.rootDepth, 0.0);
    EXPECT_EQ(s.crownHullVolume, 0.0);  // two points
    EXPECT_EQ(s.segmentsPerOrder, std::vector<int64_t>{1});
}

TEST(TreeStats, HullOfUnitCubeCornersPlusCentreIsOne) {
    std::vector<Vec3> pts;
    for (int i = 0; i < 8; ++i)
        pts.push_back({double(i & 1), double((i >> 1) & 1), double(i >> 2)});
    pts.push_back({0.5, 0.5, 0.5});
    EXPECT_NEAR(convexHullVolume(pts), 1.0, 1e-12);

    // Same through computeStats: a star of shoot nodes from the root at corner (0,0,0).
    Tree t;
    addNode(t, -1, pts[0]);
    for (size_t i = 1; i < pts.size(); ++i) addNode(t, 0, pts[i]);
    EXPECT_NEAR(computeStats(t).crownHullVolume, 1.0, 1e-12);
}

// The hull of every point (CGAL, no throw-away), its tetrahedra summed in `Number` in face
// order, |sum| / 6 as a double.
template <class Number>
double hullOfAllIn(const std::vector<Vec3>& points) {
    using K = CGAL::Exact_predicates_inexact_constructions_kernel;
    std::vector<K::Point_3> pts;
    for (const Vec3& p : points) pts.emplace_back(p.x, p.y, p.z);
    CGAL::Surface_mesh<K::Point_3> hull;
    CGAL::convex_hull_3(pts.begin(), pts.end(), hull);
    using Q = Number;
    const K::Point_3& o = hull.point(*hull.vertices().begin());
    Q vol6 = 0;
    for (auto f : hull.faces()) {
        auto h = hull.halfedge(f);
        const K::Point_3& a = hull.point(hull.target(h));
        const K::Point_3& b = hull.point(hull.target(hull.next(h)));
        const K::Point_3& c = hull.point(hull.source(h));
        const Q ax = Q(a.x()) - o.x(), ay = Q(a.y()) - o.y(), az = Q(a.z()) - o.z();
        const Q bx = Q(b.x()) - o.x(), by = Q(b.y()) - o.y(), bz = Q(b.z()) - o.z();
        const Q cx = Q(c.x()) - o.x(), cy = Q(c.y()) - o.y(), cz = Q(c.z()) - o.z();
        vol6 += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
    }
    return std::abs(CGAL::to_double(vol6)) / 6.0;
}

// The exact volume of the hull of every point, summed in rationals throughout, as
// convexHullVolume computed it before it threw away the points inside the polytope of 26
// extreme points and before it summed in Mpzf: the reference for both.
double hullOfAll(const std::vector<Vec3>& points) {
    return hullOfAllIn<CGAL::Exact_rational>(points);
}

TEST(TreeStats, HullIgnoresInteriorPointsToTheBit) {
    // A lattice of 17³ points 1/8 apart (exact in binary), as canopy nodes lie: a 2 m cube.
    std::vector<Vec3> lattice;
    for (int x = 0; x <= 16; ++x)
        for (int y = 0; y <= 16; ++y)
            for (int z = 0; z <= 16; ++z) lattice.push_back({x / 8.0, y / 8.0, z / 8.0});
    EXPECT_EQ(convexHullVolume(lattice), 8.0);
    // Clouds with most points inside: a ball with a dense core, and a crown-like cone, with
    // a few points just outside the polytope of extreme points (within its margin, 1e-9 of
    // the extent) and on the clouds' lattice planes. The same volume as the hull of all.
    Rng rng(11);
    for (int trial = 0; trial < 6; ++trial) {
        std::vector<Vec3> cloud;
        for (int i = 0; i < 3000; ++i) {
            const Vec3 u = rng.unitVector();
            const double r = i % 3 == 0 ? 1.0 : std::cbrt(rng.uniform()) * (trial % 2 ? 0.5 : 1.0);
            Vec3 p = u * r;
            if (trial >= 4) p = {std::round(p.x * 16) / 16, std::round(p.y * 16) / 16, p.z};
            cloud.push_back(p + Vec3{3.0 * trial, 10.0, -2.0});
        }
        EXPECT_EQ(convexHullVolume(cloud), hullOfAll(cloud)) << "trial " << trial;
    }
}

// The exact sum runs in binary floating point (Mpzf) and becomes a rational once: the same
// double as summing in rationals throughout, also where a double sum loses bits — small, thin
// or flat clouds far from the origin, their coordinates using every mantissa bit.
TEST(TreeStats, HullSumIsTheRationalSumToTheBit) {
    Rng rng(17);
    int roundedApart = 0;
    for (int trial = 0; trial < 12; ++trial) {
        const double offset = std::ldexp(1.0, 3 * trial) * (1.0 + rng.uniform());
        const Vec3 scale{rng.uniform(1e-3, 2.0), rng.uniform(1e-6, 2.0), rng.uniform(1e-3, 2.0)};
        std::vector<Vec3> cloud;
        for (int i = 0; i < 400; ++i) {
            const Vec3 u = rng.unitVector();
            cloud.push_back(
                {offset + u.x * scale.x, -offset + u.y * scale.y, offset + u.z * scale.z});
        }
        const double v = convexHullVolume(cloud);
        EXPECT_EQ(v, hullOfAll(cloud)) << "trial " << trial;
        EXPECT_GT(v, 0.0) << "trial " << trial;
        roundedApart += v != hullOfAllIn<double>(cloud);  // what the exact sum avoids
    }
    // The clouds exercise the rounding: a double sum gets most of them wrong in the last bits.
    EXPECT_GE(roundedApart, 6);
}

TEST(TreeStats, DegenerateHullsAreZero) {
    EXPECT_EQ(convexHullVolume({}), 0.0);
    EXPECT_EQ(convexHullVolume({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), 0.0);
    // Coplanar (z = 2) and collinear sets, and repeated points.
    EXPECT_EQ(convexHullVolume({{0, 0, 2}, {1, 0, 2}, {0, 1, 2}, {1, 1, 2}, {0.3, 0.2, 2}}), 0.0);
    EXPECT_EQ(convexHullVolume({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}}), 0.0);
    EXPECT_EQ(convexHullVolume({{1, 2, 3}, {1, 2, 3}, {1, 2, 3}, {1, 2, 3}}), 0.0);
    // A tetrahedron: 1/6.
    EXPECT_NEAR(convexHullVolume({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}), 1.0 / 6, 1e-12);
}

// pruneTree: a node outside goes with everything above it and the leaves on it; the rest keep
// their order, parents renumbered; endpoints recomputed.
TEST(PruneTree, CutsSubtreesOutsideAndTheirLeaves) {
    Tree t;
    t.nodes.resize(5);
    t.nodes[0].position = {0, 0, 0};
    t.nodes[1].position = {0, 1, 0};
    t.nodes[1].parent = 0;
    t.nodes[2].position = {2, 1, 0};  // outside x ≤ 1: cut, with node 3 above it
    t.nodes[2].parent = 1;
    t.nodes[3].position = {0.5, 2, 0};
    t.nodes[3].parent = 2;
    t.nodes[4].position = {-1, 2, 0};
    t.nodes[4].parent = 1;
    t.endpoints = {3, 4};
    Leaf onCut, onKept, outside;
    onCut.node = 3;
    onCut.position = {0.5, 2, 0};
    onKept.node = 4;
    onKept.position = {-1, 2, 0};
    outside.position = {3, 0, 0};
    t.leaves = {onCut, onKept, outside};
    pruneTree(t, [](const Vec3& p) { return p.x <= 1.0; });
    ASSERT_EQ(t.nodes.size(), 3u);
    EXPECT_EQ(t.nodes[2].position.x, -1.0);
    EXPECT_EQ(t.nodes[2].parent, 1);
    ASSERT_EQ(t.leaves.size(), 1u);
    EXPECT_EQ(t.leaves[0].node, 2);
    EXPECT_EQ(t.endpoints, std::vector<int32_t>{2});
    // Nothing outside: untouched, the method's own endpoints too.
    const std::vector<int32_t> before = t.endpoints = {0, 2};
    pruneTree(t, [](const Vec3&) { return true; });
    EXPECT_EQ(t.nodes.size(), 3u);
    EXPECT_EQ(t.endpoints, before);
}

}  // namespace
}  // namespace sylva
