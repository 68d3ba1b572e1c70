// A CPU renderer of one view: the tree's mesh as sylva writes it (branch tubes and leaf
// outlines), z-buffered into a silhouette, a depth map and a label image; plus silhouette
// statistics.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "pipeline/render/camera.h"
#include "species/geometry/mesh.h"
#include "species/geometry/tube_mesh.h"
#include "species/model/tree.h"

namespace sylva {

// Label values in label images: 0 background, 1 + branch order for the shoot's wood (at most
// 253), 254 the root system's wood, 255 leaves.
constexpr uint8_t kLabelBackground = 0;
constexpr uint8_t kLabelRoot = 254;
constexpr uint8_t kLabelLeaf = 255;
inline uint8_t woodLabel(int order) { return static_cast<uint8_t>(std::clamp(order + 1, 1, 253)); }
// The label of the segment ending at `node`: root wood, or shoot wood of the node's order.
inline uint8_t segmentLabel(const SkeletonNode& node) {
    return node.part == kRootPart ? kLabelRoot : woodLabel(node.order);
}

// Label colours for looking at trees (contact sheets, previews): white background, the trunk
// dark brown, branch orders 1–5 orange, blue, purple, teal, magenta (repeating above), roots
// dark red, leaves green. RGB.
struct Rgb {
    uint8_t r, g, b;
};
Rgb labelColour(uint8_t label);
// A label image as RGB (3 bytes per pixel) in those colours.
std::vector<uint8_t> colourLabels(const std::vector<uint8_t>& labels);

struct ViewImage {
    int width = 0, height = 0;
    std::vector<uint8_t> silhouette;  // 0 background, 255 tree; row-major, row 0 at the top
    std::vector<float> depth;         // metres along the view axis; 0 = background
    std::vector<uint8_t> labels;      // 0 background, 1 + branch order for wood, 255 leaves
    std::vector<uint16_t> ids;        // renderScene: instance id of the nearest surface
};

// Options of the renderer beyond the camera.
struct RenderOptions {
    // [views] min_width_px. 0 (default): the views show the mesh and nothing else. > 0: every
    // skeleton segment is also drawn as a line at least this many pixels wide (a pixel is
    // covered when the projected axis passes within min_width_px / 2 of its centre, at the
    // depth of the nearest such axis point), so twigs thinner than a pixel stay unbroken lines.
    // 1.415 (just over √2) covers every pixel the axis passes through.
    double minWidthPx = 0.0;
};

// Renders one view of a tree whose branch tubes are already made: `wood` and `woodNodes` as
// tubeMesh(tree, tubes, &woodNodes) returns them (the views of one tree share them). A pixel is
// drawn iff its centre is inside a triangle of the tubes or of a leaf outline (edges
// inclusive: a binary mask, no anti-aliasing): the triangles of `wood` (float positions, as
// written) and each leaf's outline triangles (the same as leafMesh's). Depth: the nearest
// triangle along the pixel-centre ray, perspective-correct. Labels: segmentLabel of the node a
// tube triangle sweeps to, kLabelLeaf for leaves. Deterministic whatever the thread count.
ViewImage renderView(const Tree& tree, const Mesh& wood, const std::vector<int32_t>& woodNodes,
                     const Camera& camera, bool wantDepth, bool wantLabels,
                     const RenderOptions& options = {});
// renderView for each camera, byte for byte, sharing the work that does not depend on the
// camera (the leaves' outline points, the labels per node).
std::vector<ViewImage> renderViews(const Tree& tree, const Mesh& wood,
                                   const std::vector<int32_t>& woodNodes,
                                   const std::vector<Camera>& cameras, bool wantDepth,
                                   bool wantLabels, const RenderOptions& options = {});

// Many objects in one z-buffer pass (a plot's trees, terrain and ground cover), `tree` and
// `wood` holding all of them (nodes, leaves and tube triangles concatenated; non-tree surfaces
// such as the terrain as wood triangles of a node of their own): the caller's label per node
// (the wood ending there) and per leaf, and an instance id per node and per leaf. Internal
// labels must be ≥ 1 (0 is the background). The same rasteriser and rules as renderView; equal
// depths go to the lower label, then to the lower id. With wantIds, `ids` holds the id of the
// nearest surface per pixel (0 where nothing is drawn). Deterministic whatever the thread count.
struct SceneLabels {
    std::vector<uint8_t> nodeLabels;  // per node of `tree`
    std::vector<uint16_t> nodeIds;    // per node
    std::vector<uint8_t> leafLabels;  // per leaf
    std::vector<uint16_t> leafIds;    // per leaf
};
ViewImage renderScene(const Tree& tree, const Mesh& wood, const std::vector<int32_t>& woodNodes,
                      const SceneLabels& labels, const Camera& camera, bool wantDepth,
                      bool wantLabels, bool wantIds, const RenderOptions& options = {});

// renderScene over objects drawn one after another into one z-buffer (a plot's trees, terrain
// and ground cover, each a tree of its own with its tubes and labels), so no merged copy of them
// is made: each draw() is renderScene's pass over one object. A pixel keeps the nearest surface,
// equal depths going to the lower label, then to the lower id — a total order — so the image
// does not depend on the order of the draws and is byte for byte renderScene's of the objects
// merged into one (PlotViews.TreeByTreeEqualsTheMergedScene).
class SceneCanvas {
  public:
    explicit SceneCanvas(const Camera& camera, const RenderOptions& options = {});
    void draw(const Tree& tree, const Mesh& wood, const std::vector<int32_t>& woodNodes,
              const SceneLabels& labels);
    // The image (as renderScene returns it); the canvas is spent.
    ViewImage finish(bool wantDepth, bool wantLabels, bool wantIds);

  private:
    Camera camera_;
    RenderOptions options_;
    std::vector<float> zbuf_;
    std::vector<uint8_t> lbuf_;
    std::vector<uint16_t> ibuf_;
};

// The same, making the tubes first (tubeMesh(tree, tubes)): for one-off views.
ViewImage renderView(const Tree& tree, const Camera& camera, bool wantDepth, bool wantLabels,
                     const TubeOptions& tubes = {}, const RenderOptions& options = {});

// Silhouette statistics.
double silhouetteCoverage(const ViewImage& view);    // fraction of tree pixels
double boxCountingDimension(const ViewImage& view);  // slope of log N(s) vs log 1/s
// Leaf pixels over tree pixels of the label images of all views; NaN without label images or
// without tree pixels.
double leafPixelFraction(const std::vector<ViewImage>& views);

}  // namespace sylva
