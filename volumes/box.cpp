// Axis-aligned box centred at the origin with full edge lengths `size`. Exact distance.
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "volumes/volume.h"

namespace sylva {
namespace {

class Box final : public Volume {
  public:
    explicit Box(const Vec3& size) : half_(size * 0.5) {}

    double signedDistance(const Vec3& p) const override {
        const Vec3 q = vabs(p) - half_;
        const double outside = length(vmax(q, Vec3{0, 0, 0}));
        return outside + std::min(std::max({q.x, q.y, q.z}), 0.0);
    }

    Aabb bounds() const override { return {-half_, half_}; }

    std::optional<Vec3> sample(Rng& rng, int) const override { return rng.inBox(bounds()); }

    double measure() const override { return 8.0 * half_.x * half_.y * half_.z; }

    std::string describe() const override {
        char buf[96];
        std::snprintf(buf, sizeof buf, "box %gx%gx%g m", 2 * half_.x, 2 * half_.y, 2 * half_.z);
        return buf;
    }

  private:
    Vec3 half_;
};

}  // namespace

VolumePtr makeBox(const Vec3& size) {
    for (int a = 0; a < 3; ++a)
        if (!(size[a] >= 0.0) || !std::isfinite(size[a]))
            throw std::invalid_argument("makeBox: edge lengths must be finite and >= 0");
    return std::make_shared<Box>(size);
}

}  // namespace sylva
