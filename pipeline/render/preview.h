// Preview drawing of a skeleton: orthographic front view (x right, y up, looking along -z),
// black branches with their thickness on white, in the style of Xu & Mould's figures.
#pragma once

#include <cstdint>
#include <vector>

#include "species/model/tree.h"

namespace sylva {

// Square single-channel raster, row-major, row 0 at the top; 0 = black ink, 255 = white.
// Every segment is a tapered capsule (radius interpolated between its nodes, at least 0.5 px)
// with anti-aliased coverage clamp(r_px + 0.5 - distance, 0, 1); overlapping shapes combine
// by max, so the result is independent of drawing order and thread count. The bounding box
// of the nodes (including radii) is centred with a 4% margin on each side. When the tree has
// a root system, a thin grey ground line is drawn at y = 0. Throws std::invalid_argument
// for size <= 0.
std::vector<uint8_t> renderPreview(const Tree& tree, int sizePixels);

}  // namespace sylva
