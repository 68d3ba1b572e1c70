// The renderer draws each leaf shape as its outline, the same triangles as the mesh: one leaf
// of every shape, seen face-on by an orthographic camera, gives a mask whose pixel count is
// the outline's shoelace area in pixels (within half a pixel along its edges), whose pixels
// all lie inside the projected mesh triangles, and which holds exactly the pixels whose centres
// are inside the outline's polygons (away from their edges); depth and labels agree.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "pipeline/render/camera.h"
#include "pipeline/render/render.h"
#include "species/geometry/leaf_mesh.h"
#include "species/model/leaf_shape.h"

namespace sylva {
namespace {

// An orthographic camera at (0, 0, 10) looking along −z, +y up, `height` metres tall.
Camera faceOnCamera(int size, double height) {
    Camera c;
    c.width = c.height = size;
    c.orthographic = true;
    c.orthoHeight = height;
    for (int i = 0; i < 4; ++i) c.cameraToWorld[i][i] = 1.0;
    c.cameraToWorld[2][3] = 10.0;
    return c;
}

// Signed distance (pixels) of p from the line a → b, positive on its left.
double edgeDistance(const Vec2& p, const Vec2& a, const Vec2& b) {
    return cross(b - a, p - a) / length(b - a);
}

// p within `eps` pixels of the triangle abc (either winding).
bool nearTriangle(const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c, double eps) {
    const double s = cross(b - a, c - a) > 0 ? 1.0 : -1.0;
    return s * edgeDistance(p, a, b) >= -eps && s * edgeDistance(p, b, c) >= -eps &&
           s * edgeDistance(p, c, a) >= -eps;
}

// Even-odd point in polygon, and the distance to the polygon's nearest edge.
bool inPolygon(const Vec2& p, const std::vector<Vec2>& v) {
    bool in = false;
    for (size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) {
        if ((v[i].y > p.y) != (v[j].y > p.y) &&
            p.x < v[j].x + (p.y - v[j].y) * (v[i].x - v[j].x) / (v[i].y - v[j].y)) {
            in = !in;
        }
    }
    return in;
}
double edgeGap(const Vec2& p, const std::vector<Vec2>& v) {
    double d = 1e300;
    for (size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) {
        const Vec2 e = v[i] - v[j];
        const double t = std::clamp(dot(p - v[j], e) / dot(e, e), 0.0, 1.0);
        d = std::min(d, length(p - (v[j] + e * t)));
    }
    return d;
}

TEST(LeafShapeRender, MaskIsTheOutlineAndInsideTheMeshTriangles) {
    constexpr int kSize = 320;
    const Camera cam = faceOnCamera(kSize, 1.2);
    const double pxPerMetre = kSize / 1.2;
    for (const auto& [word, shape] : leafShapeWords()) {
        SCOPED_TRACE(word);
        const LeafOutline& o = leafOutline(shape);
        Tree tree;
        Leaf leaf;
        leaf.position = {0.0123, -0.0071, 0.0};
        leaf.normal = {0, 0, 1};
        leaf.tangent = normalize(Vec3{1, 0.05, 0});  // a little off the pixel grid
        leaf.size = 1.0;
        leaf.aspect = o.naturalAspect;
        leaf.shape = shape;
        tree.leaves = {leaf};
        const ViewImage v = renderView(tree, cam, true, true);

        // The outline's parts in pixels, projected by the camera from the card coordinates
        // (position + tangent·x·size + across·y·size·aspect, across = normal × tangent).
        const Vec3 along = normalize(leaf.tangent), across = cross(leaf.normal, along);
        auto toPixel = [&](const Vec3& w) {
            double x, y, depth;
            EXPECT_TRUE(cam.project(w, x, y, depth));
            return Vec2{x, y};
        };
        std::vector<std::vector<Vec2>> parts;
        double perimeter = 0;
        for (size_t k = 0; k < o.partCount(); ++k) {
            parts.emplace_back();
            for (uint32_t i = o.parts[k]; i < o.parts[k + 1]; ++i) {
                const Vec2 c = o.points[i];
                parts.back().push_back(toPixel(leaf.position + along * (c.x * leaf.size) +
                                               across * (c.y * leaf.size * leaf.aspect)));
            }
            for (size_t i = 0, j = parts.back().size() - 1; i < parts.back().size(); j = i++) {
                perimeter += length(parts.back()[i] - parts.back()[j]);
            }
        }
        // The mesh's front triangles in pixels.
        const Mesh m = leafMesh(tree);
        std::vector<std::array<Vec2, 3>> tris;
        for (size_t f = 0; f < o.triangleCount(); ++f) {
            std::array<Vec2, 3> t;
            for (int c = 0; c < 3; ++c) {
                const uint32_t i = m.indices[3 * f + c];
                t[c] =
                    toPixel({m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]});
            }
            tris.push_back(t);
        }

        double lox = 1e300, hix = -1e300, loy = 1e300, hiy = -1e300;
        for (const auto& part : parts) {
            for (const Vec2& q : part) {
                lox = std::min(lox, q.x), hix = std::max(hix, q.x);
                loy = std::min(loy, q.y), hiy = std::max(hiy, q.y);
            }
        }
        size_t count = 0;
        for (int y = 0; y < kSize; ++y) {
            for (int x = 0; x < kSize; ++x) {
                const size_t k = static_cast<size_t>(y) * kSize + x;
                const bool drawn = v.silhouette[k] == 255;
                const Vec2 p{x + 0.5, y + 0.5};
                if (drawn) {
                    ++count;
                    EXPECT_EQ(v.labels[k], kLabelLeaf);
                    EXPECT_NEAR(v.depth[k], 10.0, 1e-5);
                    bool inMesh = false;
                    for (const auto& t : tris)
                        inMesh = inMesh || nearTriangle(p, t[0], t[1], t[2], 1e-3);
                    ASSERT_TRUE(inMesh) << "pixel " << x << ", " << y << " outside the mesh";
                } else {
                    EXPECT_EQ(v.labels[k], kLabelBackground);
                    EXPECT_EQ(v.depth[k], 0.0f);
                }
                // Exactly the pixels whose centres are inside the outline, away from its edges.
                if (p.x < lox - 1 || p.x > hix + 1 || p.y < loy - 1 || p.y > hiy + 1) {
                    ASSERT_FALSE(drawn);
                    continue;
                }
                bool inside = false, nearEdge = false;
                for (const auto& part : parts) {
                    inside = inside || inPolygon(p, part);
                    nearEdge = nearEdge || edgeGap(p, part) < 1e-3;
                }
                if (!nearEdge) {
                    ASSERT_EQ(drawn, inside) << "pixel " << x << ", " << y;
                }
            }
        }
        // Area: the outline's shoelace area in pixels, within half a pixel along its edges.
        const double expected =
            o.area * leaf.size * leaf.size * leaf.aspect * pxPerMetre * pxPerMetre;
        EXPECT_NEAR(static_cast<double>(count), expected, 0.5 * perimeter)
            << "perimeter " << perimeter << " px";
        EXPECT_GT(count, 0.1 * expected);
    }
}

}  // namespace
}  // namespace sylva
