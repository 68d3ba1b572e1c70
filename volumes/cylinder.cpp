// Cylinder of radius R, base disc at y = 0 and top at y = h. Exact capped-cylinder distance.
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "volumes/volume.h"

namespace sylva {
namespace {

// √(a² + b²) without std::hypot's overflow guards, which cost a third of the Poisson
// benchmark; crown coordinates are far from overflow.
inline double norm2d(double a, double b) { return std::sqrt(a * a + b * b); }

class Cylinder final : public Volume {
  public:
    Cylinder(double r, double h) : r_(r), h_(h) {}

    double signedDistance(const Vec3& p) const override {
        // 2-D box distance in the (r, y) half-plane of the solid of revolution.
        const double dr = norm2d(p.x, p.z) - r_;
        const double dy = std::abs(p.y - 0.5 * h_) - 0.5 * h_;
        const double outside = norm2d(std::max(dr, 0.0), std::max(dy, 0.0));
        return outside + std::min(std::max(dr, dy), 0.0);
    }

    Aabb bounds() const override { return {{-r_, 0.0, -r_}, {r_, h_, r_}}; }

    // Disc radius R·√u (area grows with r²), height uniform.
    std::optional<Vec3> sample(Rng& rng, int) const override {
        const double r = r_ * std::sqrt(rng.uniform());
        const double phi = rng.uniform(0.0, 2.0 * kPi);
        const double y = rng.uniform(0.0, h_);
        return Vec3{r * std::cos(phi), y, r * std::sin(phi)};
    }

    double measure() const override { return kPi * r_ * r_ * h_; }

    std::string describe() const override {
        char buf[80];
        std::snprintf(buf, sizeof buf, "cylinder r=%g m h=%g m", r_, h_);
        return buf;
    }

  private:
    double r_, h_;
};

}  // namespace

VolumePtr makeCylinder(double radius, double height) {
    if (!(radius >= 0.0) || !std::isfinite(radius) || !(height >= 0.0) || !std::isfinite(height))
        throw std::invalid_argument("makeCylinder: radius and height must be finite and >= 0");
    return std::make_shared<Cylinder>(radius, height);
}

}  // namespace sylva
