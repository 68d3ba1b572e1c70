// A volume realised as a narrow-band OpenVDB level set. levelSetGrid() samples any Volume
// into the grid (also used by `sylva volume`); the LevelSet volume answers queries from it.
// Distances inside the band are trilinear interpolations of the source distance at voxel
// centres; outside the band, flood-filled tiles give ±(band width), so the sign stays right.
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include "volumes/level_set_grid.h"
#include "volumes/volume.h"

namespace sylva {
namespace {

constexpr int kLeafDim = VdbBlock::kDim;  // 8 voxels per leaf edge

// Largest multiple of 8 not above v (floor division also for negative indices).
int leafFloor(int v) { return static_cast<int>(std::floor(v / double(kLeafDim))) * kLeafDim; }

void checkVoxel(const char* who, double voxel, double halfWidth) {
    if (!(voxel > 0.0) || !std::isfinite(voxel))
        throw std::invalid_argument(std::string(who) + ": voxelSize must be finite and > 0");
    if (!(halfWidth >= 1.0) || !std::isfinite(halfWidth))
        throw std::invalid_argument(std::string(who) + ": halfWidth must be finite and >= 1 voxel");
}

// The grid of `source` sampled into the leaf blocks over `bounds` (see level_set_grid.h).
VdbGridPtr sampleGrid(const Volume& source, const Aabb& bounds, double voxel, double band) {
    const double inv = 1.0 / voxel;
    const int pad = static_cast<int>(std::ceil(band * inv)) + 1;
    int lo[3], nb[3];
    for (int a = 0; a < 3; ++a) {
        const double l = std::floor(bounds.lo[a] * inv) - pad;
        const double h = std::ceil(bounds.hi[a] * inv) + pad;
        if (!(h - l < 1e7)) throw std::invalid_argument("levelSetGrid: grid would be too large");
        // OpenVDB's voxel indices are 32-bit integers (casting beyond them is undefined).
        if (!(std::abs(l) < 1e9 && std::abs(h) < 1e9)) {
            throw std::invalid_argument(
                "levelSetGrid: the volume lies over 10⁹ voxels from the origin");
        }
        lo[a] = leafFloor(static_cast<int>(l));
        nb[a] = (leafFloor(static_cast<int>(h)) - lo[a]) / kLeafDim + 1;
    }
    const size_t blocks = size_t(nb[0]) * nb[1] * nb[2];
    // Centre of a block to its farthest voxel centre: 3.5 voxels along each axis.
    const double halfDiagonal = std::sqrt(3.0) * 0.5 * (kLeafDim - 1) * voxel;
    const float background = static_cast<float>(band);

    // Each block depends only on its own voxel positions (the module keeps them in block
    // order), so the result does not depend on the thread count or scheduling.
    return vdbModule().gridFromBlocks(voxel, background, blocks, [&](size_t b, VdbBlock& block) {
        const int bx = int(b % nb[0]), by = int((b / nb[0]) % nb[1]),
                  bz = int(b / (size_t(nb[0]) * nb[1]));
        const int origin[3] = {lo[0] + bx * kLeafDim, lo[1] + by * kLeafDim, lo[2] + bz * kLeafDim};
        const double c = 0.5 * (kLeafDim - 1);
        const Vec3 centre{(origin[0] + c) * voxel, (origin[1] + c) * voxel,
                          (origin[2] + c) * voxel};
        // The source distance is a lower bound of a 1-Lipschitz true distance, so no voxel of a
        // block whose centre is this far away can be in the band.
        if (std::abs(source.signedDistance(centre)) > halfDiagonal + band) return false;
        for (int a = 0; a < 3; ++a) block.origin[a] = origin[a];
        bool any = false;
        for (int i = 0; i < kLeafDim; ++i)
            for (int j = 0; j < kLeafDim; ++j)
                for (int k = 0; k < kLeafDim; ++k) {
                    const double d =
                        source.signedDistance({(origin[0] + i) * voxel, (origin[1] + j) * voxel,
                                               (origin[2] + k) * voxel});
                    const int n = (i * kLeafDim + j) * kLeafDim + k;
                    if (std::abs(d) < band) {
                        block.set(n, static_cast<float>(d), true);
                        any = true;
                    } else {
                        block.set(n, d < 0 ? -background : background, false);
                    }
                }
        return any;
    });
}

}  // namespace

VdbGridPtr levelSetGrid(const Volume& v, double voxel, double halfWidth) {
    checkVoxel("levelSetGrid", voxel, halfWidth);
    const double band = halfWidth * voxel;
    const Aabb bounds = v.bounds();
    if (bounds.empty()) return vdbModule().gridFromBlocks(voxel, float(band), 0, {});
    return sampleGrid(v, bounds, voxel, band);
}

double interiorVoxelCount(const VdbGrid& grid) { return vdbModule().interiorVoxelCount(grid); }

double GridVolume::signedDistance(const Vec3& p) const {
    const Vec3 q = p / voxel_;  // index space
    return vdbModule().sample(*grid_, q.x, q.y, q.z);
}

VolumePtr makeLevelSet(const Volume& source, double voxelSize, double halfWidth) {
    checkVoxel("makeLevelSet", voxelSize, halfWidth);
    VdbGridPtr grid = levelSetGrid(source, voxelSize, halfWidth);
    // The realised surface can sit up to a voxel outside the source's bounds.
    Aabb bounds = source.bounds();
    if (!bounds.empty()) {
        const Vec3 pad{voxelSize, voxelSize, voxelSize};
        bounds.lo -= pad;
        bounds.hi += pad;
    }
    // Measure: the voxels whose centre is inside, times the voxel volume — the measure of the
    // realised level set (not of the source), accurate to about a voxel layer of surface.
    const double measure = interiorVoxelCount(*grid) * voxelSize * voxelSize * voxelSize;
    char buf[64];
    std::snprintf(buf, sizeof buf, " (level set, voxel %g m)", voxelSize);
    return std::make_shared<GridVolume>(std::move(grid), voxelSize, bounds, measure,
                                        source.describe() + buf);
}

}  // namespace sylva
