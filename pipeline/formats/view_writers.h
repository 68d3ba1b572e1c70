// Per-view files: the nerfstudio / instant-ngp transforms.json, grey PNGs, depth EXRs, labelled
// point clouds, contact sheets and skeleton previews. Formats are described at the top of
// view_writers.cpp. Every file is written atomically (temp name + rename).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pipeline/render/camera.h"
#include "pipeline/render/colour_render.h"
#include "pipeline/render/render.h"
#include "species/model/tree.h"

namespace sylva {

// The files of an instance's views, paths relative to the instance directory, one per camera
// (an empty list: not written).
struct ViewFiles {
    std::vector<std::string> images;    // silhouettes: file_path, and mask_path (nerfstudio)
    std::vector<std::string> depthExr;  // depth_file_path (nerfstudio: float metres)
    std::vector<std::string> depthPng;  // depth_path (instant-ngp: uint16 × integer_depth_scale)
    std::vector<std::string> labels;    // label_file_path
    // Colour pictures: file_path (the training images) when given, the silhouettes staying
    // mask_path; each frame also records its light (colour_render.h ColourLight).
    std::vector<std::string> colour;
    std::vector<ColourLight> lights;
    double integerDepthScale = 0.0;  // metres per PNG unit, with depthPng
};

// transforms.json (nerfstudio / instant-ngp) for the views of one instance; `placement` gives
// instant-ngp's scale and offset (camera.h ngpPlacement).
nlohmann::json transformsJson(const std::vector<Camera>& cameras, const ViewFiles& files,
                              const NgpPlacement& placement);

// Writers (atomic: temp name + rename), and the bytes each writes.
void writeGreyPng(const std::filesystem::path& path, int width, int height,
                  const std::vector<uint8_t>& pixels);
std::string greyPngBytes(int width, int height, const std::vector<uint8_t>& pixels);
// half: the channel as 16-bit half floats; zip: ZIP compression, else RLE (image_codecs.h).
void writeDepthExr(const std::filesystem::path& path, int width, int height,
                   const std::vector<float>& depth, bool half = false, bool zip = false);
std::string depthExrBytes(int width, int height, const std::vector<float>& depth, bool half,
                          bool zip = false);

// A colour picture's bytes: an RGBA PNG (sRGB, straight alpha), or with `jpeg` a JPEG of its RGB
// at `quality` (1–100; opaque backgrounds only: the alpha is dropped).
std::string encodeColourImage(const ColourImage& image, bool jpeg, int quality);
// All colour views of an instance tiled in a grid, over white (RGB PNG).
void writeColourContactSheet(const std::filesystem::path& path,
                             const std::vector<ColourImage>& images, int columns);

// 16-bit depth PNGs (instant-ngp's depth_path): value v ↔ depth v × integer_depth_scale metres,
// 0 = no hit. The scale (metres per unit) is 0.001 — millimetres, nerfstudio's default depth
// unit — when every depth of the instance rounds to at most 65535 mm (65.535 m), else the
// smallest of 2, 5, 10, 20, 50, … mm that holds the farthest hit (2 mm: 131 m, 5 mm: 327 m);
// the rounding error is at most half a unit.
double integerDepthScale(const std::vector<ViewImage>& views);
// round(depth / scale) (halves up), 0 where depth is not > 0, at least 1 where it is. Throws
// std::invalid_argument when a depth needs more than 65535 units.
std::vector<uint16_t> depthToUnits(const std::vector<float>& depth, double scale);
void writeDepthPng(const std::filesystem::path& path, int width, int height,
                   const std::vector<float>& depth, double scale);
std::string depthPngBytes(int width, int height, const std::vector<float>& depth, double scale);
// Depth maps back-projected to world points: binary PLY with float x y z, uchar label,
// uchar view.
std::string pointCloudPly(const std::vector<Camera>& cameras, const std::vector<ViewImage>& views);
// All views of an instance tiled in a grid (silhouettes, black tree on white).
void writeContactSheet(const std::filesystem::path& path, const std::vector<ViewImage>& views,
                       int columns);
// A species' contact sheet (contact/<species>.png): one tile per instance directory, its
// first view (views/000_rgb.png over white, else views/000_label.png in label colours, else
// views/000.png), each view shown at
// least kSpeciesSheetMinTile pixels wide so a twig can be seen. RGB PNG.
constexpr int kSpeciesSheetMinTile = 256;
// An instance's files by their path in its directory ("views/000.png"): the bytes, or nullopt
// when it has none such (a directory on disk, or a packed instance's tar members: pack.h).
using InstanceFileReader = std::function<std::optional<std::string>(const std::string& relPath)>;
InstanceFileReader instanceDirReader(const std::filesystem::path& dir);
void writeSpeciesSheet(const std::filesystem::path& path,
                       const std::vector<InstanceFileReader>& instances);
void writeSpeciesSheet(const std::filesystem::path& path,
                       const std::vector<std::filesystem::path>& instanceDirs);

// One view of the tree in label colours (render.h labelColour), an RGB PNG of size × size
// pixels: a perspective camera at azimuth 0 (looking along −z), 10° above the horizon,
// framing the tree as the dataset views do (`sylva grow`'s preview). `wood` and `woodNodes`:
// the tree's tubes as tubeMesh (tube_mesh.h) makes them with default options, when the caller
// has them (`sylva grow` draws three previews from one mesh); the first form makes them.
void writeLabelPreviewPng(const Tree& tree, const std::filesystem::path& path, int size);
void writeLabelPreviewPng(const Tree& tree, const Mesh& wood, const std::vector<int32_t>& woodNodes,
                          const std::filesystem::path& path, int size);

// The same view as a colour picture (colour_render.h) of the tree in `look`, over white, the
// exposure metering the tree, 4 samples per pixel, its light drawn from `seed`: an RGB PNG of
// size × size pixels (`sylva grow`'s preview_rgb.png).
void writeColourPreviewPng(const Tree& tree, const Mesh& wood,
                           const std::vector<int32_t>& woodNodes, const Look& look, uint64_t seed,
                           const std::filesystem::path& path, int size);

// renderPreview() (pipeline/render/preview.h) written as an 8-bit greyscale PNG, atomically
// (temp sibling + rename; never a torn file). Creates parent directories. Throws
// std::runtime_error on I/O failure.
void writePreviewPng(const Tree& tree, const std::filesystem::path& path, int sizePixels = 1024);

}  // namespace sylva
