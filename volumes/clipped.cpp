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

}  // namespace

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
