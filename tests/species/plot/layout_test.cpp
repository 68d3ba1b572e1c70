// Plot terrains and layouts (species/plot/terrain.h, layout.h): stems stand exactly on the
// terrain, whose heights match the slope, noise and DEM they were made from; the species mix
// and ids; the same seed gives the same layout.
#include "species/plot/layout.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

#include "pipeline/batch/dataset.h"
#include "species/plot/point_process.h"
#include "species/plot/terrain.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

const std::string kPlotData = std::string(SYLVA_SOURCE_DIR) + "/tests/data/plot/";

const PlotSpec& plotNamed(const DatasetSpec& d, const std::string& name) {
    for (const PlotSpec& p : d.plots)
        if (p.name == name) return p;
    throw std::runtime_error("no plot " + name);
}

// Every stem base is on the terrain: y is the terrain's height at (x, z), exactly.
void expectOnTerrain(const PlotLayout& l) {
    for (const PlotStem& s : l.stems) {
        ASSERT_EQ(s.base.y, l.terrain.height(s.base.x, s.base.z)) << s.id;
    }
}

// The grid covers the area and its margin on every side, centred.
TEST(TerrainGrid, CoversAreaAndMargin) {
    PlotArea a;
    a.width = 40;
    a.depth = 30;
    const TerrainGrid g = terrainGrid(a, 4, 0.5);
    EXPECT_EQ(g.nx, 97);  // 48 m / 0.5 + 1
    EXPECT_EQ(g.nz, 77);
    EXPECT_DOUBLE_EQ(g.x0, -24);
    EXPECT_DOUBLE_EQ(g.z0, -19);
    const DemPixels need = demPixelsNeeded(g, 0.5, 0.25);
    EXPECT_EQ(need.width, 193);
    EXPECT_EQ(need.height, 153);
}

// A slope of 15° facing east (+x): the heightfield is the plane h = −tan 15° · x at every
// sample (float precision), and each stem stands on it.
TEST(PlotLayout, StemsOnTheSlope) {
    const DatasetSpec d = loadDataset(kPlotData + "plots.toml");
    const PlotSpec& spec = plotNamed(d, "mixed-slope");
    ASSERT_EQ(spec.terrain.kind, TerrainOptions::Kind::kSlope);
    const PlotLayout l = layoutPlot(spec, 1234);
    ASSERT_FALSE(l.stems.empty());
    expectOnTerrain(l);
    const double t = std::tan(15 * kPi / 180);
    for (const PlotStem& s : l.stems) {
        EXPECT_NEAR(s.base.y, -t * s.base.x, 1e-4) << s.id;
        EXPECT_TRUE(spec.area.contains(s.base.x, s.base.z));
    }
    EXPECT_NEAR(slopeHeight(spec.terrain, 10, 3), -t * 10, 1e-12);
}

// Smooth noise: within ±amplitude, the heightfield interpolates noiseHeight (the difference is
// the bilinear error of a surface with 25 m features on a 1 m grid), stems stand on it, and
// another seed makes another surface.
TEST(PlotLayout, StemsOnTheNoise) {
    const DatasetSpec d = loadDataset(kPlotData + "plots.toml");
    const PlotSpec& spec = plotNamed(d, "round-noise");
    const PlotLayout l = layoutPlot(spec, 99);
    expectOnTerrain(l);
    const TerrainOptions& o = spec.terrain;
    double spread = 0;
    for (const float h : l.terrain.heights()) {
        EXPECT_LE(std::abs(h), o.amplitude + 1e-6);
        spread = std::max(spread, std::abs(double(h)));
    }
    EXPECT_GT(spread, 0.3 * o.amplitude);  // not flat
    for (const PlotStem& s : l.stems) {
        EXPECT_NEAR(s.base.y, noiseHeight(o, 99, s.base.x, s.base.z), 0.05 * o.amplitude) << s.id;
    }
    EXPECT_NE(noiseHeight(o, 99, 3.3, 4.4), noiseHeight(o, 100, 3.3, 4.4));
    EXPECT_EQ(noiseHeight(o, 99, 3.3, 4.4), noiseHeight(o, 99, 3.3, 4.4));
}

// The DEM fixture (dem_plane.png, 64 × 56 pixels of 16-bit value 1000 + 40·column + 25·row,
// centred on the plot at 0.5 m per pixel, heights 0.01 × value − 20 m): the terrain is that
// plane — x runs along columns, z along rows — and every stem stands on it.
TEST(PlotLayout, StemsOnTheDem) {
    const DatasetSpec d = loadDataset(kPlotData + "dem.toml");
    ASSERT_EQ(d.plots.size(), 1u);
    EXPECT_TRUE(d.species.empty());
    const PlotSpec& spec = d.plots[0];
    auto analytic = [](double x, double z) {
        const double column = x / 0.5 + 31.5, row = z / 0.5 + 27.5;
        return 0.01 * (1000 + 40 * column + 25 * row) - 20;
    };
    const PlotLayout l = layoutPlot(spec, 5);
    ASSERT_EQ(l.stems.size(), 30u);
    expectOnTerrain(l);
    for (const PlotStem& s : l.stems) {
        EXPECT_NEAR(s.base.y, analytic(s.base.x, s.base.z), 1e-3) << s.id;
    }
    // Corners of the grid (the area and its 2 m margin).
    EXPECT_NEAR(l.terrain.height(-12, -12), analytic(-12, -12), 1e-3);
    EXPECT_NEAR(l.terrain.height(12, 12), analytic(12, 12), 1e-3);
    EXPECT_NEAR(analytic(0, 0), 0.01 * (1000 + 40 * 31.5 + 25 * 27.5) - 20, 1e-12);
}

// TIFF DEMs through OpenImageIO: a float image's values are metres as stored, an 8-bit
// image's are its integers (not the [0, 1] OpenImageIO scales them to), each × height_scale +
// height_offset; the 12 × 10 plane value = column + 2·row is resampled exactly.
TEST(PlotLayout, TiffDemsFloatAndEightBit) {
    test::TempDir t;
    const int w = 12, h = 10;
    for (const OIIO::TypeDesc& type :
         {OIIO::TypeDesc(OIIO::TypeDesc::FLOAT), OIIO::TypeDesc(OIIO::TypeDesc::UINT8)}) {
        SCOPED_TRACE(type.c_str());
        const std::string file = (t / (std::string(type.c_str()) + ".tif")).string();
        std::vector<float> f;
        std::vector<uint8_t> b;
        for (int r = 0; r < h; ++r) {
            for (int c = 0; c < w; ++c) {
                f.push_back(float(c + 2 * r));
                b.push_back(uint8_t(c + 2 * r));
            }
        }
        auto out = OIIO::ImageOutput::create(file);
        ASSERT_TRUE(out);
        ASSERT_TRUE(out->open(file, OIIO::ImageSpec(w, h, 1, type)));
        if (type == OIIO::TypeDesc::FLOAT) {
            ASSERT_TRUE(out->write_image(type, f.data()));
        } else {
            ASSERT_TRUE(out->write_image(type, b.data()));
        }
        out->close();
        TerrainOptions o;
        o.kind = TerrainOptions::Kind::kDem;
        o.demPath = file;
        o.metresPerPixel = 2;
        o.heightScale = 0.5;
        o.heightOffset = 3;
        o.cell = 1;
        PlotArea a;
        a.width = 16;
        a.depth = 14;
        const Terrain terrain = makeTerrain(o, a, 2, 1);  // 20 × 18 m: 11 × 10 pixels needed
        for (double x = -10; x <= 10; x += 2.5) {
            for (double z = -9; z <= 9; z += 3) {
                const double column = x / 2 + 5.5, row = z / 2 + 4.5;
                EXPECT_NEAR(terrain.height(x, z), 0.5 * (column + 2 * row) + 3, 1e-5)
                    << x << ", " << z;
            }
        }
    }
}

// The species mix: counts as asked (count exactly; density × area rounded under hard-core),
// understory by its own Poisson process after the canopy, ids 1…N in order, heights drawn
// from each species' distribution, seeds hashed from the plot seed and id.
TEST(PlotLayout, SpeciesMixIdsHeightsAndSeeds) {
    const DatasetSpec d = loadDataset(kPlotData + "plots.toml");
    const PlotSpec& spec = plotNamed(d, "mixed-slope");
    ASSERT_EQ(spec.species.size(), 3u);
    const PlotLayout l = layoutPlot(spec, 77);
    std::map<int32_t, int> counts;
    bool understorySeen = false;
    for (size_t k = 0; k < l.stems.size(); ++k) {
        const PlotStem& s = l.stems[k];
        EXPECT_EQ(s.id, static_cast<int32_t>(k + 1));
        EXPECT_EQ(s.seed, plotTreeSeed(77, s.id));
        ++counts[s.species];
        const bool understory = spec.species[size_t(s.species)].understory;
        if (understory) understorySeen = true;
        EXPECT_FALSE(understorySeen && !understory) << "canopy after understory at " << s.id;
        if (s.species == 0) {
            EXPECT_TRUE(s.targetHeight >= 8 && s.targetHeight <= 12);
        } else if (s.species == 1) {
            EXPECT_EQ(s.targetHeight, 6);
        } else {
            EXPECT_GT(s.targetHeight, 0);
        }
    }
    EXPECT_EQ(counts[0], 36);  // 300 /ha on 0.12 ha
    EXPECT_EQ(counts[1], 20);
    EXPECT_GT(counts[2], 5);  // Poisson, mean 24
    EXPECT_LT(counts[2], 50);
    // Canopy stems keep the hard-core spacing whatever their species.
    std::vector<Vec2> canopy;
    for (const PlotStem& s : l.stems)
        if (s.species != 2) canopy.emplace_back(s.base.x, s.base.z);
    for (double nn : nearestNeighbourDistances(canopy)) EXPECT_GE(nn, 2.5);
}

bool sameLayout(const PlotLayout& a, const PlotLayout& b) {
    if (a.stems.size() != b.stems.size() || a.terrain.heights() != b.terrain.heights())
        return false;
    for (size_t k = 0; k < a.stems.size(); ++k) {
        const PlotStem &s = a.stems[k], &t = b.stems[k];
        if (s.id != t.id || s.species != t.species || !(s.base == t.base) ||
            s.targetHeight != t.targetHeight || s.seed != t.seed)
            return false;
    }
    return true;
}

// The same seed gives the same layout (every plot of the fixture, every process and terrain);
// another seed another.
TEST(PlotLayout, SameSeedSameLayout) {
    const DatasetSpec d = loadDataset(kPlotData + "plots.toml");
    for (const PlotSpec& spec : d.plots) {
        SCOPED_TRACE(spec.name);
        const PlotLayout a = layoutPlot(spec, 42), b = layoutPlot(spec, 42);
        EXPECT_TRUE(sameLayout(a, b));
        EXPECT_FALSE(sameLayout(a, layoutPlot(spec, 43)));
        expectOnTerrain(a);
        for (const PlotStem& s : a.stems) EXPECT_TRUE(spec.area.contains(s.base.x, s.base.z));
    }
}

// Ground cover: a Poisson count of density × area cards (mean 10/m² on the 40 × 30 m slope:
// 12,000, sd 110), each inside the plot with its base — the card's lower end — on the terrain,
// leaning 20–70° from vertical, no longer than `height` and at least half of it, `width` wide;
// the same seed the same cards, a plot without [ground_cover] none.
TEST(PlotLayout, GroundCoverStandsOnTheTerrain) {
    const DatasetSpec d = loadDataset(kPlotData + "plots.toml");
    const PlotSpec& spec = plotNamed(d, "mixed-slope");
    ASSERT_EQ(spec.groundCover.density, 10);
    const PlotLayout l = layoutPlot(spec, 99);
    EXPECT_NEAR(static_cast<double>(l.groundCover.size()), 12000, 5 * 110);
    for (const Leaf& c : l.groundCover) {
        const Vec3 base = c.position - c.tangent * (c.size / 2);
        ASSERT_TRUE(spec.area.contains(base.x, base.z));
        ASSERT_NEAR(base.y, l.terrain.height(base.x, base.z), 1e-9);
        const double lean = std::acos(c.tangent.y) * 180 / kPi;
        ASSERT_GE(lean, 20 - 1e-9);
        ASSERT_LE(lean, 70 + 1e-9);
        ASSERT_NEAR(dot(c.normal, c.tangent), 0, 1e-12);
        ASSERT_NEAR(length(c.normal), 1, 1e-12);
        ASSERT_GE(c.size, 0.5 * 0.25 - 1e-12);
        ASSERT_LE(c.size, 0.25 + 1e-12);
        ASSERT_NEAR(c.size * c.aspect, 0.12, 1e-12);
    }
    const PlotLayout again = layoutPlot(spec, 99);
    ASSERT_EQ(again.groundCover.size(), l.groundCover.size());
    for (size_t k = 0; k < l.groundCover.size(); ++k) {
        ASSERT_EQ(again.groundCover[k].position.x, l.groundCover[k].position.x);
    }
    EXPECT_TRUE(layoutPlot(plotNamed(d, "clustered"), 99).groundCover.empty());
}

}  // namespace
}  // namespace sylva
