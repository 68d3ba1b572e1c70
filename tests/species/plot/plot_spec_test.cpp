// Reading [[plot]] tables (species/plot/plot_spec.h through loadDataset): every key lands in
// PlotSpec with its unit converted, the defaults are the documented ones, and a plots-only
// dataset is a dataset. Bad plot specs are tests/cli/plot_cli_test.cpp's.
#include "species/plot/plot_spec.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "pipeline/batch/dataset.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

const std::string kPlotData = std::string(SYLVA_SOURCE_DIR) + "/tests/data/plot/";

TEST(PlotSpec, ReadsEveryKey) {
    const toml::table t = parseTomlFile(kPlotData + "plots.toml");
    EXPECT_TRUE(isDatasetFile(t));  // [[plot]] without [[species]]
    const DatasetSpec d = loadDataset(kPlotData + "plots.toml");
    EXPECT_TRUE(d.species.empty());
    EXPECT_EQ(DatasetInstances(d).size(), 6);  // every plot instance is an instance
    ASSERT_EQ(d.plots.size(), 5u);

    const PlotSpec& a = d.plots[0];
    EXPECT_EQ(a.name, "mixed-slope");
    EXPECT_EQ(a.keyPath, "plot[0]");
    EXPECT_EQ(a.count, 2);
    EXPECT_EQ(a.area.shape, PlotArea::Shape::kRectangle);
    EXPECT_EQ(a.area.width, 40);
    EXPECT_EQ(a.area.depth, 30);
    EXPECT_EQ(a.margin, 4);
    EXPECT_EQ(a.lai, 0.2);
    EXPECT_TRUE(a.neighbours);
    EXPECT_EQ(a.terrain.kind, TerrainOptions::Kind::kSlope);
    EXPECT_NEAR(a.terrain.slopeRad, 15 * kPi / 180, 1e-12);
    EXPECT_NEAR(a.terrain.aspectRad, kPi / 2, 1e-12);
    EXPECT_EQ(a.terrain.cell, 0.5);
    EXPECT_EQ(a.process.kind, PointProcessOptions::Kind::kHardCore);
    EXPECT_EQ(a.process.minSpacing, 2.5);
    ASSERT_EQ(a.species.size(), 3u);
    EXPECT_EQ(a.species[0].species.name, "tiny");
    EXPECT_EQ(a.species[0].density, 300);
    EXPECT_EQ(a.species[0].count, -1);
    EXPECT_TRUE(a.species[0].hasHeight);
    EXPECT_EQ(a.species[0].crownShyness, 0.15);
    EXPECT_EQ(a.species[0].maxOverlap, 0.1);
    EXPECT_EQ(a.species[0].lai, -1);
    EXPECT_EQ(a.species[1].count, 20);
    EXPECT_FALSE(a.species[1].understory);
    EXPECT_TRUE(a.species[2].understory);
    EXPECT_EQ(a.species[2].keyPath, "plot[0].understory[0]");
    EXPECT_EQ(a.groundCover.density, 10);
    EXPECT_EQ(a.groundCover.height, 0.25);
    EXPECT_EQ(a.groundCover.width, 0.12);
    EXPECT_NEAR(expectedStems(a.species[0], a.area), 36, 1e-9);

    const PlotSpec& b = d.plots[1];
    EXPECT_EQ(b.area.shape, PlotArea::Shape::kCircle);
    EXPECT_EQ(b.area.radius, 15);
    EXPECT_EQ(b.count, 1);  // default
    EXPECT_FALSE(b.neighbours);
    EXPECT_EQ(b.lai, -1);
    EXPECT_EQ(b.species[0].lai, 0.1);
    EXPECT_EQ(b.terrain.kind, TerrainOptions::Kind::kNoise);
    EXPECT_EQ(b.terrain.amplitude, 3);
    EXPECT_EQ(b.terrain.wavelength, 25);
    EXPECT_EQ(b.terrain.octaves, 4);
    EXPECT_EQ(b.process.kind, PointProcessOptions::Kind::kStrauss);
    EXPECT_EQ(b.process.interaction, 0.2);

    const PlotSpec& c = d.plots[2];
    EXPECT_EQ(c.process.kind, PointProcessOptions::Kind::kThomas);
    EXPECT_EQ(c.process.parentDensity, 20);
    EXPECT_EQ(c.process.clusterSigma, 4);
    EXPECT_EQ(c.area.width, 50);  // defaults
    EXPECT_EQ(c.area.depth, 50);
    EXPECT_EQ(c.margin, 5);
    EXPECT_EQ(c.terrain.kind, TerrainOptions::Kind::kFlat);
    EXPECT_EQ(c.species[0].crownShyness, 0.1);
    EXPECT_EQ(c.species[0].maxOverlap, 0.05);

    const PlotSpec& e = d.plots[3];
    EXPECT_EQ(e.process.kind, PointProcessOptions::Kind::kRows);
    EXPECT_EQ(e.process.rowSpacing, 3);
    EXPECT_EQ(e.process.stemSpacing, 2);
    EXPECT_NEAR(e.process.rowAzimuthRad, kPi / 6, 1e-12);
    EXPECT_EQ(e.process.jitter, 0.2);

    EXPECT_EQ(plotInstanceId("stand", 7), "stand-00007");
}

// The DEM's keys; its bytes join the dataset fingerprint (a changed DEM is a changed dataset).
TEST(PlotSpec, DemKeysAndFingerprint) {
    const DatasetSpec d = loadDataset(kPlotData + "dem.toml");
    const TerrainOptions& t = d.plots[0].terrain;
    EXPECT_EQ(t.kind, TerrainOptions::Kind::kDem);
    EXPECT_NE(t.demPath.find("dem_plane.png"), std::string::npos);
    EXPECT_EQ(t.metresPerPixel, 0.5);
    EXPECT_EQ(t.heightScale, 0.01);
    EXPECT_EQ(t.heightOffset, -20);
    EXPECT_EQ(t.cell, 1);
    EXPECT_EQ(d.fingerprint.size(), 16u);
}

// With a PlotFileCache, a species file is loaded and validated once: read again (a sweep point),
// the plot takes the cached species even after the file has changed on disk, where a read
// without the cache loads the file anew (and here fails on it). The fingerprint gets the file's
// bytes on every read that asks for them.
TEST(PlotSpec, ACacheLoadsEachSpeciesFileOnce) {
    const fs::path dir =
        fs::temp_directory_path() / ("sylva_plot_cache_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    fs::copy_file(kPlotData + "../tiny.toml", dir / "tiny.toml",
                  fs::copy_options::overwrite_existing);
    const std::string file = (dir / "plot.toml").string();
    std::ofstream(file) << "name = \"c\"\n[[plot]]\nname = \"p\"\nwidth = 10\ndepth = 10\n"
                           "[[plot.species]]\nfile = \"tiny.toml\"\ncount = 2\n";
    const toml::table t = parseTomlFile(file);
    auto read = [&](PlotFileCache* cache, std::string* fingerprint) {
        DrawContext draw;
        draw.draw = false;
        Params top(t, file, "", &draw);
        std::vector<Params> plots = top.tableArray("plot");
        return readPlot(plots[0], BudgetTable{}, false, fingerprint, cache);
    };
    PlotFileCache cache;
    std::string fingerprint;
    const PlotSpec first = read(&cache, &fingerprint);
    EXPECT_EQ(first.species[0].species.name, "tiny");
    EXPECT_EQ(cache.species.size(), 1u);
    const size_t bytes = fingerprint.size();
    EXPECT_EQ(bytes, fs::file_size(dir / "tiny.toml"));
    std::ofstream(dir / "tiny.toml") << "name = \"tiny\"\nmethod = \"no-such-method\"\n";
    const PlotSpec again = read(&cache, &fingerprint);
    EXPECT_EQ(again.species[0].species.name, "tiny");
    EXPECT_EQ(again.species[0].count, 2);
    EXPECT_GT(fingerprint.size(), bytes);  // the file's bytes as they are now
    EXPECT_THROW((void)read(nullptr, nullptr), SpecError);
    fs::remove_all(dir);
}

// Sweeps over a plot's own keys: one plot per point, named "<plot>-p<point>", each the plot read
// with the point's values; same_seed axes leave the seeds alone (the same stand at another LAI),
// the others change them; species and unswept plots are untouched.
TEST(PlotSweep, PointsAreThePlotWithTheAxesValues) {
    const DatasetSpec d = loadDataset(kPlotData + "sweep.toml");
    ASSERT_EQ(d.species.size(), 1u);
    EXPECT_EQ(d.species[0].points.size(), 1u);  // plot axes do not apply to species
    ASSERT_EQ(d.plots.size(), 5u);
    const double lai[] = {0.005, 0.01, 0.005, 0.01};
    const double density[] = {200, 200, 400, 400};
    for (int k = 0; k < 4; ++k) {
        const PlotSpec& p = d.plots[k];
        EXPECT_EQ(p.name, "stand-p00" + std::to_string(k));
        EXPECT_EQ(p.sweptFrom, "stand");
        EXPECT_EQ(p.keyPath, "plot[0]");
        EXPECT_EQ(p.lai, lai[k]);
        EXPECT_EQ(p.species[0].density, density[k]);
        EXPECT_EQ(p.area.width, 20);  // the rest as written
        EXPECT_EQ(p.sweep.at("lai"), k % 2 ? "0.01" : "0.005");
        EXPECT_EQ(p.sweep.at("species[0].density"), k < 2 ? "200" : "400");
        EXPECT_EQ(p.seedKey, k < 2 ? "species[0].density=200" : "species[0].density=400");
    }
    EXPECT_EQ(d.plots[4].name, "other");
    EXPECT_TRUE(d.plots[4].sweptFrom.empty());
    EXPECT_TRUE(d.plots[4].sweep.empty());

    const DatasetInstances inst(d);
    ASSERT_EQ(inst.size(), 1 + 4 + 1);
    EXPECT_EQ(inst[1].id, "stand-p000-00000");
    EXPECT_EQ(inst[4].id, "stand-p003-00000");
    EXPECT_EQ(inst[5].id, "other-00000");
    EXPECT_EQ(inst.find("stand-p002-00000"), std::optional<int64_t>(3));
    EXPECT_EQ(inst[1].seed, inst[2].seed);  // lai is same_seed
    EXPECT_EQ(inst[3].seed, inst[4].seed);
    EXPECT_NE(inst[1].seed, inst[3].seed);  // density is not
    // An unswept plot's seed is what it was before sweeps existed.
    EXPECT_EQ(inst[5].seed, instanceSeed(d.seed, "plot:other", "", 0));
}

}  // namespace
}  // namespace sylva
