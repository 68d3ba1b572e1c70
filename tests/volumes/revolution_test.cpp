// Surfaces of revolution of sketched strokes (Xu & Mould 2012 §3.3.1): a revolved semicircle
// is a sphere and a revolved rectangle a cylinder (measure and inside tests), a tilted axis
// rotates the volume, the revolved mesh passes CGAL's checks, Poisson samples lie inside,
// bad strokes give their errors, SVG paths and traced images give the expected strokes.
#include "volumes/revolution.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/params.h"
#include "species/spec/volume_spec.h"
#include "tests/test_support.h"
#include "volumes/poisson.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;
namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;

using sylva::test::TempDir;

void spit(const fs::path& p, const std::string& text) {
    std::ofstream out(p, std::ios::binary);
    out << text;
}

// Semicircle of radius r in the meridian half-plane, from the top pole to the bottom pole.
std::vector<Vec2> semicircle(double r, int n = 200) {
    std::vector<Vec2> s;
    for (int i = 0; i <= n; ++i) {
        const double phi = kPi * i / n;
        s.push_back({r * std::sin(phi), r * std::cos(phi)});
    }
    return s;
}

// Rectangle profile: radius R, height H; 101 samples put the resampled points on its corners.
std::vector<Vec2> rectangle(double R, double H) { return {{0, 0}, {R, 0}, {R, H}, {0, H}}; }
StrokeCleaning exactCorners() {
    StrokeCleaning c;
    c.samples = 101;
    c.smoothing = 0;
    return c;
}

std::string strokeErrorOf(const std::vector<Vec2>& stroke, StrokeCleaning c = {}) {
    try {
        cleanStroke(stroke, c);
    } catch (const StrokeError& e) {
        return e.what();
    }
    return "(no error)";
}

// Counts points (uniform in `box`) where the volume and `truth` (signed distance) disagree,
// skipping those within `skip` of the true surface.
int disagreements(const Volume& v, const Aabb& box, double (*truth)(const Vec3&), double skip,
                  int n = 10000, int* tested = nullptr) {
    Rng rng(42);
    int bad = 0, count = 0;
    for (int i = 0; i < n; ++i) {
        const Vec3 p = rng.inBox(box);
        const double d = truth(p);
        if (std::abs(d) < skip) continue;
        ++count;
        if (v.inside(p) != (d <= 0)) ++bad;
    }
    if (tested) *tested = count;
    return bad;
}

Mesh toMesh(const TriangleSoup& soup) {
    Mesh m;
    std::vector<Mesh::Vertex_index> v;
    for (const Vec3& p : soup.points) v.push_back(m.add_vertex({p.x, p.y, p.z}));
    for (const auto& t : soup.triangles) {
        EXPECT_NE(m.add_face(v[t[0]], v[t[1]], v[t[2]]), Mesh::null_face());
    }
    return m;
}

// --- the sphere and the cylinder -------------------------------------------------------------

double sphereDistance2(const Vec3& p) { return length(p) - 2.0; }

TEST(Revolution, SemicircleGivesASphere) {
    const double r = 2.0, voxel = r / 50;
    const std::vector<Vec2> profile = cleanStroke(semicircle(r), {});
    VolumePtr v = makeRevolution(profile, voxel);
    const double exact = 4.0 / 3.0 * kPi * r * r * r;
    EXPECT_NEAR(v->measure(), exact, 0.01 * exact);
    // What the inside test realises (the generic stratified estimate over bounds()).
    EXPECT_NEAR(v->Volume::measure(), exact, 0.01 * exact);
    const Aabb box{{-1.2 * r, -1.2 * r, -1.2 * r}, {1.2 * r, 1.2 * r, 1.2 * r}};
    int tested = 0;
    EXPECT_EQ(disagreements(*v, box, sphereDistance2, 1.5 * voxel, 10000, &tested), 0);
    EXPECT_GT(tested, 9000);
    // Bounds: the sphere's, padded by about a voxel.
    for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(v->bounds().lo[a], -r, 2 * voxel);
        EXPECT_NEAR(v->bounds().hi[a], r, 2 * voxel);
    }
    // Distances near the surface are metric (trilinear in the narrow band).
    EXPECT_NEAR(v->signedDistance({r - 0.05, 0, 0}), -0.05, 0.5 * voxel);
    EXPECT_NEAR(v->signedDistance({0, 0, r + 0.05}), 0.05, 0.5 * voxel);
    EXPECT_LT(v->signedDistance({0, 0, 0}), 0);  // deep inside, beyond the band
    EXPECT_GT(v->signedDistance({3 * r, 0, 0}), 0);
    EXPECT_NE(v->describe().find("revolution of a"), std::string::npos) << v->describe();
    EXPECT_NE(v->describe().find("voxel 0.04 m"), std::string::npos) << v->describe();
}

double cylinderDistance(const Vec3& p) {  // radius 1, height 3, base at y = 0
    const double dr = std::hypot(p.x, p.z) - 1.0;
    const double dy = std::max(-p.y, p.y - 3.0);
    return std::max(dr, dy);
}

TEST(Revolution, RectangleGivesACylinder) {
    const double voxel = 0.03;
    const std::vector<Vec2> profile = cleanStroke(rectangle(1, 3), exactCorners());
    VolumePtr v = makeRevolution(profile, voxel);
    const double exact = kPi * 1 * 1 * 3;
    EXPECT_NEAR(v->measure(), exact, 0.01 * exact);
    EXPECT_NEAR(v->Volume::measure(), exact, 0.01 * exact);
    const Aabb box{{-1.3, -0.3, -1.3}, {1.3, 3.3, 1.3}};
    EXPECT_EQ(disagreements(*v, box, cylinderDistance, 1.5 * voxel), 0);
}

TEST(Revolution, ConcurrentReadersAgreeWithSerial) {
    VolumePtr v = makeRevolution(cleanStroke(semicircle(1.0), {}), 0.03);
    Rng rng(5);
    std::vector<Vec3> pts(20000);
    for (Vec3& p : pts) p = rng.inBox({{-1.2, -1.2, -1.2}, {1.2, 1.2, 1.2}});
    std::vector<double> serial(pts.size()), parallel(pts.size());
    for (size_t i = 0; i < pts.size(); ++i) serial[i] = v->signedDistance(pts[i]);
    tbb::parallel_for(size_t(0), pts.size(),
                      [&](size_t i) { parallel[i] = v->signedDistance(pts[i]); });
    EXPECT_EQ(serial, parallel);
}

// --- placement through the spec ----------------------------------------------------------------

VolumePtr parseCrown(const std::string& toml, const fs::path& file = "test.toml") {
    toml::table t = toml::parse(toml, file.string());
    DrawContext draw;
    Params p(t, file.string(), "crown", &draw);
    return parseVolume(p);
}

TEST(Revolution, TiltedAxisRotatesTheVolume) {
    VolumePtr v = parseCrown(
        "type = \"revolution\"\n"
        "stroke = [[0, 0], [1, 0], [1, 3], [0, 3]]\n"
        "samples = 101\nsmoothing = 0\nlevel_set_voxel = 0.03\n"
        "axis = [1, 1, 0]\n");
    const Vec3 a = normalize({1, 1, 0});
    const Vec3 nearTop = a * 2.8;                     // on the tilted axis, near its top
    const Vec3 mirrored{-nearTop.x, nearTop.y, 0.0};  // mirrored across the x = 0 plane
    EXPECT_TRUE(v->inside(nearTop));
    EXPECT_FALSE(v->inside(mirrored));
    EXPECT_FALSE(v->inside({0, 2.8, 0}));  // where the untilted cylinder's axis would be
    EXPECT_TRUE(v->inside(a * 1.5 + Vec3{0, 0, 0.9}));
    EXPECT_NEAR(v->measure(), kPi * 3, 0.01 * kPi * 3);
}

TEST(Revolution, SpecErrorsNameTheSourceKey) {
    try {
        parseCrown("type = \"revolution\"\nstroke = [[0, 0], [1, 1], [1.9, 3]]\n");
        FAIL() << "no error";
    } catch (const SpecError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("test.toml:2:"), std::string::npos) << m;
        EXPECT_NE(m.find("crown.stroke"), std::string::npos) << m;
        EXPECT_NE(m.find("never reaches the axis: its top end is 1.9 m from it"), std::string::npos)
            << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
    EXPECT_THROW(parseCrown("type = \"revolution\"\n"), SpecError);  // no source
    EXPECT_THROW(parseCrown("type = \"revolution\"\nstroke = [[0, 0], [1, 1], [0, 2]]\n"
                            "svg = \"a.svg\"\n"),
                 SpecError);  // two sources
    EXPECT_THROW(parseCrown("type = \"revolution\"\nstroke = [[0, 0], [1, 1], [0, 2]]\n"
                            "close_tolerance = 1.5\n"),
                 SpecError);
    EXPECT_THROW(parseCrown("type = \"revolution\"\nstroke = [[0, 0], [1, 1], [0, 2]]\n"
                            "segments = 4\n"),
                 SpecError);
    EXPECT_THROW(parseCrown("type = \"revolution\"\nstroke = [[0, 0], [1, 1], [0, 2]]\n"
                            "axis_x = 3\n"),
                 SpecError);  // axis_x only with svg/image: unknown key
}

// --- the mesh ------------------------------------------------------------------------------------

TEST(Revolution, RevolvedMeshPassesCgalChecks) {
    for (const auto& stroke :
         {semicircle(1.5), rectangle(1, 2),
          std::vector<Vec2>{{0.2, 0}, {1.5, 1}, {0.5, 2}, {1.2, 3.5}, {0, 4}}}) {
        const std::vector<Vec2> profile = cleanStroke(stroke, {});
        const int segments = 48;
        const TriangleSoup soup = revolveProfile(profile, segments);
        // Poles: one vertex per axis end, a ring per interior profile point.
        EXPECT_EQ(soup.points.size(), (profile.size() - 2) * segments + 2);
        Mesh m = toMesh(soup);
        EXPECT_TRUE(m.is_valid());
        EXPECT_TRUE(CGAL::is_closed(m));
        EXPECT_TRUE(CGAL::is_triangle_mesh(m));
        EXPECT_FALSE(PMP::does_self_intersect(m));
        EXPECT_TRUE(PMP::is_outward_oriented(m));
        const long chi =
            long(m.number_of_vertices()) - long(m.number_of_edges()) + long(m.number_of_faces());
        EXPECT_EQ(chi, 2);
        for (Mesh::Face_index f : m.faces()) {
            EXPECT_FALSE(PMP::is_degenerate_triangle_face(f, m));
        }
        EXPECT_GT(PMP::volume(m), 0);
        // The closed-form measure is the mesh's volume to within the quads' triangulation.
        const double measured = makeRevolution(profile, 0.05, segments)->measure();
        EXPECT_NEAR(PMP::volume(m), measured, 0.002 * measured);
    }
}

TEST(Revolution, PoissonSamplesAreInside) {
    const std::vector<Vec2> stroke = {{0.3, 0}, {1.8, 1.2}, {0.6, 2.5}, {1.4, 3.6}, {0.1, 5}};
    VolumePtr v = makeRevolution(cleanStroke(stroke, {}), 0.05);
    Rng rng(3);
    PoissonOptions o;
    o.count = 400;
    o.minDistance = 0.25;
    const std::vector<Vec3> pts = poissonSample(*v, o, rng);
    ASSERT_EQ(pts.size(), 400u);
    for (const Vec3& p : pts) EXPECT_TRUE(v->inside(p)) << p.x << " " << p.y << " " << p.z;
}

// --- bad strokes ---------------------------------------------------------------------------------

TEST(Revolution, BadStrokesSayWhy) {
    EXPECT_NE(
        strokeErrorOf({{0, 0}, {2, 2}, {2, 0}, {0, 2}}).find("the stroke crosses itself near"),
        std::string::npos)
        << strokeErrorOf({{0, 0}, {2, 2}, {2, 0}, {0, 2}});
    const std::string never = strokeErrorOf({{0, 0}, {1, 1}, {1, 3}});
    EXPECT_NE(never.find("never reaches the axis: its top end is 1 m from it"), std::string::npos)
        << never;
    const std::string neverBottom = strokeErrorOf({{0.9, 0}, {1, 1}, {0, 3}});
    EXPECT_NE(neverBottom.find("its bottom end"), std::string::npos) << neverBottom;
    const std::string negative = strokeErrorOf({{0, 0}, {1, 1}, {-0.5, 2}, {0, 3}});
    EXPECT_NE(negative.find("crosses the axis: point 3 at (-0.50, 2.00) m"), std::string::npos)
        << negative;
    EXPECT_NE(strokeErrorOf({{1, 1}}).find("fewer than two distinct points"), std::string::npos);
    EXPECT_NE(strokeErrorOf({{1, 1}, {1, 1}}).find("fewer than two distinct points"),
              std::string::npos);
    EXPECT_NE(strokeErrorOf({{0, 0}, {0, 2}}).find("lies on the axis"), std::string::npos);
    EXPECT_NE(strokeErrorOf({{0, 1}, {1, 2}, {2, 1}, {1, 0}, {0, 1}}).find("same height"),
              std::string::npos);
    StrokeCleaning loose;
    loose.closeTolerance = 1.0;
    EXPECT_NO_THROW(cleanStroke({{0, 0}, {1, 1}, {1, 3}}, loose));
    // A cleaned stroke: counter-clockwise, from the lower axis point to the upper one.
    const std::vector<Vec2> p = cleanStroke({{0.2, 3}, {1, 1.5}, {0.1, 0}}, {});
    EXPECT_EQ(p.front().x, 0.0);
    EXPECT_EQ(p.back().x, 0.0);
    EXPECT_DOUBLE_EQ(p.front().y, 0.0);
    EXPECT_DOUBLE_EQ(p.back().y, 3.0);
    EXPECT_EQ(p.size(), 96u + 2u);
}

TEST(Revolution, ProfileThatTouchesTheAxisIsRejected) {
    StrokeCleaning c;
    c.samples = 5;  // keep the middle point where it is
    c.smoothing = 0;
    const std::string m = strokeErrorOf({{0, 0}, {1, 1}, {0, 2}, {1, 3}, {0, 4}}, c);
    EXPECT_NE(m.find("touches the axis between its ends near (0.00, 2.00) m"), std::string::npos)
        << m;
}

// --- SVG
// -------------------------------------------------------------------------------------------

std::vector<Vec2> svgStroke(const TempDir& t, const std::string& d, double axisX, double height) {
    const fs::path f = t / "s.svg";
    spit(f,
         "<?xml version=\"1.0\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\">\n"
         "<!-- <path d=\"M 0 0 L 9 9\"/> -->\n"
         "  <path id=\"stroke\" style=\"fill:none\"\n        d=\"" +
             d + "\"/>\n  <path d=\"M 5 5 L 6 6\"/>\n</svg>\n");
    return readSvgStroke(f.string(), axisX, height);
}

void expectPoint(const Vec2& got, const Vec2& want, double tol = 1e-9) {
    EXPECT_NEAR(got.x, want.x, tol);
    EXPECT_NEAR(got.y, want.y, tol);
}

TEST(Revolution, SvgRelativeCommandsAndCubic) {
    TempDir t;
    // From the axis x = 10 at the bottom (y = 100, SVG y runs down), a relative line, then a
    // relative cubic back to the axis at the top; 90 units tall scaled to 9 m.
    const std::vector<Vec2> s = svgStroke(t, "M 10 100 l 20 -10 c 0,-20 10,-40 -20,-80", 10, 9);
    ASSERT_EQ(s.size(), 18u);  // moveto, lineto, 16 curve steps
    expectPoint(s[0], {0, 0});
    expectPoint(s[1], {2, 1});
    expectPoint(s[9], {2.125, 4.25});  // the cubic at t = 1/2
    expectPoint(s[17], {0, 9});
}

TEST(Revolution, SvgNumbersAndImplicitCommands) {
    TempDir t;
    // ".5.5" is two numbers, "1e1-1.5e-1" two more; a moveto's extra pairs are linetos.
    const std::vector<Vec2> s = svgStroke(t, "M0,0 .5.5 L1e1-1.5e-1", 0, 0.65);
    ASSERT_EQ(s.size(), 3u);
    expectPoint(s[0], {0, 0.5});
    expectPoint(s[1], {0.5, 0});
    expectPoint(s[2], {10, 0.65});
    const std::vector<Vec2> h = svgStroke(t, "m 0 0 2 0 h 1 v -3 H 0 V -4 z", 0, 4);
    ASSERT_EQ(h.size(), 7u);
    expectPoint(h[1], {2, 0});
    expectPoint(h[2], {3, 0});
    expectPoint(h[3], {3, 3});
    expectPoint(h[4], {0, 3});
    expectPoint(h[5], {0, 4});
    expectPoint(h[6], {0, 0});  // z: back to the start
    // S reflects the previous cubic's second control point; T the previous quadratic's.
    const std::vector<Vec2> c = svgStroke(t, "M0 0 C 0 1 1 1 1 0 S 2 -1 2 0", 0, 1.5);
    ASSERT_EQ(c.size(), 33u);
    const std::vector<Vec2> q = svgStroke(t, "M0 0 Q 1 -2 2 0 T 4 0", 0, 2);
    ASSERT_EQ(q.size(), 33u);
    expectPoint(q[24], {3, 0});  // mid second curve: ctrl (3, 2) → y = −1 below the start
}

TEST(Revolution, SvgErrors) {
    TempDir t;
    auto errorOf = [&](const std::string& d, double axisX = 0) {
        try {
            svgStroke(t, d, axisX, 1);
        } catch (const StrokeError& e) {
            return std::string(e.what());
        }
        return std::string("(no error)");
    };
    EXPECT_NE(errorOf("M0,0 L1,x").find("bad SVG path data at \"x\""), std::string::npos)
        << errorOf("M0,0 L1,x");
    EXPECT_NE(errorOf("M0,0 L1").find("bad SVG path data"), std::string::npos);
    EXPECT_NE(errorOf("L1,1").find("moveto"), std::string::npos);
    EXPECT_NE(errorOf("M0,0 A 1 1 0 0 1 2 2").find("arc"), std::string::npos);
    EXPECT_NE(errorOf("M-1,0 L1,1").find("crosses the axis x = 0"), std::string::npos);
    EXPECT_NE(errorOf("M0,0 L1,1 M 3 3 L 4 4").find("more than one piece"), std::string::npos);
    EXPECT_NE(errorOf("M0,0 L1,0").find("no height"), std::string::npos);
    try {
        readSvgStroke((t / "missing.svg").string(), 0, 1);
        ADD_FAILURE() << "no error";
    } catch (const StrokeError& e) {
        EXPECT_NE(std::string(e.what()).find("cannot read the SVG file"), std::string::npos);
    }
    // A FIFO (which would block the reader) and a directory are not files to read.
    ASSERT_EQ(::mkfifo((t / "fifo.svg").c_str(), 0600), 0);
    fs::create_directory(t / "dir.svg");
    for (const char* name : {"fifo.svg", "dir.svg"}) {
        try {
            readSvgStroke((t / name).string(), 0, 1);
            ADD_FAILURE() << name << ": no error";
        } catch (const StrokeError& e) {
            EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos)
                << e.what();
        }
    }
    spit(t / "nopath.svg", "<svg><pathway d=\"M0 0 L1 1\"/></svg>");
    EXPECT_THROW(readSvgStroke((t / "nopath.svg").string(), 0, 1), StrokeError);
}

// Issue 15: a hostile SVG fails at once instead of filling memory or time: coordinates within
// 1e9, at most 100000 points after flattening, at most 16 MiB; comments stripped in one pass.
TEST(Revolution, SvgLimits) {
    TempDir t;
    auto errorOf = [&](const std::string& name, const std::string& text) {
        spit(t / name, text);
        try {
            readSvgStroke((t / name).string(), 0, 1);
        } catch (const StrokeError& e) {
            return std::string(e.what());
        }
        return std::string("(no error)");
    };
    EXPECT_NE(errorOf("huge.svg", "<svg><path d=\"M 0 0 L 1e308 1 L 0 5\"/></svg>")
                  .find("SVG path coordinate 1e+308 (character 9 of the d attribute) is over "
                        "1e+09 in magnitude"),
              std::string::npos);
    std::string curves = "<svg><path d=\"M 0 0";
    for (int i = 0; i < 6251; ++i) curves += " c 1 1 2 2 " + std::to_string(i % 7 + 1) + " 3";
    EXPECT_NE(errorOf("curves.svg", curves + "\"/></svg>").find("over 100000 points"),
              std::string::npos);
    EXPECT_NE(errorOf("big.svg", std::string((16 << 20) + 1, ' ')).find("at most 16777216"),
              std::string::npos);
    // Many comments, one of them hiding a path: the path after them is the one read.
    std::string comments = "<svg>";
    for (int i = 0; i < 20000; ++i) comments += "<!-- <path d=\"M 0 0 L 9 9\"/> -->";
    const fs::path f = t / "comments.svg";
    spit(f, comments + "<path d=\"M 0 0 L 2 -3 L 0 -6\"/></svg>");
    const std::vector<Vec2> s = readSvgStroke(f.string(), 0, 6);
    ASSERT_EQ(s.size(), 3u);
    expectPoint(s[1], {2, 3});
}

TEST(Revolution, SvgSourceInASpecResolvesRelativeToTheSpecFile) {
    TempDir t;
    fs::create_directories(t / "sketches");
    spit(t / "sketches" / "dome.svg",
         "<svg><path d=\"M 50 100 C 100 100 100 0 50 0\"/></svg>");  // axis x = 50
    fs::create_directories(t / "presets");
    const fs::path spec = t / "presets" / "crown.toml";
    VolumePtr v = parseCrown(
        "type = \"revolution\"\nsvg = \"../sketches/dome.svg\"\n"
        "axis_x = 50\nheight = 4\n",
        spec);
    EXPECT_TRUE(v->inside({0, 2, 0}));
    EXPECT_FALSE(v->inside({0, 4.5, 0}));
    EXPECT_FALSE(v->inside({3.5, 2, 0}));
    try {
        parseCrown("type = \"revolution\"\nsvg = \"../sketches/nothere.svg\"\nheight = 4\n", spec);
        ADD_FAILURE() << "no error";
    } catch (const SpecError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("crown.svg"), std::string::npos) << m;
        EXPECT_NE(m.find("file not found"), std::string::npos) << m;
    }
}

// --- images
// ----------------------------------------------------------------------------------------

void writeImage(const fs::path& f, int w, int h, int channels, const std::vector<uint8_t>& px) {
    auto out = OIIO::ImageOutput::create(f.string());
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(w, h, channels, OIIO::TypeDesc::UINT8);
    if (channels == 4) spec.alpha_channel = 3;
    ASSERT_TRUE(out->open(f.string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px.data()));
    out->close();
}

TEST(Revolution, TracedImageGivesTheProfile) {
    TempDir t;
    const int w = 20, h = 10, axis = 2;
    const int radius[h] = {0, 1, 3, 5, 6, 6, 5, 3, 1, 0};  // top row first
    std::vector<uint8_t> grey(w * h, 255);
    for (int row = 0; row < h; ++row) {
        grey[row * w + axis + radius[row]] = 0;
        if (radius[row] > 2) grey[row * w + axis + 1] = 0;  // nearer pixels do not count
    }
    grey[4 * w + 0] = 0;  // a pixel left of the axis, nearer than the row's farthest
    writeImage(t / "stroke.png", w, h, 1, grey);
    const std::vector<Vec2> s = traceStrokeImage((t / "stroke.png").string(), axis, 9.0);
    ASSERT_EQ(s.size(), 10u);
    for (int row = 0; row < h; ++row) expectPoint(s[row], {double(radius[row]), 9.0 - row});

    // Opaque strokes on a transparent background (colour ignored), rows with no stroke skipped,
    // a fractional axis column, scaling to the height.
    std::vector<uint8_t> rgba(w * h * 4, 0);
    auto set = [&](int row, int col) {
        for (int c = 0; c < 4; ++c) rgba[(row * w + col) * 4 + c] = 255;
    };
    set(1, 10);
    set(5, 14);
    set(9, 11);
    writeImage(t / "alpha.png", w, h, 4, rgba);
    const std::vector<Vec2> a = traceStrokeImage((t / "alpha.png").string(), 10.5, 4.0);
    ASSERT_EQ(a.size(), 3u);
    expectPoint(a[0], {0.25, 4});
    expectPoint(a[1], {3.5 * 0.5, 2});
    expectPoint(a[2], {0.25, 0});

    // Blank image, unreadable file.
    writeImage(t / "blank.png", w, h, 1, std::vector<uint8_t>(w * h, 255));
    try {
        traceStrokeImage((t / "blank.png").string(), 0, 1);
        ADD_FAILURE() << "no error";
    } catch (const StrokeError& e) {
        EXPECT_NE(std::string(e.what()).find("no stroke pixels"), std::string::npos);
    }
    spit(t / "junk.png", "not an image");
    EXPECT_THROW(traceStrokeImage((t / "junk.png").string(), 0, 1), StrokeError);
}

// --- shipped presets ----------------------------------------------------------------------------

TEST(Revolution, ShippedSketchPresetsParse) {
    const fs::path presets = fs::path(SYLVA_SOURCE_DIR) / "species" / "papers" / "xu-mould-2012";
    int found = 0;
    for (const char* name :
         {"xm-sketch-poplar.toml", "xm-sketch-umbrella.toml", "xm-sketch-twotier.toml"}) {
        const fs::path f = presets / name;
        ASSERT_TRUE(fs::exists(f)) << f;
        toml::table t = parseTomlFile(f.string());
        DrawContext draw;
        Params sp(t, f.string(), "", &draw);
        Params crown = sp.table("crown");
        VolumePtr v = parseVolume(crown);
        EXPECT_GT(v->measure(), 1.0) << name;
        ++found;
    }
    EXPECT_EQ(found, 3);
}

}  // namespace
}  // namespace sylva
