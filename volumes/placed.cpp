// A volume moved into the world: local +y turned onto `axis`, scaled component-wise in the
// local frame, then translated. world = position + R·(scale ∘ local), where R is the
// shortest-arc rotation (Frame::alignY) so that the default axis +y means no rotation at all;
// Frame::fromAxis would twist a +y-aligned box or ellipsoid by 90° about y.
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "volumes/volume.h"

namespace sylva {
namespace {

class Placed final : public Volume {
  public:
    Placed(VolumePtr inner, const Placement& pl)
        : inner_(std::move(inner)),
          pl_(pl),
          frame_(Frame::alignY(pl.axis)),
          minScale_(std::min({pl.scale.x, pl.scale.y, pl.scale.z})) {}

    Vec3 toLocal(const Vec3& p) const { return cdiv(frame_.toLocal(p - pl_.position), pl_.scale); }
    Vec3 toWorld(const Vec3& q) const { return pl_.position + frame_.toWorld(cmul(pl_.scale, q)); }

    // The world→local map stretches lengths by at most 1/min(scale), so the local distance
    // times min(scale) never exceeds the world distance (exact for uniform scale).
    double signedDistance(const Vec3& p) const override {
        return inner_->signedDistance(toLocal(p)) * minScale_;
    }

    Aabb bounds() const override {
        const Aabb b = inner_->bounds();
        Aabb out;
        if (b.empty()) return out;
        for (int i = 0; i < 8; ++i) {
            Vec3 c{(i & 1) ? b.hi.x : b.lo.x, (i & 2) ? b.hi.y : b.lo.y, (i & 4) ? b.hi.z : b.lo.z};
            out.extend(toWorld(c));
        }
        return out;
    }

    // Affine maps keep uniform densities uniform.
    std::optional<Vec3> sample(Rng& rng, int maxTries) const override {
        auto q = inner_->sample(rng, maxTries);
        if (!q) return std::nullopt;
        return toWorld(*q);
    }

    double measure() const override {
        return inner_->measure() * pl_.scale.x * pl_.scale.y * pl_.scale.z;
    }

    std::string describe() const override {
        char buf[192];
        const Vec3& p = pl_.position;
        std::string s = inner_->describe();
        std::snprintf(buf, sizeof buf, " at (%g, %g, %g) m", p.x, p.y, p.z);
        s += buf;
        const Vec3 a = normalize(pl_.axis);
        if (!(a == Vec3{0, 1, 0})) {
            std::snprintf(buf, sizeof buf, " axis (%.3g, %.3g, %.3g)", a.x, a.y, a.z);
            s += buf;
        }
        const Vec3& k = pl_.scale;
        if (!(k == Vec3{1, 1, 1})) {
            std::snprintf(buf, sizeof buf, " scale (%g, %g, %g)", k.x, k.y, k.z);
            s += buf;
        }
        return s;
    }

  private:
    VolumePtr inner_;
    Placement pl_;
    Frame frame_;
    double minScale_;
};

}  // namespace

VolumePtr makePlaced(VolumePtr inner, const Placement& placement) {
    if (!inner) throw std::invalid_argument("makePlaced: inner volume is null");
    for (int a = 0; a < 3; ++a) {
        if (!(placement.scale[a] > 0.0) || !std::isfinite(placement.scale[a]))
            throw std::invalid_argument("makePlaced: scale components must be finite and > 0");
        if (!std::isfinite(placement.position[a]) || !std::isfinite(placement.axis[a]))
            throw std::invalid_argument("makePlaced: position and axis must be finite");
    }
    return std::make_shared<Placed>(std::move(inner), placement);
}

}  // namespace sylva
