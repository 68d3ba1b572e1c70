// The watertight wood mesh: closed, manifold, free of self-intersections and outward-wound
// (checked with CGAL), capsule volumes, every preset tree contains its skeleton, identical
// output for any thread count, and the .vdb level set written and read back.
#include "species/geometry/watertight.h"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/manifoldness.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <string>
#include <vector>

#include "core/errors.h"
#include "species/model/tree.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;

struct Converted {
    SurfaceMesh sm;
    size_t rejectedFaces = 0;  // faces Surface_mesh refused (non-manifold edges, bad winding)
};

Converted toSurfaceMesh(const Mesh& m) {
    Converted c;
    std::vector<SurfaceMesh::Vertex_index> v(m.vertexCount());
    for (size_t i = 0; i < v.size(); ++i)
        v[i] = c.sm.add_vertex(
            Point(m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]));
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        auto f = c.sm.add_face(v[m.indices[t]], v[m.indices[t + 1]], v[m.indices[t + 2]]);
        if (f == SurfaceMesh::null_face()) ++c.rejectedFaces;
    }
    return c;
}

// Closed and manifold: every face accepted, no border, no pinched vertex, no unused vertex.
void expectClosedManifold(const Converted& c) {
    EXPECT_EQ(c.rejectedFaces, 0u);
    EXPECT_TRUE(CGAL::is_closed(c.sm));
    std::vector<SurfaceMesh::Halfedge_index> pinched;  // one halfedge per pinched vertex
    PMP::non_manifold_vertices(c.sm, std::back_inserter(pinched));
    EXPECT_EQ(pinched.size(), 0u);
    size_t isolated = 0;
    for (auto vd : c.sm.vertices())
        if (c.sm.is_isolated(vd)) ++isolated;
    EXPECT_EQ(isolated, 0u);
}

size_t componentCount(SurfaceMesh& sm) {
    auto fcc = sm.add_property_map<SurfaceMesh::Face_index, size_t>("f:cc").first;
    return PMP::connected_components(sm, fcc);
}

// Every array of the mesh has the right size; normals are unit; colour 0; no uvs.
void expectWellFormed(const Mesh& m) {
    const size_t n = m.vertexCount();
    ASSERT_EQ(m.positions.size(), 3 * n);
    ASSERT_EQ(m.normals.size(), 3 * n);
    ASSERT_EQ(m.order.size(), n);
    ASSERT_EQ(m.colour.size(), n);
    EXPECT_TRUE(m.uvs.empty());
    ASSERT_EQ(m.indices.size() % 3, 0u);
    for (uint32_t i : m.indices) ASSERT_LT(i, n);
    for (size_t i = 0; i < n; ++i) {
        const double len = std::sqrt(m.normals[3 * i] * m.normals[3 * i] +
                                     m.normals[3 * i + 1] * m.normals[3 * i + 1] +
                                     m.normals[3 * i + 2] * m.normals[3 * i + 2]);
        ASSERT_NEAR(len, 1.0, 1e-5);
        ASSERT_EQ(m.colour[i], 0);
    }
}

Tree segmentTree(const Vec3& a, double ra, const Vec3& b, double rb) {
    Tree t;
    t.nodes.resize(2);
    t.nodes[0].position = a;
    t.nodes[0].radius = ra;
    t.nodes[1].position = b;
    t.nodes[1].radius = rb;
    t.nodes[1].parent = 0;
    return t;
}

Vec3 vertex(const Mesh& m, size_t i) {
    return {m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]};
}

bool identicalMeshes(const Mesh& a, const Mesh& b) {
    return a.positions == b.positions && a.normals == b.normals && a.indices == b.indices &&
           a.order == b.order && a.colour == b.colour && a.uvs == b.uvs;
}

openvdb::FloatGrid::Ptr readTreeSdf(const std::filesystem::path& p) {
    openvdb::initialize();
    openvdb::io::File file(p.string());
    file.open();
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("tree_sdf"));
    file.close();
    return grid;
}

// Same topology, values, activity and tiles, visited in the same order.
bool identicalGrids(const openvdb::FloatGrid& a, const openvdb::FloatGrid& b) {
    if (a.activeVoxelCount() != b.activeVoxelCount() ||
        a.tree().leafCount() != b.tree().leafCount())
        return false;
    auto ia = a.tree().cbeginValueAll();
    auto ib = b.tree().cbeginValueAll();
    for (; ia && ib; ++ia, ++ib)
        if (ia.getCoord() != ib.getCoord() || ia.getDepth() != ib.getDepth() ||
            ia.isValueOn() != ib.isValueOn() || *ia != *ib)
            return false;
    return !ia && !ib;
}

std::filesystem::path scratchDir(const std::string& name) {
    auto dir = std::filesystem::temp_directory_path() /
               ("sylva_watertight_" + name + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

std::vector<std::filesystem::path> presetFiles() { return test::shippedSpeciesFiles(); }

double treeExtent(const Tree& t) {
    Aabb b;
    for (const auto& n : t.nodes) {
        const Vec3 r{n.radius, n.radius, n.radius};
        b.extend(n.position - r);
        b.extend(n.position + r);
    }
    const Vec3 s = b.size();
    return std::max({s.x, s.y, s.z});
}

// ------------------------------------------------------------------------------------------

TEST(Watertight, EmptyAndSingleNodeTreesGiveEmptyMeshes) {
    const WatertightOptions o{0.02, 3.0};
    Tree empty;
    Mesh m;
    EXPECT_NO_THROW(m = watertightMesh(empty, o));
    EXPECT_TRUE(m.empty());
    EXPECT_EQ(m.vertexCount(), 0u);

    Tree one;
    one.nodes.resize(1);
    one.nodes[0].radius = 0.3;
    EXPECT_NO_THROW(m = watertightMesh(one, o));
    EXPECT_TRUE(m.empty());
    EXPECT_EQ(m.vertexCount(), 0u);

    // The .vdb of an empty tree is an empty level set.
    const auto dir = scratchDir("empty");
    const auto path = dir / "empty.vdb";
    EXPECT_NO_THROW(m = watertightMesh(one, o, path.string()));
    EXPECT_TRUE(m.empty());
    auto grid = readTreeSdf(path);
    ASSERT_TRUE(grid);
    EXPECT_EQ(grid->activeVoxelCount(), 0u);
    std::filesystem::remove_all(dir);
}

TEST(Watertight, RejectsBadOptions) {
    const Tree t = segmentTree({0, 0, 0}, 0.1, {0, 1, 0}, 0.1);
    EXPECT_THROW(watertightMesh(t, {0.0, 3.0}), std::invalid_argument);
    EXPECT_THROW(watertightMesh(t, {-0.01, 3.0}), std::invalid_argument);
    EXPECT_THROW(watertightMesh(t, {std::nan(""), 3.0}), std::invalid_argument);
    EXPECT_THROW(watertightMesh(t, {0.01, 0.5}), std::invalid_argument);
    Tree bad = t;
    bad.nodes[1].parent = 1;
    EXPECT_THROW(watertightMesh(bad, {0.01, 3.0}), std::invalid_argument);
}

// A zero-length segment is a sphere: outward winding (positive signed volume), normals point
// away from the centre, volume close to 4/3 π r³.
TEST(Watertight, SphereIsOutwardWound) {
    const double r = 0.1;
    const Vec3 c{0.3, 1.2, -0.4};
    const Mesh m = watertightMesh(segmentTree(c, r, c, r), {0.005, 3.0});
    ASSERT_FALSE(m.empty());
    expectWellFormed(m);
    Converted cm = toSurfaceMesh(m);
    expectClosedManifold(cm);
    EXPECT_FALSE(PMP::does_self_intersect(cm.sm));
    const double volume = PMP::volume(cm.sm);
    const double expected = 4.0 / 3.0 * kPi * r * r * r;
    EXPECT_GT(volume, 0.0);
    EXPECT_NEAR(volume / expected, 1.0, 0.02);
    for (size_t i = 0; i < m.vertexCount(); ++i) {
        const Vec3 p = vertex(m, i);
        ASSERT_NEAR(distance(p, c), r, 0.005);
        const Vec3 n{m.normals[3 * i], m.normals[3 * i + 1], m.normals[3 * i + 2]};
        ASSERT_GT(dot(n, normalize(p - c)), 0.9);
    }
}

// (a) A vertical capsule of radius r and length h: volume π r² h + 4/3 π r³ within 3%.
TEST(Watertight, CapsuleVolume) {
    const double r = 0.05, h = 0.6;
    Tree t = segmentTree({0, 0, 0}, r, {0, h, 0}, r);
    t.nodes[0].order = 3;
    t.nodes[1].order = 2;
    const Mesh m = watertightMesh(t, {0.004, 3.0});
    ASSERT_FALSE(m.empty());
    expectWellFormed(m);
    Converted cm = toSurfaceMesh(m);
    expectClosedManifold(cm);
    EXPECT_FALSE(PMP::does_self_intersect(cm.sm));
    EXPECT_EQ(componentCount(cm.sm), 1u);
    const double expected = kPi * r * r * h + 4.0 / 3.0 * kPi * r * r * r;
    EXPECT_NEAR(PMP::volume(cm.sm) / expected, 1.0, 0.03);
    // Order comes from the segment's child node.
    for (int32_t o : m.order) ASSERT_EQ(o, 2);
}

// A tilted, tapered segment in several voxel sizes: closed, manifold, the volume of the
// round cone (the hull of its end spheres), the axis inside.
TEST(Watertight, TaperedSegment) {
    const Vec3 a{0.1, -0.2, 0.05}, b{0.5, 0.4, -0.3};
    const double ra = 0.08, rb = 0.03;
    // Round cone volume: the truncated cone between the tangent circles plus two caps.
    const double l = distance(a, b);
    const double s = (ra - rb) / l;  // sine of the half-angle
    const double c = std::sqrt(1 - s * s);
    const double h1 = ra * s, h2 = rb * s;  // tangent circles sit at a + h1, b + h2 along axis
    const double R1 = ra * c, R2 = rb * c;
    const double frustumH = l + h2 - h1;
    const double frustum = kPi * frustumH / 3 * (R1 * R1 + R1 * R2 + R2 * R2);
    auto cap = [](double r, double hc) { return kPi * hc * hc * (3 * r - hc) / 3; };
    const double expected = frustum + cap(ra, ra + h1) + cap(rb, rb - h2);
    for (double voxel : {0.004, 0.01}) {
        SCOPED_TRACE("voxel " + std::to_string(voxel));
        const Mesh m = watertightMesh(segmentTree(a, ra, b, rb), {voxel, 3.0});
        expectWellFormed(m);
        Converted cm = toSurfaceMesh(m);
        expectClosedManifold(cm);
        EXPECT_FALSE(PMP::does_self_intersect(cm.sm));
        EXPECT_NEAR(PMP::volume(cm.sm) / expected, 1.0, voxel < 0.005 ? 0.03 : 0.08);
        CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel> inside(cm.sm);
        for (double u : {0.0, 0.25, 0.5, 0.75, 1.0}) {
            const Vec3 p = a + (b - a) * u;
            EXPECT_EQ(inside(Point(p.x, p.y, p.z)), CGAL::ON_BOUNDED_SIDE) << u;
        }
    }
}

// Twigs thinner than a voxel (even radius 0) are thickened so that they survive as one
// closed piece containing their axis, in any direction.
TEST(Watertight, ThinTwigsAreThickenedAndStayWhole) {
    const double voxel = 0.01;
    for (int k = 0; k < 12; ++k) {
        SCOPED_TRACE("twig " + std::to_string(k));
        const double polar = 0.3 + 0.23 * k, azimuth = 0.7 * k;
        const Vec3 dir{std::sin(polar) * std::cos(azimuth), std::cos(polar),
                       std::sin(polar) * std::sin(azimuth)};
        const Vec3 a{0.0013 * k, 0.0007 * k, -0.0011 * k};
        const Vec3 b = a + dir * 0.3;
        const Mesh m = watertightMesh(segmentTree(a, 0.0, b, 0.002), {voxel, 3.0});
        ASSERT_FALSE(m.empty());
        Converted cm = toSurfaceMesh(m);
        expectClosedManifold(cm);
        EXPECT_FALSE(PMP::does_self_intersect(cm.sm));
        EXPECT_EQ(componentCount(cm.sm), 1u);
        CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel> inside(cm.sm);
        for (double u : {0.1, 0.5, 0.9}) {
            const Vec3 p = a + (b - a) * u;
            EXPECT_EQ(inside(Point(p.x, p.y, p.z)), CGAL::ON_BOUNDED_SIDE) << u;
        }
    }
}

// The ends of thin twigs too: a node of radius 0 lies inside the mesh, and not on a knife's
// edge, wherever it falls in its voxel and whichever way its twig points. 400 twigs 1 to 5
// voxels long: directions on a golden-angle spiral over the sphere, tips spread over one voxel
// by a low-discrepancy sequence. At a minimum radius of √3/2 voxel every end here was inside
// but the shallowest only 0.053 voxel deep (and one tip of a library tree fell outside); at 1
// voxel the shallowest is 0.26 voxel deep.
TEST(Watertight, ThinTwigEndsAreInside) {
    using Primitive = CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh>;
    using AabbTree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
    const double voxel = 0.01;
    const double golden = 2.399963229728653;  // rad
    const auto frac = [](double v) { return v - std::floor(v); };
    double shallowest = 1e9;  // voxels; negative when outside
    for (int k = 0; k < 400; ++k) {
        const double z = 1.0 - (2.0 * k + 1.0) / 400.0;
        const double s = std::sqrt(1.0 - z * z);
        const Vec3 dir{s * std::cos(golden * k), z, s * std::sin(golden * k)};
        const double length = (1.0 + 0.5 * (k % 9)) * voxel;
        // Voxel centres sit at integer multiples of the voxel; these offsets cover the cell.
        const Vec3 tip{(17 + frac(0.5 + k * 0.7548776662)) * voxel,
                       (5 + frac(0.5 + k * 0.5698402910)) * voxel,
                       (-9 + frac(0.5 + k * 0.4301597090)) * voxel};
        const Vec3 base = tip - dir * length;
        const Mesh m = watertightMesh(segmentTree(base, 0.0, tip, 0.0), {voxel, 3.0});
        ASSERT_FALSE(m.empty());
        Converted cm = toSurfaceMesh(m);
        CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel> inside(cm.sm);
        const AabbTree surface(faces(cm.sm).first, faces(cm.sm).second, cm.sm);
        for (const Vec3& p : {tip, base}) {
            const Point q(p.x, p.y, p.z);
            const double depth = std::sqrt(surface.squared_distance(q)) / voxel;
            shallowest = std::min(shallowest, inside(q) == CGAL::ON_BOUNDED_SIDE ? depth : -depth);
        }
    }
    EXPECT_GE(shallowest, 0.15) << "voxels inside the surface, the shallowest twig end";
}

// Order per vertex is that of the segment whose surface the vertex lies on.
TEST(Watertight, OrderFromNearestSegment) {
    Tree t;
    t.nodes.resize(4);
    t.nodes[0] = {{0, 0, 0}, 0.08, -1, 0};
    t.nodes[1] = {{0, 0.5, 0}, 0.07, 0, 0};
    t.nodes[2] = {{0, 1.0, 0}, 0.06, 1, 0};
    t.nodes[3] = {{0.4, 0.8, 0}, 0.03, 1, 1};  // lateral from node 1
    const Mesh m = watertightMesh(t, {0.01, 3.0});
    ASSERT_FALSE(m.empty());
    Converted cm = toSurfaceMesh(m);
    expectClosedManifold(cm);
    EXPECT_EQ(componentCount(cm.sm), 1u);
    size_t lateral = 0, trunk = 0;
    for (size_t i = 0; i < m.vertexCount(); ++i) {
        const Vec3 p = vertex(m, i);
        if (p.x > 0.2) {  // well out on the lateral
            ASSERT_EQ(m.order[i], 1);
            ++lateral;
        } else if (p.x < 0.0 || p.y < 0.4) {  // trunk side away from the lateral
            ASSERT_EQ(m.order[i], 0);
            ++trunk;
        }
    }
    EXPECT_GT(lateral, 100u);
    EXPECT_GT(trunk, 100u);
}

// Many overlapping segments (a star of branches through one point, and a zig-zag that
// doubles back on itself): still one closed manifold mesh without self-intersections.
TEST(Watertight, OverlappingSegments) {
    Tree t;
    t.nodes.push_back({{0, 0, 0}, 0.05, -1, 0});
    for (int k = 0; k < 10; ++k) {
        const double a = 0.9 * k;
        t.nodes.push_back({{0.3 * std::cos(a), 0.2 + 0.02 * k, 0.3 * std::sin(a)}, 0.03, 0, 1});
    }
    int32_t prev = 0;
    for (int k = 0; k < 8; ++k) {
        t.nodes.push_back({{(k % 2) * 0.05, 0.05 * k, 0.0}, 0.04, prev, 0});
        prev = static_cast<int32_t>(t.nodes.size() - 1);
    }
    const Mesh m = watertightMesh(t, {0.006, 3.0});
    expectWellFormed(m);
    Converted cm = toSurfaceMesh(m);
    expectClosedManifold(cm);
    EXPECT_FALSE(PMP::does_self_intersect(cm.sm));
    EXPECT_EQ(componentCount(cm.sm), 1u);
    EXPECT_GT(PMP::volume(cm.sm), 0.0);
}

// A root system below ground and a trunk above: one closed mesh spanning both.
TEST(Watertight, RootsBelowGround) {
    Tree t;
    t.nodes.push_back({{0, 0, 0}, 0.06, -1, 0});
    t.nodes.push_back({{0, 0.8, 0}, 0.04, 0, 0});
    t.nodes.push_back({{0, -0.5, 0}, 0.05, 0, 0, 0, kRootPart});
    t.nodes.push_back({{0.3, -0.3, 0.1}, 0.02, 0, 1, 0, kRootPart});
    t.nodes.push_back({{-0.2, -0.9, -0.2}, 0.01, 2, 1, 0, kRootPart});
    const Mesh m = watertightMesh(t, {0.008, 3.0});
    Converted cm = toSurfaceMesh(m);
    expectClosedManifold(cm);
    EXPECT_FALSE(PMP::does_self_intersect(cm.sm));
    EXPECT_EQ(componentCount(cm.sm), 1u);
    CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel> inside(cm.sm);
    for (const auto& n : t.nodes)
        EXPECT_EQ(inside(Point(n.position.x, n.position.y, n.position.z)), CGAL::ON_BOUNDED_SIDE);
    float minY = 0;
    for (size_t i = 0; i < m.vertexCount(); ++i) minY = std::min(minY, m.positions[3 * i + 1]);
    EXPECT_LT(minY, -0.9);
}

// (b) Every preset, seed 1, voxel = extent / 150: closed, manifold, no self-intersections,
// positive volume, one piece, and every skeleton node inside (all of them, not only those of
// radius >= 2 voxels: thin twigs are thickened around their axis).
TEST(Watertight, EveryPresetIsClosedManifoldAndContainsItsSkeleton) {
    const auto files = presetFiles();
    ASSERT_GE(files.size(), 48u) << "the preset library in " << SYLVA_SOURCE_DIR;
    for (const auto& file : files) {
        SCOPED_TRACE(file.filename().string());
        const SpeciesFile species = loadSpecies(file.string());
        const GrownTree g = growSpecies(species, 1, nullptr, true);
        const double voxel = treeExtent(g.tree) / 150;
        const Mesh m = watertightMesh(g.tree, {voxel, 3.0});
        ASSERT_FALSE(m.empty());
        expectWellFormed(m);
        Converted cm = toSurfaceMesh(m);
        expectClosedManifold(cm);
        EXPECT_FALSE(PMP::does_self_intersect(cm.sm));
        EXPECT_GT(PMP::volume(cm.sm), 0.0);
        EXPECT_EQ(componentCount(cm.sm), 1u);
        CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel> inside(cm.sm);
        size_t outside = 0, thick = 0;
        for (const auto& n : g.tree.nodes) {
            if (n.radius >= 2 * voxel) ++thick;
            if (inside(Point(n.position.x, n.position.y, n.position.z)) != CGAL::ON_BOUNDED_SIDE)
                ++outside;
        }
        EXPECT_EQ(outside, 0u) << "of " << g.tree.nodes.size() << " nodes (" << thick
                               << " of radius >= 2 voxels)";
        // Orders on the mesh are orders of the tree.
        int32_t maxOrder = 0;
        for (const auto& n : g.tree.nodes) maxOrder = std::max(maxOrder, n.order);
        for (int32_t o : m.order) ASSERT_TRUE(o >= 0 && o <= maxOrder);
    }
}

// (c) Identical mesh and .vdb bytes with one thread and with the default thread count.
TEST(Watertight, IdenticalForAnyThreadCount) {
    const auto file =
        std::filesystem::path(SYLVA_SOURCE_DIR) / "species/papers/xu-mould-2012/xm-a.toml";
    const GrownTree g = growSpecies(loadSpecies(file.string()), 1, nullptr, true);
    const WatertightOptions o{treeExtent(g.tree) / 250, 3.0};
    const auto dir = scratchDir("threads");
    const Mesh threaded = watertightMesh(g.tree, o, (dir / "threaded.vdb").string());
    Mesh single;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        single = watertightMesh(g.tree, o, (dir / "single.vdb").string());
    }
    ASSERT_FALSE(threaded.empty());
    EXPECT_TRUE(identicalMeshes(threaded, single));
    // The files differ only in their random UUID: compare the grids read back.
    auto a = readTreeSdf(dir / "threaded.vdb"), b = readTreeSdf(dir / "single.vdb");
    ASSERT_TRUE(a && b);
    EXPECT_GT(a->activeVoxelCount(), 0u);
    EXPECT_TRUE(identicalGrids(*a, *b));
    const Mesh again = watertightMesh(g.tree, o);
    EXPECT_TRUE(identicalMeshes(threaded, again));
    // No temporary files are left behind.
    size_t files = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
    EXPECT_EQ(files, 2u);
    std::filesystem::remove_all(dir);
}

// (e) Past the file size limit (what a full disk does to a write, EFBIG instead of ENOSPC;
// set in a child process): a ResourceError naming the .vdb, and no file — OpenVDB's own writer
// ignores the failed stream and would leave a truncated .vdb in its place.
TEST(Watertight, VdbOnAFullDiskIsAResourceErrorAndNoFile) {
    const auto dir = scratchDir("vdb_full");
    const auto path = dir / "capsule.vdb";
    const pid_t child = ::fork();
    if (child == 0) {
        ::signal(SIGXFSZ, SIG_IGN);
        struct rlimit rl = {2048, 2048};
        if (::setrlimit(RLIMIT_FSIZE, &rl) != 0) ::_exit(10);
        try {
            watertightMesh(segmentTree({0, 0, 0}, 0.06, {0.2, 0.5, 0}, 0.06), {0.01, 3.0},
                           path.string());
        } catch (const ResourceError& e) {
            ::_exit(e.error() == EFBIG && e.path() == path.string() ? 0 : 11);
        } catch (...) {
            ::_exit(12);
        }
        ::_exit(13);  // no error: the truncated file was kept
    }
    ASSERT_GT(child, 0);
    int status = 0;
    ::waitpid(child, &status, 0);
    ASSERT_TRUE(WIFEXITED(status)) << status;
    EXPECT_EQ(WEXITSTATUS(status), 0);
    EXPECT_TRUE(std::filesystem::is_empty(dir)) << "a .vdb or its temp file was left";
    std::filesystem::remove_all(dir);
}

// (d) The .vdb read back: a level set named tree_sdf with the voxel size, the narrow band of
// exact capsule distances (active voxel count and values), and the same mesh as before.
TEST(Watertight, VdbRoundTrip) {
    const Vec3 a{0.02, -0.1, 0.03}, b{0.25, 0.5, -0.2};
    const double r = 0.06, voxel = 0.01, halfWidth = 3.0;
    const auto dir = scratchDir("vdb");
    const auto path = dir / "capsule.vdb";
    const Mesh m = watertightMesh(segmentTree(a, r, b, r), {voxel, halfWidth}, path.string());
    ASSERT_FALSE(m.empty());

    openvdb::initialize();
    openvdb::io::File file(path.string());
    file.open();
    auto base = file.readGrid("tree_sdf");
    file.close();
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    ASSERT_TRUE(grid);
    EXPECT_EQ(grid->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_NEAR(grid->voxelSize()[0], voxel, 1e-12);
    auto meta = grid->getMetadata<openvdb::DoubleMetadata>("voxel_size");
    ASSERT_TRUE(meta);
    EXPECT_EQ(meta->value(), voxel);
    const float background = static_cast<float>(halfWidth * voxel);
    EXPECT_FLOAT_EQ(grid->background(), background);

    // Brute force over the lattice: distance to the capsule, active where inside the band.
    auto capsule = [&](const Vec3& p) {
        const Vec3 ab = b - a;
        const double u = std::clamp(dot(p - a, ab) / length2(ab), 0.0, 1.0);
        return distance(p, a + ab * u) - r;
    };
    const double band = halfWidth * voxel;
    size_t expectedActive = 0;
    std::vector<std::pair<openvdb::Coord, float>> samples;
    const int lo[3] = {int(std::floor((std::min(a.x, b.x) - r - band) / voxel)) - 1,
                       int(std::floor((std::min(a.y, b.y) - r - band) / voxel)) - 1,
                       int(std::floor((std::min(a.z, b.z) - r - band) / voxel)) - 1};
    const int hi[3] = {int(std::ceil((std::max(a.x, b.x) + r + band) / voxel)) + 1,
                       int(std::ceil((std::max(a.y, b.y) + r + band) / voxel)) + 1,
                       int(std::ceil((std::max(a.z, b.z) + r + band) / voxel)) + 1};
    for (int i = lo[0]; i <= hi[0]; ++i)
        for (int j = lo[1]; j <= hi[1]; ++j)
            for (int k = lo[2]; k <= hi[2]; ++k) {
                const double d = capsule({i * voxel, j * voxel, k * voxel});
                float f = static_cast<float>(std::max(d, -band));
                // watertightMesh keeps values 0.001 voxel off zero.
                const float nudge = static_cast<float>(1e-3 * voxel);
                if (std::abs(f) < nudge) f = f < 0 ? -nudge : nudge;
                if (f > -background && f < background) {
                    ++expectedActive;
                    if ((i + 3 * j + 7 * k) % 97 == 0)
                        samples.emplace_back(openvdb::Coord(i, j, k), f);
                }
            }
    EXPECT_EQ(grid->activeVoxelCount(), expectedActive);
    ASSERT_GT(samples.size(), 10u);
    auto acc = grid->getConstAccessor();
    for (const auto& [ijk, value] : samples) {
        EXPECT_TRUE(acc.isValueOn(ijk));
        EXPECT_NEAR(acc.getValue(ijk), value, 1e-6);
    }
    // Far inside and far outside: ∓ background.
    const Vec3 mid = (a + b) * 0.5;
    EXPECT_EQ(acc.getValue(openvdb::Coord(int(std::lround(mid.x / voxel)),
                                          int(std::lround(mid.y / voxel)),
                                          int(std::lround(mid.z / voxel)))),
              -background);
    EXPECT_EQ(acc.getValue(openvdb::Coord(1000, 1000, 1000)), background);
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sylva
