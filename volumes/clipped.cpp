// Half-space clips of a volume: a crown cut by the planes between a plot tree and its
// neighbours (species/plot/plot_growth.cpp), at every height or within layers (ShyBound),
// signed distance max(inner, planes).
#include <algorithm>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "volumes/volume.h"

namespace sylva {
namespace {

// Every bound holds within its layer (a half-space of makeClipped: at every height): the sign
// of the distance exact, its magnitude a bound only near a layer's edges (where a plane's
// distance starts or stops counting).
class Clipped final : public Volume {
  public:
    Clipped(VolumePtr inner, std::vector<ShyBound> bounds, bool layered)
        : inner_(std::move(inner)), bounds_(std::move(bounds)), layered_(layered) {}

    double signedDistance(const Vec3& p) const override {
        double d = inner_->signedDistance(p);
        for (const ShyBound& b : bounds_) {
            if (p.y >= b.low && p.y <= b.high) d = std::max(d, b.plane.distance(p));
        }
        return d;
    }
    Aabb bounds() const override { return inner_->bounds(); }
    std::string describe() const override {
        return inner_->describe() + " clipped by " + std::to_string(bounds_.size()) + " planes" +
               (layered_ ? " within layers" : "");
    }

  private:
    VolumePtr inner_;
    std::vector<ShyBound> bounds_;
    bool layered_;
};

}  // namespace

VolumePtr makeShyClipped(VolumePtr inner, std::vector<ShyBound> bounds) {
    if (!inner) throw std::invalid_argument("makeShyClipped: no volume");
    if (bounds.empty()) return inner;
    return std::make_shared<Clipped>(std::move(inner), std::move(bounds), true);
}

VolumePtr makeClipped(VolumePtr inner, std::vector<HalfSpace> cut) {
    if (!inner) throw std::invalid_argument("makeClipped: no volume");
    if (cut.empty()) return inner;
    std::vector<ShyBound> bounds;
    bounds.reserve(cut.size());
    const double inf = std::numeric_limits<double>::infinity();
    for (const HalfSpace& h : cut) bounds.push_back({h, -inf, inf});
    return std::make_shared<Clipped>(std::move(inner), std::move(bounds), false);
}

bool insideAll(const std::vector<HalfSpace>& cut, const Vec3& p) {
    for (const HalfSpace& h : cut) {
        if (h.distance(p) > 0) return false;
    }
    return true;
}

Vec3 projectInside(const std::vector<HalfSpace>& cut, Vec3 p) {
    for (const HalfSpace& h : cut) {
        const double d = h.distance(p);
        if (d > 0) p -= h.normal * d;
    }
    return p;
}

}  // namespace sylva
