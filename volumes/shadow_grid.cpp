#include "volumes/shadow_grid.h"

#include <algorithm>
#include <cmath>

namespace sylva {

ShadowGrid::ShadowGrid(const Aabb& box, double voxel, double strength, double decay, int depth)
    : strength_(strength), decay_(decay), depth_(depth) {
    // At most 2^24 voxels: a coarser grid for a huge box rather than gigabytes of shade.
    const Vec3 size = box.size();
    voxel = std::max(voxel, std::cbrt(size.x * size.y * size.z / double(1 << 24)));
    inv_ = 1.0 / voxel;
    lo_ = box.lo;
    nx_ = static_cast<int64_t>(std::ceil(size.x * inv_)) + 1;
    ny_ = static_cast<int64_t>(std::ceil(size.y * inv_)) + 1;
    nz_ = static_cast<int64_t>(std::ceil(size.z * inv_)) + 1;
    shade_.assign(static_cast<size_t>(nx_ * ny_ * nz_), 0.0);
}

bool ShadowGrid::index(const Vec3& p, int64_t& i, int64_t& j, int64_t& k) const {
    const Vec3 g = (p - lo_) * inv_;
    if (!(g.x >= 0 && g.y >= 0 && g.z >= 0)) return false;
    i = static_cast<int64_t>(g.x);
    j = static_cast<int64_t>(g.y);
    k = static_cast<int64_t>(g.z);
    return i < nx_ && j < ny_ && k < nz_;
}

void ShadowGrid::cast(const Vec3& p, double sign) {
    int64_t i, j, k;
    if (!index(p, i, j, k)) return;
    double s = sign * strength_;
    for (int q = 0; q <= depth_ && j - q >= 0; ++q, s /= decay_) {
        const int64_t y = j - q;
        for (int64_t x = std::max<int64_t>(0, i - q); x <= std::min(nx_ - 1, i + q); ++x) {
            for (int64_t z = std::max<int64_t>(0, k - q); z <= std::min(nz_ - 1, k + q); ++z) {
                shade_[static_cast<size_t>((x * ny_ + y) * nz_ + z)] += s;
            }
        }
    }
}

double ShadowGrid::exposure(const Vec3& p) const {
    int64_t i, j, k;
    if (!index(p, i, j, k)) return 1.0;
    const double s = shade_[static_cast<size_t>((i * ny_ + j) * nz_ + k)];
    return std::clamp(1.0 - s + strength_, 0.0, 1.0);
}

}  // namespace sylva
