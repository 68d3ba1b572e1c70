// Silhouette masks (Liu et al. 2020 §4.3): reading (volumes/image_file.h), exact distance
// transforms, the logistic fall-off of marker spread at the border, the half-profile of a
// mask, and the mask-revolution volume (the profile revolved by volumes/revolution.h).
#include "volumes/mask.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "volumes/image_file.h"

namespace sylva {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Abscissa where the parabolas of samples p < q (centres p + shift, q + shift) cross.
inline double intersection(const double* f, double shift, int p, int q) {
    const double cp = p + shift, cq = q + shift;
    return ((f[q] + cq * cq) - (f[p] + cp * cp)) / (2.0 * (cq - cp));
}

// Felzenszwalb & Huttenlocher 2012, "Distance transforms of sampled functions", algorithm
// DT(f): d(x) = min_i (x − c_i)² + f(i) for x = 0..n−1, with parabola centres c_i = i + shift.
// Infinite f(i) take no part. v, z are scratch buffers of size n and n + 1.
void lowerEnvelope(const double* f, int n, double shift, double* d, std::vector<int>& v,
                   std::vector<double>& z) {
    int k = -1;
    for (int q = 0; q < n; ++q) {
        if (!std::isfinite(f[q])) continue;
        if (k < 0) {
            k = 0;
            v[0] = q;
            z[0] = -kInf;
            z[1] = kInf;
            continue;
        }
        // z[0] = −∞ stops the loop at k = 0.
        double s = intersection(f, shift, v[k], q);
        while (s <= z[k]) s = intersection(f, shift, v[--k], q);
        ++k;
        v[k] = q;
        z[k] = s;
        z[k + 1] = kInf;
    }
    if (k < 0) {
        std::fill(d, d + n, kInf);
        return;
    }
    int j = 0;
    for (int x = 0; x < n; ++x) {
        while (z[j + 1] < x) ++j;
        const double c = v[j] + shift;
        d[x] = (x - c) * (x - c) + f[v[j]];
    }
}

// One 1-D pass of a separable transform along lines of `n` values.
//   Point metric: min_i (x − i)² + f(i).
//   Square metric: min_i φ(x − i) + f(i), φ(t) = max(|t| − ½, 0)², the squared distance from a
//   point to a unit pixel square along one axis. Written as min(f(x), envelope with centres at
//   i + ½, envelope with centres at i − ½): for i < x the first envelope is exactly φ(x − i)
//   and the second over-estimates it, for i > x the other way round, so the minimum is exact.
struct Pass1d {
    bool squares = false;
    std::vector<int> v;
    std::vector<double> z, a, b;

    void run(const double* f, int n, double* d) {
        v.resize(n);
        z.resize(n + 1);
        if (!squares) {
            lowerEnvelope(f, n, 0.0, d, v, z);
            return;
        }
        a.resize(n);
        b.resize(n);
        lowerEnvelope(f, n, 0.5, a.data(), v, z);
        lowerEnvelope(f, n, -0.5, b.data(), v, z);
        for (int x = 0; x < n; ++x) d[x] = std::min({f[x], a[x], b[x]});
    }
};

// Squared distance from every pixel centre to the nearest feature (centre or square).
std::vector<double> transform2d(int width, int height, const std::vector<uint8_t>& feature,
                                bool squares) {
    std::vector<double> g(static_cast<size_t>(width) * height);
    for (size_t i = 0; i < g.size(); ++i) g[i] = feature[i] ? 0.0 : kInf;
    Pass1d pass;
    pass.squares = squares;
    std::vector<double> in(std::max(width, height)), out(std::max(width, height));
    for (int x = 0; x < width; ++x) {  // columns
        for (int y = 0; y < height; ++y) in[y] = g[static_cast<size_t>(y) * width + x];
        pass.run(in.data(), height, out.data());
        for (int y = 0; y < height; ++y) g[static_cast<size_t>(y) * width + x] = out[y];
    }
    for (int y = 0; y < height; ++y) {  // rows
        double* row = g.data() + static_cast<size_t>(y) * width;
        std::copy(row, row + width, in.begin());
        pass.run(in.data(), width, row);
    }
    return g;
}

}  // namespace

size_t Mask::count() const {
    return static_cast<size_t>(std::count_if(on.begin(), on.end(), [](uint8_t b) { return b; }));
}

Mask readMask(const std::string& path, bool invert) {
    ImageFile img;
    try {
        img = readImageFile(path);  // checked before decoding (volumes/image_file.h)
    } catch (const ImageError& e) {
        throw MaskError(e.what());
    }
    const int w = img.width, h = img.height, nc = img.channels;
    const std::vector<float>& px = img.pixels;
    const int alpha = img.alphaChannel;
    Mask m;
    m.width = w;
    m.height = h;
    m.on.resize(static_cast<size_t>(w) * h);
    for (size_t i = 0; i < m.on.size(); ++i) {
        const float* p = &px[i * nc];
        double grey;
        if (alpha >= 0 && alpha < nc) {
            grey = p[alpha];
        } else if (nc >= 3) {
            grey = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];  // Rec. 709 luminance
        } else {
            grey = p[0];
        }
        m.on[i] = static_cast<uint8_t>((grey >= 0.5) != invert);
    }
    if (m.count() == 0) {
        throw MaskError("mask " + path + " is empty: no pixel has grey value " +
                        (invert ? "< 0.5 (invert = true)" : "≥ 0.5"));
    }
    return m;
}

std::vector<double> squaredDistanceTransform(int width, int height,
                                             const std::vector<uint8_t>& feature) {
    return transform2d(width, height, feature, false);
}

// The signed distance on the mask padded by one outside pixel all round, (w + 2) × (h + 2):
// the padding stands for everything beyond the image, which is never nearer than it.
std::vector<double> paddedSignedDistancePixels(const Mask& mask) {
    const int w = mask.width + 2, h = mask.height + 2;
    std::vector<uint8_t> in(static_cast<size_t>(w) * h, 0), out(in.size(), 1);
    for (int y = 0; y < mask.height; ++y)
        for (int x = 0; x < mask.width; ++x) {
            const size_t i = static_cast<size_t>(y + 1) * w + (x + 1);
            in[i] = mask.at(x, y);
            out[i] = !in[i];
        }
    const std::vector<double> toIn = transform2d(w, h, in, true);
    const std::vector<double> toOut = transform2d(w, h, out, true);
    std::vector<double> s(in.size());
    for (size_t i = 0; i < s.size(); ++i) s[i] = in[i] ? -std::sqrt(toOut[i]) : std::sqrt(toIn[i]);
    return s;
}

std::vector<double> signedDistancePixels(const Mask& mask) {
    const std::vector<double> padded = paddedSignedDistancePixels(mask);
    std::vector<double> s(static_cast<size_t>(mask.width) * mask.height);
    for (int y = 0; y < mask.height; ++y)
        for (int x = 0; x < mask.width; ++x) {
            s[static_cast<size_t>(y) * mask.width + x] =
                padded[static_cast<size_t>(y + 1) * (mask.width + 2) + (x + 1)];
        }
    return s;
}

std::vector<uint8_t> unmaskedNeighbourCounts(const Mask& mask) {
    std::vector<uint8_t> n(static_cast<size_t>(mask.width) * mask.height);
    for (int y = 0; y < mask.height; ++y)
        for (int x = 0; x < mask.width; ++x) {
            int c = 0;
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx) c += !mask.at(x + dx, y + dy);
            n[static_cast<size_t>(y) * mask.width + x] = static_cast<uint8_t>(c);
        }
    return n;
}

// Liu 2020 §4.3: r_m(x) = R·(1/(1 + e^(−k·n_x)) − 0.5) (the paper's "1 − e" is a misprint).
double falloffRadius(int unmaskedNeighbours, const MaskFalloff& falloff) {
    if (!falloff.enabled) return 0.0;
    return falloff.radius * (1.0 / (1.0 + std::exp(-falloff.k * unmaskedNeighbours)) - 0.5);
}

Vec3 uniformInBall(Rng& rng, double radius) {
    return rng.unitVector() * (radius * std::cbrt(rng.uniform()));
}

// Per row (top first): the farthest inside pixel edge from the axis on the chosen side, in
// pixels, or −1 when the row has none there.
std::vector<double> rowExtents(const Mask& mask, double axisColumn, ProfileSide side) {
    std::vector<double> e(mask.height, -1.0);
    for (int y = 0; y < mask.height; ++y) {
        double right = -1.0, left = -1.0;
        for (int x = 0; x < mask.width; ++x) {
            if (!mask.at(x, y)) continue;
            if (x + 1 > axisColumn) right = std::max(right, x + 1 - axisColumn);
            if (x < axisColumn) left = std::max(left, axisColumn - x);
        }
        e[y] = side == ProfileSide::kRight  ? right
               : side == ProfileSide::kLeft ? left
                                            : std::max(left, right);
    }
    return e;
}

std::vector<Vec2> maskHalfProfile(const Mask& mask, double axisColumn, ProfileSide side,
                                  double metresPerPixel) {
    const std::vector<double> e = rowExtents(mask, axisColumn, side);
    std::vector<Vec2> stroke;
    int lowest = -1, highest = -1;
    for (int y = mask.height - 1; y >= 0; --y) {  // bottom row first
        if (e[y] < 0) continue;                   // rows without pixels on this side are skipped
        if (lowest < 0) lowest = y;
        highest = y;
    }
    if (lowest < 0) {
        throw MaskError(std::string("the mask has no inside pixel ") +
                        (side == ProfileSide::kRight  ? "right of"
                         : side == ProfileSide::kLeft ? "left of"
                                                      : "on either side of") +
                        " its axis column");
    }
    auto heightOf = [&](double row) { return (mask.height - row) * metresPerPixel; };
    stroke.push_back({0.0, heightOf(lowest + 1)});  // on the axis at the bottom edge
    stroke.push_back({e[lowest] * metresPerPixel, heightOf(lowest + 1)});
    for (int y = lowest; y >= highest; --y) {
        if (e[y] >= 0) stroke.push_back({e[y] * metresPerPixel, heightOf(y + 0.5)});
    }
    stroke.push_back({e[highest] * metresPerPixel, heightOf(highest)});
    stroke.push_back({0.0, heightOf(highest)});  // back on the axis at the top edge
    return stroke;
}

namespace {

// The revolved mask: the revolution's geometry, with sampling softened at the border by the
// fall-off evaluated on the meridian section (the profile's extent per row, mirrored).
class MaskRevolution final : public Volume {
  public:
    MaskRevolution(VolumePtr inner, const Mask& mask, const std::vector<double>& extents,
                   double metresPerPixel, const MaskFalloff& falloff)
        : inner_(std::move(inner)), mpp_(metresPerPixel), rows_(mask.height), falloff_(falloff) {
        double widest = 0.0;
        for (double e : extents) widest = std::max(widest, e);
        half_ = static_cast<int>(std::ceil(widest)) + 3;
        Mask meridian;
        meridian.width = 2 * half_;
        meridian.height = mask.height;
        meridian.on.assign(static_cast<size_t>(meridian.width) * meridian.height, 0);
        for (int y = 0; y < mask.height; ++y)
            for (int x = 0; x < meridian.width; ++x) {
                const double offset = std::abs(x + 0.5 - half_);
                meridian.on[static_cast<size_t>(y) * meridian.width + x] = offset < extents[y];
            }
        const std::vector<uint8_t> n = unmaskedNeighbourCounts(meridian);
        radius_.resize(n.size());
        for (size_t i = 0; i < n.size(); ++i) radius_[i] = falloffRadius(n[i], falloff) * mpp_;
        outsideRadius_ = falloffRadius(25, falloff) * mpp_;
        description_ = "mask-revolution of a " + std::to_string(mask.width) + "x" +
                       std::to_string(mask.height) + " px mask";
    }

    double signedDistance(const Vec3& p) const override { return inner_->signedDistance(p); }
    Aabb bounds() const override { return inner_->bounds(); }
    double measure() const override { return inner_->measure(); }
    std::string describe() const override { return description_; }

    // Liu 2020 §4.3: a uniform interior point x is spread over a ball of radius r_m(x), which
    // is 0 where the 5×5 neighbourhood of x's meridian pixel is all inside and grows with the
    // number of outside pixels in it (to 4.8 px for a pixel on a straight edge at R = 10,
    // k = 0.4; 3.8 px one pixel further in). Spread points that leave the volume are drawn
    // again, so samples stay inside and their density falls from 1 deep inside to about a third
    // in the outermost pixel, the lost border mass reappearing a few pixels further in.
    std::optional<Vec3> sample(Rng& rng, int maxTries) const override {
        for (int t = 0; t < maxTries; ++t) {
            std::optional<Vec3> x = inner_->sample(rng, maxTries);
            if (!x || !falloff_.enabled) return x;
            const double r = radiusAt(*x);
            if (!(r > 0.0)) return x;
            const Vec3 y = *x + uniformInBall(rng, r);
            if (inner_->inside(y)) return y;
        }
        return std::nullopt;
    }

  private:
    double radiusAt(const Vec3& p) const {
        const double column = half_ + std::sqrt(p.x * p.x + p.z * p.z) / mpp_;
        const double row = rows_ - p.y / mpp_;
        const int c = static_cast<int>(std::floor(column));
        const int r = static_cast<int>(std::floor(row));
        if (c < 0 || r < 0 || c >= 2 * half_ || r >= rows_) return outsideRadius_;
        return radius_[static_cast<size_t>(r) * (2 * half_) + c];
    }

    VolumePtr inner_;
    double mpp_;
    int rows_;
    int half_ = 0;  // meridian mask: 2·half_ columns, the axis between columns half_−1 and half_
    MaskFalloff falloff_;
    std::vector<double> radius_;  // r_m per meridian pixel, metres
    double outsideRadius_ = 0.0;
    std::string description_;
};

}  // namespace

VolumePtr makeMaskRevolution(const Mask& mask, const MaskRevolutionOptions& options) {
    if (mask.width <= 0 || mask.height <= 0 || mask.count() == 0) {
        throw MaskError("the mask is empty: no inside pixel");
    }
    if (!(options.metresPerPixel > 0.0)) {
        throw std::invalid_argument("makeMaskRevolution: metresPerPixel must be > 0");
    }
    const double axis = options.axisColumn < 0 ? mask.width / 2.0 : options.axisColumn;
    const std::vector<Vec2> stroke =
        maskHalfProfile(mask, axis, options.side, options.metresPerPixel);
    const std::vector<Vec2> profile = cleanStroke(stroke, options.cleaning);
    double voxel = options.voxelSize;
    if (!(voxel > 0.0)) {
        double widest = 0.0, lo = 1e300, hi = -1e300;
        for (const Vec2& q : profile) {
            widest = std::max(widest, q.x);
            lo = std::min(lo, q.y);
            hi = std::max(hi, q.y);
        }
        voxel = std::max(2.0 * widest, hi - lo) / 100.0;
    }
    VolumePtr inner = makeRevolution(profile, voxel, options.segments);
    std::vector<double> extents = rowExtents(mask, axis, options.side);
    return std::make_shared<MaskRevolution>(std::move(inner), mask, extents, options.metresPerPixel,
                                            options.falloff);
}

}  // namespace sylva
