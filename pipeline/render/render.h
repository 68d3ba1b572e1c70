// A CPU renderer of one view: the skeleton's tapered capsules and the leaves, z-buffered
// into a silhouette, a depth map and a label image; plus silhouette statistics.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "pipeline/render/camera.h"
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
};

// Renders one view: every skeleton segment as a tapered capsule (its screen radius at least
// √½ px, so sub-pixel twigs still appear as unbroken lines) and every leaf as the triangles of
// its outline (the same triangles as the mesh's leaves), z-buffered. Deterministic whatever the
// thread count.
ViewImage renderView(const Tree& tree, const Camera& camera, bool wantDepth, bool wantLabels);

// Silhouette statistics.
double silhouetteCoverage(const ViewImage& view);    // fraction of tree pixels
double boxCountingDimension(const ViewImage& view);  // slope of log N(s) vs log 1/s
// Leaf pixels over tree pixels of the label images of all views; NaN without label images or
// without tree pixels.
double leafPixelFraction(const std::vector<ViewImage>& views);

}  // namespace sylva
