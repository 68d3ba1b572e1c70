// Per-view files: the nerfstudio / instant-ngp transforms.json, grey PNGs, depth EXRs, labelled
// point clouds, contact sheets and skeleton previews. Formats are described at the top of
// view_writers.cpp. Every file is written atomically (temp name + rename).
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pipeline/render/camera.h"
#include "pipeline/render/render.h"
#include "species/model/tree.h"

namespace sylva {

// transforms.json (nerfstudio / instant-ngp) for the views of one instance; file paths
// relative to the instance directory.
nlohmann::json transformsJson(const std::vector<Camera>& cameras,
                              const std::vector<std::string>& imagePaths,
                              const std::vector<std::string>& depthPaths,
                              const std::vector<std::string>& labelPaths);

// Writers (atomic: temp name + rename).
void writeGreyPng(const std::filesystem::path& path, int width, int height,
                  const std::vector<uint8_t>& pixels);
void writeDepthExr(const std::filesystem::path& path, int width, int height,
                   const std::vector<float>& depth);
// Depth maps back-projected to world points: binary PLY with float x y z, uchar label,
// uchar view.
std::string pointCloudPly(const std::vector<Camera>& cameras, const std::vector<ViewImage>& views);
// All views of an instance tiled in a grid (silhouettes, black tree on white).
void writeContactSheet(const std::filesystem::path& path, const std::vector<ViewImage>& views,
                       int columns);
// A species' contact sheet (contact/<species>.png): one tile per instance directory, its
// first view (views/000_label.png in label colours, else views/000.png), each view shown at
// least kSpeciesSheetMinTile pixels wide so a twig can be seen. RGB PNG.
constexpr int kSpeciesSheetMinTile = 256;
void writeSpeciesSheet(const std::filesystem::path& path,
                       const std::vector<std::filesystem::path>& instanceDirs);

// One view of the tree in label colours (render.h labelColour), an RGB PNG of size × size
// pixels: a perspective camera at azimuth 0 (looking along −z), 10° above the horizon,
// framing the tree as the dataset views do (`sylva grow`'s preview).
void writeLabelPreviewPng(const Tree& tree, const std::filesystem::path& path, int size);

// renderPreview() (pipeline/render/preview.h) written as an 8-bit greyscale PNG, atomically
// (temp sibling + rename; never a torn file). Creates parent directories. Throws
// std::runtime_error on I/O failure.
void writePreviewPng(const Tree& tree, const std::filesystem::path& path, int sizePixels = 1024);

}  // namespace sylva
