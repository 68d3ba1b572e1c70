// Multi-view outputs: cameras framed to the tree's bounding sphere, a CPU renderer of the
// skeleton's tapered capsules and the leaf cards (silhouette, depth, labels), the
// nerfstudio / instant-ngp transforms.json, labelled point clouds and contact sheets.
// Frame: world +y up, metres. Cameras follow the OpenGL / nerfstudio convention: in camera
// space the camera looks along −z with +y up; transform_matrix is camera-to-world.
#pragma once

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "species/tree.h"
#include "volumes/rng.h"

namespace sylva {

struct ViewOptions {
    int count = 0;                          // cameras per instance; 0 = no views
    std::vector<double> elevationsDeg{20};  // cycled over the cameras, or …
    bool elevationRange = false;            // … spread evenly from elevationsDeg[0] to [1]
    bool randomAzimuth = true;              // azimuth offset drawn per instance …
    double azimuthOffsetDeg = 0.0;          // … or this fixed offset; cameras 360°/count apart
    bool orthographic = false;
    double fovDeg = 40.0;           // vertical field of view (perspective)
    int width = 256, height = 256;  // pixels
    double margin = 1.05;           // bounding sphere radius × margin fills the frame
    bool depth = false;             // depth EXR per view
    bool labels = false;            // label PNG per view
    bool pointCloud = false;        // labelled point cloud PLY per instance (needs depth)
    bool contactSheet = true;       // all views tiled, per instance
};

struct Camera {
    int width = 0, height = 0;
    bool orthographic = false;
    double fovY = 0.0;                // radians (perspective)
    double orthoHeight = 0.0;         // metres spanned vertically (orthographic)
    double cameraToWorld[4][4] = {};  // OpenGL convention (looks along −z)
    double azimuthDeg = 0.0, elevationDeg = 0.0;
    // Pixel focal lengths and principal point (perspective; for orthographic fx = fy =
    // pixels per metre).
    double fx() const;
    double fy() const;
    double cx() const { return width * 0.5; }
    double cy() const { return height * 0.5; }
    // World point → pixel (x right, y down, continuous; pixel centres at +0.5) and depth
    // along the view axis in metres (positive in front). False if behind the camera.
    bool project(const Vec3& world, double& px, double& py, double& depth) const;
    // Pixel + depth along the view axis → world point.
    Vec3 unproject(double px, double py, double depth) const;
};

// Cameras around the tree: evenly spaced azimuths (+ offset), elevations per options, all
// looking at the centre of the bounding sphere of skeleton (with radii) and leaves, at a
// distance that frames that sphere. rng is used only for a random azimuth offset.
std::vector<Camera> makeCameras(const Tree& tree, const ViewOptions& options, Rng& rng);

// Label values in label PNGs.
constexpr uint8_t kLabelBackground = 0;
constexpr uint8_t kLabelLeaf = 255;
inline uint8_t woodLabel(int order) { return static_cast<uint8_t>(std::min(order + 1, 254)); }

struct ViewImage {
    int width = 0, height = 0;
    std::vector<uint8_t> silhouette;  // 0 background, 255 tree; row-major, row 0 at the top
    std::vector<float> depth;         // metres along the view axis; 0 = background
    std::vector<uint8_t> labels;      // 0 background, 1 + branch order for wood, 255 leaves
};

// Renders one view: every skeleton segment as a tapered capsule (its screen radius at least
// √½ px, so sub-pixel twigs still appear as unbroken lines) and every leaf card as two triangles,
// z-buffered. Deterministic whatever the thread count.
ViewImage renderView(const Tree& tree, const Camera& camera, bool wantDepth, bool wantLabels);

// Silhouette statistics.
double silhouetteCoverage(const ViewImage& view);    // fraction of tree pixels
double boxCountingDimension(const ViewImage& view);  // slope of log N(s) vs log 1/s

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

}  // namespace sylva
