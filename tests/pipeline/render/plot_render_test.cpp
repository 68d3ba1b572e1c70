#include "pipeline/render/plot_render.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <set>

#include "tests/plot_fixture.h"

namespace sylva {
namespace {

ViewOptions smallViews() {
    ViewOptions o;
    o.count = 1;
    o.width = 240;
    o.height = 180;
    return o;
}

GrownPlot fourTrees(PlotSpec& spec) {
    // Crowns 2 m wide 3 m apart: they overlap in the views and hide one another.
    return test::handPlot(spec, {{-3, -2}, {0, 0}, {3, 1}, {-1, 4}});
}

// A plot holding only tree k (or no tree), the same terrain and ground cover.
GrownPlot only(const GrownPlot& plot, int k) {
    GrownPlot one;
    one.spec = plot.spec;
    one.layout = plot.layout;
    one.groundCover = plot.groundCover;
    if (k >= 0) one.trees.push_back(plot.trees[k]);
    return one;
}

// Instance ids exactly cover each tree's pixels: a pixel has id k iff tree k, rendered alone
// with the same camera, covers it and is nearest there among all trees and the terrain (the
// terrain and ground cover, rendered alone, occlude too). Equal depths: the id is one of the
// nearest. The depth is the nearest of them all.
TEST(PlotRender, InstanceIdsAreTheNearestTreeAlone) {
    PlotSpec spec;
    const GrownPlot plot = fourTrees(spec);
    const PlotScene scene = makePlotScene(plot, {});
    const PlotRenderScene all = makePlotRenderScene(plot, scene);
    const std::vector<Camera> cameras = makePlotCameras(plot, smallViews());
    ASSERT_EQ(cameras.size(), 3u);
    std::vector<PlotRenderScene> alone;
    std::vector<PlotScene> aloneScenes;
    for (size_t k = 0; k < plot.trees.size(); ++k) {
        const GrownPlot one = only(plot, static_cast<int>(k));
        aloneScenes.push_back(makePlotScene(one, {}));
        alone.push_back(makePlotRenderScene(one, aloneScenes.back(), false, false));
    }
    const GrownPlot ground = only(plot, -1);
    const PlotScene groundScene = makePlotScene(ground, {});
    const PlotRenderScene groundOnly = makePlotRenderScene(ground, groundScene);
    for (const Camera& cam : cameras) {
        const ViewImage v = renderPlotView(all, cam, true, true);
        const ViewImage g = renderPlotView(groundOnly, cam, true, true);
        std::vector<ViewImage> trees;
        for (const PlotRenderScene& s : alone) trees.push_back(renderPlotView(s, cam, true, true));
        std::set<int> seen;
        int64_t treePixels = 0, groundPixels = 0, occluded = 0;
        for (size_t p = 0; p < v.ids.size(); ++p) {
            float nearest = g.depth[p] > 0 ? g.depth[p] : std::numeric_limits<float>::infinity();
            for (const ViewImage& t : trees) {
                if (t.depth[p] > 0) nearest = std::min(nearest, t.depth[p]);
            }
            std::set<int> ids;
            if (g.depth[p] > 0 && g.depth[p] == nearest) ids.insert(0);
            int covering = 0;
            for (size_t k = 0; k < trees.size(); ++k) {
                if (trees[k].depth[p] > 0) ++covering;
                if (trees[k].depth[p] > 0 && trees[k].depth[p] == nearest) {
                    ids.insert(plot.trees[k].stem.id);
                }
            }
            if (!std::isfinite(nearest)) {
                ASSERT_EQ(v.ids[p], 0);
                ASSERT_EQ(v.depth[p], 0.0f);
                ASSERT_EQ(v.labels[p], kPartBackground);
                continue;
            }
            ASSERT_EQ(v.depth[p], nearest) << "pixel " << p;
            ASSERT_TRUE(ids.count(v.ids[p])) << "pixel " << p << " id " << v.ids[p];
            ASSERT_EQ(v.silhouette[p], v.ids[p] ? 255 : 0);
            if (v.ids[p]) {
                ++treePixels;
                seen.insert(v.ids[p]);
                ASSERT_TRUE(v.labels[p] >= kPartStem && v.labels[p] <= kPartRoot);
            } else {
                ++groundPixels;
                ASSERT_TRUE(v.labels[p] == kPartTerrain || v.labels[p] == kPartLowVegetation);
                occluded += covering > 0;  // a tree alone covers it, the ground is in front
            }
        }
        EXPECT_EQ(seen.size(), plot.trees.size()) << "every tree is seen";
        EXPECT_GT(treePixels, 100);
        EXPECT_GT(groundPixels, 200);
        if (!cam.orthographic) {
            EXPECT_GT(occluded, 0) << "the terrain hides some tree pixels";
        }
    }
}

// The top view is an orthophoto: north up, east right, each stem's top at its (x, z).
TEST(PlotRender, TopViewLooksStraightDown) {
    PlotSpec spec;
    const GrownPlot plot = fourTrees(spec);
    const std::vector<Camera> cams = makePlotCameras(plot, smallViews());
    const Camera& top = cams[2];
    ASSERT_TRUE(top.orthographic);
    double px, py, d;
    ASSERT_TRUE(top.project({1, 0, -1}, px, py, d));
    double qx, qy;
    ASSERT_TRUE(top.project({2, 0, -3}, qx, qy, d));
    EXPECT_GT(qx, px);  // east: right
    EXPECT_LT(qy, py);  // north: up
    // The whole area is in frame.
    for (double x : {-10.0, 10.0}) {
        for (double z : {-10.0, 10.0}) {
            ASSERT_TRUE(top.project({x, 0, z}, px, py, d));
            EXPECT_TRUE(px > 0 && px < top.width && py > 0 && py < top.height);
        }
    }
    const PlotScene scene = makePlotScene(plot, {});
    const ViewImage v = renderPlotView(makePlotRenderScene(plot, scene), top, true, true);
    // Every pixel of the orthophoto sees the ground or a tree: no sky inside the area.
    ASSERT_TRUE(top.project({0, 0, 0}, px, py, d));
    EXPECT_NE(v.labels[static_cast<size_t>(py) * top.width + static_cast<size_t>(px)],
              kPartBackground);
}

TEST(PlotRender, SameImagesWhateverTheThreadCount) {
    PlotSpec spec;
    const GrownPlot plot = fourTrees(spec);
    const PlotScene scene = makePlotScene(plot, {});
    const PlotRenderScene rs = makePlotRenderScene(plot, scene);
    for (const Camera& cam : makePlotCameras(plot, smallViews())) {
        const ViewImage many = renderPlotView(rs, cam, true, true);
        ViewImage one;
        {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
            one = renderPlotView(rs, cam, true, true);
        }
        EXPECT_EQ(many.ids, one.ids);
        EXPECT_EQ(many.labels, one.labels);
        EXPECT_EQ(many.depth, one.depth);
    }
}

// The views drawn tree by tree into one z-buffer per camera (renderPlotViews, the build's way)
// are byte for byte those of the whole plot merged into one object (makePlotRenderScene, the
// way before): with the scene's tubes or tubes made per tree, leaf outlines or cards, with and
// without minimum-width skeleton lines.
TEST(PlotRender, TreeByTreeEqualsTheMergedScene) {
    PlotSpec spec;
    const GrownPlot plot = fourTrees(spec);
    const std::vector<Camera> cameras = makePlotCameras(plot, smallViews());
    for (const bool outlines : {true, false}) {
        for (const double minWidth : {0.0, 1.415}) {
            RenderOptions options;
            options.minWidthPx = minWidth;
            const PlotScene scene = makePlotScene(plot, {}, /*leafMeshes=*/false, outlines);
            const PlotRenderScene merged = makePlotRenderScene(plot, scene);
            const std::vector<ViewImage> withScene =
                renderPlotViews(plot, &scene, {}, outlines, cameras, true, true, options);
            const std::vector<ViewImage> madeHere =
                renderPlotViews(plot, nullptr, {}, outlines, cameras, true, true, options);
            ASSERT_EQ(withScene.size(), cameras.size());
            ASSERT_EQ(madeHere.size(), cameras.size());
            for (size_t k = 0; k < cameras.size(); ++k) {
                SCOPED_TRACE(testing::Message() << "outlines " << outlines << ", min width "
                                                << minWidth << ", camera " << k);
                const ViewImage m = renderPlotView(merged, cameras[k], true, true, options);
                for (const ViewImage* v : {&withScene[k], &madeHere[k]}) {
                    EXPECT_EQ(v->silhouette, m.silhouette);
                    EXPECT_EQ(v->depth, m.depth);
                    EXPECT_EQ(v->labels, m.labels);
                    EXPECT_EQ(v->ids, m.ids);
                }
                // Trees, terrain and sky all in the picture.
                std::set<int> ids(m.ids.begin(), m.ids.end());
                EXPECT_GE(ids.size(), 4u);
                EXPECT_NE(std::count(m.labels.begin(), m.labels.end(), kPartTerrain), 0);
            }
        }
    }
    // Without labels: none returned, the rest the same.
    const PlotScene scene = makePlotScene(plot, {}, false);
    const std::vector<ViewImage> noLabels =
        renderPlotViews(plot, &scene, {}, true, cameras, false, false);
    EXPECT_TRUE(noLabels[0].labels.empty());
    EXPECT_TRUE(noLabels[0].depth.empty());
    EXPECT_EQ(noLabels[0].ids,
              renderPlotView(makePlotRenderScene(plot, scene), cameras[0], true, true).ids);
}

// The scene's wood vertices carry the part of their skeleton node: the trunk's are stems, the
// taproot's roots.
TEST(PlotRender, SceneMeshPartsFollowTheSkeleton) {
    PlotSpec spec;
    const GrownPlot plot = fourTrees(spec);
    const PlotScene scene = makePlotScene(plot, {});
    ASSERT_EQ(scene.trees.size(), 4u);
    for (const PlotSceneTree& t : scene.trees) {
        ASSERT_EQ(t.woodParts.size(), t.mesh.wood.vertexCount());
        int stem = 0, branch = 0, root = 0;
        for (uint8_t p : t.woodParts) {
            stem += p == kPartStem;
            branch += p == kPartBranch;
            root += p == kPartRoot;
        }
        EXPECT_GT(stem, 0);
        EXPECT_GT(branch, 0);
        EXPECT_GT(root, 0);
        EXPECT_EQ(stem + branch + root, static_cast<int>(t.woodParts.size()));
    }
    EXPECT_EQ(scene.terrain.vertexCount(),
              static_cast<size_t>(plot.layout.terrain.nx()) * plot.layout.terrain.nz());
    EXPECT_EQ(scene.groundCover.triangleCount(), 6u * 2 * 2);  // 6 cards, 2 faces of 2 triangles
}

}  // namespace
}  // namespace sylva
