// Cameras around a tree for its views: the [views] options, the camera model and its framing
// of the tree's bounding sphere.
// Frame: world +y up, metres. Cameras follow the OpenGL / nerfstudio convention: in camera
// space the camera looks along −z with +y up; transform_matrix is camera-to-world.
#pragma once

#include <vector>

#include "core/math.h"
#include "core/rng.h"
#include "species/model/tree.h"

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
    bool depth = false;             // depth EXR per view (float metres; nerfstudio, Blender)
    bool depthHalf = false;         // the depth EXR's channel as 16-bit half floats
    bool depthZip = false;          // the depth EXR ZIP-compressed (else RLE)
    bool depthPng = false;          // 16-bit depth PNG per view (instant-ngp)
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
    // The same with fx() given: for many points of one camera (fx() takes a tangent).
    Vec3 unproject(double px, double py, double depth, double focal) const;
};

// Cameras around the tree: evenly spaced azimuths (+ offset), elevations per options, all
// looking at the centre of the bounding sphere of skeleton (with radii) and leaves, at a
// distance that frames that sphere. rng is used only for a random azimuth offset.
std::vector<Camera> makeCameras(const Tree& tree, const ViewOptions& options, Rng& rng);

// The sphere makeCameras frames: centre of the axis-aligned box of every node sphere and
// leaf-card corner, radius the largest distance from it to any of them (metres; a tree with
// no extent gets radius 1).
struct BoundingSphere {
    Vec3 centre;
    double radius = 1.0;
};
BoundingSphere treeBoundingSphere(const Tree& tree);
// makeCameras around `sphere` (treeBoundingSphere(tree)), for a caller that needs it too.
std::vector<Camera> makeCameras(const BoundingSphere& sphere, const ViewOptions& options, Rng& rng);

// How instant-ngp's loader (src/nerf_loader.cu, nerf_matrix_to_ngp) places the scene: a
// transforms.json position p (metres, sylva's axes) becomes p · scale + offset, whose axes it
// then cycles (x, y, z) → (y, z, x); the scene is the unit cube [0, 1]³ (× aabb_scale about
// its centre, 0.5). ngpPlacement centres the tree's bounding sphere at (0.5, 0.5, 0.5) and
// scales its diameter × kNgpCubeMargin to 1: every point of the tree lands inside the cube
// (the box of the sphere holds it), with a 2.4% margin on each side, and the cameras, which
// aim at the sphere's centre, see the cube's centre at their image centre. Depth maps scale
// with the same factor in the loader (depth × integer_depth_scale × scale).
constexpr double kNgpCubeMargin = 1.05;
struct NgpPlacement {
    double scale = 1.0;  // cube units per metre
    Vec3 offset;         // cube units, in sylva's axes (added before the axis cycle)
};
NgpPlacement ngpPlacement(const Tree& tree);
// The same for any sphere (a plot's: plot_render.h).
NgpPlacement ngpPlacement(const BoundingSphere& sphere);

}  // namespace sylva
