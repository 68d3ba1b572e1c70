// The colour renderer: registered with the mask, known radiance under a known light, shadows,
// light through leaves, and the same bytes on any thread count.
#include "pipeline/render/colour_render.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "species/geometry/leaf_mesh.h"
#include "species/geometry/tube_mesh.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

// A library tree's views: grown once for the tests below.
struct Grown {
    Tree tree;
    Mesh wood, leaves;
    std::vector<int32_t> nodes;
    std::vector<Camera> cameras;
    std::vector<ViewImage> views;
    Look look;
};

const Grown& hawthorn() {
    static const Grown g = [] {
        Grown out;
        const SpeciesFile sp =
            loadSpecies(std::string(SYLVA_SOURCE_DIR) + "/species/presets/hawthorn.toml");
        out.tree = growSpecies(sp, 11, nullptr, false).tree;
        out.look = *sp.look;
        out.wood = tubeMesh(out.tree, TubeOptions{}, &out.nodes);
        out.leaves = leafMesh(out.tree);
        ViewOptions vo;
        vo.count = 3;
        vo.width = vo.height = 160;
        vo.elevationsDeg = {-10, 20, 60};
        Rng rng(5);
        out.cameras = makeCameras(out.tree, vo, rng);
        for (const Camera& c : out.cameras) {
            out.views.push_back(renderView(out.tree, out.wood, out.nodes, c, false, false));
        }
        return out;
    }();
    return g;
}

// The registration the colour images promise (colour_render.h): alpha 255 only on the mask,
// alpha > 0 on every mask pixel, partial alpha only on the mask or next to it; and no centre
// ray that Embree and the rasteriser decide differently.
TEST(ColourViews, EveryColourImageIsRegisteredWithItsMask) {
    const Grown& g = hawthorn();
    const ColourScene scene(g.tree, g.wood, g.leaves, g.look, 11);
    ColourOptions o;
    o.enabled = true;
    for (size_t k = 0; k < g.cameras.size(); ++k) {
        const ViewImage& v = g.views[k];
        const ColourImage img = scene.render(g.cameras[k], v, o, Rng(3).derive(k));
        ASSERT_EQ(img.rgba.size(), size_t(4) * v.width * v.height);
        auto mask = [&](int x, int y) {
            return x >= 0 && y >= 0 && x < v.width && y < v.height &&
                   v.silhouette[size_t(y) * v.width + x] != 0;
        };
        int64_t tree = 0, full = 0, partial = 0, partialOutside = 0;
        for (int y = 0; y < v.height; ++y) {
            for (int x = 0; x < v.width; ++x) {
                const uint8_t a = img.rgba[4 * (size_t(y) * v.width + x) + 3];
                const bool m = mask(x, y);
                tree += m;
                if (a == 255) {
                    ++full;
                    EXPECT_TRUE(m) << "view " << k << " pixel " << x << "," << y;
                }
                if (m) {
                    EXPECT_GT(a, 0) << "view " << k << " pixel " << x << "," << y;
                }
                if (a > 0 && a < 255) {
                    ++partial;
                    bool touches = false;
                    for (int dy = -1; dy <= 1; ++dy) {
                        for (int dx = -1; dx <= 1; ++dx) touches = touches || mask(x + dx, y + dy);
                    }
                    partialOutside += !touches;
                }
            }
        }
        EXPECT_GT(tree, 500) << "the tree fills part of the view";
        EXPECT_GT(full, tree / 4) << "most tree pixels are fully covered";
        EXPECT_GT(partial, 50) << "edges are anti-aliased";
        EXPECT_EQ(partialOutside, 0);
        EXPECT_LE(img.centreMisses, tree / 1000) << "Embree and the rasteriser agree on centres";
    }
}

// Each on a scene of its own, so that the light the scene keeps for its views (the near sky
// per leaf and wood vertex) is found afresh on one thread and on many.
TEST(ColourViews, TheSameBytesOnOneThreadAndOnMany) {
    const Grown& g = hawthorn();
    ColourOptions o;
    o.background = ColourBackground::kSky;
    std::vector<uint8_t> one, many;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        const ColourScene scene(g.tree, g.wood, g.leaves, g.look, 11);
        one = scene.render(g.cameras[1], g.views[1], o, Rng(9)).rgba;
    }
    const ColourScene scene(g.tree, g.wood, g.leaves, g.look, 11);
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 8);
        many = scene.render(g.cameras[1], g.views[1], o, Rng(9)).rgba;
    }
    EXPECT_EQ(one, many);
    // Another view stream: another light.
    const ColourImage other = scene.render(g.cameras[1], g.views[1], o, Rng(10));
    EXPECT_NE(other.rgba, one);
}

// What a scene keeps for its views is a property of the leaves and vertices alone: a view is the
// same bytes whether the scene rendered others before it or not.
TEST(ColourViews, AViewIsTheSameWhateverViewsCameBefore) {
    const Grown& g = hawthorn();
    ColourOptions o;
    const ColourScene fresh(g.tree, g.wood, g.leaves, g.look, 11);
    const std::vector<uint8_t> alone = fresh.render(g.cameras[2], g.views[2], o, Rng(4)).rgba;
    const ColourScene used(g.tree, g.wood, g.leaves, g.look, 11);
    for (int k : {0, 1}) (void)used.render(g.cameras[k], g.views[k], o, Rng(k));
    EXPECT_EQ(used.render(g.cameras[2], g.views[2], o, Rng(4)).rgba, alone);
}

// A horizontal square leaf (normal +y) 1 m across, at y = 1 over a short stub of wood, seen by
// an orthographic camera from straight above or straight below, the sun at the zenith.
struct Card {
    Tree tree;
    Mesh wood, leaves;
    std::vector<int32_t> nodes;
};

// Square leaves (normal +y) at (x, y, 0), `size` metres across.
struct CardLeaf {
    double x = 0, y = 1, size = 1;
};

Card cards(const std::vector<CardLeaf>& leaves) {
    Card c;
    addNode(c.tree, -1, {3, 0, 3}, 0.01);
    addNode(c.tree, 0, {3, 0.05, 3}, 0.01);
    for (const CardLeaf& l : leaves) {
        Leaf leaf;
        leaf.position = {l.x, l.y, 0};
        leaf.normal = {0, 1, 0};
        leaf.tangent = {1, 0, 0};
        leaf.size = l.size;
        leaf.aspect = 1.0;
        leaf.colour = 2;
        c.tree.leaves.push_back(leaf);
    }
    c.wood = tubeMesh(c.tree, TubeOptions{}, &c.nodes);
    c.leaves = leafMesh(c.tree);
    return c;
}

Card card(std::vector<double> heights) {
    std::vector<CardLeaf> leaves;
    for (double h : heights) leaves.push_back({0.0, h, 1.0});
    return cards(leaves);
}

Camera orthoCamera(bool fromAbove) {
    Camera cam;
    cam.width = cam.height = 64;
    cam.orthographic = true;
    cam.orthoHeight = 2.0;
    const double s = fromAbove ? 1.0 : -1.0;
    // Columns: right (1, 0, 0); up (0, 0, −s); back (0, s, 0) (looking along −back); eye.
    const double m[4][4] = {{1, 0, 0, 0}, {0, 0, s, 5 * s}, {0, -s, 0, 0}, {0, 0, 0, 1}};
    std::memcpy(cam.cameraToWorld, m, sizeof m);
    return cam;
}

ColourOptions zenithSun() {
    ColourOptions o;
    o.enabled = true;
    o.aoRays = 0;  // no sky light: the sun alone
    o.sunElevationDeg[0] = o.sunElevationDeg[1] = 90;
    o.exposureEv[0] = o.exposureEv[1] = 0;
    o.autoExposure = false;  // the light as it is
    o.samples = 1;
    return o;
}

Look matte() {
    Look l;
    l.leafVariation = 0;
    l.leafSpecular = 0;
    l.leafTranslucency = 0.4;
    LinearRgb grey;
    parseHexColour("#c0b8a8", grey);  // light: an 8-bit step is ≈ 0.5 % of its linear value
    l.leaf.assign(3, grey);
    return l;
}

// The centre pixel's colour, linear.
LinearRgb centre(const ColourImage& img) {
    const size_t i = 4 * (size_t(img.height / 2) * img.width + img.width / 2);
    return {float(srgbToLinear(img.rgba[i] / 255.0)), float(srgbToLinear(img.rgba[i + 1] / 255.0)),
            float(srgbToLinear(img.rgba[i + 2] / 255.0))};
}

// Lambert under the sun: radiance = albedo · E / π, E = π · 0.95 · (1, 0.96, 0.90) at normal
// incidence (colour_render.cpp's daylight), so the leaf shows 0.95 × its albedo × the sun's tint;
// its underside, lit through the leaf, 0.4 of that of the underside's colour.
TEST(ColourViews, ALeafUnderAZenithSunShowsItsAlbedoAndPassesLightThrough) {
    const Card c = card({1.0});
    const Look look = matte();
    const ColourScene scene(c.tree, c.wood, c.leaves, look, 1);
    for (bool above : {true, false}) {
        const Camera cam = orthoCamera(above);
        const ViewImage v = renderView(c.tree, c.wood, c.nodes, cam, false, false);
        ASSERT_NE(v.silhouette[size_t(32) * 64 + 32], 0);
        const ColourImage img = scene.render(cam, v, zenithSun(), Rng(1));
        EXPECT_NEAR(img.light.sunDirection.y, 1.0, 1e-12);
        const LinearRgb seen = centre(img);
        const LinearRgb albedo = above ? look.leafFront(2) : look.leafUnderside(2);
        const double k = 0.95 * (above ? 1.0 : 0.4);
        // 8-bit sRGB: half a step is ≈ 0.3 % of these linear values (≤ 0.003).
        EXPECT_NEAR(seen.r, k * albedo.r * 1.00, 0.003) << above;
        EXPECT_NEAR(seen.g, k * albedo.g * 0.96, 0.003) << above;
        EXPECT_NEAR(seen.b, k * albedo.b * 0.90, 0.003) << above;
    }
}

// A second leaf above the first hides the sun: seen from below, the lower leaf's underside would
// get light only through both leaves, and shadow rays stop at the first leaf — black without
// the sky; alone, the same leaf passes the sun's light.
TEST(ColourViews, ALeafInTheShadowOfAnotherGetsNoSun) {
    const Card lit = card({1.0});
    const Card shaded = card({1.0, 1.5});
    const Camera cam = orthoCamera(false);
    for (const Card* c : {&lit, &shaded}) {
        const ColourScene scene(c->tree, c->wood, c->leaves, matte(), 1);
        const ViewImage v = renderView(c->tree, c->wood, c->nodes, cam, false, false);
        const LinearRgb seen = centre(scene.render(cam, v, zenithSun(), Rng(1)));
        if (c == &lit) {
            EXPECT_GT(seen.g, 0.02);
        } else {
            EXPECT_EQ(seen.r + seen.g + seen.b, 0.0f);
        }
    }
}

// A small leaf (corners within 15 cm of its centre) is lit as one: its centre decides. A
// square leaf 0.2 m across at y = 1 under a zenith sun, seen from below (the sun through it),
// with a large leaf 0.5 m above that shades its centre and its half at x < 0.05 m: every pixel
// of the small leaf is dark, those at x > 0.05 m too, which a leaf lit point by point would show
// in the sun. With the large leaf moved off its centre (shading x < −0.05 m only), all of it is
// lit.
TEST(ColourViews, ASmallLeafIsLitAsOne) {
    auto scene = [](double blockerX) { return cards({{0.0, 1.0, 0.2}, {blockerX, 1.5, 1.0}}); };
    const Camera cam = orthoCamera(false);  // 64 px over 2 m: 3.125 cm a pixel, x right
    auto green = [&](const Card& c, int px) {
        const ColourScene s(c.tree, c.wood, c.leaves, matte(), 1);
        const ViewImage v = renderView(c.tree, c.wood, c.nodes, cam, false, false);
        const ColourImage img = s.render(cam, v, zenithSun(), Rng(1));
        return srgbToLinear(img.rgba[4 * (size_t(32) * 64 + px) + 1] / 255.0);
    };
    const Card shadedCentre = scene(-0.45), litCentre = scene(-0.55);
    // Pixel centres on the small leaf: 29 at x = −0.078 m, 32 at 0.016, 34 at 0.078.
    for (int px : {29, 32, 34}) {
        EXPECT_EQ(green(shadedCentre, px), 0.0) << px;
        EXPECT_GT(green(litCentre, px), 0.02) << px;
    }
}

}  // namespace
}  // namespace sylva

namespace sylva {
namespace {

// The sky light as the renderer estimates it (the sky grid and 4 near rays) against 256 rays
// cast to infinity, at 300 points on a hawthorn's leaves and wood: close in the mean and better
// correlated than 4 rays to infinity (the estimate it replaced); the grid without its near rays
// is too bright, and its near rays without the grid far too bright.
TEST(ColourViews, TheSkyGridAgreesWithTracedSkyLight) {
    const Grown& g = hawthorn();
    const ColourScene scene(g.tree, g.wood, g.leaves, g.look, 11);
    Rng rng(7);
    struct Sums {
        double a = 0, b = 0, aa = 0, bb = 0, ab = 0;
        int n = 0;
        void add(double x, double y) { a += x, b += y, aa += x * x, bb += y * y, ab += x * y, ++n; }
        double meanRatio() const { return b / a; }
        double correlation() const {
            const double ma = a / n, mb = b / n;
            return (ab / n - ma * mb) / std::sqrt((aa / n - ma * ma) * (bb / n - mb * mb));
        }
    };
    Sums grid, fourRays, gridAlone;
    for (int i = 0; i < 300; ++i) {
        const Mesh& m = i % 3 ? g.leaves : g.wood;
        const size_t t = rng.below(m.triangleCount());
        auto v = [&](int c) {
            const uint32_t k = m.indices[3 * t + c];
            return Vec3{m.positions[3 * k], m.positions[3 * k + 1], m.positions[3 * k + 2]};
        };
        const Vec3 n = normalize(cross(v(1) - v(0), v(2) - v(0)));
        const Vec3 p = (v(0) + v(1) + v(2)) / 3.0 + n * 1e-3;
        const double traced = scene.skyViewTraced(p, n, 256, rng);
        grid.add(traced, scene.skyView(p, n, 4, rng));
        fourRays.add(traced, scene.skyViewTraced(p, n, 4, rng));
        gridAlone.add(traced, scene.skyView(p, n, 0, rng));
    }
    EXPECT_NEAR(grid.meanRatio(), 1.0, 0.12);
    EXPECT_GT(grid.correlation(), 0.82);
    EXPECT_GT(grid.correlation(), fourRays.correlation() + 0.04);
    EXPECT_GT(gridAlone.meanRatio(), 1.1);
    EXPECT_NEAR(fourRays.meanRatio(), 1.0, 0.12);  // the check itself: 4 rays are unbiased
}

// colour_lighting = "none": every surface shows its own colour, whatever the light.
TEST(ColourViews, UnlitPicturesShowTheAlbedo) {
    const Card c = card({1.0});
    Look look = matte();
    const ColourScene scene(c.tree, c.wood, c.leaves, look, 1);
    ColourOptions o = zenithSun();
    o.unlit = true;
    o.exposureEv[0] = o.exposureEv[1] = 1.5;  // ignored
    for (bool above : {true, false}) {
        const Camera cam = orthoCamera(above);
        const ViewImage v = renderView(c.tree, c.wood, c.nodes, cam, false, false);
        const ColourImage img = scene.render(cam, v, o, Rng(1));
        const size_t i = 4 * (size_t(32) * 64 + 32);
        const LinearRgb a = above ? look.leafFront(2) : look.leafUnderside(2);
        EXPECT_EQ(img.rgba[i], std::lround(linearToSrgb(a.r) * 255)) << above;
        EXPECT_EQ(img.rgba[i + 1], std::lround(linearToSrgb(a.g) * 255)) << above;
        EXPECT_EQ(img.rgba[i + 2], std::lround(linearToSrgb(a.b) * 255)) << above;
    }
}

}  // namespace
}  // namespace sylva
