// Cone or frustum (capped cone): base disc of radius R at y = 0, top disc of radius r at
// y = h (r = 0 is a pointed cone). Exact distance, direct uniform sampling.
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "volumes/volume.h"

namespace sylva {
namespace {

// √(a² + b²) without std::hypot's overflow guards, which cost a third of the Poisson
// benchmark; crown coordinates are far from overflow.
inline double norm2d(double a, double b) { return std::sqrt(a * a + b * b); }

// Distance from (px, py) to the segment a–b in the plane.
double segmentDistance(double px, double py, double ax, double ay, double bx, double by) {
    const double ex = bx - ax, ey = by - ay;
    const double e2 = ex * ex + ey * ey;
    double t = e2 > 0.0 ? ((px - ax) * ex + (py - ay) * ey) / e2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    return norm2d(px - ax - t * ex, py - ay - t * ey);
}

class Cone final : public Volume {
  public:
    Cone(double base, double h, double top) : rb_(base), h_(h), rt_(top) {}

    double signedDistance(const Vec3& p) const override {
        // The solid is a solid of revolution: its distance equals the 2-D distance in the
        // (r = |xz|, y) half-plane to the trapezoid (0,0)–(R,0)–(r,h)–(0,h). The axis edge is
        // not a surface, so only the base, slant and top edges count.
        const double r = norm2d(p.x, p.z), y = p.y;
        const double d = std::min({segmentDistance(r, y, 0.0, 0.0, rb_, 0.0),
                                   segmentDistance(r, y, rb_, 0.0, rt_, h_),
                                   segmentDistance(r, y, 0.0, h_, rt_, h_)});
        bool in = y >= 0.0 && y <= h_;
        if (in) {
            const double t = h_ > 0.0 ? y / h_ : 0.0;
            in = r <= rb_ + (rt_ - rb_) * t;
        }
        return in ? -d : d;
    }

    Aabb bounds() const override {
        const double m = std::max(rb_, rt_);
        return {{-m, 0.0, -m}, {m, h_, m}};
    }

    // The slice area at height t·h is π·ρ(t)², ρ linear in t, so the CDF of ρ is
    // (ρ³ − R³)/(r³ − R³): invert it, then place the point in the slice's disc (radius ρ·√u).
    std::optional<Vec3> sample(Rng& rng, int) const override {
        const double u = rng.uniform();
        double t;
        const double dr = rt_ - rb_;
        if (std::abs(dr) <= 1e-9 * std::max(rb_, rt_)) {
            t = u;  // a cylinder: uniform height
        } else {
            const double b3 = rb_ * rb_ * rb_, t3 = rt_ * rt_ * rt_;
            const double rho = std::cbrt(b3 + u * (t3 - b3));
            t = std::clamp((rho - rb_) / dr, 0.0, 1.0);
        }
        const double rho = rb_ + dr * t;
        const double r = rho * std::sqrt(rng.uniform());
        const double phi = rng.uniform(0.0, 2.0 * kPi);
        return Vec3{r * std::cos(phi), t * h_, r * std::sin(phi)};
    }

    double measure() const override { return kPi * h_ / 3.0 * (rb_ * rb_ + rb_ * rt_ + rt_ * rt_); }

    std::string describe() const override {
        char buf[96];
        if (rt_ > 0.0)
            std::snprintf(buf, sizeof buf, "frustum r=%g..%g m h=%g m", rb_, rt_, h_);
        else
            std::snprintf(buf, sizeof buf, "cone r=%g m h=%g m", rb_, h_);
        return buf;
    }

  private:
    double rb_, h_, rt_;
};

}  // namespace

VolumePtr makeCone(double baseRadius, double height, double topRadius) {
    for (double v : {baseRadius, height, topRadius})
        if (!(v >= 0.0) || !std::isfinite(v))
            throw std::invalid_argument("makeCone: radii and height must be finite and >= 0");
    return std::make_shared<Cone>(baseRadius, height, topRadius);
}

}  // namespace sylva
