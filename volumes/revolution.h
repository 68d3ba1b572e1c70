// Surfaces of revolution of a sketched stroke (Xu & Mould 2012 §3.3.1, Figure 8): the user
// draws a curve beside an axis; the curve, revolved about the axis, encloses the crown.
//
// Profiles are in the meridian half-plane: Vec2{x = distance from the axis (≥ 0), y = height
// along the axis}, metres. The volume's local +y is the axis (tilt it with a Placement).
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/math.h"
#include "volumes/volume.h"

namespace sylva {

// A stroke that cannot be turned into a volume; the message says why in one line.
class StrokeError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

constexpr int kRevolutionSegments = 64;  // steps around the axis, by default

struct StrokeCleaning {
    int samples = 96;              // points after arc-length resampling
    int smoothing = 2;             // Laplacian smoothing passes (the end points stay fixed)
    double closeTolerance = 0.25;  // an end may lie at most this fraction of the stroke's
                                   // largest radius from the axis, or the stroke "never
                                   // reaches the axis"
};

// Cleans a raw stroke: drops repeated points, resamples it evenly by arc length, smooths it,
// and closes it to the axis at both ends (each end joined to the axis by a horizontal
// segment). Returns the closed profile from one axis point to the other. Throws StrokeError
// for fewer than two distinct points, points on the wrong side of the axis (x < 0), a stroke
// that never reaches the axis, a self-intersecting profile, or a profile enclosing no area.
std::vector<Vec2> cleanStroke(const std::vector<Vec2>& stroke, const StrokeCleaning& options);

// A closed triangle mesh (indices counter-clockwise seen from outside).
struct TriangleSoup {
    std::vector<Vec3> points;
    std::vector<std::array<uint32_t, 3>> triangles;
};

// The cleaned profile revolved about local +y with `segments` steps around: a CGAL
// Surface_mesh checked with Polygon Mesh Processing (closed, triangle mesh, no
// self-intersections, outward oriented); throws StrokeError when a check fails.
TriangleSoup revolveProfile(const std::vector<Vec2>& profile, int segments);

// The revolved volume as an OpenVDB level set (MeshToVolume) of voxel size `voxelSize`
// metres: inside tests exact to about a voxel, distances trilinear in the narrow band (±3
// voxels; beyond it ±3 voxels with the right sign). bounds() is the mesh's plus a voxel.
// measure() is closed-form, not a voxel count: Pappus' volume 2π·∫∫x dA of the revolved
// profile polygon times n·sin(2π/n)/2π, the share of each circle the mesh's n-gon
// cross-sections cover (the faceted solid the level set realises). Safe for concurrent readers.
// `profile` is a cleaned one (cleanStroke); throws StrokeError like revolveProfile.
// Memoized: the same profile, voxel size and segments give the same volume (the 8 most
// recently used are kept), so a sketch named twice in a species is built once.
VolumePtr makeRevolution(const std::vector<Vec2>& profile, double voxelSize,
                         int segments = kRevolutionSegments);

// --- Stroke sources --------------------------------------------------------------------------
// All return raw strokes in metres (x from the axis, y up) for cleanStroke.

// The first <path> of an SVG file (its `d` attribute: M/L/H/V/C/S/Q/T/Z, absolute and
// relative; curves flattened), x measured from the vertical line x = axisX (SVG units, y
// down), scaled so the stroke's height is `height` metres with its lowest point at y = 0.
std::vector<Vec2> readSvgStroke(const std::string& path, double axisX, double height);

// A stroke drawn in an image (dark strokes on a light background, or opaque on transparent),
// read through OpenImageIO and traced row by row: for every row holding stroke pixels, the
// one farthest from the axis column `axisColumn` (pixels, may be fractional) gives a point.
// Scaled like readSvgStroke. A stroke pixel is one with alpha > 0.5 when the image has an
// alpha channel that is not opaque everywhere, otherwise one with luminance < 0.5. The trace
// is one point per row (x as a function of height): draw the outer outline, ends near the
// axis.
// Errors of both readers (StrokeError): unreadable file, no <path> / no d / bad path data
// (with the token), arcs, a path in several pieces or crossing the axis, no height, an image
// without stroke pixels. The SVG reader ignores `transform` attributes and the viewBox (the
// scale comes from `height`); curves are flattened with 16 steps each.
std::vector<Vec2> traceStrokeImage(const std::string& path, double axisColumn, double height);

}  // namespace sylva
