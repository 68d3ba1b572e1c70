// Canopy envelope (Shesh et al. §3.2, Eq. 1): an ellipsoid or cone whose radius is modulated
// by f(φ, θ) = Σ pⁱ gᵢ(2ⁱφ, 2ⁱθ). Every layer is turned into a grid once (images as read,
// blobs and noise rasterised), so f costs one bilinear lookup per layer — the paper's GPU
// textures — and the envelope is immutable after construction (thread-safe queries).
#include "volumes/canopy_envelope.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "volumes/image_file.h"

namespace sylva {

namespace {

constexpr int kJitterU = 64, kJitterV = 32;      // jitter value grid over (u, v)
constexpr int kBoundU = 256, kBoundV = 128;      // scan for max f (bounds)
constexpr int kMeasureU = 512, kMeasureV = 256;  // midpoint grid for the volume integral

inline int wrapIndex(int i, int n) {
    i %= n;
    return i < 0 ? i + n : i;
}

inline double frac(double x) { return x - std::floor(x); }

// Coordinate inside the tile of a layer read at frequency 2ⁱ. For v, 1 stays 1 (the last
// tile's bottom edge) instead of wrapping to 0, which matters for grids that clamp in v.
inline double tileU(double u, double tiles) { return frac(u * tiles); }
inline double tileV(double v, double tiles) {
    const double t = v * tiles;
    double k = std::floor(t);
    if (k >= tiles) k = tiles - 1;
    return t - k;
}

// Lipschitz constants of a grid's interpolant in (u, v) units: the largest neighbour
// difference times the resolution (a bilinear patch never has a steeper slope). Nearest
// sampling jumps instead; it is treated as if bilinear (the distance is approximate there).
void gridLipschitz(const CanopyGrid& g, double* lu, double* lv) {
    double du = 0, dv = 0;
    for (int r = 0; r < g.height; ++r) {
        for (int c = 0; c < g.width; ++c) {
            const float a = g.values[size_t(r) * g.width + c];
            if (g.width > 1) {
                const float b = g.values[size_t(r) * g.width + wrapIndex(c + 1, g.width)];
                du = std::max(du, double(std::abs(a - b)));
            }
            if (g.height > 1 && (g.wrapV || r + 1 < g.height)) {
                const float b = g.values[size_t(wrapIndex(r + 1, g.height)) * g.width + c];
                dv = std::max(dv, double(std::abs(a - b)));
            }
        }
    }
    *lu = du * g.width;
    *lv = dv * g.height;
}

// Shesh Figure 2: Gaussians centred at random positions, g = A·min(1, Σ exp(−d²/2σ²)), d the
// wrap-around distance (the tile repeats in u and v). The Gaussian is separable, so each blob
// costs one row and one column of exponentials plus a multiply-add per node.
CanopyGrid rasteriseBlobs(const CanopyLayer& l, Rng rng) {
    std::vector<Vec2> centres = l.centres;
    if (centres.empty()) {
        for (int j = 0; j < l.count; ++j) {
            const double u = rng.uniform();
            const double v = rng.uniform();
            centres.push_back({u, v});
        }
    }
    // ≥ 16 nodes per σ keeps the bilinear error at a peak below ~0.1 % of the amplitude.
    const int res = std::clamp(static_cast<int>(std::ceil(16.0 / l.sigma)), 32, 1024);
    CanopyGrid g;
    g.width = g.height = res;
    g.wrapV = true;
    std::vector<double> acc(size_t(res) * res, 0.0), ex(res), ey(res);
    const double k = -0.5 / (l.sigma * l.sigma);
    for (const Vec2& c : centres) {
        for (int i = 0; i < res; ++i) {
            const double x = (i + 0.5) / res;
            double du = std::abs(x - c.x);
            du = std::min(du, 1.0 - du);
            double dv = std::abs(x - c.y);
            dv = std::min(dv, 1.0 - dv);
            ex[i] = std::exp(k * du * du);
            ey[i] = std::exp(k * dv * dv);
        }
        for (int r = 0; r < res; ++r) {
            double* row = acc.data() + size_t(r) * res;
            for (int i = 0; i < res; ++i) row[i] += ey[r] * ex[i];
        }
    }
    g.values.resize(acc.size());
    for (size_t i = 0; i < acc.size(); ++i) {
        g.values[i] = static_cast<float>(l.amplitude * std::min(1.0, acc[i]));
    }
    return g;
}

// White noise: a resolution² value grid, uniform in [0, 1) times the amplitude.
CanopyGrid rasteriseNoise(const CanopyLayer& l, Rng rng) {
    CanopyGrid g;
    g.width = g.height = l.resolution;
    g.wrapV = true;
    g.nearest = l.nearest;
    g.values.resize(size_t(l.resolution) * l.resolution);
    for (auto& v : g.values) v = static_cast<float>(l.amplitude * rng.uniform());
    return g;
}

CanopyGrid jitterGrid(Rng& rng, double amplitude) {
    CanopyGrid g;
    g.width = kJitterU;
    g.height = kJitterV;
    g.wrapV = true;
    g.values.resize(size_t(kJitterU) * kJitterV);
    for (auto& v : g.values) v = static_cast<float>(amplitude * rng.uniform(-1.0, 1.0));
    return g;
}

}  // namespace

// --- grids and images --------------------------------------------------------------------

// u and v lie in [0, 1], so the node indices below are in [−1, n]: one compare wraps them
// (no integer division, which dominated the inside test).
double CanopyGrid::at(double u, double v) const {
    if (nearest) {
        int c = static_cast<int>(u * width);
        c = c >= width ? c - width : (c < 0 ? c + width : c);
        int r = static_cast<int>(v * height);
        r = r >= height ? (wrapV ? r - height : height - 1) : (r < 0 ? 0 : r);
        return values[size_t(r) * width + c];
    }
    const double x = u * width - 0.5;
    const double fx = std::floor(x);
    const double tx = x - fx;
    int c0 = static_cast<int>(fx);
    if (c0 < 0) c0 += width;
    if (c0 >= width) c0 -= width;
    const int c1 = c0 + 1 == width ? 0 : c0 + 1;
    const double y = v * height - 0.5;
    int r0, r1;
    double ty;
    if (wrapV) {
        const double fy = std::floor(y);
        ty = y - fy;
        r0 = static_cast<int>(fy);
        if (r0 < 0) r0 += height;
        if (r0 >= height) r0 -= height;
        r1 = r0 + 1 == height ? 0 : r0 + 1;
    } else if (y <= 0.0) {
        r0 = r1 = 0;
        ty = 0.0;
    } else if (y >= height - 1) {
        r0 = r1 = height - 1;
        ty = 0.0;
    } else {
        const double fy = std::floor(y);
        ty = y - fy;
        r0 = static_cast<int>(fy);
        r1 = r0 + 1;
    }
    const float* a = values.data() + size_t(r0) * width;
    const float* b = values.data() + size_t(r1) * width;
    const double top = a[c0] + (a[c1] - a[c0]) * tx;
    const double bottom = b[c0] + (b[c1] - b[c0]) * tx;
    return top + (bottom - top) * ty;
}

double CanopyGrid::maxValue() const {
    return values.empty() ? 0.0 : *std::max_element(values.begin(), values.end());
}

CanopyGrid CanopyImage::channel(int c) const {
    if (c < 0 || c >= channels) {
        throw std::out_of_range("CanopyImage::channel: channel " + std::to_string(c) +
                                " of an image with " + std::to_string(channels));
    }
    CanopyGrid g;
    g.width = width;
    g.height = height;
    g.values.resize(size_t(width) * height);
    for (size_t i = 0; i < g.values.size(); ++i) g.values[i] = pixels[i * channels + c];
    return g;
}

CanopyImage readCanopyImage(const std::string& path) {
    // Packed images use alpha as a fourth function: the stored values, not premultiplied by
    // alpha (readImageFile never premultiplies). Checked before decoding (image_file.h).
    ImageFile file = readImageFile(path);
    CanopyImage img;
    img.width = file.width;
    img.height = file.height;
    img.channels = file.channels;
    img.pixels = std::move(file.pixels);
    for (float& v : img.pixels) {
        if (!std::isfinite(v)) v = 0.0f;
    }
    return img;
}

// --- the envelope ------------------------------------------------------------------------

CanopyEnvelope::CanopyEnvelope(const CanopyEnvelopeOptions& options, Rng& rng) : o_(options) {
    for (int a = 0; a < 3; ++a) {
        if (!(o_.radii[a] > 0.0) || !std::isfinite(o_.radii[a]))
            throw std::invalid_argument("CanopyEnvelope: radii must be finite and > 0");
    }
    if (!(o_.persistence >= 0.0 && o_.persistence <= 1.0))
        throw std::invalid_argument("CanopyEnvelope: persistence must lie in [0, 1]");
    if (!(o_.jitter >= 0.0) || !std::isfinite(o_.jitter))
        throw std::invalid_argument("CanopyEnvelope: jitter must be finite and >= 0");
    if (o_.layers.size() > 10)
        throw std::invalid_argument("CanopyEnvelope: at most 10 layers (2^10 tiles)");

    // g₀: the base image, or the constant 1 (a 1 × 1 grid).
    if (o_.hasBase) {
        grids_.push_back(o_.base);
    } else {
        CanopyGrid one;
        one.width = one.height = 1;
        one.values = {1.0f};
        grids_.push_back(one);
    }
    for (size_t i = 0; i < o_.layers.size(); ++i) {
        const CanopyLayer& l = o_.layers[i];
        Rng lr = rng.derive("layers[" + std::to_string(i) + "]");
        switch (l.kind) {
            case CanopyLayer::Kind::kGrid:
                grids_.push_back(l.grid);
                break;
            case CanopyLayer::Kind::kBlobs:
                if (!(l.sigma > 0.0 && l.sigma <= 0.5))
                    throw std::invalid_argument("CanopyEnvelope: blob sigma must lie in (0, 0.5]");
                if (l.centres.empty() && l.count < 1)
                    throw std::invalid_argument("CanopyEnvelope: blob count must be >= 1");
                grids_.push_back(rasteriseBlobs(l, lr));
                break;
            case CanopyLayer::Kind::kNoise:
                if (l.resolution < 1 || l.resolution > 4096)
                    throw std::invalid_argument("CanopyEnvelope: noise resolution in [1, 4096]");
                grids_.push_back(rasteriseNoise(l, lr));
                break;
        }
    }
    for (const auto& g : grids_) {
        if (g.width <= 0 || g.height <= 0 || g.values.size() != size_t(g.width) * g.height)
            throw std::invalid_argument(
                "CanopyEnvelope: a layer grid has no or wrong-sized values");
    }
    // Eq. 1's weights pⁱ, with p⁰ = 1 even for p = 0.
    double w = 1.0;
    for (size_t i = 0; i < grids_.size(); ++i, w *= o_.persistence) {
        weights_.push_back(w);
        tiles_.push_back(std::ldexp(1.0, int(i)));  // layer i tiles 2ⁱ times
    }

    if (o_.jitter > 0.0) {
        Rng jr = rng.derive("jitter");
        jitterPhi_ = jitterGrid(jr, o_.jitter);
        jitterTheta_ = jitterGrid(jr, o_.jitter);
    }

    // Slopes of the un-jittered f in (u, v), then per radian of φ (u = φ/2π) and θ (v = θ/π).
    double lu = 0, lv = 0, upper = 0;
    for (size_t i = 0; i < grids_.size(); ++i) {
        double gu, gv;
        gridLipschitz(grids_[i], &gu, &gv);
        lu += weights_[i] * std::ldexp(gu, int(i));
        lv += weights_[i] * std::ldexp(gv, int(i));
        upper += weights_[i] * grids_[i].maxValue();
    }
    const double g0Phi = lu / (2 * kPi), g0Theta = lv / kPi;
    // The jitter moves (φ, θ) by δ(φ, θ); f(φ + δφ, θ + δθ) has slopes up to G·(1 + a) + G'·a,
    // a the jitter grid's slope per radian.
    double a = 0.0;
    if (o_.jitter > 0.0) {
        for (const CanopyGrid* g : {&jitterPhi_, &jitterTheta_}) {
            double gu, gv;
            gridLipschitz(*g, &gu, &gv);
            a = std::max({a, gu / (2 * kPi), gv / kPi});
        }
    }
    gPhi_ = g0Phi * (1 + a) + g0Theta * a;
    gTheta_ = g0Theta * (1 + a) + g0Phi * a;

    // max f: the un-jittered sum on a midpoint grid, plus the slope times half a cell (every
    // (u, v) lies within half a cell of a node); the jitter only re-parameterises, so it cannot
    // exceed this. Capped by Σ pⁱ max gᵢ, which is always an upper bound.
    double scanMax = -1e300;
    for (int r = 0; r < kBoundV; ++r) {
        for (int c = 0; c < kBoundU; ++c) {
            scanMax = std::max(scanMax, pureSum((c + 0.5) / kBoundU, (r + 0.5) / kBoundV));
        }
    }
    const double margin = 0.5 * (lu / kBoundU + lv / kBoundV);
    fMax_ = std::max(0.0, std::min(upper, scanMax + margin));

    // Volume of the star-shaped region: midpoint rule in φ, exact weights in θ per row.
    const double dPhi = 2 * kPi / kMeasureU, dTheta = kPi / kMeasureV;
    std::vector<double> rowSum(kMeasureV, 0.0);
    tbb::parallel_for(tbb::blocked_range<int>(0, kMeasureV), [&](const auto& range) {
        for (int r = range.begin(); r != range.end(); ++r) {
            const double ta = r * dTheta, tb = (r + 1) * dTheta, tm = (r + 0.5) * dTheta;
            double s = 0.0;
            for (int c = 0; c < kMeasureU; ++c) {
                const double fv = f((c + 0.5) * dPhi, tm);
                s += o_.domain == CanopyDomain::kEllipsoid ? fv * fv * fv / 3.0 : 0.5 * fv * fv;
            }
            const double weight = o_.domain == CanopyDomain::kEllipsoid
                                      ? std::cos(ta) - std::cos(tb)
                                      : (tb * tb * tb - ta * ta * ta) / (3 * kPi * kPi);
            rowSum[r] = s * dPhi * weight;
        }
    });
    double total = 0.0;
    for (double s : rowSum) total += s;  // serial, fixed order: deterministic
    const Vec3& k = o_.radii;
    measure_ = o_.domain == CanopyDomain::kEllipsoid ? total * k.x * k.y * k.z
                                                     : total * k.x * k.z * k.y / kPi;
}

double CanopyEnvelope::pureSum(double u, double v) const {
    double s = 0.0;
    for (size_t i = 0; i < grids_.size(); ++i) {
        if (weights_[i] == 0.0) continue;
        s += weights_[i] * grids_[i].at(tileU(u, tiles_[i]), tileV(v, tiles_[i]));
    }
    return s;
}

double CanopyEnvelope::layerValue(size_t i, double phi, double theta) const {
    if (i >= grids_.size()) throw std::out_of_range("CanopyEnvelope::layerValue: no such layer");
    const double u = frac(phi / (2 * kPi)), v = std::clamp(theta / kPi, 0.0, 1.0);
    return grids_[i].at(tileU(u, tiles_[i]), tileV(v, tiles_[i]));
}

double CanopyEnvelope::f(double phi, double theta) const {
    theta = std::clamp(theta, 0.0, kPi);
    if (o_.jitter > 0.0) {
        const double u = frac(phi / (2 * kPi)), v = theta / kPi;
        const double dPhi = jitterPhi_.at(u, v), dTheta = jitterTheta_.at(u, v);
        phi += dPhi;
        theta = std::clamp(theta + dTheta, 0.0, kPi);
    }
    return std::max(0.0, pureSum(frac(phi / (2 * kPi)), theta / kPi));
}

Vec2 CanopyEnvelope::angles(const Vec3& p) const {
    const Vec3& k = o_.radii;
    const double qx = p.x / k.x, qz = p.z / k.z;
    double phi = std::atan2(qz, qx);
    if (phi < 0) phi += 2 * kPi;
    if (o_.domain == CanopyDomain::kCone) {
        return {phi, kPi * std::clamp(1.0 - p.y / k.y, 0.0, 1.0)};
    }
    const double qy = p.y / k.y;
    const double r = std::sqrt(qx * qx + qy * qy + qz * qz);
    if (!(r > 0.0)) return {0.0, 0.0};
    return {phi, std::acos(std::clamp(qy / r, -1.0, 1.0))};
}

Vec3 CanopyEnvelope::surfacePoint(double phi, double theta) const {
    theta = std::clamp(theta, 0.0, kPi);
    const double fv = f(phi, theta);
    const Vec3& k = o_.radii;
    if (o_.domain == CanopyDomain::kCone) {
        const double t = theta / kPi;  // 0 at the apex, 1 at the base
        const double rho = t * fv;
        return {k.x * rho * std::cos(phi), k.y * (1.0 - t), k.z * rho * std::sin(phi)};
    }
    const double s = std::sin(theta);
    return {k.x * fv * s * std::cos(phi), k.y * fv * std::cos(theta), k.z * fv * s * std::sin(phi)};
}

double CanopyEnvelope::signedDistance(const Vec3& p) const {
    const Vec3& k = o_.radii;
    const double qx = p.x / k.x, qz = p.z / k.z;
    double phi = std::atan2(qz, qx);
    if (phi < 0) phi += 2 * kPi;
    const double tiny = 1e-3 * std::max(fMax_, 1e-12);
    if (o_.domain == CanopyDomain::kEllipsoid) {
        const double qy = p.y / k.y;
        const double r = std::sqrt(qx * qx + qy * qy + qz * qz);
        const double kMin = std::min({k.x, k.y, k.z});
        const double theta = r > 0.0 ? std::acos(std::clamp(qy / r, -1.0, 1.0)) : 0.0;
        const double fv = f(phi, theta);
        const double excess = r - fv;  // in q units; ≤ 0 inside (exact sign)
        // |∇(r − f(ω))| ≤ √(1 + (|∇_S f|/r)²) in q units; |∇_S f|² = f_θ² + (f_φ/sinθ)².
        const double s = std::max(std::sin(theta), 0.05);
        const double g = std::sqrt(gTheta_ * gTheta_ + (gPhi_ / s) * (gPhi_ / s));
        const double rr = std::max(std::min(r, fv), tiny);
        double d = excess * kMin / std::sqrt(1.0 + (g / rr) * (g / rr));
        if (excess > 0.0) d = std::max(d, (r - fMax_) * kMin);  // outside the ball of fMax
        return d;
    }
    // Cone: radial excess ρ − t·f with t = 1 − y/ky, capped by the base and apex planes.
    const double t = 1.0 - p.y / k.y;
    const double tc = std::clamp(t, 0.0, 1.0);
    const double rho = std::sqrt(qx * qx + qz * qz);
    const double fv = f(phi, kPi * tc);
    const double excess = rho - tc * fv;
    const double kxz = std::min(k.x, k.z);
    const double rr = std::max(std::min(rho, tc * fv), tiny);
    const double lateral = (1.0 + (tc * gPhi_ / rr) * (tc * gPhi_ / rr)) / (kxz * kxz);
    const double vertical = (fMax_ + kPi * tc * gTheta_) / k.y;
    const double dr = excess / std::sqrt(lateral + vertical * vertical);
    return std::max({dr, -p.y, p.y - k.y});
}

Aabb CanopyEnvelope::bounds() const {
    if (!(fMax_ > 0.0)) return {};
    const Vec3 e = o_.radii * fMax_;
    if (o_.domain == CanopyDomain::kCone) return {{-e.x, 0.0, -e.z}, {e.x, o_.radii.y, e.z}};
    return {-e, e};
}

std::optional<Vec3> CanopyEnvelope::sample(Rng& rng, int maxTries) const {
    if (!(fMax_ > 0.0)) return std::nullopt;
    const Vec3& k = o_.radii;
    for (int i = 0; i < maxTries; ++i) {
        // The largest of three uniforms has density ∝ s²: the radius law of a uniform ball,
        // and the depth law below a cone's apex (slice area ∝ s²).
        const double s = std::max({rng.uniform(), rng.uniform(), rng.uniform()});
        Vec3 p;
        if (o_.domain == CanopyDomain::kEllipsoid) {
            p = cmul(rng.unitVector() * (s * fMax_), k);
        } else {
            const double rho = s * fMax_ * std::sqrt(rng.uniform());
            const double phi = rng.uniform(0.0, 2 * kPi);
            p = {k.x * rho * std::cos(phi), k.y * (1.0 - s), k.z * rho * std::sin(phi)};
        }
        if (inside(p)) return p;
    }
    return std::nullopt;
}

std::string CanopyEnvelope::describe() const {
    char buf[160];
    std::snprintf(buf, sizeof buf, "canopy envelope (%s k=(%g, %g, %g) m, p=%g, %zu layers)",
                  o_.domain == CanopyDomain::kCone ? "cone" : "ellipsoid", o_.radii.x, o_.radii.y,
                  o_.radii.z, o_.persistence, grids_.size() - 1);
    return buf;
}

std::shared_ptr<const CanopyEnvelope> makeCanopyEnvelope(const CanopyEnvelopeOptions& options,
                                                         Rng& rng) {
    return std::make_shared<CanopyEnvelope>(options, rng);
}

}  // namespace sylva
