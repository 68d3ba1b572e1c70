// A volume realised as a narrow-band OpenVDB level set. levelSetGrid() samples any Volume
// into the grid (also used by `sylva volume`); the LevelSet volume answers queries from it.
// Distances inside the band are trilinear interpolations of the source distance at voxel
// centres; outside the band, flood-filled tiles give ±(band width), so the sign stays right.
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <stdexcept>

#include "volumes/level_set_grid.h"
#include "volumes/volume.h"

namespace sylva {
namespace {

using LeafT = openvdb::FloatTree::LeafNodeType;
constexpr int kLeafDim = static_cast<int>(LeafT::DIM);  // 8 voxels per leaf edge

// Largest multiple of 8 not above v (floor division also for negative indices).
int leafFloor(int v) { return static_cast<int>(std::floor(v / double(kLeafDim))) * kLeafDim; }

void checkVoxel(const char* who, double voxel, double halfWidth) {
    if (!(voxel > 0.0) || !std::isfinite(voxel))
        throw std::invalid_argument(std::string(who) + ": voxelSize must be finite and > 0");
    if (!(halfWidth >= 1.0) || !std::isfinite(halfWidth))
        throw std::invalid_argument(std::string(who) + ": halfWidth must be finite and >= 1 voxel");
}

// Samples `source` into the leaf blocks over `bounds` (see level_set_grid.h).
void sampleInto(openvdb::FloatGrid& grid, const Volume& source, const Aabb& bounds, double voxel,
                double band) {
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
    std::vector<std::unique_ptr<LeafT>> leaves(blocks);
    // Centre of a block to its farthest voxel centre: 3.5 voxels along each axis.
    const double halfDiagonal = std::sqrt(3.0) * 0.5 * (kLeafDim - 1) * voxel;
    const float background = static_cast<float>(band);

    // Each leaf depends only on its own voxel positions, so the result does not depend on
    // the thread count or scheduling.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks), [&](const auto& range) {
        for (size_t b = range.begin(); b != range.end(); ++b) {
            const int bx = int(b % nb[0]), by = int((b / nb[0]) % nb[1]),
                      bz = int(b / (size_t(nb[0]) * nb[1]));
            const openvdb::Coord origin(lo[0] + bx * kLeafDim, lo[1] + by * kLeafDim,
                                        lo[2] + bz * kLeafDim);
            const double c = 0.5 * (kLeafDim - 1);
            const Vec3 centre{(origin.x() + c) * voxel, (origin.y() + c) * voxel,
                              (origin.z() + c) * voxel};
            // The source distance is a lower bound of a 1-Lipschitz true distance, so no
            // voxel of a block whose centre is this far away can be in the band.
            if (std::abs(source.signedDistance(centre)) > halfDiagonal + band) continue;
            auto leaf = std::make_unique<LeafT>(origin, background, false);
            bool any = false;
            for (int i = 0; i < kLeafDim; ++i)
                for (int j = 0; j < kLeafDim; ++j)
                    for (int k = 0; k < kLeafDim; ++k) {
                        const openvdb::Coord ijk = origin.offsetBy(i, j, k);
                        const double d = source.signedDistance(
                            {ijk.x() * voxel, ijk.y() * voxel, ijk.z() * voxel});
                        if (std::abs(d) < band) {
                            leaf->setValueOn(ijk, static_cast<float>(d));
                            any = true;
                        } else {
                            leaf->setValueOff(ijk, d < 0 ? -background : background);
                        }
                    }
            if (any) leaves[b] = std::move(leaf);
        }
    });
    openvdb::FloatTree& tree = grid.tree();
    for (auto& leaf : leaves)
        if (leaf) tree.addLeaf(leaf.release());  // the tree takes ownership
    // Interior tiles between the band's leaves become −background.
    openvdb::tools::signedFloodFill(tree);
}

}  // namespace

void initializeOpenVdbOnce() {
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

openvdb::FloatGrid::Ptr levelSetGrid(const Volume& v, double voxel, double halfWidth) {
    checkVoxel("levelSetGrid", voxel, halfWidth);
    initializeOpenVdbOnce();
    const double band = halfWidth * voxel;
    auto grid = openvdb::FloatGrid::create(static_cast<float>(band));
    grid->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    const Aabb bounds = v.bounds();
    if (!bounds.empty()) sampleInto(*grid, v, bounds, voxel, band);
    return grid;
}

double interiorVoxelCount(const openvdb::FloatGrid& grid) {
    double n = 0;
    for (auto it = grid.constTree().cbeginValueAll(); it; ++it)
        if (*it <= 0.0f) n += static_cast<double>(it.getVoxelCount());
    return n;
}

double GridVolume::signedDistance(const Vec3& p) const {
    // An unregistered accessor per call: cheap, and safe for concurrent readers because the
    // tree is never modified after construction.
    openvdb::tree::ValueAccessor<const openvdb::FloatTree, false> acc(grid_->constTree());
    float value = 0.0f;
    openvdb::tools::BoxSampler::sample(acc, openvdb::Vec3R(p.x, p.y, p.z) / voxel_, value);
    return value;
}

VolumePtr makeLevelSet(const Volume& source, double voxelSize, double halfWidth) {
    checkVoxel("makeLevelSet", voxelSize, halfWidth);
    openvdb::FloatGrid::Ptr grid = levelSetGrid(source, voxelSize, halfWidth);
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
