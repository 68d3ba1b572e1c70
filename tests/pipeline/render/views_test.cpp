// Views: cameras, the renderer of the mesh (tubes and leaf outlines, optional skeleton lines),
// silhouette statistics, transforms.json, image writers, the labelled point cloud and contact
// sheets.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "pipeline/formats/view_writers.h"
#include "pipeline/render/camera.h"
#include "pipeline/render/render.h"
#include "species/geometry/leaf_mesh.h"
#include "species/geometry/tube_mesh.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

namespace fs = std::filesystem;

Vec3 column(const Camera& c, int j) {
    return {c.cameraToWorld[0][j], c.cameraToWorld[1][j], c.cameraToWorld[2][j]};
}

// A camera looking along −z from (0, 0, z) with +y up.
Camera frontCamera(bool ortho, int w, int h, double eyeZ, double fovDeg, double orthoHeight) {
    Camera c;
    c.width = w;
    c.height = h;
    c.orthographic = ortho;
    c.fovY = fovDeg * kPi / 180.0;
    c.orthoHeight = orthoHeight;
    for (int i = 0; i < 4; ++i) c.cameraToWorld[i][i] = 1.0;
    c.cameraToWorld[2][3] = eyeZ;
    return c;
}

// World metres per pixel at a depth.
double footprint(const Camera& c, double depth) {
    return c.orthographic ? 1.0 / c.fx() : depth / c.fx();
}

const Tree& grownTree() {
    static const Tree tree = [] {
        SpeciesFile species =
            loadSpecies(SYLVA_SOURCE_DIR "/species/papers/xu-mould-2012/xm-a.toml");
        return growSpecies(species, 1, nullptr, true).tree;
    }();
    return tree;
}

ViewOptions ringOptions(bool ortho) {
    ViewOptions o;
    o.count = 8;
    o.orthographic = ortho;
    o.elevationsDeg = {20, -10, 60};
    o.randomAzimuth = false;
    o.azimuthOffsetDeg = 10;
    o.width = 256;
    o.height = 192;
    return o;
}

size_t at(const ViewImage& v, int x, int y) { return static_cast<size_t>(y) * v.width + x; }

double pointSegmentDistance(const Vec3& p, const Vec3& a, const Vec3& b, double& t) {
    const Vec3 e = b - a;
    const double ee = dot(e, e);
    t = ee > 0 ? std::clamp(dot(p - a, e) / ee, 0.0, 1.0) : 0.0;
    return distance(p, a + e * t);
}

struct TempDir {
    fs::path path;
    TempDir() {
        path = fs::temp_directory_path() / ("sylva-views-test-" + std::to_string(getpid()));
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path, ec);
    }
};

std::string readBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// ---------------------------------------------------------------------------------------------
// Cameras

TEST(ViewCamera, ProjectUnprojectRoundTrip) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1);
    addNode(t, 0, {0.5, 3, -0.2}, 0.05);
    for (bool ortho : {false, true}) {
        ViewOptions o = ringOptions(ortho);
        o.width = 320;
        o.height = 200;
        Rng rng(3);
        for (const Camera& c : makeCameras(t, o, rng)) {
            for (double px : {0.0, 0.5, 17.25, 160.0, 319.9}) {
                for (double py : {0.0, 99.5, 199.75}) {
                    for (double depth : {0.5, 4.0, 13.0}) {
                        const Vec3 w = c.unproject(px, py, depth);
                        double qx, qy, qd;
                        ASSERT_TRUE(c.project(w, qx, qy, qd));
                        EXPECT_NEAR(qx, px, 1e-9);
                        EXPECT_NEAR(qy, py, 1e-9);
                        EXPECT_NEAR(qd, depth, 1e-12);
                    }
                }
            }
            // And world → pixel → world.
            for (const SkeletonNode& n : t.nodes) {
                double px, py, d;
                ASSERT_TRUE(c.project(n.position, px, py, d));
                const Vec3 back = c.unproject(px, py, d);
                EXPECT_NEAR(distance(back, n.position), 0.0, 1e-12);
            }
        }
    }
}

TEST(ViewCamera, PixelConventionAndIntrinsics) {
    Camera c = frontCamera(false, 200, 100, 10.0, 90.0, 0);
    EXPECT_NEAR(c.fx(), 50.0, 1e-12);  // (h/2)/tan(45°)
    EXPECT_EQ(c.fy(), c.fx());
    EXPECT_EQ(c.cx(), 100.0);
    EXPECT_EQ(c.cy(), 50.0);
    double px, py, d;
    ASSERT_TRUE(c.project({1, 1, 8}, px, py, d));  // 2 m in front, up-right
    EXPECT_NEAR(d, 2.0, 1e-12);
    EXPECT_NEAR(px, 100 + 50 * 0.5, 1e-12);          // x right
    EXPECT_NEAR(py, 50 - 50 * 0.5, 1e-12);           // y down
    EXPECT_FALSE(c.project({0, 0, 11}, px, py, d));  // behind

    Camera o = frontCamera(true, 200, 100, 10.0, 0, 4.0);
    EXPECT_NEAR(o.fx(), 25.0, 1e-12);  // pixels per metre
    ASSERT_TRUE(o.project({1, -1, 3}, px, py, d));
    EXPECT_NEAR(px, 125.0, 1e-12);
    EXPECT_NEAR(py, 75.0, 1e-12);
    EXPECT_NEAR(d, 7.0, 1e-12);
}

TEST(ViewCamera, RingFramesTheBoundingSphere) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.2);
    addNode(t, 0, {0, 4, 0}, 0.1);
    addNode(t, 1, {1.5, 5, 0.5}, 0.05, 1);
    Leaf leaf;
    leaf.position = {-1, 5, 0};
    leaf.size = 0.4;
    t.leaves.push_back(leaf);
    for (bool ortho : {false, true}) {
        ViewOptions o = ringOptions(ortho);
        Rng rng(1);
        const auto cams = makeCameras(t, o, rng);
        ASSERT_EQ(cams.size(), 8u);
        // Every camera looks at the same centre (projects to the principal point) from the
        // same distance.
        const Vec3 eye0 = column(cams[0], 3);
        Vec3 centre;
        {
            // Centre along the view axis of camera 0 at the framing distance: recover it from
            // two cameras' axes (they intersect at the centre).
            const Vec3 f0 = -column(cams[0], 2), f2 = -column(cams[2], 2);
            const Vec3 e2 = column(cams[2], 3);
            // Solve eye0 + s f0 ≈ e2 + u f2 (least squares).
            const double a = dot(f0, f0), b = dot(f0, f2), c = dot(f2, f2);
            const Vec3 w = eye0 - e2;
            const double d = dot(f0, w), e = dot(f2, w);
            const double s = (b * e - c * d) / (a * c - b * b);
            centre = eye0 + f0 * s;
        }
        for (int k = 0; k < 8; ++k) {
            const Camera& c = cams[k];
            EXPECT_NEAR(c.azimuthDeg, 10 + 45.0 * k, 1e-12);
            EXPECT_EQ(c.elevationDeg, o.elevationsDeg[k % 3]);
            // Orthonormal, right-handed, level right vector.
            const Vec3 r = column(c, 0), u = column(c, 1), b = column(c, 2);
            EXPECT_NEAR(dot(r, u), 0, 1e-12);
            EXPECT_NEAR(dot(r, b), 0, 1e-12);
            EXPECT_NEAR(length(cross(r, u) - b), 0, 1e-12);
            EXPECT_NEAR(r.y, 0, 1e-12);
            EXPECT_GT(u.y, 0);
            EXPECT_NEAR(std::asin(b.y) * 180 / kPi, c.elevationDeg, 1e-9);
            EXPECT_EQ(c.cameraToWorld[3][3], 1.0);
            double px, py, d;
            ASSERT_TRUE(c.project(centre, px, py, d));
            EXPECT_NEAR(px, c.cx(), 1e-6);
            EXPECT_NEAR(py, c.cy(), 1e-6);
            EXPECT_NEAR(distance(column(c, 3), centre), distance(eye0, centre), 1e-9);
            // Everything (node spheres' extreme points, leaf centre) is inside the image.
            for (const SkeletonNode& n : t.nodes) {
                for (const Vec3& dir : {r, -r, u, -u}) {
                    ASSERT_TRUE(c.project(n.position + dir * n.radius, px, py, d));
                    EXPECT_GE(px, 0);
                    EXPECT_LE(px, c.width);
                    EXPECT_GE(py, 0);
                    EXPECT_LE(py, c.height);
                }
            }
        }
        if (ortho) {
            EXPECT_GT(cams[0].orthoHeight, 0);
        } else {
            EXPECT_NEAR(cams[0].fovY, 40 * kPi / 180, 1e-12);
        }
    }
}

TEST(ViewCamera, AzimuthOffsetAndElevationRange) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1);
    addNode(t, 0, {0, 1, 0}, 0.1);
    ViewOptions o;
    o.count = 5;
    o.elevationsDeg = {-10, 70};
    o.elevationRange = true;
    o.randomAzimuth = true;
    Rng a(7), b(7), c(8);
    const auto ca = makeCameras(t, o, a), cb = makeCameras(t, o, b), cc = makeCameras(t, o, c);
    ASSERT_EQ(ca.size(), 5u);
    const double offset = ca[0].azimuthDeg;
    EXPECT_GE(offset, 0.0);
    EXPECT_LT(offset, 360.0);
    EXPECT_EQ(cb[0].azimuthDeg, offset);
    EXPECT_NE(cc[0].azimuthDeg, offset);
    for (int k = 0; k < 5; ++k) {
        EXPECT_NEAR(ca[k].azimuthDeg, offset + 72.0 * k, 1e-9);
        EXPECT_NEAR(ca[k].elevationDeg, -10 + 20.0 * k, 1e-12);
    }
    o.count = 0;
    EXPECT_TRUE(makeCameras(t, o, a).empty());
}

// ---------------------------------------------------------------------------------------------
// Renderer

// min_width_px (RenderOptions::minWidthPx) just over √2: the pixel of every skeleton point.
RenderOptions widened() {
    RenderOptions o;
    o.minWidthPx = 1.415;
    return o;
}

TEST(ViewRender, WithMinWidthLinesGrownTreeNodesLandInsideTheSilhouette) {
    const Tree& tree = grownTree();
    ASSERT_GT(tree.nodes.size(), 100u);
    for (bool ortho : {false, true}) {
        Rng rng(2);
        const auto cams = makeCameras(tree, ringOptions(ortho), rng);
        for (const Camera& c : cams) {
            const ViewImage v = renderView(tree, c, true, true, TubeOptions{}, widened());
            ASSERT_EQ(v.silhouette.size(), size_t(c.width) * c.height);
            ASSERT_EQ(v.depth.size(), v.silhouette.size());
            ASSERT_EQ(v.labels.size(), v.silhouette.size());
            int behind = 0;
            for (const SkeletonNode& n : tree.nodes) {
                double px, py, d;
                ASSERT_TRUE(c.project(n.position, px, py, d));
                const int x = static_cast<int>(std::floor(px)),
                          y = static_cast<int>(std::floor(py));
                ASSERT_TRUE(x >= 0 && x < c.width && y >= 0 && y < c.height);
                ASSERT_EQ(v.silhouette[at(v, x, y)], 255) << "node at " << px << "," << py;
                // The pixel holds the node, so its depth is never behind the node (it may be
                // much nearer: the node's own surface, or another branch in front).
                behind += v.depth[at(v, x, y)] > d * (1 + 1e-6);
            }
            EXPECT_EQ(behind, 0);
            // Background pixels: depth 0, label 0; tree pixels: depth > 0, label ≠ 0.
            for (size_t k = 0; k < v.silhouette.size(); ++k) {
                ASSERT_EQ(v.silhouette[k] == 255, v.depth[k] > 0);
                ASSERT_EQ(v.silhouette[k] == 255, v.labels[k] != kLabelBackground);
            }
            const double cov = silhouetteCoverage(v);
            EXPECT_GT(cov, 0.01);
            EXPECT_LT(cov, 0.9);
        }
    }
}

// Ray casting, independent of the rasteriser: the pixel-centre ray (origin at depth 0,
// direction advancing depth by 1 per unit) against every triangle of the tubes (tubeMesh) and
// of the leaves (leafMesh, both faces), Möller–Trumbore in double precision.
struct RayHit {
    double depth = -1;    // nearest hit whose barycentric weights are all ≥ −kEdge; −1: none
    bool strict = false;  // some hit has every weight ≥ +kEdge (clearly inside)
    int label = kLabelBackground;
    double secondDepth = -1;  // the nearest hit with a different label (ties make labels moot)
};
constexpr double kEdge = 1e-7;

RayHit castRay(const Camera& c, double px, double py, const std::vector<const Mesh*>& meshes,
               const std::vector<std::vector<uint8_t>>& labels) {
    const Vec3 p1 = c.unproject(px, py, 1.0), p2 = c.unproject(px, py, 2.0);
    const Vec3 dir = p2 - p1, origin = p1 - dir;
    RayHit hit;
    for (size_t m = 0; m < meshes.size(); ++m) {
        const Mesh& mesh = *meshes[m];
        auto vertex = [&](uint32_t i) {
            return Vec3{mesh.positions[3 * i], mesh.positions[3 * i + 1],
                        mesh.positions[3 * i + 2]};
        };
        for (size_t t = 0; t < mesh.triangleCount(); ++t) {
            const Vec3 a = vertex(mesh.indices[3 * t]), b = vertex(mesh.indices[3 * t + 1]),
                       d = vertex(mesh.indices[3 * t + 2]);
            const Vec3 e1 = b - a, e2 = d - a, pv = cross(dir, e2);
            const double det = dot(e1, pv);
            if (det == 0) continue;
            const double inv = 1.0 / det;
            const Vec3 tv = origin - a, qv = cross(tv, e1);
            const double u = dot(tv, pv) * inv, v = dot(dir, qv) * inv, w = 1.0 - u - v;
            if (u < -kEdge || v < -kEdge || w < -kEdge) continue;
            const double depth = dot(e2, qv) * inv;
            if (depth <= 0) continue;
            hit.strict |= u >= kEdge && v >= kEdge && w >= kEdge;
            const int label = labels[m][t];
            if (hit.depth < 0 || depth < hit.depth) {
                if (label != hit.label) hit.secondDepth = hit.depth;
                hit.depth = depth;
                hit.label = label;
            } else if (label != hit.label && (hit.secondDepth < 0 || depth < hit.secondDepth)) {
                hit.secondDepth = depth;
            }
        }
    }
    return hit;
}

// A small tree: a tapering trunk, a branch, a sub-pixel twig and three leaves of different
// shapes, one of them in front of the trunk.
Tree smallLeafyTree() {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.3);
    addNode(t, 0, {0.2, 2, 0.3}, 0.15);
    addNode(t, 1, {1.2, 2.8, 0.1}, 0.06, 1);
    addNode(t, 2, {1.6, 3.4, 0.4}, 0.004, 2);
    addNode(t, 1, {0.1, 3.2, 0.2}, 0.1);
    const LeafShape shapes[] = {LeafShape::kCard, LeafShape::kLobed, LeafShape::kSimple};
    const Vec3 where[] = {{0.1, 1.2, 0.6}, {1.3, 2.9, 0.2}, {0.0, 3.4, 0.0}};
    for (int i = 0; i < 3; ++i) {
        Leaf leaf;
        leaf.position = where[i];
        leaf.normal = normalize(Vec3{0.3 * i, 1.0, 1.0 - 0.4 * i});
        leaf.tangent = anyPerpendicular(leaf.normal);
        leaf.size = 0.5;
        leaf.aspect = 0.6;
        leaf.shape = shapes[i];
        t.leaves.push_back(leaf);
    }
    return t;
}

// Every pixel of a view against ray casting of the mesh's triangles: drawn iff the centre's ray
// hits a triangle (up to rays within kEdge of an edge), at the nearest hit's depth, with its
// label (tubes: segmentLabel of the triangle's node; leaves 255).
TEST(ViewRender, PixelsAreRayCastsOfTheMeshTriangles) {
    const Tree t = smallLeafyTree();
    TubeOptions tubes;
    tubes.maxSides = 9;
    tubes.edgeLength = 0.1;
    std::vector<int32_t> nodes;
    const Mesh wood = tubeMesh(t, tubes, &nodes);
    const Mesh leaves = leafMesh(t);
    std::vector<std::vector<uint8_t>> labels(2);
    for (int32_t n : nodes) labels[0].push_back(segmentLabel(t.nodes[n]));
    labels[1].assign(leaves.triangleCount(), kLabelLeaf);
    for (bool ortho : {false, true}) {
        Rng rng(5);
        ViewOptions o = ringOptions(ortho);
        o.count = 4;
        o.width = 72;
        o.height = 71;  // 5,112 pixels: not a multiple of the 16 the image is finished in
        for (const Camera& c : makeCameras(t, o, rng)) {
            const ViewImage v = renderView(t, wood, nodes, c, true, true);
            int drawn = 0;
            for (int y = 0; y < v.height; ++y) {
                for (int x = 0; x < v.width; ++x) {
                    const RayHit hit = castRay(c, x + 0.5, y + 0.5, {&wood, &leaves}, labels);
                    const size_t k = at(v, x, y);
                    const bool on = v.silhouette[k] == 255;
                    drawn += on;
                    // The silhouette is 0 or 255, and the depth 0 exactly off it.
                    ASSERT_TRUE(on || v.silhouette[k] == 0) << x << "," << y;
                    if (on) {
                        ASSERT_GT(v.depth[k], 0.0f) << x << "," << y;
                    } else {
                        ASSERT_EQ(v.depth[k], 0.0f) << x << "," << y;
                    }
                    if (hit.strict) {
                        ASSERT_TRUE(on) << x << "," << y << " ortho " << ortho;
                    }
                    if (hit.depth < 0) {
                        ASSERT_FALSE(on) << x << "," << y << " ortho " << ortho;
                    }
                    if (!on || !hit.strict) continue;
                    EXPECT_NEAR(v.depth[k], hit.depth, 1e-5 * hit.depth) << x << "," << y;
                    if (hit.secondDepth < 0 || hit.secondDepth > hit.depth * (1 + 1e-5)) {
                        EXPECT_EQ(v.labels[k], hit.label) << x << "," << y;
                    }
                }
            }
            EXPECT_GT(drawn, 200);
        }
    }
}

TEST(ViewRender, WithMinWidthLinesAThinSegmentCoversItsWholeProjectedLength) {
    for (bool ortho : {false, true}) {
        // 10 px per metre at the segment (z = 0) in both projections.
        Camera c = frontCamera(ortho, 120, 100, 10.0, 2 * std::atan(5.0 / 10.0) * 180 / kPi, 10.0);
        ASSERT_NEAR(footprint(c, 10.0), 0.1, 1e-12);
        for (Vec3 end : {Vec3{4.5, 0.3, 0}, Vec3{4.0, 3.2, 0}, Vec3{-1.2, 4.4, 0}}) {
            Tree t;
            const Vec3 start{-4.1, -2.3, 0};
            addNode(t, -1, start, 0.005);  // 0.05 px radius: 1/10 px wide
            addNode(t, 0, end, 0.005);
            const ViewImage v = renderView(t, c, false, false, TubeOptions{}, widened());
            EXPECT_TRUE(v.depth.empty());
            // Every pixel the axis passes through is drawn (sample the axis densely).
            for (int i = 0; i <= 2000; ++i) {
                const Vec3 p = start + (end - start) * (i / 2000.0);
                double px, py, d;
                ASSERT_TRUE(c.project(p, px, py, d));
                ASSERT_EQ(v.silhouette[at(v, static_cast<int>(px), static_cast<int>(py))], 255)
                    << px << "," << py;
            }
            // … and the line stays thin: at most 3 pixels across the major axis.
            double ax, ay, bx, by, d;
            c.project(start, ax, ay, d);
            c.project(end, bx, by, d);
            const bool steep = std::abs(by - ay) > std::abs(bx - ax);
            int maxRun = 0;
            size_t total = 0;
            for (int i = 0; i < (steep ? c.height : c.width); ++i) {
                int run = 0;
                for (int j = 0; j < (steep ? c.width : c.height); ++j) {
                    run += v.silhouette[steep ? at(v, j, i) : at(v, i, j)] != 0;
                }
                maxRun = std::max(maxRun, run);
                total += run;
            }
            EXPECT_LE(maxRun, 3);
            const double len = std::max(std::abs(bx - ax), std::abs(by - ay));
            EXPECT_GE(total, len - 1);
            EXPECT_LE(total, 2.1 * len + 6);
        }
    }
}

// By default a twig thinner than a pixel is not widened: only pixels whose centres its tube
// covers are drawn, each within its radius of the axis (or of the tip cone, one radius beyond).
TEST(ViewRender, SubPixelTwigDrawsOnlyThePixelCentresItCovers) {
    for (bool ortho : {false, true}) {
        Camera c = frontCamera(ortho, 120, 100, 10.0, 2 * std::atan(5.0 / 10.0) * 180 / kPi, 10.0);
        const Vec3 start{-4.1, -2.3, 0}, end{4.5, 0.3, 0};
        for (double radius : {0.005, 0.03}) {  // 0.05 px and 0.3 px at 10 px per metre
            Tree t;
            addNode(t, -1, start, radius);
            addNode(t, 0, end, radius);
            const ViewImage v = renderView(t, c, false, false);
            double ax, ay, bx, by, d;
            c.project(start, ax, ay, d);
            c.project(end + normalize(end - start) * radius, bx, by, d);  // the tip cone's apex
            const double rPx = radius * 10.0;
            int drawn = 0;
            for (int y = 0; y < c.height; ++y) {
                for (int x = 0; x < c.width; ++x) {
                    if (v.silhouette[at(v, x, y)] == 0) continue;
                    ++drawn;
                    const Vec3 p{x + 0.5, y + 0.5, 0}, a{ax, ay, 0}, b{bx, by, 0};
                    double s;
                    EXPECT_LE(pointSegmentDistance(p, a, b, s), rPx * (1 + 1e-6));
                }
            }
            // About the tube's screen area (width < 2 r, length ≈ 91 px) in pixel centres.
            const double area = 2 * rPx * std::hypot(bx - ax, by - ay);
            EXPECT_LE(drawn, area + 4);
            if (radius > 0.01) {
                EXPECT_GE(drawn, 0.3 * area);
            }
        }
    }
}

TEST(ViewRender, LabelsWoodOrderAndLeaves) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1);         // trunk, order 0
    addNode(t, 0, {0, 2, 0}, 0.08);         //
    addNode(t, 1, {1.2, 2.6, 0}, 0.03, 1);  // lateral branch, order 1
    Leaf leaf;                              // a card facing the camera, in front of
    leaf.position = {0, 1.0, 0.5};          // the trunk's middle, 0.4 m square
    leaf.normal = {0, 0, 1};
    leaf.tangent = {0, 1, 0};
    leaf.size = 0.4;
    leaf.aspect = 1.0;
    t.leaves.push_back(leaf);
    for (bool ortho : {false, true}) {
        Camera c = frontCamera(ortho, 200, 200, 10.0, 40, 7.0);
        const ViewImage v = renderView(t, c, true, true);
        auto labelAt = [&](const Vec3& p, float* depth = nullptr) -> int {
            double px, py, d;
            EXPECT_TRUE(c.project(p, px, py, d));
            const int x = static_cast<int>(std::floor(px)), y = static_cast<int>(std::floor(py));
            EXPECT_TRUE(x >= 0 && x < c.width && y >= 0 && y < c.height);
            if (!(x >= 0 && x < c.width && y >= 0 && y < c.height)) return -1;
            if (depth) *depth = v.depth[at(v, x, y)];
            return v.labels[at(v, x, y)];
        };
        float z;
        EXPECT_EQ(labelAt({0, 1.0, 0.5}, &z), kLabelLeaf);  // the leaf hides the trunk
        EXPECT_NEAR(z, 9.5f, 1e-5);                         // card faces the camera: exact
        EXPECT_EQ(labelAt({0.15, 1.15, 0.5}), kLabelLeaf);
        EXPECT_EQ(labelAt({0, 0.4, 0}, &z), woodLabel(0));
        EXPECT_EQ(woodLabel(0), 1);
        EXPECT_NEAR(z, 10.0 - 0.096, 0.01);  // the front of the trunk
        EXPECT_EQ(labelAt({0, 1.7, 0}), 1);
        EXPECT_EQ(labelAt({0.6, 2.3, 0}), 2);  // order 1
        EXPECT_EQ(labelAt({-0.8, 1.0, 0}, &z), kLabelBackground);
        EXPECT_EQ(z, 0.0f);
        EXPECT_EQ(labelAt({0.3, 1.0, 0.5}), kLabelBackground);  // beside the card
    }
}

TEST(ViewRender, LeafCardSeenObliquelyHasPerspectiveCorrectDepth) {
    Tree t;
    Leaf leaf;
    leaf.position = {0, 0, 0};
    leaf.normal = normalize(Vec3{0, 1, 1});  // tilted 45° about x
    leaf.tangent = {1, 0, 0};
    leaf.size = 2.0;
    leaf.aspect = 1.0;
    t.leaves.push_back(leaf);
    Camera c = frontCamera(false, 128, 128, 3.0, 60, 0);
    const ViewImage v = renderView(t, c, true, true);
    int checked = 0;
    for (int y = 0; y < v.height; ++y) {
        for (int x = 0; x < v.width; ++x) {
            const float z = v.depth[at(v, x, y)];
            if (z <= 0) continue;
            ASSERT_EQ(v.labels[at(v, x, y)], kLabelLeaf);
            // The point seen lies on the card plane (n · p = 0).
            const Vec3 p = c.unproject(x + 0.5, y + 0.5, z);
            EXPECT_NEAR(dot(p, leaf.normal), 0.0, 1e-5);
            ++checked;
        }
    }
    EXPECT_GT(checked, 500);
}

TEST(ViewRender, SameBytesOnOneThreadAndMany) {
    const Tree& tree = grownTree();
    Tree withLeaves = tree;
    Rng rng(11);
    for (size_t i = 1; i < tree.nodes.size(); i += 7) {
        Leaf l;
        l.position = tree.nodes[i].position;
        l.normal = rng.unitVector();
        l.tangent = anyPerpendicular(l.normal);
        l.size = 0.15;
        withLeaves.leaves.push_back(l);
    }
    for (bool ortho : {false, true}) {
        Rng r(4);
        ViewOptions o = ringOptions(ortho);
        o.count = 3;
        for (const Camera& c : makeCameras(withLeaves, o, r)) {
            ViewImage one;
            {
                tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
                one = renderView(withLeaves, c, true, true);
            }
            const ViewImage many = renderView(withLeaves, c, true, true);
            EXPECT_EQ(one.silhouette, many.silhouette);
            EXPECT_EQ(one.labels, many.labels);
            ASSERT_EQ(one.depth.size(), many.depth.size());
            EXPECT_EQ(0, std::memcmp(one.depth.data(), many.depth.data(),
                                     one.depth.size() * sizeof(float)));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Silhouette statistics

ViewImage blank(int w, int h) {
    ViewImage v;
    v.width = w;
    v.height = h;
    v.silhouette.assign(static_cast<size_t>(w) * h, 0);
    return v;
}

// The pixel counts are summed in short stretches: images of 65,536 and 90,000 pixels, all the
// tree's (and all leaves, or leaves on every third pixel), count every pixel.
TEST(ViewStats, PixelCountsHoldOverLargeImages) {
    for (int side : {256, 300}) {
        ViewImage v = blank(side, side);
        std::fill(v.silhouette.begin(), v.silhouette.end(), uint8_t{255});
        EXPECT_DOUBLE_EQ(silhouetteCoverage(v), 1.0) << side;
        v.labels.assign(v.silhouette.size(), kLabelLeaf);
        std::vector<ViewImage> views(3, v);
        EXPECT_DOUBLE_EQ(leafPixelFraction(views), 1.0) << side;
        size_t leaves = 0;
        for (size_t k = 0; k < v.labels.size(); ++k) {
            v.labels[k] = k % 3 == 0 ? kLabelLeaf : uint8_t{2};
            leaves += k % 3 == 0;
        }
        v.silhouette[7] = 0;  // background in the silhouette only
        EXPECT_DOUBLE_EQ(silhouetteCoverage(v), (v.silhouette.size() - 1.0) / v.silhouette.size());
        EXPECT_DOUBLE_EQ(leafPixelFraction({v}),
                         static_cast<double>(leaves) / static_cast<double>(v.labels.size()));
    }
    EXPECT_TRUE(std::isnan(leafPixelFraction({blank(4, 4)})));  // no label image
}

TEST(ViewStats, CoverageAndBoxCountingKnownAnswers) {
    ViewImage v = blank(256, 256);
    EXPECT_EQ(silhouetteCoverage(v), 0.0);
    EXPECT_EQ(boxCountingDimension(v), 0.0);

    ViewImage square = blank(256, 256);
    for (int y = 64; y < 192; ++y) {
        for (int x = 64; x < 192; ++x) square.silhouette[at(square, x, y)] = 255;
    }
    EXPECT_DOUBLE_EQ(silhouetteCoverage(square), 0.25);
    EXPECT_NEAR(boxCountingDimension(square), 2.0, 0.1);

    ViewImage line = blank(256, 256);
    for (int x = 10; x < 246; ++x) line.silhouette[at(line, x, 100)] = 255;
    EXPECT_NEAR(boxCountingDimension(line), 1.0, 0.1);

    ViewImage diagonal = blank(256, 256);
    for (int x = 0; x < 256; ++x) diagonal.silhouette[at(diagonal, x, x)] = 255;
    EXPECT_NEAR(boxCountingDimension(diagonal), 1.0, 0.1);

    // A small image still uses three box sizes.
    ViewImage small = blank(16, 16);
    for (int y = 0; y < 16; ++y) {
        for (int x = 0; x < 16; ++x) small.silhouette[at(small, x, y)] = 255;
    }
    EXPECT_NEAR(boxCountingDimension(small), 2.0, 1e-9);

    // A grown tree lies in between.
    Rng rng(1);
    const Tree& tree = grownTree();
    const ViewImage tv =
        renderView(tree, makeCameras(tree, ringOptions(false), rng)[0], false, false);
    const double dim = boxCountingDimension(tv);
    EXPECT_GT(dim, 1.0);
    EXPECT_LT(dim, 2.0);
}

// ---------------------------------------------------------------------------------------------
// transforms.json, PLY, image files

TEST(ViewTransforms, NerfstudioFields) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1);
    addNode(t, 0, {0, 2, 0}, 0.1);
    for (bool ortho : {false, true}) {
        Rng rng(1);
        ViewOptions o = ringOptions(ortho);
        o.width = 320;
        o.height = 240;
        const auto cams = makeCameras(t, o, rng);
        ViewFiles files;
        for (int k = 0; k < 8; ++k) {
            files.images.push_back("views/" + std::to_string(k) + ".png");
            files.depthExr.push_back("views/" + std::to_string(k) + "_depth.exr");
        }
        const std::vector<std::string>& images = files.images;
        const std::vector<std::string>& depths = files.depthExr;
        const nlohmann::json j = transformsJson(cams, files, ngpPlacement(t));
        EXPECT_EQ(j.at("camera_model"), "OPENCV");
        EXPECT_EQ(j.at("w"), 320);
        EXPECT_EQ(j.at("h"), 240);
        EXPECT_DOUBLE_EQ(j.at("fl_x").get<double>(), cams[0].fx());
        EXPECT_DOUBLE_EQ(j.at("fl_y").get<double>(), cams[0].fy());
        EXPECT_DOUBLE_EQ(j.at("cx").get<double>(), 160.0);
        EXPECT_DOUBLE_EQ(j.at("cy").get<double>(), 120.0);
        for (const char* k : {"k1", "k2", "p1", "p2"}) EXPECT_EQ(j.at(k).get<double>(), 0.0);
        if (ortho) {
            EXPECT_TRUE(j.at("orthographic").get<bool>());
            EXPECT_DOUBLE_EQ(j.at("ortho_height_m").get<double>(), cams[0].orthoHeight);
            EXPECT_FALSE(j.contains("camera_angle_x"));
        } else {
            EXPECT_FALSE(j.contains("orthographic"));
            EXPECT_NEAR(j.at("camera_angle_x").get<double>(), 2 * std::atan(160.0 / cams[0].fx()),
                        1e-12);
        }
        ASSERT_EQ(j.at("frames").size(), 8u);
        for (int k = 0; k < 8; ++k) {
            const auto& f = j["frames"][k];
            EXPECT_EQ(f.at("file_path"), images[k]);
            EXPECT_EQ(f.at("depth_file_path"), depths[k]);
            EXPECT_FALSE(f.contains("label_file_path"));
            EXPECT_DOUBLE_EQ(f.at("azimuth_deg").get<double>(), cams[k].azimuthDeg);
            EXPECT_DOUBLE_EQ(f.at("elevation_deg").get<double>(), cams[k].elevationDeg);
            const auto& m = f.at("transform_matrix");
            ASSERT_EQ(m.size(), 4u);
            auto col = [&](int c) {
                return Vec3{m[0][c].get<double>(), m[1][c].get<double>(), m[2][c].get<double>()};
            };
            const Vec3 eye = col(3);
            EXPECT_EQ(eye, column(cams[k], 3));
            // Third column = −forward: from the look-at centre (the box centre) to the eye.
            const Vec3 centre{0, 1, 0};
            EXPECT_NEAR(length(col(2) - normalize(eye - centre)), 0.0, 1e-12);
            EXPECT_EQ(m[3], nlohmann::json({0, 0, 0, 1}));
        }
        ViewFiles one;
        one.images = {"a.png"};
        EXPECT_THROW(transformsJson(cams, one, ngpPlacement(t)), std::invalid_argument);
    }
}

TEST(ViewPointCloud, PointsLieOnTheSkeleton) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.12);
    addNode(t, 0, {0, 1.5, 0}, 0.08);
    addNode(t, 1, {0.8, 2.2, 0.3}, 0.03, 1);
    addNode(t, 1, {-0.5, 2.5, -0.4}, 0.02, 1);
    addNode(t, 3, {-0.6, 2.9, -0.2}, 0.004, 2);  // sub-pixel twig
    ViewOptions o = ringOptions(false);
    o.count = 4;
    o.width = 96;
    o.height = 96;
    Rng rng(9);
    const auto cams = makeCameras(t, o, rng);
    std::vector<ViewImage> views;
    size_t expected = 0;
    for (size_t v = 0; v < cams.size(); ++v) {
        views.push_back(renderView(t, cams[v], true, v != 1));  // view 1: no labels
        for (float z : views.back().depth) expected += z > 0;
    }
    const std::string ply = pointCloudPly(cams, views);
    const std::string endHeader = "end_header\n";
    const size_t body = ply.find(endHeader);
    ASSERT_NE(body, std::string::npos);
    const std::string header = ply.substr(0, body);
    EXPECT_NE(header.find("format binary_little_endian 1.0"), std::string::npos);
    EXPECT_NE(header.find("element vertex " + std::to_string(expected) + "\n"), std::string::npos);
    EXPECT_NE(header.find("property float x\nproperty float y\nproperty float z\n"
                          "property uchar label\nproperty uchar view\n"),
              std::string::npos);
    // The header names every label the points can carry, as the label images have them.
    EXPECT_NE(header.find("comment label: 1 + branch order for shoot wood, 254 for root wood, "
                          "255 for leaves; view: camera index\n"),
              std::string::npos);
    const char* p = ply.data() + body + endHeader.size();
    ASSERT_EQ(ply.size() - (body + endHeader.size()), expected * 14);
    int lastView = -1;
    for (size_t i = 0; i < expected; ++i, p += 14) {
        float xyz[3];
        std::memcpy(xyz, p, 12);  // the test host is little-endian
        const uint8_t label = static_cast<uint8_t>(p[12]);
        const int view = static_cast<uint8_t>(p[13]);
        ASSERT_GE(view, lastView);  // (view, row, column) order
        lastView = view;
        const Vec3 q{xyz[0], xyz[1], xyz[2]};
        double px, py, d;
        ASSERT_TRUE(cams[view].project(q, px, py, d));
        const double tol = 1.5 * footprint(cams[view], d) + 1e-5;
        // Within tolerance of some segment's surface, and labelled like one such segment.
        bool near = false, labelOk = view == 1 && label == 1;  // view 1 has no labels: 1
        for (size_t n = 1; n < t.nodes.size(); ++n) {
            double s;
            const SkeletonNode& a = t.nodes[t.nodes[n].parent];
            const SkeletonNode& b = t.nodes[n];
            const double dist = pointSegmentDistance(q, a.position, b.position, s) -
                                (a.radius + s * (b.radius - a.radius));
            if (dist <= tol) {
                near = true;
                labelOk |= view != 1 && label == woodLabel(b.order);
            }
        }
        ASSERT_TRUE(near) << "point " << i << " view " << view;
        EXPECT_TRUE(labelOk) << "point " << i << " label " << int(label);
    }
    EXPECT_EQ(lastView, 3);
    // Deterministic.
    EXPECT_EQ(pointCloudPly(cams, views), ply);
    // Views without depth cannot be back-projected.
    views[0].depth.clear();
    EXPECT_THROW(pointCloudPly(cams, views), std::invalid_argument);
}

TEST(ViewWriters, PngAndExrRoundTrip) {
    TempDir dir;
    const int w = 37, h = 23;
    std::vector<uint8_t> grey(w * h);
    std::vector<float> depth(w * h);
    for (int k = 0; k < w * h; ++k) {
        grey[k] = static_cast<uint8_t>((k * 37) % 256);
        depth[k] = k % 5 == 0 ? 0.0f : 0.1f + 1.0f / (k + 3) + k * 1e-3f;
    }
    const fs::path png = dir.path / "sub" / "a.png";
    const fs::path exr = dir.path / "sub" / "a.exr";
    writeGreyPng(png, w, h, grey);
    writeDepthExr(exr, w, h, depth);
    {
        auto in = OIIO::ImageInput::open(png.string());
        ASSERT_TRUE(in);
        EXPECT_EQ(in->spec().width, w);
        EXPECT_EQ(in->spec().height, h);
        EXPECT_EQ(in->spec().nchannels, 1);
        EXPECT_EQ(in->spec().format, OIIO::TypeDesc::UINT8);
        std::vector<uint8_t> back(w * h);
        ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT8, back.data()));
        EXPECT_EQ(back, grey);
    }
    {
        auto in = OIIO::ImageInput::open(exr.string());
        ASSERT_TRUE(in);
        EXPECT_EQ(in->spec().nchannels, 1);
        EXPECT_EQ(in->spec().channelnames.at(0), "Y");
        EXPECT_EQ(in->spec().format, OIIO::TypeDesc::FLOAT);
        std::vector<float> back(w * h);
        ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, back.data()));
        EXPECT_EQ(0, std::memcmp(back.data(), depth.data(), depth.size() * sizeof(float)));
    }
    // Same pixels → same bytes (nothing time-varying is embedded).
    const std::string pngBytes = readBytes(png), exrBytes = readBytes(exr);
    writeGreyPng(png, w, h, grey);
    writeDepthExr(exr, w, h, depth);
    EXPECT_EQ(readBytes(png), pngBytes);
    EXPECT_EQ(readBytes(exr), exrBytes);
    // No temp files left behind.
    size_t files = 0;
    for (const auto& e : fs::directory_iterator(dir.path / "sub")) files += e.is_regular_file();
    EXPECT_EQ(files, 2u);
    EXPECT_THROW(writeGreyPng(png, w, h + 1, grey), std::invalid_argument);
    EXPECT_THROW(writeDepthExr(exr, w + 1, h, depth), std::invalid_argument);
}

std::vector<uint8_t> readGreyFile(const fs::path& p, int& w, int& h) {
    auto in = OIIO::ImageInput::open(p.string());
    EXPECT_TRUE(in);
    if (!in) return {};
    w = in->spec().width;
    h = in->spec().height;
    EXPECT_EQ(in->spec().nchannels, 1);
    std::vector<uint8_t> px(static_cast<size_t>(w) * h);
    EXPECT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT8, px.data()));
    return px;
}

TEST(ViewContactSheet, TilesSilhouettesBlackOnWhite) {
    TempDir dir;
    std::vector<ViewImage> views;
    for (int k = 0; k < 5; ++k) {
        ViewImage v = blank(30, 20);
        v.silhouette[at(v, k, 3)] = 255;
        views.push_back(v);
    }
    const fs::path sheet = dir.path / "sheet.png";
    writeContactSheet(sheet, views, 3);
    int w = 0, h = 0;
    const auto px = readGreyFile(sheet, w, h);
    EXPECT_EQ(w, 3 * 30 + 4 * 2);
    EXPECT_EQ(h, 2 * 20 + 3 * 2);
    auto pix = [&](int x, int y) { return px.at(static_cast<size_t>(y) * w + x); };
    EXPECT_EQ(pix(0, 0), 200);                    // gutter
    EXPECT_EQ(pix(2 + 30, 10), 200);              // gutter between columns
    EXPECT_EQ(pix(2, 2 + 3), 0);                  // view 0's tree pixel: black
    EXPECT_EQ(pix(3, 2 + 3), 255);                // background: white
    EXPECT_EQ(pix(2 + 32 + 1, 2 + 3), 0);         // view 1, pixel (1, 3)
    EXPECT_EQ(pix(2 + 32 + 4, 2 + 22 + 3), 0);    // view 4 (row 1, column 1), pixel (4, 3)
    EXPECT_EQ(pix(2 + 64 + 5, 2 + 22 + 5), 200);  // empty cell stays grey
}

// RGB pixels of an image file, read through OpenImageIO.
std::vector<uint8_t> readRgbFile(const fs::path& p, int& w, int& h) {
    auto in = OIIO::ImageInput::open(p.string());
    EXPECT_TRUE(in);
    if (!in) return {};
    w = in->spec().width;
    h = in->spec().height;
    EXPECT_EQ(in->spec().nchannels, 3);
    std::vector<uint8_t> px(3 * static_cast<size_t>(w) * h);
    EXPECT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, px.data()));
    return px;
}

TEST(ViewLabels, ColoursAreDistinctPerPart) {
    std::set<std::tuple<int, int, int>> seen;
    for (int label : {0, 1, 2, 3, 4, 5, 6, 254, 255}) {
        const Rgb c = labelColour(static_cast<uint8_t>(label));
        EXPECT_TRUE(seen.insert({c.r, c.g, c.b}).second) << label;
    }
    EXPECT_EQ(labelColour(7).r, labelColour(2).r);  // orders repeat after five
    const Rgb white = labelColour(kLabelBackground);
    EXPECT_EQ(white.r + white.g + white.b, 3 * 255);
    EXPECT_EQ(woodLabel(0), 1);
    EXPECT_EQ(woodLabel(400), 253);  // never the root or leaf label
    SkeletonNode root;
    root.part = kRootPart;
    root.order = 0;
    EXPECT_EQ(segmentLabel(root), kLabelRoot);
}

// The species sheet: each instance's first view in label colours, at least 256 px, exact.
TEST(ViewContactSheet, SpeciesSheetShowsFirstViewsInLabelColours) {
    TempDir dir;
    std::vector<fs::path> instances;
    for (int k = 0; k < 3; ++k) {
        const fs::path inst = dir.path / ("i" + std::to_string(k));
        std::vector<uint8_t> labels(64 * 64, kLabelBackground), sil(64 * 64, 0);
        for (int y = 10; y < 20; ++y) {
            for (int x = 0; x < 64; ++x) {
                labels[y * 64 + x] = x < 32 ? woodLabel(k) : kLabelLeaf;
                sil[y * 64 + x] = 255;
            }
        }
        writeGreyPng(inst / "views" / "000.png", 64, 64, sil);
        if (k != 2) writeGreyPng(inst / "views" / "000_label.png", 64, 64, labels);
        instances.push_back(inst);
    }
    const fs::path sheet = dir.path / "species.png";
    writeSpeciesSheet(sheet, instances);
    int w = 0, h = 0;
    const auto px = readRgbFile(sheet, w, h);
    const int tile = kSpeciesSheetMinTile;  // 64 px views, enlarged 4× to 256
    EXPECT_EQ(w, 2 * tile + 3 * 2);
    EXPECT_EQ(h, 2 * tile + 3 * 2);
    auto pix = [&](int x, int y) {
        const uint8_t* p = px.data() + 3 * (static_cast<size_t>(y) * w + x);
        return std::make_tuple(int(p[0]), int(p[1]), int(p[2]));
    };
    auto colour = [](uint8_t label) {
        const Rgb c = labelColour(label);
        return std::make_tuple(int(c.r), int(c.g), int(c.b));
    };
    EXPECT_EQ(pix(2 + 4 * 5, 2 + 4 * 12), colour(woodLabel(0)));  // tile 0: the trunk colour
    EXPECT_EQ(pix(2 + 4 * 40, 2 + 4 * 12), colour(kLabelLeaf));   // leaves
    EXPECT_EQ(pix(2 + 4 * 5, 2 + 4 * 40), colour(kLabelBackground));
    EXPECT_EQ(pix(4 + tile + 4 * 5, 2 + 4 * 12), colour(woodLabel(1)));  // tile 1: order 1
    // Tile 2 has no label image: its silhouette, dark grey on white.
    EXPECT_EQ(pix(2 + 4 * 5, 4 + tile + 4 * 12), std::make_tuple(40, 40, 40));
    EXPECT_EQ(pix(2 + 4 * 5, 4 + tile + 4 * 40), std::make_tuple(255, 255, 255));
    EXPECT_EQ(pix(0, 0), std::make_tuple(200, 200, 200));  // gutter
    EXPECT_THROW(writeSpeciesSheet(sheet, {dir.path / "missing"}), std::runtime_error);
}

// `sylva grow`'s preview: one view in label colours; roots in the root colour.
TEST(ViewLabels, LabelPreviewShowsTrunkRootsAndLeaves) {
    Tree t;
    test::addNode(t, -1, {0, 0, 0}, 0.2);
    test::addNode(t, 0, {0, 3, 0}, 0.15);
    test::addNode(t, 0, {0, -2, 0}, 0.15, 0, kRootPart);
    Leaf leaf;
    leaf.position = {0, 3.3, 0};
    leaf.normal = {0, 0, 1};
    leaf.size = 0.6;
    leaf.aspect = 1.0;
    leaf.node = 1;
    t.leaves.push_back(leaf);
    TempDir dir;
    writeLabelPreviewPng(t, dir.path / "preview.png", 256);
    int w = 0, h = 0;
    const auto px = readRgbFile(dir.path / "preview.png", w, h);
    ASSERT_EQ(w, 256);
    ASSERT_EQ(h, 256);
    std::map<std::tuple<int, int, int>, int> count;
    for (size_t k = 0; k < px.size(); k += 3) ++count[{px[k], px[k + 1], px[k + 2]}];
    for (uint8_t label : {woodLabel(0), kLabelRoot, kLabelLeaf, kLabelBackground}) {
        const Rgb c = labelColour(label);
        EXPECT_GT((count[{c.r, c.g, c.b}]), 100) << int(label);
    }
}

}  // namespace
}  // namespace sylva
