// Leaf shapes (species/model/leaf_shape.h) with known answers: the card is the unit square of
// old; every outline fits and spans the unit card and attaches at its base; the triangulation
// covers each outline exactly (triangle areas sum to the shoelace area, every triangle is
// counter-clockwise, and a grid of points is in exactly as many triangles as parts); the
// simple blade's area converges to its closed form; the ear clipper on small polygons;
// leafPoints and leafArea on placed leaves.
#include "species/model/leaf_shape.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace sylva {
namespace {

constexpr LeafShape kShapes[] = {LeafShape::kCard,    LeafShape::kSimple,   LeafShape::kLobed,
                                 LeafShape::kPalmate, LeafShape::kCompound, LeafShape::kNeedles,
                                 LeafShape::kFrond};

double triArea(const Vec2& a, const Vec2& b, const Vec2& c) { return 0.5 * cross(b - a, c - a); }

// Even-odd point in polygon.
bool inPolygon(const Vec2& p, const Vec2* v, size_t n) {
    bool in = false;
    for (size_t i = 0, j = n - 1; i < n; j = i++) {
        if ((v[i].y > p.y) != (v[j].y > p.y) &&
            p.x < v[j].x + (p.y - v[j].y) * (v[i].x - v[j].x) / (v[i].y - v[j].y)) {
            in = !in;
        }
    }
    return in;
}

bool inTriangle(const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c) {
    return cross(b - a, p - a) >= 0 && cross(c - b, p - b) >= 0 && cross(a - c, p - c) >= 0;
}

TEST(LeafShape, WordsNameEveryShapeInEnumOrder) {
    const auto& words = leafShapeWords();
    ASSERT_EQ(words.size(), std::size(kShapes));
    const char* names[] = {"card", "simple", "lobed", "palmate", "compound", "needles", "frond"};
    for (size_t i = 0; i < words.size(); ++i) {
        EXPECT_EQ(words[i].first, names[i]);
        EXPECT_EQ(words[i].second, kShapes[i]);
    }
}

TEST(LeafShape, CardIsTheUnitSquareInTwoTriangles) {
    const LeafOutline& o = leafOutline(LeafShape::kCard);
    const std::vector<Vec2> corners{{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};
    EXPECT_EQ(o.points, corners);
    EXPECT_EQ(o.triangles, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
    EXPECT_EQ(o.parts, (std::vector<uint32_t>{0, 4}));
    EXPECT_EQ(o.area, 1.0);  // exactly: leaf_area_m2 of card leaves is size² · aspect
}

TEST(LeafShape, EveryOutlineFitsAndSpansTheCardAndAttachesAtItsBase) {
    for (LeafShape s : kShapes) {
        SCOPED_TRACE(static_cast<int>(s));
        const LeafOutline& o = leafOutline(s);
        double x0 = 1e9, x1 = -1e9, y = 0, baseHalfWidth = 0;
        for (const Vec2& p : o.points) {
            x0 = std::min(x0, p.x);
            x1 = std::max(x1, p.x);
            y = std::max(y, std::abs(p.y));
        }
        for (const Vec2& p : o.points) {
            if (p.x < -0.49) baseHalfWidth = std::max(baseHalfWidth, std::abs(p.y));
        }
        EXPECT_NEAR(x0, -0.5, 1e-12);
        EXPECT_NEAR(x1, 0.5, 1e-12);
        EXPECT_NEAR(y, 0.5, 1e-12);
        // The base (where the leaf meets its twig, x = −0.5) is narrow and on the midline
        // (a tuft of needles: its short shoot), except for the card, whose whole near edge
        // is its base.
        if (s != LeafShape::kCard) {
            EXPECT_LT(baseHalfWidth, 0.3);
        }
        EXPECT_GT(o.naturalAspect, 0.2);
        EXPECT_LE(o.naturalAspect, 1.0);
    }
}

TEST(LeafShape, TriangulationCoversEachOutlineExactly) {
    for (LeafShape s : kShapes) {
        SCOPED_TRACE(static_cast<int>(s));
        const LeafOutline& o = leafOutline(s);
        ASSERT_GE(o.partCount(), 1u);
        ASSERT_EQ(o.parts.back(), o.points.size());
        // Per part: counter-clockwise, n − 2 triangles of its own points.
        std::vector<int> partOf(o.points.size());
        size_t expectedTriangles = 0;
        double shoelace = 0;
        for (size_t k = 0; k < o.partCount(); ++k) {
            const size_t b = o.parts[k], e = o.parts[k + 1];
            ASSERT_GE(e - b, 3u);
            double a = 0;
            for (size_t i = b; i < e; ++i) {
                a += 0.5 * cross(o.points[i], o.points[i + 1 < e ? i + 1 : b]);
                partOf[i] = static_cast<int>(k);
            }
            EXPECT_GT(a, 0) << "part " << k << " is not counter-clockwise";
            shoelace += a;
            expectedTriangles += e - b - 2;
        }
        EXPECT_NEAR(o.area, shoelace, 1e-14);
        ASSERT_EQ(o.triangles.size() % 3, 0u);
        EXPECT_EQ(o.triangleCount(), expectedTriangles);
        double sum = 0;
        for (size_t t = 0; t < o.triangles.size(); t += 3) {
            const uint32_t i = o.triangles[t], j = o.triangles[t + 1], k = o.triangles[t + 2];
            ASSERT_LT(std::max({i, j, k}), o.points.size());
            EXPECT_EQ(partOf[i], partOf[j]);
            EXPECT_EQ(partOf[i], partOf[k]);
            const double a = triArea(o.points[i], o.points[j], o.points[k]);
            EXPECT_GT(a, 0) << "triangle " << t / 3 << " is inverted or degenerate";
            sum += a;
        }
        EXPECT_NEAR(sum, o.area, 1e-12);
        // Cover: a point off every edge lies in at most one part (the parts do not overlap)
        // and in exactly as many triangles as parts (no gap, no overlap).
        constexpr int kGrid = 301;
        int inside = 0;
        for (int gy = 0; gy < kGrid; ++gy) {
            for (int gx = 0; gx < kGrid; ++gx) {
                // Irrational offsets keep the points off the outline's edges and vertices.
                const Vec2 p{-0.5 + (gx + 0.5 * std::sqrt(2.0) - 0.2) / kGrid,
                             -0.5 + (gy + 0.5 * std::sqrt(3.0) - 0.4) / kGrid};
                int parts = 0, triangles = 0;
                for (size_t k = 0; k < o.partCount(); ++k) {
                    parts +=
                        inPolygon(p, o.points.data() + o.parts[k], o.parts[k + 1] - o.parts[k]);
                }
                for (size_t t = 0; t < o.triangles.size(); t += 3) {
                    triangles +=
                        inTriangle(p, o.points[o.triangles[t]], o.points[o.triangles[t + 1]],
                                   o.points[o.triangles[t + 2]]);
                }
                ASSERT_LE(parts, 1) << "parts overlap at " << p.x << ", " << p.y;
                ASSERT_EQ(triangles, parts) << "at " << p.x << ", " << p.y;
                inside += parts;
            }
        }
        // And the grid's share inside estimates the area (to within the grid's resolution).
        EXPECT_NEAR(inside / double(kGrid * kGrid), o.area, 0.01);
    }
}

TEST(LeafShape, SimpleBladeConvergesToItsClosedForm) {
    // Profile t^a (1 − t)^b scaled to half-width 0.5 at its peak, length 1: area =
    // B(a + 1, b + 1) / (t*^a (1 − t*)^b), t* = a / (a + b) (documented: a = 0.8, b = 1.25).
    const double a = 0.8, b = 1.25, peak = a / (a + b);
    const double exact = std::beta(a + 1, b + 1) / (std::pow(peak, a) * std::pow(1 - peak, b));
    // The inscribed polygon is smaller, by O(1/n²).
    const double coarse = leafOutline(LeafShape::kSimple).area;
    EXPECT_LT(coarse, exact);
    EXPECT_NEAR(coarse, exact, 0.04 * exact);
    EXPECT_NEAR(buildLeafOutline(LeafShape::kSimple, 16).area, exact, 4e-4 * exact);
    EXPECT_NEAR(buildLeafOutline(LeafShape::kSimple, 64).area, exact, 3e-5 * exact);
}

TEST(LeafShape, CurvedOutlinesConvergeAsTheirResolutionGrows) {
    // The shipped outlines are within a few per cent of the curves they sample (the lobed blade
    // 5 % under, the compound's leaflets, six points each, 9 % under).
    const std::pair<LeafShape, double> within[] = {{LeafShape::kSimple, 0.04},
                                                   {LeafShape::kLobed, 0.06},
                                                   {LeafShape::kPalmate, 0.04},
                                                   {LeafShape::kCompound, 0.1}};
    for (const auto& [s, tolerance] : within) {
        SCOPED_TRACE(static_cast<int>(s));
        const double fine = buildLeafOutline(s, 16).area, finer = buildLeafOutline(s, 32).area;
        EXPECT_NEAR(fine, finer, 2e-3 * finer);
        EXPECT_NEAR(leafOutline(s).area, finer, tolerance * finer);
    }
}

TEST(LeafShape, ShippedAreasAndTriangleCountsAreTheDocumentedOnes) {
    // docs/specs.md, "Leaf shapes": area (fraction of the card) and triangles per outline.
    struct Expected {
        LeafShape shape;
        double area;
        size_t triangles;
    };
    const Expected table[] = {
        {LeafShape::kCard, 1.0, 2},        {LeafShape::kSimple, 0.630, 12},
        {LeafShape::kLobed, 0.548, 28},    {LeafShape::kPalmate, 0.286, 25},
        {LeafShape::kCompound, 0.266, 46}, {LeafShape::kNeedles, 0.317, 14},
        {LeafShape::kFrond, 0.166, 58},
    };
    for (const Expected& e : table) {
        SCOPED_TRACE(static_cast<int>(e.shape));
        EXPECT_NEAR(leafOutline(e.shape).area, e.area, 5e-4);
        EXPECT_EQ(leafOutline(e.shape).triangleCount(), e.triangles);
        EXPECT_LE(e.triangles, 80u);  // tens per leaf, not hundreds
    }
}

TEST(LeafShape, EarClippingKnownPolygons) {
    // A convex hexagon: n − 2 triangles of the polygon's area.
    std::vector<Vec2> hex;
    for (int k = 0; k < 6; ++k) hex.push_back({std::cos(k * kPi / 3), std::sin(k * kPi / 3)});
    auto area = [](const std::vector<Vec2>& p, const std::vector<uint32_t>& t) {
        double s = 0;
        for (size_t i = 0; i < t.size(); i += 3) s += triArea(p[t[i]], p[t[i + 1]], p[t[i + 2]]);
        return s;
    };
    const auto th = triangulatePolygon(hex);
    EXPECT_EQ(th.size(), 12u);
    EXPECT_NEAR(area(hex, th), 1.5 * std::sqrt(3.0), 1e-12);
    // A "U" (non-convex, not star-shaped from its centre): 8 points, area 3·2 − 1·1.5 = 4.5.
    const std::vector<Vec2> u{{0, 0}, {3, 0}, {3, 2}, {2, 2}, {2, 0.5}, {1, 0.5}, {1, 2}, {0, 2}};
    const auto tu = triangulatePolygon(u);
    EXPECT_EQ(tu.size(), 18u);
    EXPECT_NEAR(area(u, tu), 4.5, 1e-12);
    for (size_t i = 0; i < tu.size(); i += 3) {
        EXPECT_GT(triArea(u[tu[i]], u[tu[i + 1]], u[tu[i + 2]]), 0);
        // No triangle bridges the notch (its centroid would lie in the gap 1 < x < 2, y > 0.5).
        const Vec2 c = (u[tu[i]] + u[tu[i + 1]] + u[tu[i + 2]]) * (1.0 / 3);
        EXPECT_FALSE(c.x > 1 && c.x < 2 && c.y > 0.5);
    }
    // Clockwise or degenerate input has no ear.
    std::vector<Vec2> cw(hex.rbegin(), hex.rend());
    EXPECT_THROW(triangulatePolygon(cw), std::invalid_argument);
    EXPECT_THROW(triangulatePolygon({{0, 0}, {1, 0}}), std::invalid_argument);
}

TEST(LeafShape, PointsAndAreaOfAPlacedLeaf) {
    Leaf leaf;
    leaf.position = {1, 2, 3};
    leaf.normal = {0, 0, 2};     // not unit: the frame normalises it
    leaf.tangent = {1, 0, 0.5};  // not perpendicular: the frame makes it so
    leaf.size = 0.3;
    leaf.aspect = 0.4;
    for (LeafShape s : kShapes) {
        SCOPED_TRACE(static_cast<int>(s));
        leaf.shape = s;
        const LeafFrame f = leafFrame(leaf);
        EXPECT_NEAR(length(f.normal - Vec3{0, 0, 1}), 0, 1e-15);
        EXPECT_NEAR(length(f.tangent - Vec3{1, 0, 0}), 0, 1e-15);
        EXPECT_NEAR(length(f.across - Vec3{0, 1, 0}), 0, 1e-15);
        const LeafOutline& o = leafOutline(s);
        std::vector<Vec3> pts{{9, 9, 9}};  // replaced, not appended to
        leafPoints(leaf, f, o, pts);
        ASSERT_EQ(pts.size(), o.points.size());
        double area = 0;
        for (size_t i = 0; i < pts.size(); ++i) {
            const Vec3 expected{1 + 0.3 * o.points[i].x, 2 + 0.12 * o.points[i].y, 3};
            EXPECT_NEAR(length(pts[i] - expected), 0, 1e-15);
        }
        for (size_t t = 0; t < o.triangles.size(); t += 3) {
            const Vec3 &a = pts[o.triangles[t]], &b = pts[o.triangles[t + 1]],
                       &c = pts[o.triangles[t + 2]];
            area += 0.5 * dot(cross(b - a, c - a), f.normal);
        }
        EXPECT_NEAR(leafArea(leaf), 0.3 * 0.3 * 0.4 * o.area, 1e-15);
        EXPECT_NEAR(area, leafArea(leaf), 1e-12);
    }
}

}  // namespace
}  // namespace sylva
