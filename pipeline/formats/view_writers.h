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
// A sheet from existing grey PNG files (per-species sheets), each fitted into a `tile`-pixel
// square; inputs are shown as they are (not inverted).
void writeContactSheetFromFiles(const std::filesystem::path& path,
                                const std::vector<std::filesystem::path>& images, int columns,
                                int tile);

// renderPreview() (pipeline/render/preview.h) written as an 8-bit greyscale PNG, atomically
// (temp sibling + rename; never a torn file). Creates parent directories. Throws
// std::runtime_error on I/O failure.
void writePreviewPng(const Tree& tree, const std::filesystem::path& path, int sizePixels = 1024);

}  // namespace sylva
