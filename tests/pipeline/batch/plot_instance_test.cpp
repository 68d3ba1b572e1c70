#include "pipeline/batch/plot_instance.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstdlib>
#include <fstream>
#include <map>

#include "core/atomic_file.h"
#include "pipeline/formats/image_codecs.h"
#include "pipeline/render/plot_render.h"
#include "tests/plot_fixture.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

OutputOptions plotOutputs(int width, int height) {
    OutputOptions o;
    o.ply = true;
    o.meshFormats = {"ply", "glb", "obj"};
    o.views.count = 3;
    o.views.width = width;
    o.views.height = height;
    o.views.depth = true;
    o.views.depthPng = true;
    o.views.labels = true;
    return o;
}

std::map<std::string, std::string> readTree(const fs::path& root) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(root)) {
        if (e.is_regular_file())
            files[fs::relative(e.path(), root).generic_string()] = test::slurp(e.path());
    }
    return files;
}

TEST(PlotInstance, WritesEveryFileAndTheRecord) {
    PlotSpec spec;
    const GrownPlot plot = test::handPlot(spec, {{-4, -3}, {1, 0}, {4, 4}});
    test::TempDir dir;
    const OutputOptions o = plotOutputs(96, 72);
    const nlohmann::json rec = writePlot(plot, o, dir.path(), "hand-0");
    EXPECT_EQ(rec["id"], "hand-0");
    EXPECT_EQ(rec["kind"], "plot");
    EXPECT_EQ(rec["plot"], "hand");
    EXPECT_EQ(rec["seed"], "0000000000001234");
    EXPECT_EQ(rec["trees"], 3);
    EXPECT_NEAR(rec["stats"]["stems_per_ha"].get<double>(), 3 / 400.0 * 1e4, 1e-9);
    const fs::path root = dir.path() / "plots" / "hand" / "hand-0";
    for (const char* key : {"scene_glb", "scene_ply", "trees_csv", "trees_json", "plot_json",
                            "transforms", "transforms_top", "views", "trees"}) {
        ASSERT_TRUE(rec["files"].contains(key)) << key;
        EXPECT_TRUE(fs::exists(dir.path() / rec["files"][key].get<std::string>())) << key;
    }
    for (const char* tree : {"tree-0001", "tree-0002", "tree-0003"}) {
        for (const char* f :
             {"skeleton.ply", "mesh.ply", "mesh.glb", "mesh.obj", "mesh.mtl", "stats.json"}) {
            EXPECT_TRUE(fs::exists(root / "trees" / tree / f)) << tree << "/" << f;
        }
    }
    for (const char* view : {"overview", "oblique", "top"}) {
        for (const char* suffix : {".png", "_depth.exr", "_depth.png", "_label.png", "_id.png"}) {
            EXPECT_TRUE(fs::exists(root / "views" / (std::string(view) + suffix)))
                << view << suffix;
        }
    }
    // The id PNG holds the render's ids.
    const PlotScene scene = makePlotScene(plot, o.tubes);
    const std::vector<Camera> cams = makePlotCameras(plot, o.views);
    const ViewImage v = renderPlotView(makePlotRenderScene(plot, scene), cams[0], true, true);
    EXPECT_EQ(test::slurp(root / "views" / "overview_id.png"),
              encodeGrey16Png(v.width, v.height, v.ids.data()));
    // trees.csv: a header and a row per tree; stats.json in plot-local metres with its base.
    const std::string csv = test::slurp(root / "trees.csv");
    EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4);
    EXPECT_EQ(csv.substr(0, csv.find('\n')),
              "id,name,species,x,y,z,height,dbh,crown_base,crown_radius_n,crown_radius_ne,"
              "crown_radius_e,crown_radius_se,crown_radius_s,crown_radius_sw,crown_radius_w,"
              "crown_radius_nw,nn_distance,leaf_area");
    const auto st = nlohmann::json::parse(test::slurp(root / "trees" / "tree-0002" / "stats.json"));
    EXPECT_EQ(st["tree_id"], 2);
    EXPECT_DOUBLE_EQ(st["base"][0].get<double>(), 1.0);
    EXPECT_NEAR(st["height_m"].get<double>(),
                plot.trees[1].grown.tree.nodes.back().position.y - plot.trees[1].stem.base.y, 6.0);
    // The perspective views in transforms.json (what nerfstudio and instant-ngp read), the
    // orthographic top view in a file of its own.
    const auto transforms = nlohmann::json::parse(test::slurp(root / "transforms.json"));
    ASSERT_EQ(transforms["frames"].size(), 2u);
    EXPECT_EQ(transforms["frames"][0]["view"], "overview");
    EXPECT_EQ(transforms["frames"][1]["view"], "oblique");
    EXPECT_FALSE(transforms.contains("orthographic"));
    for (const auto& f : transforms["frames"]) EXPECT_FALSE(f.contains("orthographic"));
    const auto top = nlohmann::json::parse(test::slurp(root / "transforms_top.json"));
    ASSERT_EQ(top["frames"].size(), 1u);
    EXPECT_EQ(top["orthographic"], true);
    EXPECT_EQ(top["frames"][0]["view"], "top");
    EXPECT_EQ(top["frames"][0]["file_path"], "views/top.png");
    EXPECT_EQ(top["frames"][0]["id_file_path"], "views/top_id.png");
    EXPECT_EQ(rec["files"]["transforms_top"], "plots/hand/hand-0/transforms_top.json");
}

// Without mesh formats: no scene or tree meshes, the views and tables all the same; without
// views: no views or transforms.json.
TEST(PlotInstance, WritesOnlyWhatTheOutputsAsk) {
    PlotSpec spec;
    const GrownPlot plot = test::handPlot(spec, {{-4, -3}, {1, 0}});
    test::TempDir dir;
    OutputOptions o = plotOutputs(64, 48);
    o.meshFormats.clear();
    o.ply = false;
    nlohmann::json rec = writePlot(plot, o, dir.path(), "a");
    const fs::path a = dir.path() / "plots" / "hand" / "a";
    EXPECT_FALSE(rec["files"].contains("scene_glb"));
    EXPECT_FALSE(fs::exists(a / "scene.glb"));
    EXPECT_FALSE(fs::exists(a / "scene.ply"));
    EXPECT_FALSE(fs::exists(a / "trees" / "tree-0001" / "mesh.ply"));
    EXPECT_FALSE(fs::exists(a / "trees" / "tree-0001" / "skeleton.ply"));
    EXPECT_TRUE(fs::exists(a / "trees" / "tree-0001" / "stats.json"));
    EXPECT_TRUE(fs::exists(a / "views" / "top_id.png"));
    EXPECT_TRUE(fs::exists(a / "trees.csv"));
    o.views.count = 0;
    rec = writePlot(plot, o, dir.path(), "b");
    const fs::path b = dir.path() / "plots" / "hand" / "b";
    EXPECT_FALSE(fs::exists(b / "views"));
    EXPECT_FALSE(fs::exists(b / "transforms.json"));
    EXPECT_FALSE(rec["files"].contains("views"));
    EXPECT_TRUE(fs::exists(b / "plot.json"));
}

// The same plot written with 1 thread and with many gives the same bytes in every file.
TEST(PlotInstance, SameBytesWhateverTheThreadCount) {
    PlotSpec spec;
    const GrownPlot plot = test::handPlot(spec, {{-4, -3}, {1, 0}, {4, 4}});
    test::TempDir a, b;
    writePlot(plot, plotOutputs(80, 60), a.path(), "p");
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        writePlot(plot, plotOutputs(80, 60), b.path(), "p");
    }
    const auto fa = readTree(a.path()), fb = readTree(b.path());
    EXPECT_GT(fa.size(), 20u);
    EXPECT_EQ(fa, fb);
}

// Writes a plot of library species for the independent readers (ctest plot_readers_*:
// tests/python/test_plot_outputs.py, tests/js/check_plot.mjs) into $SYLVA_PLOT_OUT, or a
// scratch directory without it: 3 trees of 2 species, 128 × 96 views. $SYLVA_PLOT_TREES and
// $SYLVA_PLOT_PX make a larger one for looking at (docs/plots.md). Beside the plot it writes
// views/<view>_id.u16: the render's ids as raw little-endian uint16, what the PNG must hold.
TEST(PlotOutputs, WritesPresetPlotForReaders) {
    const char* outEnv = std::getenv("SYLVA_PLOT_OUT");
    const char* treesEnv = std::getenv("SYLVA_PLOT_TREES");
    const char* pxEnv = std::getenv("SYLVA_PLOT_PX");
    const int n = treesEnv ? std::atoi(treesEnv) : 3;
    const int px = pxEnv ? std::atoi(pxEnv) : 128;
    test::TempDir scratch;
    const fs::path out = outEnv ? fs::path(outEnv) : scratch.path();
    std::vector<Vec2> xz;
    const double side = n <= 3 ? 16 : 30;
    for (int k = 0; k < n; ++k) {  // a jittered grid
        const int cols = static_cast<int>(std::ceil(std::sqrt(n)));
        const double step = side / cols;
        xz.push_back({-0.5 * side + step * (k % cols + 0.5) + 0.9 * std::sin(3.7 * k),
                      -0.5 * side + step * (k / cols + 0.5) + 0.9 * std::cos(2.3 * k)});
    }
    PlotSpec spec;
    const std::vector<std::string> species =
        n <= 3 ? std::vector<std::string>{"umbrella-thorn", "lemon"}
               : std::vector<std::string>{"scots-pine", "silver-birch", "hawthorn"};
    GrownPlot plot = test::presetPlot(spec, species, xz, side, side);
    for (int g = 0; g < 40 * n; ++g) {  // ground cover
        Leaf card;
        const double x = -0.5 * side + side * std::fmod(0.618 * g, 1.0);
        const double z = -0.5 * side + side * std::fmod(0.377 * g + 0.1, 1.0);
        card.position = {x, plot.layout.terrain.height(x, z) + 0.12, z};
        card.normal = normalize(Vec3{std::sin(g), 0, std::cos(g)});
        card.tangent = {0, 1, 0};
        card.size = 0.25;
        card.aspect = 0.4;
        plot.groundCover.push_back(card);
    }
    OutputOptions o = plotOutputs(px, px * 3 / 4);
    o.meshFormats = {"ply", "glb"};
    const nlohmann::json rec = writePlot(plot, o, out, "presets-0");
    const fs::path root = out / "plots" / "presets" / "presets-0";
    std::ofstream(root / "record.json") << rec.dump(2) << "\n";
    const PlotScene scene = makePlotScene(plot, o.tubes);
    const PlotRenderScene rs = makePlotRenderScene(plot, scene);
    const std::vector<Camera> cams = makePlotCameras(plot, o.views);
    for (size_t k = 0; k < cams.size(); ++k) {
        const ViewImage v = renderPlotView(rs, cams[k], false, true);
        std::string raw;
        for (uint16_t id : v.ids) {
            raw.push_back(static_cast<char>(id & 0xff));
            raw.push_back(static_cast<char>(id >> 8));
        }
        std::ofstream(root / "views" / (std::string(kPlotViewNames[k]) + "_id.u16"),
                      std::ios::binary)
            << raw;
        if (outEnv) {  // for looking: parts and ids in colours
            writeFileAtomic(root / "views" / (std::string(kPlotViewNames[k]) + "_parts_rgb.png"),
                            encodeRgbPng(v.width, v.height, colourParts(v.labels).data()));
            writeFileAtomic(root / "views" / (std::string(kPlotViewNames[k]) + "_ids_rgb.png"),
                            encodeRgbPng(v.width, v.height, colourIds(v.ids, v.labels).data()));
        }
    }
    EXPECT_EQ(rec["trees"], n);
    // The same plot textured ([outputs] textures), meshes only, beside it for the readers.
    OutputOptions t = o;
    t.textures = true;
    t.meshFormats = {"glb", "obj"};
    t.views.count = 0;
    writePlot(plot, t, out / "textured", "presets-0");
    const fs::path textured = out / "textured" / "plots" / "presets" / "presets-0";
    EXPECT_TRUE(fs::exists(textured / "scene.glb"));
    EXPECT_TRUE(fs::exists(textured / "trees" / "tree-0001" / "mesh_bark.png"));
}

}  // namespace
}  // namespace sylva
