// Guides for the `space-colonization` method (Liu et al. 2020 §4.3): persistent markers from
// brush strokes (Figs 11–13) and from a silhouette mask (Fig. 15). The generators are plain
// functions of plain structs (testable without TOML); parseGuides reads a species' [guides]
// table into markers.
//
// Frame: +y up, metres, the tree's root at the origin.
//
// Brush strokes. A stroke is a 3-D polyline with a radius: round(density × polyline length)
// markers are drawn uniformly in the union of the capsules of radius `radius` about its
// segments (density is markers per metre of stroke, so a thicker brush spreads the same markers
// more thinly). Each marker records d, its distance to the polyline, and v_stroke, the unit
// drawing direction (first point → last) of its nearest segment; its weight is
//   ω = weight · exp(−d²/2σ²) / √(2π)
// — the paper's normal density with d measured in units of σ (σ metres, default radius / 2).
// Measuring d in σ keeps ω free of the length unit: the paper's 1/(√(2π)σ) with σ in metres
// would make a centimetre-wide brush pull a hundred times harder than a metre-wide one. ω is
// 0.399·weight on the stroke and 0.054·weight at d = 2σ (the brush's edge by default).
//
// Silhouette. A binary mask drawn as seen from azimuth a (degrees about +y; a = 0 is the x–y
// plane seen from +z, as in volumes/mask.h's MaskView): image columns run along
// (cos a, 0, −sin a), rows down −y, the bottom edge at y = 0 and the axis column on the y axis;
// the view direction (toward the viewer) is (sin a, 0, cos a). Every masked pixel gets
// markers_per_pixel markers (fractions carried from pixel to pixel, so the total is
// floor(markers_per_pixel × masked pixels)), each at the pixel centre plus a uniform offset in
// a ball of radius r_m(x) = R·(1/(1 + e^(−k·n_x)) − 0.5) pixels (Liu 2020 §4.3; n_x = unmasked
// pixels in the 5×5 neighbourhood), plus a uniform offset along the view direction: in
// [−depth/2, depth/2] for depth_profile = "slab" (the paper's single view; a slab-like crown),
// or for "round" in [−s/2, s/2] with s = depth · (e_row / e_max) · √(1 − t²), where e_row is the
// row's half extent (leftmost to rightmost masked pixel edge), e_max the widest row's and t the
// pixel centre's offset from the row's middle in units of e_row: every horizontal section is
// an ellipse as wide as the drawing and depth · e_row / (2·e_max) deep, so the crown narrows
// from the side and from above where the drawing does (markers crowd toward each row's ends,
// where the chord is short). Deep inside (n_x = 0) r_m = 0 and markers sit on the pixel centres;
// toward the border r_m grows (n_x = 5 on a straight edge: 0.38·R, a corner more) up to R/2, so
// markers spill past the outline and thin out there: the border is soft, not a cut. Silhouette
// markers carry no direction and weight 0: they only offer space.
#pragma once

#include <vector>

#include "core/params.h"
#include "core/rng.h"
#include "species/methods/space_colonization.h"
#include "volumes/mask.h"

namespace sylva {

struct BrushStroke {
    std::vector<Vec3> points;  // metres, ≥ 2, drawn first to last
    double radius = 0.0;       // metres: markers lie within it of the polyline (required)
    double density = 0.0;      // markers per metre of polyline length (required)
    double sigma = 0.0;        // metres, ω's σ; ≤ 0 means radius / 2
    double weight = 1.0;       // multiplies ω
};

// Markers of one stroke: round(density × length), uniform in the union of the segments'
// capsules (each candidate drawn in one capsule is kept only if that segment is its nearest,
// ties to the lower index, so overlapping capsules at joints are not counted twice). Requires
// ≥ 2 points, radius > 0; zero-length segments are skipped (a stroke of length 0 gives none).
std::vector<GuideMarker> strokeMarkers(const BrushStroke& stroke, Rng& rng);

// Distance from p to the polyline and the index of the nearest segment (ties to the lower
// index; zero-length segments count as points). Exposed for tests.
struct NearestSegment {
    double distance = 0.0;
    size_t segment = 0;
};
NearestSegment nearestSegment(const std::vector<Vec3>& polyline, const Vec3& p);

// ω for a marker at distance d (metres) from a stroke: weight · exp(−d²/2σ²) / √(2π).
double strokeWeight(double d, double sigma, double weight);

struct SilhouetteGuide {
    Mask mask;
    double metresPerPixel = 0.01;
    double azimuthDeg = 0.0;   // the view, degrees about +y (see the file comment)
    double axisColumn = -1.0;  // pixels; < 0 means width / 2
    MaskFalloff falloff;       // R = 10 px, k = 0.4 (`enabled` false: r_m = 0 everywhere)
    double markersPerPixel = 1.0;
    double depth = -1.0;  // metres, full spread along the view direction; < 0: width·mpp / 2
    // kSlab: every pixel spreads over the full depth; kRound: elliptical horizontal sections
    // scaled by each row's extent (see the file comment).
    enum class DepthProfile { kSlab, kRound } depthProfile = DepthProfile::kSlab;
};

// The tree-frame position of image point (column, row) (pixels, fractional; pixel centres at
// +0.5) at `depth` metres toward the viewer.
Vec3 silhouetteToTree(const SilhouetteGuide& g, double column, double row, double depth);

// Markers around every masked pixel (see the file comment). Deterministic for a given rng.
std::vector<GuideMarker> silhouetteMarkers(const SilhouetteGuide& guide, Rng& rng);

// Reads a species' [guides] table. Its keys, units, defaults and ranges are documented in
// docs/methods/space-colonization.md (tests/project/spec_keys_test.cpp checks them against this
// reader); defaults are BrushStroke's and SilhouetteGuide's.
//
// Stroke i draws from rng.derive("strokes[i]"), the silhouette from rng.derive("silhouette"), so
// adding a stroke changes no other guide's markers. Errors go through Params (file:line:col
// and key path). Reads every key of `guides` and calls guides.finish().
std::vector<GuideMarker> parseGuides(Params& guides, Rng& rng);

}  // namespace sylva
