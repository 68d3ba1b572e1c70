// Half-space clips of a volume: a crown cut by the planes between a plot tree and its
// neighbours (species/plot/plot_growth.cpp), signed distance max(inner, planes).
#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "volumes/volume.h"

namespace sylva {
namespace {

class Clipped final : public Volume {
  public:
    Clipped(VolumePtr inner, std::vector<HalfSpace> cut)
        : inner_(std::move(inner)), cut_(std::move(cut)) {}

    double signedDistance(const Vec3& p) const override {
        double d = inner_->signedDistance(p);
        for (const HalfSpace& h : cut_) d = std::max(d, h.distance(p));
        return d;
    }
    Aabb bounds() const override { return inner_->bounds(); }
    std::string describe() const override {
        return inner_->describe() + " clipped by " + std::to_string(cut_.size()) + " planes";
    }

  private:
    VolumePtr inner_;
    std::vector<HalfSpace> cut_;
};

// The half-spaces hold only within their layers: the sign is exact, the magnitude a bound
// only near a layer's edges (where a plane's distance starts or stops counting).
class ShyClipped final : public Volume {
  public:
    ShyClipped(VolumePtr inner, std::vector<ShyBound> bounds)
        : inner_(std::move(inner)), bounds_(std::move(bounds)) {}

    double signedDistance(const Vec3& p) const override {
        double d = inner_->signedDistance(p);
        for (const ShyBound& b : bounds_) {
            if (p.y >= b.low && p.y <= b.high) d = std::max(d, b.plane.distance(p));
        }
        return d;
    }
    Aabb bounds() const override { return inner_->bounds(); }
    std::string describe() const override {
        return inner_->describe() + " clipped by " + std::to_string(bounds_.size()) +
               " planes within layers";
    }

  private:
    VolumePtr inner_;
    std::vector<ShyBound> bounds_;
};

}  // namespace

VolumePtr makeShyClipped(VolumePtr inner, std::vector<ShyBound> bounds) {
    if (!inner) throw std::invalid_argument("makeShyClipped: no volume");
    if (bounds.empty()) return inner;
    return std::make_shared<ShyClipped>(std::move(inner), std::move(bounds));
}

VolumePtr makeClipped(VolumePtr inner, std::vector<HalfSpace> cut) {
    if (!inner) throw std::invalid_argument("makeClipped: no volume");
    if (cut.empty()) return inner;
    return std::make_shared<Clipped>(std::move(inner), std::move(cut));
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
