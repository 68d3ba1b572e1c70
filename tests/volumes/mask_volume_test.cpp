// Silhouette-mask volumes (Liu et al. 2020 §4.3): reading masks, exact distance transforms
// against brute force, the logistic fall-off and its effect on sample density, the visual hull
// of a disc seen twice (Steinmetz solid), a revolved disc (sphere), and the spec readers.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/params.h"
#include "species/spec/volume_spec.h"
#include "tests/test_support.h"
#include "volumes/mask.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

using sylva::test::TempDir;

void writeImage(const fs::path& f, int w, int h, int channels, const std::vector<uint8_t>& px) {
    auto out = OIIO::ImageOutput::create(f.string());
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(w, h, channels, OIIO::TypeDesc::UINT8);
    if (channels == 4 || channels == 2) spec.alpha_channel = channels - 1;
    ASSERT_TRUE(out->open(f.string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px.data()));
    out->close();
}

// A w × h mask whose inside is where inside(column centre, row centre) holds.
template <class F>
Mask makeMask(int w, int h, F inside) {
    Mask m;
    m.width = w;
    m.height = h;
    m.on.resize(static_cast<size_t>(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) m.on[static_cast<size_t>(y) * w + x] = inside(x + 0.5, y + 0.5);
    return m;
}

// Disc of `r` pixels centred at (cx, cy) (pixel coordinates, rows down).
Mask discMask(int w, int h, double cx, double cy, double r) {
    return makeMask(w, h, [&](double x, double y) {
        return (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r;
    });
}

Mask squareMask(int size, int lo, int hi) {  // inside columns and rows [lo, hi)
    return makeMask(size, size,
                    [&](double x, double y) { return x > lo && x < hi && y > lo && y < hi; });
}

VolumePtr parseCrown(const std::string& text, const fs::path& file) {
    toml::table t = toml::parse(text, file.string());
    DrawContext draw;
    Params p(t, file.string(), "crown", &draw);
    return parseVolume(p);
}

// --- reading ---------------------------------------------------------------------------------

TEST(MaskRead, GreyAlphaLuminanceAndInvert) {
    TempDir t;
    // Grey: 0.5 is inside (≥ 0.5), 127/255 is not.
    writeImage(t / "grey.png", 3, 1, 1, {0, 127, 128});
    Mask m = readMask((t / "grey.png").string(), false);
    ASSERT_EQ(m.width, 3);
    ASSERT_EQ(m.height, 1);
    EXPECT_EQ(m.on, (std::vector<uint8_t>{0, 0, 1}));
    EXPECT_EQ(readMask((t / "grey.png").string(), true).on, (std::vector<uint8_t>{1, 1, 0}));
    // RGB: Rec.709 luminance — pure green (0.715) is inside, pure blue (0.072) is not.
    writeImage(t / "rgb.png", 2, 1, 3, {0, 255, 0, 0, 0, 255});
    EXPECT_EQ(readMask((t / "rgb.png").string(), false).on, (std::vector<uint8_t>{1, 0}));
    // RGBA: alpha decides, whatever the colour; top row first.
    writeImage(t / "rgba.png", 1, 2, 4, {0, 0, 0, 255, 255, 255, 255, 0});
    Mask a = readMask((t / "rgba.png").string(), false);
    EXPECT_EQ(a.on, (std::vector<uint8_t>{1, 0}));
    EXPECT_TRUE(a.at(0, 0));
    EXPECT_FALSE(a.at(0, 1));
    EXPECT_FALSE(a.at(-1, 0));
}

TEST(MaskRead, MissingFileAndEmptyMaskAreOneLineErrors) {
    TempDir t;
    try {
        readMask((t / "nothere.png").string(), false);
        FAIL() << "no error";
    } catch (const MaskError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("nothere.png"), std::string::npos) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
    writeImage(t / "black.png", 4, 4, 1, std::vector<uint8_t>(16, 0));
    try {
        readMask((t / "black.png").string(), false);
        FAIL() << "no error";
    } catch (const MaskError& e) {
        EXPECT_NE(std::string(e.what()).find("is empty"), std::string::npos) << e.what();
    }
    EXPECT_EQ(readMask((t / "black.png").string(), true).count(), 16u);  // inverted: all inside
    std::ofstream(t / "junk.png") << "not a png";
    EXPECT_THROW(readMask((t / "junk.png").string(), false), MaskError);
}

// --- distance transforms ---------------------------------------------------------------------

TEST(MaskDistance, TransformsMatchBruteForce) {
    Rng rng(7);
    const int w = 23, h = 17;
    Mask m = makeMask(w, h, [&](double, double) { return rng.uniform() < 0.3; });
    m.on[5 * w + 5] = 1;
    const std::vector<double> d2 = squaredDistanceTransform(w, h, m.on);
    const std::vector<double> sd = signedDistancePixels(m);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double centres = 1e300, toIn = 1e300, toOut = 1e300;
            // Beyond the image is outside: the nearest such point is on the image's edge.
            toOut = std::min({x + 0.5, w - x - 0.5, y + 0.5, h - y - 0.5});
            for (int j = 0; j < h; ++j)
                for (int i = 0; i < w; ++i) {
                    // Distance from the centre to the closed pixel square (i, j).
                    const double dx = std::max(std::abs(i - x) - 0.5, 0.0);
                    const double dy = std::max(std::abs(j - y) - 0.5, 0.0);
                    const double square = std::sqrt(dx * dx + dy * dy);
                    if (m.at(i, j)) {
                        centres = std::min(centres, double((i - x) * (i - x) + (j - y) * (j - y)));
                        toIn = std::min(toIn, square);
                    } else {
                        toOut = std::min(toOut, square);
                    }
                }
            const size_t k = static_cast<size_t>(y) * w + x;
            EXPECT_DOUBLE_EQ(d2[k], centres) << x << "," << y;
            EXPECT_NEAR(sd[k], m.at(x, y) ? -toOut : toIn, 1e-12) << x << "," << y;
        }
    // No feature at all: infinitely far.
    const std::vector<double> none = squaredDistanceTransform(3, 2, std::vector<uint8_t>(6, 0));
    for (double v : none) EXPECT_TRUE(std::isinf(v));
}

// --- the fall-off ------------------------------------------------------------------------------

TEST(MaskFalloff, RadiusIsZeroDeepInsideAndGrowsWithOutsideNeighbours) {
    const MaskFalloff f;  // R = 10, k = 0.4
    EXPECT_EQ(falloffRadius(0, f), 0.0);
    for (int n = 1; n <= 25; ++n) EXPECT_GT(falloffRadius(n, f), falloffRadius(n - 1, f)) << n;
    EXPECT_LT(falloffRadius(25, f), 5.0);  // approaches R/2
    EXPECT_NEAR(falloffRadius(10, f), 10 * (1 / (1 + std::exp(-4.0)) - 0.5), 1e-12);
    MaskFalloff off;
    off.enabled = false;
    EXPECT_EQ(falloffRadius(10, off), 0.0);

    // n_x of a 20 × 20 square in a 30 × 30 image (columns and rows 5..24).
    const Mask m = squareMask(30, 5, 25);
    const std::vector<uint8_t> n = unmaskedNeighbourCounts(m);
    auto at = [&](int x, int y) { return n[static_cast<size_t>(y) * 30 + x]; };
    EXPECT_EQ(at(15, 15), 0);   // deep inside
    EXPECT_EQ(at(24, 15), 10);  // on the right edge: two outside columns of five
    EXPECT_EQ(at(23, 15), 5);   // one pixel in
    EXPECT_EQ(at(22, 15), 0);   // two in: the neighbourhood is all inside
    EXPECT_EQ(at(24, 24), 16);  // corner: 25 − 3·3
    EXPECT_EQ(at(0, 0), 25);    // far outside
}

// The density of soft-edged samples near a straight border of a box-shaped hull has a known
// profile: points of the outermost pixel column (n_x = 10) spread over balls of r0 = r_m(10),
// those one column in (n_x = 5) over r1 = r_m(5), deeper ones stay put, and spread points
// that leave are drawn again. The 1-D marginal of a uniform ball of radius r is
// 3/(4r)·(1 − (w/r)²), so relative to the deep inside the outermost pixel receives
//   E = ∫₀¹∫₀¹ f_r0(t − s) ds dt + ∫₀¹∫₁² f_r1(t − s) ds dt.
TEST(MaskFalloff, SamplesThinTowardTheBorderAsPredicted) {
    const int size = 60, lo = 10, hi = 50;  // a 40-pixel square, axis at column 30
    const double mpp = 0.05;
    auto hull = [&](bool soft) {
        MaskFalloff f;
        f.enabled = soft;
        std::vector<MaskView> views;
        for (double az : {0.0, 90.0}) views.push_back({squareMask(size, lo, hi), az, mpp, 30.0});
        return makeVisualHull(views, f);
    };
    const MaskFalloff f;
    const double r0 = falloffRadius(10, f), r1 = falloffRadius(5, f);
    auto marginal = [](double w, double r) {
        return std::abs(w) < r ? 0.75 / r * (1 - (w / r) * (w / r)) : 0.0;
    };
    double expected = 0.0;
    const int steps = 400;
    for (int i = 0; i < steps; ++i)
        for (int j = 0; j < steps; ++j) {
            const double t = (i + 0.5) / steps, s = (j + 0.5) / steps;
            expected += (marginal(t - s, r0) + marginal(t - (1 + s), r1)) / (steps * steps);
        }
    ASSERT_GT(expected, 0.25);
    ASSERT_LT(expected, 0.45);

    // Depths in pixels from the four side faces (x = ±1, z = ±1) and the top and bottom
    // (y = 0.5, 2.5). Count points in the outermost pixel of one side face and in a slab
    // 12 pixels in, both at least 8 pixels from every other face (clear of edges).
    for (bool soft : {true, false}) {
        SCOPED_TRACE(soft ? "soft edge" : "uniform");
        VolumePtr v = hull(soft);
        EXPECT_NEAR(v->measure(), 2.0 * 2.0 * 2.0, 1e-9);
        Rng rng(11);
        int shell = 0, deep = 0;
        for (int i = 0; i < 300000; ++i) {
            const Vec3 p = *v->sample(rng);
            const double d[6] = {(1 - p.x) / mpp, (p.x + 1) / mpp,   (1 - p.z) / mpp,
                                 (p.z + 1) / mpp, (2.5 - p.y) / mpp, (p.y - 0.5) / mpp};
            for (int face = 0; face < 4; ++face) {
                bool clear = true;
                for (int other = 0; other < 6; ++other) {
                    if (other != face && d[other] < 8) clear = false;
                }
                if (!clear) continue;
                if (d[face] < 1) ++shell;
                if (d[face] >= 12 && d[face] < 13) ++deep;
            }
        }
        const double ratio = double(shell) / deep;
        const double sigma = ratio * std::sqrt(1.0 / shell + 1.0 / deep);
        EXPECT_NEAR(ratio, soft ? expected : 1.0, 5 * sigma) << shell << " / " << deep;
    }
}

// --- visual hull ---------------------------------------------------------------------------------

// A disc of radius r seen from the front and the side: the intersection of two perpendicular
// cylinders, the Steinmetz solid of volume 16/3·r³.
TEST(VisualHull, DiscFromTwoSidesIsTheSteinmetzSolid) {
    const int size = 128;
    const double rPx = 60, mpp = 1.0 / 60, r = 1.0, cy = (size - 60) * mpp;
    const Mask disc = discMask(size, size, 64, 60, rPx);  // centre at row 60
    VolumePtr v = makeVisualHull({{disc, 0.0, mpp, 64.0}, {disc, 90.0, mpp, 64.0}}, {});
    EXPECT_NEAR(v->measure(), 16.0 / 3.0 * r * r * r, 0.02 * 16.0 / 3.0);
    const Aabb b = v->bounds();
    EXPECT_NEAR(b.lo.x, -r, 2 * mpp);
    EXPECT_NEAR(b.hi.z, r, 2 * mpp);
    EXPECT_NEAR(b.lo.y, cy - r, 2 * mpp);
    EXPECT_NEAR(b.hi.y, cy + r, 2 * mpp);
    Rng rng(3);
    int checked = 0;
    for (int i = 0; i < 20000; ++i) {
        const Vec3 p = rng.inBox({{-1.2, cy - 1.2, -1.2}, {1.2, cy + 1.2, 1.2}});
        const double dy = p.y - cy;
        const double a = std::sqrt(p.x * p.x + dy * dy), c = std::sqrt(p.z * p.z + dy * dy);
        const double margin = 2 * mpp;
        const bool surely = a < r - margin && c < r - margin;
        const bool surelyNot = a > r + margin || c > r + margin;
        if (!surely && !surelyNot) continue;
        ++checked;
        EXPECT_EQ(v->inside(p), surely) << p.x << " " << p.y << " " << p.z;
        EXPECT_EQ(v->signedDistance(p) <= 0, v->inside(p));
    }
    EXPECT_GT(checked, 15000);
}

// Two square masks give a box: its exact distance checks the hull's signed distance, which
// must have the exact sign, never exceed the true distance, and be exact to a pixel for inside
// points and for outside points facing one face.
TEST(VisualHull, SignedDistanceIsConservativeWithExactSign) {
    const double mpp = 0.05;
    VolumePtr v = makeVisualHull(
        {{squareMask(60, 10, 50), 0.0, mpp, 30.0}, {squareMask(60, 10, 50), 90.0, mpp, 30.0}}, {});
    VolumePtr box = makePlaced(makeBox({2, 2, 2}), {{0, 1.5, 0}, {0, 1, 0}, {1, 1, 1}});
    Rng rng(5);
    for (int i = 0; i < 20000; ++i) {
        const Vec3 p = rng.inBox({{-2, -0.5, -2}, {2, 3.5, 2}});
        const double truth = box->signedDistance(p), s = v->signedDistance(p);
        const Vec3 q = vabs(p - Vec3{0, 1.5, 0});
        const int outsideAxes = (q.x > 1) + (q.y > 1) + (q.z > 1);
        if (std::abs(truth) < 1e-9) continue;
        EXPECT_EQ(s <= 0, truth < 0) << p.x << " " << p.y << " " << p.z;
        EXPECT_LE(std::abs(s), std::abs(truth) + 1e-9);
        if (truth < 0 || outsideAxes == 1) {
            EXPECT_NEAR(s, truth, mpp) << p.x << " " << p.y << " " << p.z;
        }
    }
    // Far outside the images: still a positive, conservative distance.
    EXPECT_GT(v->signedDistance({40, 1.5, 0}), 30.0);
    EXPECT_LE(v->signedDistance({40, 1.5, 0}), 39.0 + 1e-9);
}

// Azimuth convention: at 0° the image's right is +x; at 90° it is −z.
TEST(VisualHull, ViewsFaceTheirAzimuths) {
    const Mask rightHalf = makeMask(40, 20, [](double x, double) { return x > 20; });
    const Mask full = makeMask(40, 20, [](double, double) { return true; });
    VolumePtr a = makeVisualHull({{rightHalf, 0.0, 0.1, 20.0}, {full, 90.0, 0.1, 20.0}}, {});
    EXPECT_TRUE(a->inside({1, 1, 1}));
    EXPECT_TRUE(a->inside({1, 1, -1}));
    EXPECT_FALSE(a->inside({-1, 1, 0}));
    EXPECT_NEAR(a->measure(), 2 * 4 * 2, 1e-9);
    VolumePtr b = makeVisualHull({{full, 0.0, 0.1, 20.0}, {rightHalf, 90.0, 0.1, 20.0}}, {});
    EXPECT_TRUE(b->inside({1, 1, -1}));
    EXPECT_FALSE(b->inside({1, 1, 1}));
    EXPECT_FALSE(b->inside({0, 2.05, -1}));   // above the top row
    EXPECT_FALSE(b->inside({0, -0.05, -1}));  // below the bottom
    // A third, oblique view: the measure stays exact (a box cut by a 45° strip).
    const Mask narrow = makeMask(40, 20, [](double x, double) { return std::abs(x - 20) < 10; });
    VolumePtr c = makeVisualHull(
        {{full, 0.0, 0.1, 20.0}, {full, 90.0, 0.1, 20.0}, {narrow, 45.0, 0.1, 20.0}}, {});
    // The square [−2, 2]² cut to |x − z| < √2 loses two corner triangles with legs 4 − √2.
    EXPECT_NEAR(c->measure(), (16 - (4 - std::sqrt(2.0)) * (4 - std::sqrt(2.0))) * 2, 1e-9);
}

TEST(VisualHull, EveryDrawLiesInsideAndDrawsAreDeterministic) {
    const Mask disc = discMask(64, 64, 32, 30, 25);
    const Mask blob = makeMask(64, 64, [](double x, double y) {
        return std::abs(x - 32) < 12 + 6 * std::sin(y / 5) && y > 4 && y < 58;
    });
    for (bool soft : {true, false}) {
        MaskFalloff f;
        f.enabled = soft;
        VolumePtr v = makeVisualHull(
            {{disc, 0.0, 0.05, 32.0}, {blob, 90.0, 0.05, 32.0}, {disc, 30.0, 0.05, 32.0}}, f);
        Rng rng(1), again(1);
        for (int i = 0; i < 5000; ++i) {
            const std::optional<Vec3> p = v->sample(rng);
            ASSERT_TRUE(p);
            EXPECT_TRUE(v->inside(*p));
            EXPECT_TRUE(v->bounds().contains(*p));
            const Vec3 q = *v->sample(again);
            EXPECT_TRUE(p->x == q.x && p->y == q.y && p->z == q.z);
        }
    }
}

TEST(VisualHull, DegenerateInputs) {
    const Mask disc = discMask(32, 32, 16, 16, 10);
    EXPECT_THROW(makeVisualHull({{disc, 0.0, 0.1, 16.0}}, {}), MaskError);
    EXPECT_THROW(makeVisualHull({{disc, 0.0, 0.1, 16.0}, {disc, 180.0, 0.1, 16.0}}, {}), MaskError);
    // Masks whose rows never overlap in height: an empty hull.
    const Mask top = makeMask(32, 32, [](double, double y) { return y < 10; });
    const Mask bottom = makeMask(32, 32, [](double, double y) { return y > 20; });
    VolumePtr v = makeVisualHull({{top, 0.0, 0.1, 16.0}, {bottom, 90.0, 0.1, 16.0}}, {});
    EXPECT_EQ(v->measure(), 0.0);
    EXPECT_TRUE(v->bounds().empty());
    Rng rng(1);
    EXPECT_FALSE(v->sample(rng, 10));
}

// --- mask revolution ---------------------------------------------------------------------------

TEST(MaskRevolution, HalfProfileOfASquareAndItsSides) {
    // Inside columns 12..15 and rows 2..7 of a 20 × 10 mask; axis at column 10.
    const Mask m =
        makeMask(20, 10, [](double x, double y) { return x > 12 && x < 16 && y > 2 && y < 8; });
    const std::vector<Vec2> s = maskHalfProfile(m, 10.0, ProfileSide::kRight, 0.5);
    ASSERT_EQ(s.size(), 2u + 6u + 2u);
    EXPECT_EQ(s.front(), Vec2(0.0, 1.0));        // on the axis at the bottom edge of row 7
    EXPECT_EQ(s[1], Vec2(3.0, 1.0));             // farthest edge: column 16, 6 px from the axis
    EXPECT_EQ(s[2], Vec2(3.0, 1.25));            // row 7's centre
    EXPECT_EQ(s[s.size() - 2], Vec2(3.0, 4.0));  // top edge of row 2
    EXPECT_EQ(s.back(), Vec2(0.0, 4.0));
    EXPECT_EQ(maskHalfProfile(m, 10.0, ProfileSide::kMax, 0.5)[1], Vec2(3.0, 1.0));
    EXPECT_THROW(maskHalfProfile(m, 10.0, ProfileSide::kLeft, 0.5), MaskError);
    // Axis inside the pixels: the left side reaches the farthest left edge.
    EXPECT_EQ(maskHalfProfile(m, 14.0, ProfileSide::kLeft, 1.0)[1], Vec2(2.0, 2.0));
    EXPECT_EQ(maskHalfProfile(m, 14.0, ProfileSide::kRight, 1.0)[1], Vec2(2.0, 2.0));
}

// A disc revolved about its centre column is a sphere.
TEST(MaskRevolution, RevolvedDiscIsASphere) {
    const double mpp = 1.0 / 40, r = 1.0, cy = 1.25;  // disc of 40 px, centre 50 px up
    const Mask disc = discMask(100, 100, 50, 50, 40);
    MaskRevolutionOptions o;
    o.metresPerPixel = mpp;
    o.voxelSize = 0.03;
    VolumePtr v = makeMaskRevolution(disc, o);
    EXPECT_NEAR(v->measure(), 4.0 / 3.0 * kPi * r * r * r, 0.02 * 4.0 / 3.0 * kPi);
    Rng rng(9);
    int checked = 0;
    for (int i = 0; i < 20000; ++i) {
        const Vec3 p = rng.inBox({{-1.2, cy - 1.2, -1.2}, {1.2, cy + 1.2, 1.2}});
        const double d = length(p - Vec3{0, cy, 0}) - r;
        if (std::abs(d) < 0.06) continue;  // two pixels and the level set's voxel
        ++checked;
        EXPECT_EQ(v->inside(p), d < 0) << p.x << " " << p.y << " " << p.z;
    }
    EXPECT_GT(checked, 15000);
    // Only the right half, revolved from its own side, is the same sphere.
    Mask half = disc;
    for (int y = 0; y < 100; ++y)
        for (int x = 0; x < 50; ++x) half.on[y * 100 + x] = 0;
    o.side = ProfileSide::kRight;
    VolumePtr w = makeMaskRevolution(half, o);
    EXPECT_NEAR(w->measure(), v->measure(), 1e-9 * v->measure());
    o.side = ProfileSide::kLeft;
    EXPECT_THROW(makeMaskRevolution(half, o), MaskError);
}

// The fall-off reaches the revolved volume's draws: within 1.5 px of the sphere's surface a
// uniform draw lands with probability 1 − (1 − 1.5/40)³ ≈ 0.108; soft-edged draws land there
// far less often (the visual-hull test above pins the exact profile).
TEST(MaskRevolution, SoftEdgedDrawsThinAtTheSurface) {
    const double mpp = 1.0 / 40, cy = 1.25;
    const Mask disc = discMask(100, 100, 50, 50, 40);
    const double uniform = 1 - std::pow(1 - 1.5 / 40, 3);
    for (bool soft : {false, true}) {
        SCOPED_TRACE(soft ? "soft edge" : "uniform");
        MaskRevolutionOptions o;
        o.metresPerPixel = mpp;
        o.voxelSize = 0.03;
        o.falloff.enabled = soft;
        VolumePtr v = makeMaskRevolution(disc, o);
        Rng rng(4);
        const int n = 20000;
        int near = 0;
        for (int i = 0; i < n; ++i) {
            const Vec3 p = *v->sample(rng);
            if (length(p - Vec3{0, cy, 0}) > 1.0 - 1.5 * mpp) ++near;
        }
        const double fraction = double(near) / n;
        if (soft) {
            EXPECT_LT(fraction, 0.6 * uniform);
        } else {
            EXPECT_NEAR(fraction, uniform, 0.15 * uniform);
        }
    }
}

TEST(MaskRevolution, EveryDrawLiesInside) {
    // A crown on a trunk: a disc over a narrow column.
    const Mask tree = makeMask(80, 100, [](double x, double y) {
        return (x - 40) * (x - 40) + (y - 40) * (y - 40) < 30 * 30 ||
               (std::abs(x - 40) < 4 && y > 40);
    });
    for (bool soft : {true, false}) {
        MaskRevolutionOptions o;
        o.metresPerPixel = 0.05;
        o.voxelSize = 0.08;
        o.falloff.enabled = soft;
        VolumePtr v = makeMaskRevolution(tree, o);
        Rng rng(2);
        for (int i = 0; i < 3000; ++i) {
            const std::optional<Vec3> p = v->sample(rng);
            ASSERT_TRUE(p);
            EXPECT_TRUE(v->inside(*p));
        }
        EXPECT_TRUE(v->inside({0, 0.5, 0}));   // the trunk
        EXPECT_FALSE(v->inside({1, 0.5, 0}));  // beside it
    }
}

// --- spec readers -------------------------------------------------------------------------------

TEST(MaskSpec, ReadersResolveFilesAndReportErrorsAtTheirKeys) {
    TempDir t;
    std::vector<uint8_t> px(64 * 64);
    const Mask disc = discMask(64, 64, 32, 32, 30);
    for (size_t i = 0; i < px.size(); ++i) px[i] = disc.on[i] ? 0 : 255;  // black on white
    writeImage(t / "disc.png", 64, 64, 1, px);
    writeImage(t / "black.png", 8, 8, 1, std::vector<uint8_t>(64, 0));
    std::vector<uint8_t> foot(64 * 64, 0);  // only the two bottom rows, below the disc
    std::fill(foot.end() - 128, foot.end(), 255);
    writeImage(t / "foot.png", 64, 64, 1, foot);
    const fs::path spec = t / "s.toml";

    VolumePtr hull = parseCrown(
        "type = \"visual-hull\"\n"
        "views = [ { mask = \"disc.png\", azimuth_deg = 0, invert = true },\n"
        "          { mask = \"disc.png\", azimuth_deg = 90, invert = true } ]\n"
        "height = 3.2\n",
        spec);
    const double r = 30 * 0.05;
    EXPECT_NEAR(hull->measure(), 16.0 / 3.0 * r * r * r, 0.03 * 16.0 / 3.0 * r * r * r);

    VolumePtr rev = parseCrown(
        "type = \"mask-revolution\"\nmask = \"disc.png\"\ninvert = true\nmetres_per_pixel = "
        "0.05\nsoft_edge = false\n",
        spec);
    EXPECT_NEAR(rev->measure(), 4.0 / 3.0 * kPi * r * r * r, 0.03 * 4.0 / 3.0 * kPi * r * r * r);

    auto expectError = [&](const std::string& text, const std::string& where,
                           const std::string& what) {
        try {
            parseCrown(text, spec);
            ADD_FAILURE() << "no error for " << text;
        } catch (const SpecError& e) {
            const std::string m = e.what();
            EXPECT_NE(m.find(where), std::string::npos) << m;
            EXPECT_NE(m.find(what), std::string::npos) << m;
            EXPECT_EQ(m.find('\n'), std::string::npos) << m;
        }
    };
    expectError(
        "type = \"visual-hull\"\nviews = [ { mask = \"disc.png\", azimuth_deg = 0 } ]\n"
        "height = 3\n",
        "s.toml:2:", "at least two views");
    expectError(
        "type = \"visual-hull\"\nheight = 3\nviews = [\n"
        "  { mask = \"disc.png\", azimuth_deg = 0 },\n"
        "  { mask = \"nothere.png\", azimuth_deg = 90 } ]\n",
        "crown.views[1].mask", "file not found");
    expectError(
        "type = \"visual-hull\"\nheight = 3\nviews = [\n"
        "  { mask = \"disc.png\", azimuth_deg = 0, invert = true },\n"
        "  { mask = \"black.png\", azimuth_deg = 90 } ]\n",
        "s.toml:5:", "is empty");
    expectError(
        "type = \"visual-hull\"\nheight = 3\nviews = [\n"
        "  { mask = \"disc.png\", azimuth_deg = 0, invert = true },\n"
        "  { mask = \"disc.png\", azimuth_deg = 90, invret = true } ]\n",
        "crown.views[1].invret", "did you mean \"invert\"");
    expectError(
        "type = \"visual-hull\"\nheight = 3\nviews = [\n"
        "  { mask = \"disc.png\", azimuth_deg = 0, invert = true },\n"
        "  { mask = \"foot.png\", azimuth_deg = 90 } ]\n",
        "crown.views", "the volume is empty");
    expectError("type = \"mask-revolution\"\nmask = \"black.png\"\nheight = 3\n",
                "s.toml:2:", "is empty");
    expectError("type = \"mask-revolution\"\nmask = \"disc.png\"\n", "crown", "expected height");
    expectError(
        "type = \"mask-revolution\"\nmask = \"disc.png\"\nheight = 3\n"
        "metres_per_pixel = 0.1\n",
        "s.toml:4:", "not both");
    expectError("type = \"mask-revolution\"\nmask = \"disc.png\"\nheight = 3\nside = \"up\"\n",
                "crown.side", "\"right\"");
}

}  // namespace
}  // namespace sylva
