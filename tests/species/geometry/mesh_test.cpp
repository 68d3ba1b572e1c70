// Branch tubes and leaf cards against closed forms (frustum volume and area), topology
// (closed per chain), frames (no twist), level of detail, and a large mesh through every writer.
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <map>
#include <numeric>
#include <sstream>

#include "pipeline/formats/mesh_writers.h"
#include "species/geometry/leaf_mesh.h"
#include "species/geometry/tube_mesh.h"
#include "species/model/leaf_shape.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

Tree segment(double r0, double r1, double h) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, r0, 0);
    addNode(t, 0, {0, h, 0}, r1, 0);
    return t;
}

// Trunk 0-1-2-6, a lateral from 1 (3, 4), one from 2 (5) and a taproot (7, 8): four chains.
Tree forkedTree() {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1, 0);                   // 0
    addNode(t, 0, {0, 0.5, 0}, 0.08, 0);                 // 1
    addNode(t, 1, {0.02, 1.0, 0}, 0.06, 0);              // 2
    addNode(t, 1, {0.3, 0.8, 0}, 0.03, 1);               // 3
    addNode(t, 3, {0.5, 1.0, 0.1}, 0.02, 1);             // 4
    addNode(t, 2, {-0.2, 1.2, 0.1}, 0.025, 1);           // 5
    addNode(t, 2, {0, 1.4, 0.03}, 0.04, 0);              // 6
    addNode(t, 0, {0, -0.3, 0.05}, 0.05, 0, kRootPart);  // 7
    addNode(t, 7, {0.1, -0.6, 0}, 0.03, 0, kRootPart);   // 8
    return t;
}

Vec3 vertexAt(const Mesh& m, size_t i) {
    return {m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]};
}
Vec3 normalAt(const Mesh& m, size_t i) {
    return {m.normals[3 * i], m.normals[3 * i + 1], m.normals[3 * i + 2]};
}

// Enclosed volume by the divergence theorem (positive for outward-wound closed meshes).
double signedVolume(const Mesh& m) {
    double v = 0;
    for (size_t f = 0; f < m.triangleCount(); ++f) {
        const Vec3 a = vertexAt(m, m.indices[3 * f]), b = vertexAt(m, m.indices[3 * f + 1]),
                   c = vertexAt(m, m.indices[3 * f + 2]);
        v += dot(a, cross(b, c)) / 6.0;
    }
    return v;
}

double triangleArea(const Mesh& m, size_t f) {
    const Vec3 a = vertexAt(m, m.indices[3 * f]), b = vertexAt(m, m.indices[3 * f + 1]),
               c = vertexAt(m, m.indices[3 * f + 2]);
    return 0.5 * length(cross(b - a, c - a));
}

// Vertices merged by bit-identical position (seams and caps duplicate vertices for their own
// normals and UVs).
std::vector<uint32_t> weld(const Mesh& m) {
    std::map<std::array<float, 3>, uint32_t> ids;
    std::vector<uint32_t> out(m.vertexCount());
    for (size_t i = 0; i < m.vertexCount(); ++i) {
        std::array<float, 3> key{m.positions[3 * i], m.positions[3 * i + 1],
                                 m.positions[3 * i + 2]};
        out[i] = ids.emplace(key, static_cast<uint32_t>(ids.size())).first->second;
    }
    return out;
}

struct Closure {
    bool closed = true;  // every directed edge met once, and its reverse once
    int components = 0;  // triangles connected through shared edges
};

Closure checkClosed(const Mesh& m) {
    const std::vector<uint32_t> id = weld(m);
    std::map<std::pair<uint32_t, uint32_t>, std::vector<size_t>> directed;
    for (size_t f = 0; f < m.triangleCount(); ++f) {
        for (int e = 0; e < 3; ++e) {
            directed[{id[m.indices[3 * f + e]], id[m.indices[3 * f + (e + 1) % 3]]}].push_back(f);
        }
    }
    Closure result;
    std::vector<size_t> parent(m.triangleCount());
    std::iota(parent.begin(), parent.end(), size_t(0));
    auto find = [&](size_t a) {
        while (parent[a] != a) a = parent[a] = parent[parent[a]];
        return a;
    };
    for (const auto& [edge, faces] : directed) {
        auto rev = directed.find({edge.second, edge.first});
        if (faces.size() != 1 || rev == directed.end() || rev->second.size() != 1) {
            result.closed = false;
            continue;
        }
        parent[find(faces[0])] = find(rev->second[0]);
    }
    for (size_t f = 0; f < m.triangleCount(); ++f) result.components += find(f) == f;
    return result;
}

TubeOptions fineOptions(int sides) {
    TubeOptions o;
    o.minSides = sides;
    o.maxSides = sides;
    return o;
}

TEST(MeshTube, FrustumVolumeAndLateralArea) {
    const double r0 = 0.2, r1 = 0.1, h = 1.5;
    const Mesh m = tubeMesh(segment(r0, r1, h), fineOptions(64));
    ASSERT_FALSE(m.empty());
    // Closed mesh = frustum + tip cone (height = tip radius) + flat base disc.
    const double frustum = kPi * h / 3.0 * (r0 * r0 + r0 * r1 + r1 * r1);
    const double cone = kPi * r1 * r1 * r1 / 3.0;
    EXPECT_NEAR(signedVolume(m), frustum + cone, 0.01 * (frustum + cone));
    // The lateral surface: triangles spanning both rings (not the disc at y = 0, not the cone).
    double lateral = 0, total = 0;
    for (size_t f = 0; f < m.triangleCount(); ++f) {
        double lo = 1e9, hi = -1e9;
        for (int c = 0; c < 3; ++c) {
            const double y = m.positions[3 * m.indices[3 * f + c] + 1];
            lo = std::min(lo, y);
            hi = std::max(hi, y);
        }
        if (lo < 1e-6 && hi > h - 1e-6 && hi < h + 1e-6) lateral += triangleArea(m, f);
        total += triangleArea(m, f);
    }
    const double expected = kPi * (r0 + r1) * std::sqrt((r0 - r1) * (r0 - r1) + h * h);
    EXPECT_NEAR(lateral, expected, 0.01 * expected);
    const double caps = kPi * r0 * r0 + kPi * r1 * std::sqrt(2.0) * r1;
    EXPECT_NEAR(total, expected + caps, 0.01 * (expected + caps));
    // The apex sits one tip radius beyond the last node.
    double top = -1e9;
    for (size_t i = 0; i < m.vertexCount(); ++i)
        top = std::max(top, double(m.positions[3 * i + 1]));
    EXPECT_NEAR(top, h + r1, 1e-6);
}

TEST(MeshTube, SingleSegmentIsClosed) {
    const Mesh m = tubeMesh(segment(0.1, 0.05, 1.0), TubeOptions{});
    const Closure c = checkClosed(m);
    EXPECT_TRUE(c.closed);
    EXPECT_EQ(c.components, 1);
    EXPECT_GT(signedVolume(m), 0.0);
}

TEST(MeshTube, ForkedTreeIsClosedPerChainWithoutGaps) {
    const Tree tree = forkedTree();
    const Mesh m = tubeMesh(tree, TubeOptions{});
    const Closure c = checkClosed(m);
    EXPECT_TRUE(c.closed);
    EXPECT_EQ(c.components, 4);  // trunk, taproot, two laterals
    // Each lateral starts at its fork node, inside the parent: its base disc centre is there.
    for (int fork : {1, 2}) {
        bool found = false;
        const Vec3 p = tree.nodes[fork].position;
        for (size_t i = 0; i < m.vertexCount(); ++i) {
            found |= distance(vertexAt(m, i), p) < 1e-6;
        }
        EXPECT_TRUE(found) << "no chain starts at fork node " << fork;
    }
    // Branch order per vertex: both orders present, nothing else.
    std::map<int32_t, int> orders;
    for (int32_t o : m.order) ++orders[o];
    EXPECT_EQ(orders.size(), 2u);
    EXPECT_GT(orders[0], 0);
    EXPECT_GT(orders[1], 0);
    for (uint8_t col : m.colour) EXPECT_EQ(col, 0);
}

TEST(MeshTube, NormalsAreUnitAndOutward) {
    const Mesh m = tubeMesh(forkedTree(), TubeOptions{});
    ASSERT_EQ(m.normals.size(), m.positions.size());
    for (size_t i = 0; i < m.vertexCount(); ++i) {
        EXPECT_NEAR(length(normalAt(m, i)), 1.0, 1e-5);
    }
    // Vertex normals agree with the winding (counter-clockwise seen from outside).
    for (size_t f = 0; f < m.triangleCount(); ++f) {
        const uint32_t a = m.indices[3 * f], b = m.indices[3 * f + 1], c = m.indices[3 * f + 2];
        const Vec3 g = cross(vertexAt(m, b) - vertexAt(m, a), vertexAt(m, c) - vertexAt(m, a));
        if (length(g) < 1e-12) continue;
        EXPECT_GT(dot(g, normalAt(m, a) + normalAt(m, b) + normalAt(m, c)), 0.0) << f;
    }
    // On a vertical frustum, ring normals point away from the axis and lean up (taper).
    const double r0 = 0.2, r1 = 0.1, h = 1.0;
    const Mesh f = tubeMesh(segment(r0, r1, h), fineOptions(32));
    int rings = 0;
    for (size_t i = 0; i < f.vertexCount(); ++i) {
        const Vec3 p = vertexAt(f, i), n = normalAt(f, i);
        const Vec3 radial{p.x, 0, p.z};
        if (length(radial) < 0.5 * r1 || std::abs(n.y) > 0.9 || p.y > h + 1e-6) continue;
        if (std::abs(dot(n, normalize(radial)) - 1 / std::sqrt(2.0)) < 1e-3) continue;  // cone
        ++rings;
        EXPECT_GT(dot(n, radial), 0.0);
        // n ∝ radial − (dr/ds)·t with dr/ds = (r1 − r0)/h.
        EXPECT_NEAR(n.y / length(Vec3{n.x, 0, n.z}), (r0 - r1) / h, 1e-4);
    }
    EXPECT_EQ(rings, 2 * 33);
}

TEST(MeshTube, RotationMinimisingFramesDoNotTwistAlongAHelix) {
    Tree t;
    const int n = 200;
    const double radius = 1.0, pitch = 0.3;
    std::vector<Vec3> x;
    for (int k = 0; k < n; ++k) {
        const double phi = 4 * kPi * k / (n - 1);
        x.push_back({radius * std::cos(phi), pitch * phi, radius * std::sin(phi)});
        addNode(t, k - 1, x.back(), 0.05, 0);
    }
    const int sides = 8;
    const Mesh m = tubeMesh(t, fineOptions(sides));
    // Tangents as the mesher defines them.
    std::vector<Vec3> tan(n);
    tan[0] = normalize(x[1] - x[0]);
    tan[n - 1] = normalize(x[n - 1] - x[n - 2]);
    for (int k = 1; k + 1 < n; ++k) {
        tan[k] = normalize(normalize(x[k] - x[k - 1]) + normalize(x[k + 1] - x[k]));
    }
    // Ring k starts at vertex k·(sides + 1) (layout documented in tube_mesh.cpp).
    auto start = [&](int k) { return normalize(vertexAt(m, size_t(k) * (sides + 1)) - x[k]); };
    double total = 0, worst = 0, frenet = 0;
    for (int k = 0; k + 1 < n; ++k) {
        const Vec3 a = start(k), b = start(k + 1);
        EXPECT_NEAR(dot(a, tan[k]), 0.0, 1e-5);
        // Carry a along by the smallest rotation taking tan[k] to tan[k+1]; the signed angle
        // from that to b about tan[k+1] is the twist of this step.
        const Vec3 axis = cross(tan[k], tan[k + 1]);
        const Vec3 carried =
            length(axis) > 1e-12 ? rotate(a, normalize(axis), angleBetween(tan[k], tan[k + 1])) : a;
        const double twist = std::atan2(dot(cross(carried, b), tan[k + 1]), dot(carried, b));
        total += twist;
        worst = std::max(worst, std::abs(twist));
        frenet += (pitch / (radius * radius + pitch * pitch)) * distance(x[k], x[k + 1]);
    }
    EXPECT_LT(worst, 1e-3);
    EXPECT_LT(std::abs(total), 0.02);
    EXPECT_GT(frenet, 3.0);  // what a Frenet frame would have twisted: the test can fail
}

TEST(MeshTube, PlanarChainKeepsItsFrameOffThePlane) {
    // A chain bending in the xy plane: the RMF component along z is constant.
    Tree t;
    for (int k = 0; k < 30; ++k) {
        const double a = 0.05 * k;
        addNode(t, k - 1, {1 - std::cos(a), std::sin(a), 0}, 0.02, 0);
    }
    const int sides = 6;
    const Mesh m = tubeMesh(t, fineOptions(sides));
    const double z0 = normalize(vertexAt(m, 0) - t.nodes[0].position).z;
    for (int k = 1; k < 30; ++k) {
        const Vec3 d = normalize(vertexAt(m, size_t(k) * (sides + 1)) - t.nodes[k].position);
        EXPECT_NEAR(d.z, z0, 1e-4) << k;
    }
}

// Distinct ring positions at y = 0 of a vertical segment, minus the disc centre: its sides.
int sidesOf(double r, const TubeOptions& o) {
    const Mesh m = tubeMesh(segment(r, r, 1.0), o);
    std::map<std::array<float, 3>, int> base;
    for (size_t i = 0; i < m.vertexCount(); ++i) {
        if (m.positions[3 * i + 1] == 0.0f) {
            base[{m.positions[3 * i], 0.0f, m.positions[3 * i + 2]}] = 1;
        }
    }
    return static_cast<int>(base.size()) - 1;
}

TEST(MeshTube, SidesFollowTheRadius) {
    TubeOptions o;                    // 3..16 sides, 3 cm edges
    EXPECT_EQ(sidesOf(0.1, o), 16);   // round(2π·0.1/0.03) = 21 → 16
    EXPECT_EQ(sidesOf(0.05, o), 10);  // round(10.47)
    EXPECT_EQ(sidesOf(0.02, o), 4);   // round(4.19)
    EXPECT_EQ(sidesOf(0.003, o), 3);  // round(0.63) → 3
    o.edgeLength = 0.01;
    EXPECT_EQ(sidesOf(0.02, o), 13);  // round(12.57)
    // UV seam: every ring has a column at u = 0 and one at u = 1 with the same position.
    const Mesh m = tubeMesh(segment(0.05, 0.05, 1.0), o);
    int seam0 = 0, seam1 = 0;
    for (size_t i = 0; i < m.vertexCount(); ++i) {
        seam0 += m.uvs[2 * i] == 0.0f;
        seam1 += m.uvs[2 * i] == 1.0f;
    }
    EXPECT_GE(seam0, 2);
    EXPECT_GE(seam1, 2);
    // v along the chain in units of the first circumference: top ring at h / (2π r).
    float vmax = 0;
    for (size_t i = 0; i < m.vertexCount(); ++i) {
        if (std::abs(m.positions[3 * i + 1] - 1.0f) < 1e-6 && std::abs(m.normals[3 * i + 1]) < 0.5)
            vmax = std::max(vmax, m.uvs[2 * i + 1]);
    }
    EXPECT_NEAR(vmax, 1.0 / (2 * kPi * 0.05), 1e-4);
}

TEST(MeshTube, ThinTwigsAreDroppedOrThickened) {
    Tree trunk;
    addNode(trunk, -1, {0, 0, 0}, 0.05, 0);
    addNode(trunk, 0, {0, 0.5, 0}, 0.04, 0);
    addNode(trunk, 1, {0, 1.0, 0}, 0.03, 0);
    Tree withTwig = trunk;
    addNode(withTwig, 1, {0.3, 0.6, 0}, 0.004, 1);
    addNode(withTwig, 3, {0.5, 0.65, 0}, 0.002, 1);  // and everything beyond it

    TubeOptions o;
    o.minRadius = 0.01;
    o.dropThin = true;
    const Mesh trunkOnly = tubeMesh(trunk, o);
    const Mesh dropped = tubeMesh(withTwig, o);
    EXPECT_EQ(dropped.positions, trunkOnly.positions);
    EXPECT_EQ(dropped.indices, trunkOnly.indices);

    o.dropThin = false;
    const Mesh kept = tubeMesh(withTwig, o);
    EXPECT_EQ(checkClosed(kept).components, 2);
    // The twig block follows the trunk: 3 rings of minSides + 1, cone 4 + 3, disc 3 + 1.
    const size_t base = trunkOnly.vertexCount();
    ASSERT_EQ(kept.vertexCount() - base, 3 * 4 + 7 + 4u);
    const Vec3 a = withTwig.nodes[1].position, b = withTwig.nodes[3].position;
    for (size_t i = base; i < base + 4; ++i) {  // the ring at the fork (tangent = axis)
        const Vec3 d = vertexAt(kept, i) - a;
        const Vec3 axis = normalize(b - a);
        EXPECT_NEAR(length(d - axis * dot(d, axis)), o.minRadius, 1e-6);
    }
}

TEST(MeshTube, DegenerateInputs) {
    EXPECT_TRUE(tubeMesh(Tree{}, TubeOptions{}).empty());
    Tree single;
    addNode(single, -1, {0, 0, 0}, 0.1, 0);
    EXPECT_TRUE(tubeMesh(single, TubeOptions{}).empty());
    // A zero-length segment and a zero radius tip stay finite and closed.
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1, 0);
    addNode(t, 0, {0, 0, 0}, 0.1, 0);
    addNode(t, 1, {0, 1, 0}, 0.0, 0);
    const Mesh m = tubeMesh(t, TubeOptions{});
    ASSERT_FALSE(m.empty());
    for (float v : m.positions) EXPECT_TRUE(std::isfinite(v));
    for (float v : m.normals) EXPECT_TRUE(std::isfinite(v));
    EXPECT_NEAR(signedVolume(m), kPi * 0.01 / 3.0, 0.02 * kPi * 0.01 / 3.0 + 1e-3);
}

TEST(MeshTube, Deterministic) {
    const Mesh a = tubeMesh(forkedTree(), TubeOptions{});
    const Mesh b = tubeMesh(forkedTree(), TubeOptions{});
    EXPECT_EQ(a.positions, b.positions);
    EXPECT_EQ(a.normals, b.normals);
    EXPECT_EQ(a.uvs, b.uvs);
    EXPECT_EQ(a.indices, b.indices);
}

TEST(MeshLeaf, DoubleSidedCardsOfTheRightSize) {
    Tree t;
    Leaf a;
    a.position = {1, 2, 3};
    a.normal = normalize(Vec3{0, 1, 1});
    a.tangent = {1, 0, 0};
    a.size = 0.2;
    a.aspect = 0.5;
    a.colour = 2;
    Leaf b;
    b.position = {-1, 0.5, 0};
    b.normal = {1, 0, 0};
    b.tangent = {0, 0, -1};
    b.size = 0.05;
    b.aspect = 1.0;
    b.colour = 1;
    t.leaves = {a, b};
    const Mesh m = leafMesh(t);
    ASSERT_EQ(m.vertexCount(), 8u * t.leaves.size());
    ASSERT_EQ(m.triangleCount(), 4u * t.leaves.size());  // two triangles per face, two faces
    for (size_t l = 0; l < t.leaves.size(); ++l) {
        const Leaf& leaf = t.leaves[l];
        const size_t v0 = 8 * l;
        EXPECT_NEAR(distance(vertexAt(m, v0), vertexAt(m, v0 + 1)), leaf.size, 1e-6);
        EXPECT_NEAR(distance(vertexAt(m, v0), vertexAt(m, v0 + 3)), leaf.size * leaf.aspect, 1e-6);
        EXPECT_NEAR(dot(vertexAt(m, v0 + 1) - vertexAt(m, v0), leaf.tangent), leaf.size, 1e-6);
        Vec3 centre;
        for (int c = 0; c < 4; ++c) centre += vertexAt(m, v0 + c) * 0.25;
        EXPECT_LT(distance(centre, leaf.position), 1e-6);
        // Front triangles face +normal, back triangles −normal; vertex normals agree.
        for (int tri = 0; tri < 4; ++tri) {
            const size_t f = 4 * l + tri;
            const uint32_t i = m.indices[3 * f], j = m.indices[3 * f + 1], k = m.indices[3 * f + 2];
            const Vec3 g =
                normalize(cross(vertexAt(m, j) - vertexAt(m, i), vertexAt(m, k) - vertexAt(m, i)));
            const double expected = tri < 2 ? 1.0 : -1.0;
            EXPECT_NEAR(dot(g, leaf.normal), expected, 1e-5);
            EXPECT_NEAR(dot(normalAt(m, i), leaf.normal), expected, 1e-6);
        }
        for (int c = 0; c < 8; ++c) {
            EXPECT_EQ(m.order[v0 + c], -1);
            EXPECT_EQ(m.colour[v0 + c], leaf.colour);
        }
        EXPECT_EQ(m.uvs[2 * v0 + 2], 1.0f);  // corner 1: (1, 0)
        EXPECT_EQ(m.uvs[2 * v0 + 5], 1.0f);  // corner 2: (1, 1)
    }
}

TEST(MeshLeaf, ShapedLeavesAreTheirOutlinesOnBothFaces) {
    Leaf leaf;
    leaf.position = {0.5, 1.5, -0.25};
    leaf.normal = normalize(Vec3{1, 2, 0.5});
    leaf.tangent = normalize(cross(leaf.normal, Vec3{0, 0, 1}));
    leaf.size = 0.25;
    leaf.aspect = 0.45;
    leaf.colour = 3;
    for (const auto& [word, shape] : leafShapeWords()) {
        SCOPED_TRACE(word);
        leaf.shape = shape;
        Tree t;
        t.leaves = {leaf, leaf};
        t.leaves[1].position = {-1, 0, 0};
        const LeafOutline& o = leafOutline(shape);
        const size_t n = o.points.size(), nt = o.triangleCount();
        const Mesh m = leafMesh(t);
        ASSERT_EQ(m.vertexCount(), 2 * 2 * n);
        ASSERT_EQ(m.triangleCount(), 2 * 2 * nt);
        for (size_t l = 0; l < 2; ++l) {
            std::vector<Vec3> pts;
            leafPoints(t.leaves[l], leafFrame(t.leaves[l]), o, pts);
            const size_t v0 = 2 * n * l, f0 = 2 * nt * l;
            for (size_t i = 0; i < n; ++i) {
                // Front and back vertices sit on the outline's points; UVs are card coordinates.
                EXPECT_LT(distance(vertexAt(m, v0 + i), pts[i]), 1e-6);
                EXPECT_EQ(vertexAt(m, v0 + n + i), vertexAt(m, v0 + i));
                EXPECT_EQ(m.uvs[2 * (v0 + i)], static_cast<float>(o.points[i].x + 0.5));
                EXPECT_EQ(m.uvs[2 * (v0 + i) + 1], static_cast<float>(o.points[i].y + 0.5));
                EXPECT_EQ(m.colour[v0 + i], 3);
                EXPECT_EQ(m.order[v0 + n + i], -1);
            }
            // Front triangles face +normal and cover the leaf's area; back ones face −normal.
            double front = 0, back = 0;
            for (size_t f = f0; f < f0 + 2 * nt; ++f) {
                const Vec3 a = vertexAt(m, m.indices[3 * f]), b = vertexAt(m, m.indices[3 * f + 1]),
                           c = vertexAt(m, m.indices[3 * f + 2]);
                const double area = 0.5 * dot(cross(b - a, c - a), leaf.normal);
                (f < f0 + nt ? front : back) += area;
                EXPECT_GT(f < f0 + nt ? area : -area, 0);
                const uint32_t i = m.indices[3 * f];
                EXPECT_GE(i, f < f0 + nt ? v0 : v0 + n);
                EXPECT_LT(i, f < f0 + nt ? v0 + n : v0 + 2 * n);
                EXPECT_NEAR(dot(normalAt(m, i), leaf.normal), f < f0 + nt ? 1.0 : -1.0, 1e-6);
            }
            EXPECT_NEAR(front, leafArea(leaf), 1e-6 * leafArea(leaf) + 1e-9);
            EXPECT_NEAR(back, -leafArea(leaf), 1e-6 * leafArea(leaf) + 1e-9);
        }
    }
}

// A long wiggly chain with more than 65,535 vertices.
Tree longChain(int n) {
    Tree t;
    for (int k = 0; k < n; ++k) {
        addNode(t, k - 1, {0.1 * std::sin(0.01 * k), 0.01 * k, 0.1 * std::cos(0.013 * k)},
                0.1 - 0.09 * k / n, 0);
    }
    return t;
}

uint32_t readU32(const std::string& s, size_t pos) {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(static_cast<uint8_t>(s.at(pos + i))) << (8 * i);
    return v;
}

TEST(MeshRoundTrip, LargeMeshKeepsIndicesAbove65535) {
    TreeMesh tm;
    tm.wood = tubeMesh(longChain(5000), TubeOptions{});
    ASSERT_GT(tm.wood.vertexCount(), 70000u);
    const uint32_t maxIndex = *std::max_element(tm.wood.indices.begin(), tm.wood.indices.end());
    ASSERT_GT(maxIndex, 65535u);

    // PLY: 38-byte vertices, then 13-byte faces.
    const std::string ply = meshPly(tm);
    const size_t body = ply.find("end_header\n") + 11;
    const size_t faces = body + 38 * tm.wood.vertexCount();
    ASSERT_EQ(ply.size(), faces + 13 * tm.wood.triangleCount());
    for (size_t f = 0; f < tm.wood.triangleCount(); ++f) {
        ASSERT_EQ(ply[faces + 13 * f], 3);
        for (int c = 0; c < 3; ++c) {
            ASSERT_EQ(readU32(ply, faces + 13 * f + 1 + 4 * c), tm.wood.indices[3 * f + c]);
        }
    }

    // OBJ: faces are 1-based a/a/a.
    const std::string obj = meshObj(tm);
    std::istringstream in(obj);
    std::string line;
    size_t f = 0, v = 0;
    while (std::getline(in, line)) {
        if (line.rfind("v ", 0) == 0) ++v;
        if (line.rfind("f ", 0) != 0) continue;
        std::istringstream ls(line.substr(2));
        for (int c = 0; c < 3; ++c) {
            std::string tok;
            ls >> tok;
            const uint32_t idx = static_cast<uint32_t>(std::stoul(tok.substr(0, tok.find('/'))));
            ASSERT_EQ(idx, tm.wood.indices[3 * f + c] + 1) << line;
            ASSERT_EQ(tok,
                      std::to_string(idx) + "/" + std::to_string(idx) + "/" + std::to_string(idx));
        }
        ++f;
    }
    EXPECT_EQ(f, tm.wood.triangleCount());
    EXPECT_EQ(v, tm.wood.vertexCount());

    // GLB: 32-bit indices read back intact.
    const std::string glb = meshGlb(tm);
    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    std::string err, warn;
    ASSERT_TRUE(loader.LoadBinaryFromMemory(&model, &err, &warn,
                                            reinterpret_cast<const unsigned char*>(glb.data()),
                                            static_cast<unsigned>(glb.size())))
        << err;
    ASSERT_EQ(model.meshes.size(), 1u);
    const tinygltf::Accessor& acc = model.accessors[model.meshes[0].primitives[0].indices];
    ASSERT_EQ(acc.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
    ASSERT_EQ(acc.count, tm.wood.indices.size());
    const tinygltf::BufferView& view = model.bufferViews[acc.bufferView];
    std::vector<uint32_t> indices(acc.count);
    std::memcpy(indices.data(),
                model.buffers[view.buffer].data.data() + view.byteOffset + acc.byteOffset,
                acc.count * 4);
    EXPECT_EQ(indices, tm.wood.indices);
}

}  // namespace
}  // namespace sylva
