// Colour pictures of a tree: Embree ray casting of the very triangles the masks are rasterised
// from (the branch tubes and the leaves' outlines), shaded with the species' look
// (species/model/look.h) under a sun with hard shadows and a sky seen through ambient-occlusion
// rays, leaves letting light through, several samples per pixel, sRGB out.
//
// Registered with the views: one camera, one mask. A pixel's first sample is its centre, the
// mask's own sample, and its coverage is the mask's; the further samples (anti-aliasing) are
// cast only in pixels of the mask and their 8 neighbours. So a pixel of alpha 1 is a tree pixel
// of the mask, every tree pixel of the mask has alpha > 0, and partial alpha lies on and next to
// the mask's edge (ColourViews tests).
//
//   ColourScene scene(tree, wood, leaves, look, seed);   // one BVH per tree, all its views …
//   ColourImage rgba = scene.render(camera, view, options, Rng(seed).derive("colour").derive(k));
//
// Deterministic: a pixel's samples and rays are drawn from the view's stream keyed by the pixel,
// so the image is the same bytes whatever the thread count.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/rng.h"
#include "pipeline/render/camera.h"
#include "pipeline/render/render.h"
#include "species/geometry/mesh.h"
#include "species/model/look.h"
#include "species/model/tree.h"

namespace sylva {

enum class ColourBackground : uint8_t {
    kTransparent,  // alpha 0 where nothing is hit (RGBA)
    kColour,       // a flat colour, alpha 1
    kSky,          // the sky and a ground plane under the tree, its shadow on it, alpha 1
};

// The [views] colour options (docs/specs.md "[views]").
struct ColourOptions {
    bool enabled = false;  // colour: an NNN_rgb image per view
    int samples = 4;       // colour_samples: samples per pixel (the centre and samples − 1 more)
    int aoRays = 4;        // colour_ao_rays: near sky rays per estimate (per small leaf side
                           // and wood vertex, once per scene; per pixel on the rest)
    ColourBackground background = ColourBackground::kTransparent;
    LinearRgb backgroundColour{1, 1, 1};       // colour_background_colour
    double sunElevationDeg[2] = {25.0, 65.0};  // colour_sun_elevation_deg: drawn per view
    bool unlit = false;                        // colour_lighting = "none": albedo pictures
    bool autoExposure = true;                  // colour_auto_exposure: meter the tree
    double exposureEv[2] = {-0.3, 0.3};        // colour_exposure_ev: drawn per view
    bool jpeg = false;                         // colour_format = "jpg" (else "png")
    int jpegQuality = 92;                      // colour_jpeg_quality
};

// What a view's light was (drawn per view; written to transforms.json with the frame).
struct ColourLight {
    Vec3 sunDirection;  // unit, towards the sun
    double sunElevationDeg = 0, sunAzimuthDeg = 0;
    double exposureEv = 0;
    double exposureScale = 1;  // what the light was multiplied by: metering × 2^exposureEv
    double haze = 0;           // 0 a deep blue sky … 1 a pale, hazy one
};

struct ColourImage {
    int width = 0, height = 0;
    std::vector<uint8_t> rgba;  // 4 bytes per pixel, sRGB, straight (not premultiplied) alpha
    ColourLight light;
    // Pixels of the mask whose centre ray found no triangle (an edge the rasteriser and Embree
    // decide differently); they take their other samples' colour.
    int64_t centreMisses = 0;
};

class ColourScene {
  public:
    // `wood` as renderView takes it (tubeMesh's); `leaves` as leafMesh(tree) makes them (front
    // faces are used; Embree hits both sides). `treeSeed` keys the per-leaf variation. Both
    // meshes must outlive the scene.
    ColourScene(const Tree& tree, const Mesh& wood, const Mesh& leaves, const Look& look,
                uint64_t treeSeed);
    // A scene of many objects (a plot): an empty scene, its trees and ground added, then
    // committed once. `leavesAsCards`: `leaves` meshes every leaf as its card ([outputs]
    // leaf_outlines = false). The ground: terrain (earth and grass) and ground cover (grass).
    ColourScene();
    void addTree(const Tree& tree, const Mesh& wood, const Mesh& leaves, const Look& look,
                 uint64_t treeSeed, bool leavesAsCards = false);
    void addGround(const Mesh& terrain, const Mesh& groundCover);
    void commit();
    ~ColourScene();
    ColourScene(const ColourScene&) = delete;
    ColourScene& operator=(const ColourScene&) = delete;

    // One view: `view` is renderView's image of the same camera (its silhouette decides the
    // centre samples' coverage: a tree's mask; with `coverage` instead, those pixels: a plot's
    // surfaces, terrain included). `rng`: the view's own stream.
    ColourImage render(const Camera& camera, const ViewImage& view, const ColourOptions& options,
                       Rng rng, const std::vector<uint8_t>* coverage = nullptr) const;

    // The share of a uniform sky's light (cosine-weighted over the hemisphere about `n`) that
    // reaches `p`: as the renderer estimates it (the sky grid and `nearRays` short rays), and
    // traced by `rays` rays to infinity — the grid's check.
    double skyView(const Vec3& p, const Vec3& n, int nearRays, Rng& rng) const;
    double skyViewTraced(const Vec3& p, const Vec3& n, int rays, Rng& rng) const;

    struct Impl;

  private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace sylva
