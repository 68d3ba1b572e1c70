// A grown plot as meshes and views: every tree's tubes and leaf cards in plot-local metres, the
// terrain and the ground cover (PlotScene, which the scene GLB / PLY writers and the views
// share), the plot's three cameras (overview, oblique, top-down orthophoto) and its views —
// silhouette, depth, part labels and instance ids from one z-buffer per view that the trees,
// the terrain and the ground cover are drawn into one after another (render.h SceneCanvas). Codes:
// docs/plots.md, "Outputs".
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/render/camera.h"
#include "pipeline/render/render.h"
#include "species/geometry/mesh.h"
#include "species/geometry/tube_mesh.h"
#include "species/plot/plot.h"

namespace sylva {

// Part codes of a plot's scene PLY (per vertex) and label images (per pixel).
enum PlotPart : uint8_t {
    kPartTerrain = 0,
    kPartStem = 1,    // order-0 wood of the shoot
    kPartBranch = 2,  // shoot wood of order ≥ 1
    kPartLeaf = 3,
    kPartRoot = 4,           // the root system's wood
    kPartLowVegetation = 5,  // ground-cover cards
};
constexpr uint8_t kPartBackground = 255;  // label images: nothing drawn (sky)
// The part of the wood ending at a skeleton node.
inline uint8_t woodPart(const SkeletonNode& n) {
    return n.part == kRootPart ? kPartRoot : n.order == 0 ? kPartStem : kPartBranch;
}

struct PlotSceneTree {
    int32_t id = 0;                  // PlotStem::id (1 … N)
    std::string name;                // "tree-0007"
    TreeMesh mesh;                   // wood (tubes) and leaves, plot-local metres
    std::vector<int32_t> woodNodes;  // per wood triangle, its skeleton node (tubeMesh)
    std::vector<uint8_t> woodParts;  // per wood vertex, its PlotPart (stem, branch, root)
};

struct PlotScene {
    std::vector<PlotSceneTree> trees;  // in the plot's tree order
    Mesh terrain;                      // terrainMesh
    Mesh groundCover;                  // the ground-cover cards as leafMesh makes them
    bool leafOutlines = true;          // leaves as their outlines, or as cards (below)
};

// The scene of a grown plot; without `leafMeshes` the trees' leaf meshes stay empty (the views
// draw the leaves from the trees themselves). Without `leafOutlines` ([outputs] leaf_outlines
// = false) every leaf is meshed and drawn as its card, one quad: the trees keep their shapes
// (the tree table's leaf areas are the outlines').
PlotScene makePlotScene(const GrownPlot& plot, const TubeOptions& tubes, bool leafMeshes = true,
                        bool leafOutlines = true);

// The plot's views, in this order.
constexpr std::array<const char*, 3> kPlotViewNames = {"overview", "oblique", "top"};

// Cameras of the plot's views, all options.width × options.height pixels, looking at the box
// of the plot area and every tree (terrain heights to the highest tree top):
//   overview: perspective (options.fovDeg), from the south-east corner (azimuth 45°, as
//     makeCameras counts it: 0 = on +z looking along −z), 35° above the horizon;
//   oblique: perspective, from the south-west (azimuth 315°), 12° above the horizon;
//   top: orthographic, looking straight down (image up = north, −z; right = east, +x),
//     spanning the box × options.margin.
// The perspective cameras aim at the box's centre from the nearest distance at which all its
// corners are inside the field of view narrowed by options.margin (tan(fov/2) / margin).
std::vector<Camera> makePlotCameras(const GrownPlot& plot, const ViewOptions& options);

// Where instant-ngp's loader puts the plot (camera.h ngpPlacement, for the same box's sphere).
NgpPlacement plotNgpPlacement(const GrownPlot& plot);

// The plot's views, one image per camera, drawn tree by tree into one z-buffer per camera
// (render.h SceneCanvas): each tree's nodes and leaves (as cards when the scene has no leaf
// outlines) with their tubes, then the terrain and the ground cover — no merged copy of the
// plot. With `scene`, its tubes and terrain; without (views and no meshes), each tree's tubes
// are made here with `tubes` once for all cameras and freed before the next tree's. Images as
// renderPlotView's below, byte for byte the same as those of the merged scene.
//   silhouette 255 where a tree (id ≥ 1) is the nearest surface, else 0; depth (metres along
//   the view axis, terrain and ground cover included, 0 = sky); labels the PlotPart of the
//   nearest surface, kPartBackground where nothing is drawn (empty without wantLabels); ids the
//   tree id of the nearest surface, 0 for terrain, ground cover and sky.
// Throws std::invalid_argument for a tree id outside 1 … 65535 (16-bit id images) or a scene
// that is not the plot's.
std::vector<ViewImage> renderPlotViews(const GrownPlot& plot, const PlotScene* scene,
                                       const TubeOptions& tubes, bool leafOutlines,
                                       const std::vector<Camera>& cameras, bool wantDepth,
                                       bool wantLabels, const RenderOptions& options = {});

// The plot merged into one object for renderScene: every tree's nodes, leaves and tubes, the
// terrain as wood of one extra node, the ground cover as leaves; internal labels are
// PlotPart + 1. It copies the whole plot (≈ 96 B per leaf, a hectare's tubes): the build draws
// with renderPlotViews; this is the reference its tests compare with, and serves small scenes
// (a tree alone, the ground alone).
struct PlotRenderScene {
    Tree tree;
    Mesh wood;
    std::vector<int32_t> woodNodes;
    SceneLabels labels;
};
PlotRenderScene makePlotRenderScene(const GrownPlot& plot, const PlotScene& scene,
                                    bool withTerrain = true, bool withGroundCover = true);

// One view of a merged plot, images as renderPlotViews'.
ViewImage renderPlotView(const PlotRenderScene& scene, const Camera& camera, bool wantDepth,
                         bool wantLabels, const RenderOptions& options = {});

// Part colours for looking at plots: terrain tan, stem dark brown, branch orange, leaf green,
// root dark red, low vegetation olive, background white. RGB, 3 bytes per pixel.
std::vector<uint8_t> colourParts(const std::vector<uint8_t>& parts);
// An id image in colours: 0 light grey (terrain) or, where `labels` say background, white;
// each tree a colour of its own (a hash of its id). RGB.
std::vector<uint8_t> colourIds(const std::vector<uint16_t>& ids, const std::vector<uint8_t>& parts);

}  // namespace sylva
