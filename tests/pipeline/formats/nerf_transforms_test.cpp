// transforms.json as nerfstudio and instant-ngp read it: the keys and their JSON types, and the
// geometry after instant-ngp's loader (src/nerf_loader.cu, nerf_matrix_to_ngp), re-implemented
// here from its source: a position p becomes p · scale + offset with the axes cycled
// (x, y, z) → (y, z, x); a camera matrix keeps column 0, negates columns 1 and 2 (OpenGL →
// x right, y down, z forward) and has its rows cycled the same way; a pixel's ray is
// d = ((u − w/2) / f, (v − h/2) / f, 1) in camera space and its depth target is
// |d| × png value × integer_depth_scale × scale. Known answers: every tree point lands in the
// unit cube, the tree centre at (0.5, 0.5, 0.5) and at every image centre, every point at the
// pixel sylva's camera projects it to, and every depth pixel back at the point it came from.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

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
using Mat34 = std::array<std::array<double, 4>, 3>;  // rows of a camera-to-world matrix

ViewOptions ring(int count) {
    ViewOptions o;
    o.count = count;
    o.width = 160;
    o.height = 120;
    o.randomAzimuth = false;
    o.azimuthOffsetDeg = 15;
    o.elevationsDeg = {20, -15, 70};
    return o;
}

ViewFiles allFiles(size_t n) {
    ViewFiles f;
    for (size_t k = 0; k < n; ++k) {
        const std::string stem = "views/00" + std::to_string(k);
        f.images.push_back(stem + ".png");
        f.depthExr.push_back(stem + "_depth.exr");
        f.depthPng.push_back(stem + "_depth.png");
        f.labels.push_back(stem + "_label.png");
    }
    f.integerDepthScale = 0.002;
    return f;
}

// instant-ngp's nerf_position_to_ngp, from the JSON's own numbers.
Vec3 toNgp(const nlohmann::json& j, const Vec3& p) {
    const double s = j.at("scale").get<double>();
    const auto& o = j.at("offset");
    const Vec3 q{p.x * s + o[0].get<double>(), p.y * s + o[1].get<double>(),
                 p.z * s + o[2].get<double>()};
    return {q.y, q.z, q.x};
}

// instant-ngp's nerf_matrix_to_ngp (scale_columns = false) of a frame's transform_matrix.
Mat34 matrixToNgp(const nlohmann::json& j, const nlohmann::json& m) {
    Mat34 r;
    const double s = j.at("scale").get<double>();
    for (int row = 0; row < 3; ++row) {
        r[row][0] = m[row][0].get<double>();
        r[row][1] = -m[row][1].get<double>();
        r[row][2] = -m[row][2].get<double>();
        r[row][3] = m[row][3].get<double>() * s + j.at("offset")[row].get<double>();
    }
    return {r[1], r[2], r[0]};  // rows cycled: xyz <- yzx
}

Vec3 col(const Mat34& m, int c) { return {m[0][c], m[1][c], m[2][c]}; }

// A point (ngp coordinates) → instant-ngp pixel coordinates (x right, y down; centres at +0.5)
// through a pinhole with focal length f pixels; false behind the camera.
bool ngpProject(const Mat34& m, double f, int w, int h, const Vec3& p, double& px, double& py) {
    const Vec3 d = p - col(m, 3);
    const double x = dot(d, col(m, 0)), y = dot(d, col(m, 1)), z = dot(d, col(m, 2));
    if (!(z > 0)) return false;
    px = 0.5 * w + f * x / z;
    py = 0.5 * h + f * y / z;
    return true;
}

TEST(NerfTransforms, KeysAreTypedAsTheReadersExpect) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.1);
    addNode(t, 0, {0.3, 2, 0}, 0.05);
    Rng unused(0);
    const auto cams = makeCameras(t, ring(4), unused);
    const ViewFiles files = allFiles(cams.size());
    const nlohmann::json j = transformsJson(cams, files, ngpPlacement(t));
    // instant-ngp: aabb_scale an integer power of two, scale a number, offset three numbers,
    // integer_depth_scale a number (read as float), up three numbers.
    ASSERT_TRUE(j.contains("aabb_scale"));
    EXPECT_TRUE(j["aabb_scale"].is_number_integer());
    EXPECT_EQ(j["aabb_scale"].get<int>(), 1);
    EXPECT_TRUE(j.at("scale").is_number_float());
    EXPECT_GT(j["scale"].get<double>(), 0.0);
    ASSERT_TRUE(j.at("offset").is_array());
    ASSERT_EQ(j["offset"].size(), 3u);
    for (const auto& v : j["offset"]) EXPECT_TRUE(v.is_number());
    EXPECT_EQ(j.at("up"), nlohmann::json({0.0, 1.0, 0.0}));
    EXPECT_TRUE(j.at("integer_depth_scale").is_number_float());
    EXPECT_EQ(j["integer_depth_scale"].get<double>(), 0.002);
    // nerfstudio: keeps the poses' orientation (its default turns them to +z up).
    EXPECT_EQ(j.at("orientation_override"), "none");
    ASSERT_EQ(j.at("frames").size(), cams.size());
    for (size_t k = 0; k < cams.size(); ++k) {
        const auto& f = j["frames"][k];
        EXPECT_EQ(f.at("file_path"), files.images[k]);
        EXPECT_EQ(f.at("mask_path"), files.images[k]);  // the silhouette
        EXPECT_EQ(f.at("depth_file_path"), files.depthExr[k]);
        EXPECT_EQ(f.at("depth_path"), files.depthPng[k]);
        EXPECT_EQ(f.at("label_file_path"), files.labels[k]);
        for (const char* key : {"file_path", "mask_path", "depth_file_path", "depth_path"}) {
            EXPECT_TRUE(f[key].is_string()) << key;
        }
    }
    // Without depth PNGs: neither integer_depth_scale nor depth_path (instant-ngp would
    // otherwise look for files that are not there).
    ViewFiles exrOnly = files;
    exrOnly.depthPng.clear();
    const nlohmann::json e = transformsJson(cams, exrOnly, ngpPlacement(t));
    EXPECT_FALSE(e.contains("integer_depth_scale"));
    for (const auto& f : e["frames"]) {
        EXPECT_FALSE(f.contains("depth_path"));
        EXPECT_TRUE(f.contains("depth_file_path"));
    }
    ViewFiles noScale = files;
    noScale.integerDepthScale = 0.0;
    EXPECT_THROW(transformsJson(cams, noScale, ngpPlacement(t)), std::invalid_argument);
    ViewFiles short1 = files;
    short1.depthPng.pop_back();
    EXPECT_THROW(transformsJson(cams, short1, ngpPlacement(t)), std::invalid_argument);
}

// A closed-form case: one vertical segment from (0, 0, 0) to (0, 4, 0), radius 0.5. Its box is
// [−0.5, 0.5] × [−0.5, 4.5] × [−0.5, 0.5], centre (0, 2, 0), bounding radius 2.5 (the far end's
// sphere: 2 + 0.5), so scale = 1 / (2 · 1.05 · 2.5) and the centre goes to 0.5.
TEST(NerfTransforms, PlacementKnownAnswer) {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.5);
    addNode(t, 0, {0, 4, 0}, 0.5);
    const NgpPlacement p = ngpPlacement(t);
    EXPECT_DOUBLE_EQ(p.scale, 1.0 / (2.0 * 1.05 * 2.5));
    EXPECT_DOUBLE_EQ(p.offset.x, 0.5);
    EXPECT_DOUBLE_EQ(p.offset.y, 0.5 - 2.0 * p.scale);
    EXPECT_DOUBLE_EQ(p.offset.z, 0.5);
    // The top of the tube (y = 4.5), one radius above the centre, at 0.5 + 1 / 2.1.
    EXPECT_NEAR(4.5 * p.scale + p.offset.y, 0.5 + 1.0 / 2.1, 1e-15);
}

class NerfTransformsSpecies : public ::testing::TestWithParam<const char*> {};

// Every skeleton node sphere and every mesh vertex (tubes and leaves) of a grown tree lands in
// instant-ngp's unit cube after the file's scale, offset and axis cycle; the tree fills most of
// it; the cameras see the cube's centre (the tree's) at the image centre and every node where
// sylva's camera puts it; and a depth pixel, read as instant-ngp reads the PNG, lands back on
// the point it was rendered from.
TEST_P(NerfTransformsSpecies, TreeInsideTheUnitCubeAndCamerasAgree) {
    const SpeciesFile species = loadSpecies(std::string(SYLVA_SOURCE_DIR) + "/" + GetParam());
    const Tree tree = growSpecies(species, 3, nullptr, true).tree;
    ASSERT_GT(tree.nodes.size(), 10u);
    const ViewOptions o = ring(6);
    Rng unused(0);
    const std::vector<Camera> cams = makeCameras(tree, o, unused);
    std::vector<ViewImage> views;
    for (const Camera& c : cams) views.push_back(renderView(tree, c, true, false));
    ViewFiles files = allFiles(cams.size());
    files.integerDepthScale = integerDepthScale(views);
    const nlohmann::json j =
        nlohmann::json::parse(transformsJson(cams, files, ngpPlacement(tree)).dump());

    // Every point inside [0, 1]³, computed in float as instant-ngp does.
    const float s = j["scale"].get<float>();
    const float off[3] = {j["offset"][0].get<float>(), j["offset"][1].get<float>(),
                          j["offset"][2].get<float>()};
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    size_t outside = 0, points = 0;
    auto check = [&](double x, double y, double z) {
        const float q[3] = {static_cast<float>(x) * s + off[0], static_cast<float>(y) * s + off[1],
                            static_cast<float>(z) * s + off[2]};
        const float ngp[3] = {q[1], q[2], q[0]};
        for (int a = 0; a < 3; ++a) {
            outside += !(ngp[a] >= 0.0f && ngp[a] <= 1.0f);
            lo[a] = std::min(lo[a], ngp[a]);
            hi[a] = std::max(hi[a], ngp[a]);
        }
        ++points;
    };
    for (const SkeletonNode& n : tree.nodes) {
        for (int a = 0; a < 3; ++a) {
            for (double sign : {-1.0, 1.0}) {
                Vec3 p = n.position;
                p[a] += sign * n.radius;
                check(p.x, p.y, p.z);
            }
        }
    }
    const Mesh wood = tubeMesh(tree, TubeOptions{});
    const Mesh leaves = leafMesh(tree);
    for (const Mesh* m : {&wood, &leaves}) {
        for (size_t v = 0; v < m->vertexCount(); ++v) {
            check(m->positions[3 * v], m->positions[3 * v + 1], m->positions[3 * v + 2]);
        }
    }
    EXPECT_EQ(outside, 0u) << "of " << points << " points; ngp box [" << lo[0] << ", " << lo[1]
                           << ", " << lo[2] << "] – [" << hi[0] << ", " << hi[1] << ", " << hi[2]
                           << "]";
    // Not trivially inside: the tree's largest extent spans over half the cube.
    double extent = 0;
    for (int a = 0; a < 3; ++a) extent = std::max(extent, double(hi[a]) - lo[a]);
    EXPECT_GT(extent, 0.5);

    const BoundingSphere sphere = treeBoundingSphere(tree);
    const Vec3 centre = toNgp(j, sphere.centre);
    EXPECT_NEAR(length(centre - Vec3{0.5, 0.5, 0.5}), 0.0, 1e-12);
    const double f = j.at("fl_x").get<double>();
    const int w = j.at("w").get<int>(), h = j.at("h").get<int>();
    ASSERT_EQ(j["frames"].size(), cams.size());
    for (size_t k = 0; k < cams.size(); ++k) {
        SCOPED_TRACE("camera " + std::to_string(k));
        const Mat34 m = matrixToNgp(j, j["frames"][k]["transform_matrix"]);
        double px, py;
        ASSERT_TRUE(ngpProject(m, f, w, h, centre, px, py));
        EXPECT_NEAR(px, 0.5 * w, 1e-9);
        EXPECT_NEAR(py, 0.5 * h, 1e-9);
        double worst = 0;
        for (const SkeletonNode& n : tree.nodes) {
            double sx, sy, sd;
            ASSERT_TRUE(cams[k].project(n.position, sx, sy, sd));
            ASSERT_TRUE(ngpProject(m, f, w, h, toNgp(j, n.position), px, py));
            worst = std::max({worst, std::abs(px - sx), std::abs(py - sy)});
        }
        EXPECT_LT(worst, 1e-6) << "pixels";

        // Depth as instant-ngp reads depth_path: the PNG's units × integer_depth_scale ×
        // scale × |d| along the normalised ray lands on the rendered point (z-depth, not ray
        // length: read as ray length it would miss by up to 7% of the distance at the edges).
        const ViewImage& v = views[k];
        const std::vector<uint16_t> units = depthToUnits(v.depth, files.integerDepthScale);
        const double unitNgp = j["integer_depth_scale"].get<double>() * j["scale"].get<double>();
        size_t hits = 0;
        double worstDepth = 0, bound = 0;
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                const size_t at = static_cast<size_t>(y) * w + x;
                if (units[at] == 0) continue;
                ++hits;
                const Vec3 dCam{(x + 0.5 - 0.5 * w) / f, (y + 0.5 - 0.5 * h) / f, 1.0};
                const Vec3 dWorld = col(m, 0) * dCam.x + col(m, 1) * dCam.y + col(m, 2) * dCam.z;
                const double target = length(dCam) * units[at] * unitNgp;
                const Vec3 hit = col(m, 3) + normalize(dWorld) * target;
                const Vec3 want = toNgp(j, cams[k].unproject(x + 0.5, y + 0.5, v.depth[at]));
                worstDepth = std::max(worstDepth, length(hit - want));
                bound = std::max(bound, length(dCam) * 0.5 * unitNgp + 1e-9);
            }
        }
        EXPECT_GT(hits, 0u);
        EXPECT_LE(worstDepth, bound);
    }
}

INSTANTIATE_TEST_SUITE_P(Species, NerfTransformsSpecies,
                         ::testing::Values("species/papers/xu-mould-2012/xm-a.toml",
                                           "species/papers/jain-2021/grammar-guava.toml",
                                           "species/papers/liu-2020/sc-broadleaf.toml",
                                           "species/papers/shesh/canopy-maple.toml",
                                           "species/presets/norway-spruce.toml"),
                         [](const auto& info) {
                             std::string name = info.param;
                             name = name.substr(name.find_last_of('/') + 1);
                             name = name.substr(0, name.find('.'));
                             for (char& c : name) {
                                 if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                             }
                             return name;
                         });

}  // namespace
}  // namespace sylva
