// @brief Any Volume sampled into an OpenVDB narrow-band level set grid. The grid is an opaque
// VdbGrid; its OpenVDB calls are the module of volumes/vdb_module.h, loaded on first use.
#pragma once

#include <string>
#include <utility>

#include "volumes/vdb_module.h"
#include "volumes/volume.h"

namespace sylva {

// The signed distance of `v` sampled at voxel centres into a FloatGrid of class
// GRID_LEVEL_SET, unnamed:
//  - voxel: voxel edge in world units (metres); index (i, j, k) is the point
//    (i, j, k)·voxel (a linear transform, no offset);
//  - halfWidth: narrow-band half width in voxels (≥ 1); the background is halfWidth·voxel;
//  - voxels whose |distance| < halfWidth·voxel are active with the source distance; the
//    others in the sampled leaf blocks are inactive ±background, and tiles enclosed by the
//    band are flood-filled to −background (inside).
// Only the 8³ leaf blocks over v.bounds() (padded by the band) that the source distance says
// can reach the band are sampled, in parallel; each block depends only on its own voxels, so
// the grid is identical for any thread count. An empty volume gives an empty grid.
// Throws std::invalid_argument for a voxel that is not finite and > 0, a halfWidth < 1, or a
// grid over 10⁷ voxels along an axis.
VdbGridPtr levelSetGrid(const Volume& v, double voxel, double halfWidth = 3.0);

// The number of voxels (tiles counted by their voxels) whose value is ≤ 0: inside.
double interiorVoxelCount(const VdbGrid& grid);

// A level-set grid (linear transform of edge `voxel`, index (i, j, k) at (i, j, k)·voxel) as
// a Volume: the signed distance is trilinear in the narrow band and ±band beyond it (the
// sign stays right). Safe for concurrent readers (the grid is never modified). bounds,
// measure and describe() are given by the maker (e.g. a voxel count or a closed form).
class GridVolume final : public Volume {
  public:
    GridVolume(VdbGridPtr grid, double voxel, const Aabb& bounds, double measure,
               std::string description)
        : grid_(std::move(grid)),
          voxel_(voxel),
          bounds_(bounds),
          measure_(measure),
          description_(std::move(description)) {}

    double signedDistance(const Vec3& p) const override;
    Aabb bounds() const override { return bounds_; }
    double measure() const override { return measure_; }
    std::string describe() const override { return description_; }

  private:
    VdbGridPtr grid_;
    double voxel_;
    Aabb bounds_;
    double measure_;
    std::string description_;
};

}  // namespace sylva
