// Silhouette masks as crown volumes (Liu et al. 2020, §4.3 "Silhouette based modeling"): a
// binary image of the crown's outline, read through OpenImageIO, becomes a volume either by
// revolving its half-profile about its vertical axis (makeMaskRevolution) or as the visual
// hull of two or more masks seen from known azimuths (makeVisualHull). Samples drawn from
// either soften toward the mask's border with the paper's logistic fall-off (MaskFalloff).
//
// Image frame: pixel (column c, row r) covers columns [c, c+1) and rows [r, r+1), row 0 at
// the top. World frame: +y up, metres; the image's bottom edge is at height 0 and its axis
// column (pixels, may be fractional) on the world y axis.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/math.h"
#include "volumes/revolution.h"
#include "volumes/volume.h"

namespace sylva {

// A mask that cannot be used (missing or unreadable file, no inside pixel); one-line message.
class MaskError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

// A binary image, row-major, top row first: on[row * width + column] is 1 inside, else 0.
struct Mask {
    int width = 0, height = 0;
    std::vector<uint8_t> on;

    bool at(int column, int row) const {
        return column >= 0 && row >= 0 && column < width && row < height &&
               on[static_cast<size_t>(row) * width + column] != 0;
    }
    size_t count() const;  // inside pixels
};

// Reads a mask through OpenImageIO: a pixel is inside when its grey value — the alpha channel
// if the image has one, else Rec.709 luminance of RGB, else the first channel — is ≥ 0.5;
// `invert` flips that (black drawings on white). Throws MaskError for a missing or unreadable
// file and for a mask with no inside pixel.
Mask readMask(const std::string& path, bool invert);

// --- Distance transforms (Felzenszwalb & Huttenlocher 2012, exact 1-D lower envelopes) -----

// Squared Euclidean distance, in pixels², from every pixel centre to the nearest centre of a
// pixel with feature[i] != 0 (+infinity when there is none). Row-major like Mask::on.
std::vector<double> squaredDistanceTransform(int width, int height,
                                             const std::vector<uint8_t>& feature);

// Exact signed distance, in pixels, from every pixel centre to the boundary of the mask seen
// as the union of its inside pixel squares (negative inside; outside the image is outside).
std::vector<double> signedDistancePixels(const Mask& mask);

// --- Liu 2020 §4.3 logistic fall-off -----------------------------------------------------------

struct MaskFalloff {
    bool enabled = true;   // soft_edge: false gives uniform samples
    double radius = 10.0;  // R, pixels: the largest jitter radius is R/2 (n_x → ∞)
    double k = 0.4;        // steepness of the logistic in n_x
};

// n_x for every pixel: how many of the 5×5 pixels centred on it are NOT inside the mask
// (pixels beyond the image count as not inside), 0..25.
std::vector<uint8_t> unmaskedNeighbourCounts(const Mask& mask);

// r_m(x) = R·(1/(1 + e^(−k·n_x)) − 0.5), pixels: 0 deep inside (n_x = 0), growing
// monotonically toward R/2 as more of the neighbourhood lies outside. The paper prints
// 1/(1 − e^(−k·n_x)), which is infinite at n_x = 0 and decreasing; the logistic
// 1/(1 + e^(−k·n_x)) is what "a logistic function" describes.
double falloffRadius(int unmaskedNeighbours, const MaskFalloff& falloff);

// Signed distance as signedDistancePixels on the mask padded by one outside pixel all round,
// (width + 2) × (height + 2): mask pixel (c, r) is padded pixel (c + 1, r + 1).
std::vector<double> paddedSignedDistancePixels(const Mask& mask);

// A uniform point in the ball of `radius` about the origin (the fall-off's spread).
Vec3 uniformInBall(Rng& rng, double radius);

// --- Mask revolution -------------------------------------------------------------------------

enum class ProfileSide { kRight, kLeft, kMax };

// The half-profile of a mask about the vertical line at `axisColumn`: for every row holding
// inside pixels on the chosen side, the distance from the axis to the farthest inside pixel
// edge on that side (the larger of both for kMax), at the row's centre height, bottom to top.
// Rows without inside pixels on that side are skipped. The stroke starts on the axis at the
// bottom edge of the lowest row, steps out to that row's extent, and ends at the highest row's
// extent then back on the axis at its top edge, so the solid spans the mask's rows exactly and
// flat tops and bottoms stay flat. Metres: x = radius, y = height above the image's bottom
// edge. Throws MaskError when no row has inside pixels on that side.
std::vector<Vec2> maskHalfProfile(const Mask& mask, double axisColumn, ProfileSide side,
                                  double metresPerPixel);

struct MaskRevolutionOptions {
    double axisColumn = -1.0;  // pixels; < 0 means the image's centre column, width / 2
    ProfileSide side = ProfileSide::kMax;
    double metresPerPixel = 0.01;
    StrokeCleaning cleaning;             // resampling and smoothing of the half-profile
    int segments = kRevolutionSegments;  // steps around the axis
    double voxelSize = 0.0;              // metres; ≤ 0: the profile's largest dimension / 100
    MaskFalloff falloff;
};

// The mask's half-profile, cleaned (cleanStroke) and revolved about local +y
// (makeRevolution). Inside tests, distances, bounds and measure are the revolution's; sample()
// softens toward the border with the fall-off evaluated on the meridian section (the profile's
// extent per row, mirrored about the axis). Throws MaskError or StrokeError.
VolumePtr makeMaskRevolution(const Mask& mask, const MaskRevolutionOptions& options);

// --- Visual hull -----------------------------------------------------------------------------

// One orthographic view of the crown, seen horizontally from azimuth a (degrees about +y;
// a = 0 looks along −z from the +z side). The image's columns run along the horizontal
// perpendicular (cos a, 0, −sin a) (the viewer's right), its rows along −y; the axis column is
// on the world y axis and the image's bottom edge at height 0.
struct MaskView {
    Mask mask;
    double azimuthDeg = 0.0;
    double metresPerPixel = 0.01;
    double axisColumn = 0.0;  // pixels
};

// The intersection of the views' extrusions: a point is inside iff every view projects it onto
// an inside pixel. signedDistance is the largest of the views' 2-D signed distances (exact at
// pixel centres, Lipschitz-bounded between them; metres): a conservative bound with the exact
// sign. bounds() and measure() are exact for the pixel model: the hull is cut into prisms
// (a convex polygon × a height band between consecutive row edges of any view), which also
// make the uniform draw in sample() exact. The fall-off uses the largest r_m among the views.
// Returns an empty volume (empty bounds, measure 0) when the extrusions do not meet. Safe for
// concurrent readers.
VolumePtr makeVisualHull(std::vector<MaskView> views, const MaskFalloff& falloff);

}  // namespace sylva
