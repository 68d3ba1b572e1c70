// Crown volumes: the regions in which growth methods place graph nodes, markers and endpoints.
// Frame: +y up, metres. Every volume answers an inside test and a signed distance
// (negative inside). Distances are exact for single primitives where the header says so;
// for CSG results and non-uniformly scaled volumes they are conservative bounds
// (|reported| ≤ true distance) whose sign is always exact.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/math.h"
#include "core/rng.h"

namespace sylva {

class Volume {
  public:
    virtual ~Volume() = default;

    // Signed distance in metres, negative inside.
    virtual double signedDistance(const Vec3& p) const = 0;
    bool inside(const Vec3& p) const { return signedDistance(p) <= 0.0; }

    // Tight (or slightly loose) world-space bounds of the inside.
    virtual Aabb bounds() const = 0;

    // A uniformly distributed point inside. The default rejects from bounds(); primitives
    // override it with direct sampling. Returns nullopt when maxTries draws all miss.
    virtual std::optional<Vec3> sample(Rng& rng, int maxTries = 100000) const;

    // Volume in cubic metres: closed form for primitives, otherwise a deterministic
    // Monte-Carlo estimate over bounds().
    virtual double measure() const;

    // Short human-readable description, for error messages ("sphere r=2 m").
    virtual std::string describe() const = 0;
};

using VolumePtr = std::shared_ptr<const Volume>;

// Placement of a primitive: its local +y axis is turned onto `axis`, then it is scaled
// (component-wise in the local frame) and moved to `position`.
struct Placement {
    Vec3 position{0, 0, 0};
    Vec3 axis{0, 1, 0};
    Vec3 scale{1, 1, 1};
};

// --- Analytic primitives, in their local frame (+y is the primitive's axis) ---------------
// sphere: centred at the origin. Exact distance.
VolumePtr makeSphere(double radius);
// hemisphere: the y ≥ 0 half of a sphere centred at the origin (a dome). Exact distance.
VolumePtr makeHemisphere(double radius);
// ellipsoid: centred at the origin with semi-axes (rx, ry, rz). Distance is a bound.
VolumePtr makeEllipsoid(const Vec3& radii);
// cylinder: base disc at y = 0, top at y = height. Exact distance.
VolumePtr makeCylinder(double radius, double height);
// cone (frustum when topRadius > 0): base disc at y = 0, top at y = height. Exact distance.
VolumePtr makeCone(double baseRadius, double height, double topRadius = 0.0);
// box: centred at the origin with full edge lengths `size`. Exact distance.
VolumePtr makeBox(const Vec3& size);
// sphere sector (spherical cone): points within `radius` of the origin whose direction lies
// within angle `alpha` (radians, 0 < α ≤ π) of +y — Xu & Mould 2012 §3.3.2 sub-graph volume.
// Exact distance.
VolumePtr makeSphereSector(double radius, double alpha);

// --- Placement and composition ---------------------------------------------------------------
VolumePtr makePlaced(VolumePtr inner, const Placement& placement);
VolumePtr makeUnion(std::vector<VolumePtr> parts);
VolumePtr makeIntersection(std::vector<VolumePtr> parts);
VolumePtr makeDifference(VolumePtr base, std::vector<VolumePtr> cut);

// --- Half-space clips (crown shyness between the trees of a plot) -----------------------------
// The half-space {p : dot(normal, p) ≤ offset}; `normal` is unit.
struct HalfSpace {
    Vec3 normal{1, 0, 0};
    double offset = 0.0;
    double distance(const Vec3& p) const { return dot(normal, p) - offset; }  // > 0: outside
};
// `inner` ∩ every half-space of `cut`: signed distance max(inner, planes) (sign exact), the
// inner volume's bounds, samples by rejection from them.
VolumePtr makeClipped(VolumePtr inner, std::vector<HalfSpace> cut);
// True when p lies in every half-space.
bool insideAll(const std::vector<HalfSpace>& cut, const Vec3& p);
// A crown-shyness bound between two trees of a plot whose crowns share a layer of height
// (species/plot/plot_growth.h): within the layer low ≤ y ≤ high the crown keeps inside the
// half-space; above or below it (where one crown overtops the other) it is free. A grower may
// move the plane back by up to `slack` metres (a ragged edge; GrammarOptions::shyBounds).
struct ShyBound {
    HalfSpace plane;
    double low = 0, high = 0;
    double slack = 0;
    // `tolerance` metres past the plane still hold (a point slid onto it).
    bool holds(const Vec3& p, double tolerance = 0) const {
        return p.y < low || p.y > high || plane.distance(p) <= tolerance;
    }
};
// True when p keeps every bound (within `tolerance` metres).
inline bool keepsAll(const std::vector<ShyBound>& bounds, const Vec3& p, double tolerance = 0) {
    for (const ShyBound& b : bounds) {
        if (!b.holds(p, tolerance)) return false;
    }
    return true;
}

// `inner` ∩ every bound (inside where each holds): the sign of the distance exact, its
// magnitude only a bound near the layers' edges; the inner volume's bounds, samples by
// rejection from them.
VolumePtr makeShyClipped(VolumePtr inner, std::vector<ShyBound> bounds);

// p moved onto the boundary of each half-space it lies outside of, in order (for a point just
// outside a corner of two planes, the second projection may leave it slightly outside the
// first: callers that need it exactly inside test insideAll).
Vec3 projectInside(const std::vector<HalfSpace>& cut, Vec3 p);

// --- OpenVDB realisation -------------------------------------------------------------------
// The volume sampled into a narrow-band OpenVDB level set (FloatGrid) with voxel size
// `voxelSize` metres and a band of `halfWidth` voxels, inside tiles flood-filled, so that
// inside tests are exact to about one voxel and distances are trilinear within the band.
VolumePtr makeLevelSet(const Volume& source, double voxelSize, double halfWidth = 3.0);

}  // namespace sylva
