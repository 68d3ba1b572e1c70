// Guides of the space-colonization method (Liu et al. 2020 §4.3): brush-stroke markers (exact
// counts, uniform over the union of capsules with no double counting at joints, within the
// radius, the nearest segment's direction, the normal weight) and silhouette markers (frame,
// counts, r_m = 0 deep inside, every marker within r_m of a masked pixel), determinism, and
// the [guides] reader and its errors.
#include "species/methods/space_colonization_guides.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "core/params.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

// Brute-force distance from p to the polyline, and the unit direction of the nearest segment.
std::pair<double, Vec3> bruteNearest(const std::vector<Vec3>& pts, const Vec3& p) {
    double best = INFINITY;
    Vec3 dir;
    for (size_t i = 0; i + 1 < pts.size(); ++i) {
        const Vec3 a = pts[i], b = pts[i + 1];
        const Vec3 ab = b - a;
        const double t = std::clamp(dot(p - a, ab) / length2(ab), 0.0, 1.0);
        const double d = distance(p, a + ab * t);
        if (d < best) {
            best = d;
            dir = normalize(ab);
        }
    }
    return {best, dir};
}

bool sameMarkers(const std::vector<GuideMarker>& a, const std::vector<GuideMarker>& b) {
    if (a.size() != b.size()) return false;
    for (size_t i = 0; i < a.size(); ++i) {
        if (!(a[i].position == b[i].position) || !(a[i].direction == b[i].direction) ||
            a[i].weight != b[i].weight) {
            return false;
        }
    }
    return true;
}

// --- brush strokes ---------------------------------------------------------------------------

TEST(ScGuideStroke, CountIsDensityTimesLength) {
    BrushStroke s;
    s.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {1, 1, 2}};  // length 4
    s.radius = 0.1;
    s.density = 250;
    Rng rng(7);
    EXPECT_EQ(strokeMarkers(s, rng).size(), 1000u);
    s.density = 12.3;  // 49.2 → 49
    EXPECT_EQ(strokeMarkers(s, rng).size(), 49u);
    // A repeated point (zero-length segment) adds no length and no markers of its own.
    s.points = {{0, 0, 0}, {0, 1, 0}, {0, 1, 0}, {0, 3, 0}};
    s.density = 100;
    std::vector<GuideMarker> m = strokeMarkers(s, rng);
    EXPECT_EQ(m.size(), 300u);
    for (const GuideMarker& g : m) EXPECT_EQ(g.direction, (Vec3{0, 1, 0}));
}

// Two collinear segments joined at x = 1: the union is one capsule of length 3. Without the
// nearest-segment rule the two half-balls overlapping at the joint would be drawn twice and
// the slab |x − 1| < r would hold ~10% of the markers instead of its volume share 6.4%.
TEST(ScGuideStroke, UniformOverTheUnionNoDoubleCountAtJoints) {
    BrushStroke s;
    s.points = {{0, 0, 0}, {1, 0, 0}, {3, 0, 0}};
    s.radius = 0.1;
    s.density = 20000.0 / 3.0;
    Rng rng(3);
    const std::vector<GuideMarker> m = strokeMarkers(s, rng);
    ASSERT_EQ(m.size(), 20000u);
    const double r = s.radius;
    const double capsule = kPi * r * r * 3 + 4.0 / 3.0 * kPi * r * r * r;
    const double slab = kPi * r * r * 2 * r;
    const double cylinderLeft = kPi * r * r * 1 + 2.0 / 3.0 * kPi * r * r * r;  // x < 1
    int inSlab = 0, left = 0;
    for (const GuideMarker& g : m) {
        inSlab += std::abs(g.position.x - 1) < r;
        left += g.position.x < 1;
    }
    // σ of a fraction over 20000 draws is ≤ 0.0035; allow ~3σ.
    EXPECT_NEAR(inSlab / 20000.0, slab / capsule, 0.006);
    EXPECT_NEAR(left / 20000.0, cylinderLeft / capsule, 0.01);
}

TEST(ScGuideStroke, WithinRadiusAndNearestSegmentDirection) {
    BrushStroke s;
    // A bent 3-D stroke with a sharp turn (capsules overlap a lot at the joints).
    s.points = {{0, 0, 0}, {0.5, 1.0, 0.2}, {0.2, 1.6, -0.3}, {1.2, 1.9, 0.4}};
    s.radius = 0.15;
    s.density = 800;
    Rng rng(11);
    const std::vector<GuideMarker> m = strokeMarkers(s, rng);
    ASSERT_GT(m.size(), 1000u);
    int nearEnd = 0;
    for (const GuideMarker& g : m) {
        const auto [d, dir] = bruteNearest(s.points, g.position);
        ASSERT_LE(d, s.radius + 1e-12);
        EXPECT_NEAR(length(g.direction), 1.0, 1e-12);
        EXPECT_NEAR(distance(g.direction, dir), 0.0, 1e-12);
        EXPECT_NEAR(g.weight, strokeWeight(d, s.radius / 2, 1.0), 1e-12);
        nearEnd += distance(g.position, s.points.back()) < s.radius;
    }
    EXPECT_GT(nearEnd, 0);  // the end caps are filled too
}

TEST(ScGuideStroke, WeightIsTheNormalDensityInUnitsOfSigma) {
    const double peak = 1.0 / std::sqrt(2 * kPi);
    EXPECT_NEAR(strokeWeight(0.0, 0.05, 1.0), peak, 1e-15);
    EXPECT_NEAR(strokeWeight(0.05, 0.05, 1.0), peak * std::exp(-0.5), 1e-15);
    EXPECT_NEAR(strokeWeight(0.1, 0.05, 2.0), 2 * peak * std::exp(-2.0), 1e-15);
    // Scale-free: the same brush in centimetres weighs the same.
    EXPECT_NEAR(strokeWeight(3.0, 5.0, 1.0), strokeWeight(0.03, 0.05, 1.0), 1e-15);

    BrushStroke s;
    s.points = {{0, 0, 0}, {0, 2, 0}};
    s.radius = 0.2;
    s.density = 500;
    s.sigma = 0.08;
    s.weight = 3.0;
    Rng rng(5);
    std::vector<GuideMarker> m = strokeMarkers(s, rng);
    std::vector<std::pair<double, double>> dw;
    for (const GuideMarker& g : m)
        dw.push_back({bruteNearest(s.points, g.position).first, g.weight});
    std::sort(dw.begin(), dw.end());
    for (size_t i = 1; i < dw.size(); ++i) EXPECT_LE(dw[i].second, dw[i - 1].second);
    EXPECT_GT(dw.front().second, 0.9 * 3.0 * peak);
    EXPECT_LT(dw.back().second, 3.0 * peak * std::exp(-0.5 * (0.18 / 0.08) * (0.18 / 0.08)));
}

TEST(ScGuideStroke, DeterministicPerSeed) {
    BrushStroke s;
    s.points = {{0, 0, 0}, {1, 1, 0}, {2, 1, 1}};
    s.radius = 0.2;
    s.density = 300;
    Rng a(42), b(42), c(43);
    const auto ma = strokeMarkers(s, a), mb = strokeMarkers(s, b), mc = strokeMarkers(s, c);
    EXPECT_TRUE(sameMarkers(ma, mb));
    EXPECT_FALSE(sameMarkers(ma, mc));
}

// --- silhouette ------------------------------------------------------------------------------

Mask discMask(int w, int h, double cx, double cy, double r) {
    Mask m;
    m.width = w;
    m.height = h;
    m.on.resize(static_cast<size_t>(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double dx = x + 0.5 - cx, dy = y + 0.5 - cy;
            m.on[static_cast<size_t>(y) * w + x] = dx * dx + dy * dy <= r * r;
        }
    return m;
}

TEST(ScGuideSilhouette, ImageToTreeFrame) {
    SilhouetteGuide g;
    g.mask = discMask(40, 20, 20, 10, 5);
    g.metresPerPixel = 0.1;
    // Azimuth 0: the x–y plane seen from +z; axis column 20 on the y axis, bottom edge y = 0.
    Vec3 p = silhouetteToTree(g, 20, 20, 0);
    EXPECT_NEAR(distance(p, {0, 0, 0}), 0, 1e-12);
    p = silhouetteToTree(g, 30.5, 0.5, 0.3);  // right of the axis, top row, toward the viewer
    EXPECT_NEAR(distance(p, {1.05, 1.95, 0.3}), 0, 1e-12);
    // Azimuth 90: image right is −z, the viewer is on +x.
    g.azimuthDeg = 90;
    p = silhouetteToTree(g, 30, 10, 0.3);
    EXPECT_NEAR(distance(p, {0.3, 1.0, -1.0}), 0, 1e-12);
    g.axisColumn = 10;
    p = silhouetteToTree(g, 10, 10, 0);
    EXPECT_NEAR(distance(p, {0, 1.0, 0}), 0, 1e-12);
}

TEST(ScGuideSilhouette, CountsPerPixel) {
    SilhouetteGuide g;
    g.mask = discMask(30, 30, 15, 15, 11);
    g.metresPerPixel = 0.05;
    const size_t pixels = g.mask.count();
    Rng rng(1);
    EXPECT_EQ(silhouetteMarkers(g, rng).size(), pixels);
    g.markersPerPixel = 2.5;
    EXPECT_EQ(silhouetteMarkers(g, rng).size(), static_cast<size_t>(std::floor(2.5 * pixels)));
    g.markersPerPixel = 0.3;
    EXPECT_EQ(silhouetteMarkers(g, rng).size(), static_cast<size_t>(std::floor(0.3 * pixels)));
}

// With one marker per pixel the markers come in row-major pixel order, so each can be checked
// against its own pixel: deep inside (n_x = 0) exactly on the pixel centre up to the depth
// spread, elsewhere within r_m (pixels) of it in the image plane.
TEST(ScGuideSilhouette, DeepInsideOnPixelCentresBorderSpreadWithinRm) {
    SilhouetteGuide g;
    g.mask = discMask(48, 40, 24, 20, 14);
    g.metresPerPixel = 0.02;
    g.azimuthDeg = 30;
    g.depth = 0.4;
    Rng rng(9);
    const std::vector<GuideMarker> m = silhouetteMarkers(g, rng);
    ASSERT_EQ(m.size(), g.mask.count());
    const std::vector<uint8_t> n = unmaskedNeighbourCounts(g.mask);
    const double a = g.azimuthDeg * kPi / 180;
    const Vec3 toViewer{std::sin(a), 0, std::cos(a)};
    size_t i = 0;
    int interior = 0, border = 0, spilled = 0;
    double depthMin = 1, depthMax = -1;
    for (int row = 0; row < g.mask.height; ++row)
        for (int col = 0; col < g.mask.width; ++col) {
            if (!g.mask.at(col, row)) continue;
            const Vec3 centre = silhouetteToTree(g, col + 0.5, row + 0.5, 0);
            const Vec3 off = m[i++].position - centre;
            const double along = dot(off, toViewer);
            const double inPlane = length(off - toViewer * along) / g.metresPerPixel;  // pixels
            const int nx = n[static_cast<size_t>(row) * g.mask.width + col];
            const double rm = falloffRadius(nx, g.falloff);
            if (nx == 0) {
                ++interior;
                EXPECT_EQ(rm, 0.0);
                EXPECT_NEAR(inPlane, 0.0, 1e-9);
                EXPECT_LE(std::abs(along), g.depth / 2);
                depthMin = std::min(depthMin, along);
                depthMax = std::max(depthMax, along);
            } else {
                ++border;
                ASSERT_GT(rm, 0.0);
                EXPECT_LE(inPlane, rm + 1e-9);
                EXPECT_LE(std::abs(along), g.depth / 2 + rm * g.metresPerPixel + 1e-12);
                spilled += inPlane > 1.0;  // moved by more than a pixel
            }
        }
    EXPECT_GT(interior, 300);
    EXPECT_GT(border, 50);
    EXPECT_GT(spilled, border / 4);           // the border is soft
    EXPECT_LT(depthMin, -0.8 * g.depth / 2);  // the depth spread is used in full
    EXPECT_GT(depthMax, 0.8 * g.depth / 2);
}

// Every marker projects back (along the view direction) to within r_m of some masked pixel's
// centre, and the border's largest r_m is below R/2.
TEST(ScGuideSilhouette, MarkersProjectBackIntoTheMask) {
    SilhouetteGuide g;
    // An L-shaped mask (corners both ways), seen from azimuth −60°, axis off-centre.
    g.mask.width = 36;
    g.mask.height = 30;
    g.mask.on.assign(36 * 30, 0);
    for (int y = 4; y < 26; ++y)
        for (int x = 5; x < 30; ++x) g.mask.on[y * 36 + x] = (x < 15 || y > 17);
    g.metresPerPixel = 0.05;
    g.azimuthDeg = -60;
    g.axisColumn = 12;
    g.markersPerPixel = 3;
    Rng rng(4);
    const std::vector<GuideMarker> m = silhouetteMarkers(g, rng);
    ASSERT_EQ(m.size(), 3 * g.mask.count());
    const std::vector<uint8_t> n = unmaskedNeighbourCounts(g.mask);
    const double a = g.azimuthDeg * kPi / 180;
    const Vec3 right{std::cos(a), 0, -std::sin(a)};
    for (const GuideMarker& marker : m) {
        EXPECT_EQ(marker.weight, 0.0);
        EXPECT_EQ(marker.direction, (Vec3{0, 0, 0}));
        // Image coordinates of the marker (pixels).
        const double col = dot(marker.position, right) / g.metresPerPixel + g.axisColumn;
        const double row = g.mask.height - marker.position.y / g.metresPerPixel;
        bool found = false;
        for (int y = 0; y < g.mask.height && !found; ++y)
            for (int x = 0; x < g.mask.width && !found; ++x) {
                if (!g.mask.at(x, y)) continue;
                const double rm = falloffRadius(n[y * g.mask.width + x], g.falloff);
                found = std::hypot(col - (x + 0.5), row - (y + 0.5)) <= rm + 1e-9;
            }
        EXPECT_TRUE(found) << "marker at column " << col << ", row " << row;
        EXPECT_LT(std::hypot(col - std::clamp(col, 5.0, 30.0), row - std::clamp(row, 4.0, 26.0)),
                  g.falloff.radius / 2);
    }
}

// depth_profile = "round": a triangle (apex up) seen from the front, its rows' sections are
// ellipses as wide as the row and depth·e_row/(2·e_max) deep, so from the side it is a
// triangle too, and from above a disc rather than a slab's rectangle.
TEST(ScGuideSilhouette, RoundDepthProfileGivesEllipticalSections) {
    SilhouetteGuide g;
    g.mask.width = 41;
    g.mask.height = 40;
    g.mask.on.assign(41 * 40, 0);
    for (int y = 0; y < 40; ++y)  // row y spans columns [20 − y/2, 20 + y/2]
        for (int x = 20 - y / 2; x <= 20 + y / 2; ++x) g.mask.on[y * 41 + x] = 1;
    g.metresPerPixel = 0.1;
    g.axisColumn = 20.5;  // the rows' middle
    g.depth = 3.9;        // at the widest rows (38, 39: 39 pixels = 3.9 m): circular sections
    g.depthProfile = SilhouetteGuide::DepthProfile::kRound;
    g.falloff.enabled = false;  // r_m = 0: only the depth spread moves a marker off its pixel
    g.markersPerPixel = 4;
    Rng rng(2);
    const std::vector<GuideMarker> m = silhouetteMarkers(g, rng);
    ASSERT_EQ(m.size(), 4 * g.mask.count());
    double topDeepest = 0, bottomDeepest = 0;
    int corner = 0;
    for (const GuideMarker& marker : m) {
        const int r = static_cast<int>(std::lround(g.mask.height - marker.position.y / 0.1 - 0.5));
        const double e = (2 * (r / 2) + 1) * 0.1 / 2;  // the row's half extent, metres
        const double semiDepth = g.depth / 2 * e / 1.95;
        const double x = marker.position.x / e, z = marker.position.z / semiDepth;
        EXPECT_LE(x * x + z * z, 1.0 + 1e-9) << marker.position.x << " " << marker.position.z;
        if (r < 10) topDeepest = std::max(topDeepest, std::abs(marker.position.z));
        if (r >= 36) bottomDeepest = std::max(bottomDeepest, std::abs(marker.position.z));
        corner += std::abs(marker.position.x) > 0.75 * e && std::abs(marker.position.z) > 0.75 * e;
    }
    EXPECT_LT(topDeepest, 0.46);    // rows 0–9: at most 9/39 of ±1.95 m
    EXPECT_GT(bottomDeepest, 1.8);  // the widest rows use nearly all of it
    EXPECT_EQ(corner, 0);           // no marker in the corners of the section's square
    // The slab: every row spreads over the full depth, corners included.
    g.depthProfile = SilhouetteGuide::DepthProfile::kSlab;
    Rng again(2);
    double topSlab = 0;
    for (const GuideMarker& marker : silhouetteMarkers(g, again)) {
        if (marker.position.y > 3.0) topSlab = std::max(topSlab, std::abs(marker.position.z));
    }
    EXPECT_GT(topSlab, 1.5);
}

TEST(ScGuideSilhouette, DeterministicPerSeed) {
    SilhouetteGuide g;
    g.mask = discMask(30, 30, 15, 15, 11);
    Rng a(8), b(8), c(9);
    const auto ma = silhouetteMarkers(g, a), mb = silhouetteMarkers(g, b),
               mc = silhouetteMarkers(g, c);
    EXPECT_TRUE(sameMarkers(ma, mb));
    EXPECT_FALSE(sameMarkers(ma, mc));
}

// --- the [guides] reader ---------------------------------------------------------------------

using sylva::test::TempDir;

void writeMaskPng(const fs::path& f, const Mask& m) {
    auto out = OIIO::ImageOutput::create(f.string());
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(m.width, m.height, 1, OIIO::TypeDesc::UINT8);
    ASSERT_TRUE(out->open(f.string(), spec));
    std::vector<uint8_t> px(m.on.size());
    for (size_t i = 0; i < px.size(); ++i) px[i] = m.on[i] ? 255 : 0;
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px.data()));
    out->close();
}

std::vector<GuideMarker> parse(const std::string& text, const fs::path& file, uint64_t seed) {
    toml::table t = toml::parse(text, file.string());
    DrawContext draw;
    Params p(t, file.string(), "", &draw);
    Params guides = p.table("guides");
    Rng rng(seed);
    return parseGuides(guides, rng);
}

// The error of a spec, or "" when it parses.
std::string parseError(const std::string& text, const fs::path& file) {
    try {
        parse(text, file, 1);
    } catch (const SpecError& e) {
        return e.what();
    }
    return "";
}

TEST(ScGuideSpec, StrokesAndSilhouetteAsTheGenerators) {
    TempDir dir;
    const Mask mask = discMask(20, 16, 10, 8, 6);
    writeMaskPng(dir / "m.png", mask);
    const std::string text = R"(
[[guides.strokes]]
points = [[0, 0, 0], [0, 1, 0], [1, 2, 0]]
radius = 0.1
density = 50

[[guides.strokes]]
points = [[0, 0, 0], [0, 0, 1]]
radius = 0.2
density = 40
sigma = 0.05
weight = 2

[guides.silhouette]
mask = "m.png"
height = 3.2
azimuth_deg = 90
axis_column = 8
falloff_radius = 6
falloff_k = 0.5
markers_per_pixel = 2
depth = 1.5
depth_profile = "round"
)";
    const std::vector<GuideMarker> got = parse(text, dir / "s.toml", 77);

    Rng rng(77);
    std::vector<GuideMarker> want;
    BrushStroke a;
    a.points = {{0, 0, 0}, {0, 1, 0}, {1, 2, 0}};
    a.radius = 0.1;
    a.density = 50;
    Rng ra = rng.derive("strokes[0]");
    for (auto& g : strokeMarkers(a, ra)) want.push_back(g);
    BrushStroke b;
    b.points = {{0, 0, 0}, {0, 0, 1}};
    b.radius = 0.2;
    b.density = 40;
    b.sigma = 0.05;
    b.weight = 2;
    Rng rb = rng.derive("strokes[1]");
    for (auto& g : strokeMarkers(b, rb)) want.push_back(g);
    SilhouetteGuide s;
    s.mask = mask;
    s.metresPerPixel = 0.2;
    s.azimuthDeg = 90;
    s.axisColumn = 8;
    s.falloff.radius = 6;
    s.falloff.k = 0.5;
    s.markersPerPixel = 2;
    s.depth = 1.5;
    s.depthProfile = SilhouetteGuide::DepthProfile::kRound;
    Rng rs = rng.derive("silhouette");
    for (auto& g : silhouetteMarkers(s, rs)) want.push_back(g);

    EXPECT_EQ(got.size(), 121 + 40 + 2 * mask.count());  // round(50·(1 + √2)), 40·1, 2/pixel
    EXPECT_TRUE(sameMarkers(got, want));
}

TEST(ScGuideSpec, Errors) {
    TempDir dir;
    const fs::path file = dir / "s.toml";
    // One point: named at the key, with its line.
    std::string e =
        parseError("[[guides.strokes]]\npoints = [[0, 0, 0]]\nradius = 0.1\ndensity = 10\n", file);
    EXPECT_NE(e.find("s.toml:2:"), std::string::npos) << e;
    EXPECT_NE(e.find("guides.strokes[0].points"), std::string::npos) << e;
    EXPECT_NE(e.find("at least 2 points"), std::string::npos) << e;
    // A point that is not [x, y, z].
    e = parseError(
        "[[guides.strokes]]\npoints = [[0, 0, 0],\n [1, 2]]\nradius = 0.1\n"
        "density = 10\n",
        file);
    EXPECT_NE(e.find("s.toml:3:"), std::string::npos) << e;
    EXPECT_NE(e.find("item 1"), std::string::npos) << e;
    // radius ≤ 0.
    e = parseError(
        "[[guides.strokes]]\npoints = [[0, 0, 0], [0, 1, 0]]\nradius = 0\ndensity = 10\n", file);
    EXPECT_NE(e.find("s.toml:3:"), std::string::npos) << e;
    EXPECT_NE(e.find("guides.strokes[0].radius"), std::string::npos) << e;
    // All points the same.
    e = parseError(
        "[[guides.strokes]]\npoints = [[0, 1, 0], [0, 1, 0]]\nradius = 1\ndensity = 10\n", file);
    EXPECT_NE(e.find("length 0"), std::string::npos) << e;
    // Misspelt key in a stroke.
    e = parseError(
        "[[guides.strokes]]\npoints = [[0, 0, 0], [0, 1, 0]]\nradius = 1\ndensity = 10\n"
        "wieght = 2\n",
        file);
    EXPECT_NE(e.find("guides.strokes[0].wieght: unknown key; did you mean \"weight\"?"),
              std::string::npos)
        << e;
    // Missing mask file.
    e = parseError("[guides.silhouette]\nmask = \"nope.png\"\nheight = 5\n", file);
    EXPECT_NE(e.find("s.toml:2:"), std::string::npos) << e;
    EXPECT_NE(e.find("guides.silhouette.mask"), std::string::npos) << e;
    EXPECT_NE(e.find("file not found"), std::string::npos) << e;
    // Empty mask.
    Mask empty;
    empty.width = empty.height = 8;
    empty.on.assign(64, 0);
    writeMaskPng(dir / "empty.png", empty);
    e = parseError("[guides.silhouette]\nmask = \"empty.png\"\nheight = 5\n", file);
    EXPECT_NE(e.find("guides.silhouette.mask"), std::string::npos) << e;
    EXPECT_NE(e.find("is empty"), std::string::npos) << e;
    // Neither height nor metres_per_pixel.
    writeMaskPng(dir / "m.png", discMask(8, 8, 4, 4, 3));
    e = parseError("[guides.silhouette]\nmask = \"m.png\"\n", file);
    EXPECT_NE(e.find("metres_per_pixel"), std::string::npos) << e;
    // Unknown key in [guides].
    e = parseError("[guides]\nstroke = 1\n", file);
    EXPECT_NE(e.find("guides.stroke: unknown key; did you mean \"strokes\"?"), std::string::npos)
        << e;
}

}  // namespace
}  // namespace sylva
