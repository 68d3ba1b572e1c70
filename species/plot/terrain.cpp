#include "species/plot/terrain.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "volumes/image_file.h"

namespace sylva {

double PlotArea::area() const {
    return shape == Shape::kCircle ? kPi * radius * radius : width * depth;
}

bool PlotArea::contains(double x, double z) const {
    if (shape == Shape::kCircle) return x * x + z * z <= radius * radius;
    return std::abs(x) <= halfX() && std::abs(z) <= halfZ();
}

Terrain::Terrain(double x0, double z0, double cell, int nx, int nz, std::vector<float> heights)
    : x0_(x0), z0_(z0), cell_(cell), nx_(nx), nz_(nz), heights_(std::move(heights)) {
    if (nx < 2 || nz < 2 || !(cell > 0) ||
        heights_.size() != static_cast<size_t>(nx) * static_cast<size_t>(nz)) {
        throw std::invalid_argument(
            "Terrain: at least 2 × 2 samples, a positive cell, nx·nz heights");
    }
}

double Terrain::height(double x, double z) const {
    if (heights_.empty()) return 0.0;
    const double u = std::clamp((x - x0_) / cell_, 0.0, nx_ - 1.0);
    const double v = std::clamp((z - z0_) / cell_, 0.0, nz_ - 1.0);
    const int i = std::min(static_cast<int>(u), nx_ - 2);
    const int j = std::min(static_cast<int>(v), nz_ - 2);
    const double fu = u - i, fv = v - j;
    auto h = [&](int a, int b) { return static_cast<double>(heights_[size_t(b) * nx_ + a]); };
    return (1 - fv) * ((1 - fu) * h(i, j) + fu * h(i + 1, j)) +
           fv * ((1 - fu) * h(i, j + 1) + fu * h(i + 1, j + 1));
}

Vec3 Terrain::normal(double x, double z) const {
    if (heights_.empty()) return {0, 1, 0};
    const double e = cell_ * 0.5;
    const double dx = (height(x + e, z) - height(x - e, z)) / (2 * e);
    const double dz = (height(x, z + e) - height(x, z - e)) / (2 * e);
    return normalize(Vec3(-dx, 1.0, -dz));
}

Mesh terrainMesh(const Terrain& terrain) {
    Mesh m;
    const int nx = terrain.nx(), nz = terrain.nz();
    if (nx < 2 || nz < 2) return m;
    m.positions.reserve(size_t(nx) * nz * 3);
    m.normals.reserve(size_t(nx) * nz * 3);
    for (int j = 0; j < nz; ++j) {
        for (int i = 0; i < nx; ++i) {
            const double x = terrain.x0() + i * terrain.cell();
            const double z = terrain.z0() + j * terrain.cell();
            const Vec3 n = terrain.normal(x, z);
            m.positions.insert(m.positions.end(),
                               {float(x), terrain.heights()[size_t(j) * nx + i], float(z)});
            m.normals.insert(m.normals.end(), {float(n.x), float(n.y), float(n.z)});
        }
    }
    m.order.assign(size_t(nx) * nz, -1);
    m.colour.assign(size_t(nx) * nz, 0);
    m.indices.reserve(size_t(nx - 1) * (nz - 1) * 6);
    for (int j = 0; j + 1 < nz; ++j) {
        for (int i = 0; i + 1 < nx; ++i) {
            const uint32_t a = uint32_t(j * nx + i), b = a + 1, c = a + uint32_t(nx), d = c + 1;
            // Seen from +y, x right and z down the page: a b / c d; (a, c, b) and (b, c, d)
            // wind counter-clockwise about +y.
            m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
        }
    }
    return m;
}

}  // namespace sylva

namespace sylva {

TerrainGrid terrainGrid(const PlotArea& area, double margin, double cell) {
    const double w = 2 * (area.halfX() + margin);
    const double d = 2 * (area.halfZ() + margin);
    TerrainGrid g;
    // Samples (n − 1)·cell ≥ the extent; the tolerance keeps an exact multiple exact.
    g.nx = static_cast<int64_t>(std::ceil(w / cell - 1e-9)) + 1;
    g.nz = static_cast<int64_t>(std::ceil(d / cell - 1e-9)) + 1;
    g.nx = std::max<int64_t>(g.nx, 2);
    g.nz = std::max<int64_t>(g.nz, 2);
    g.x0 = -0.5 * static_cast<double>(g.nx - 1) * cell;
    g.z0 = -0.5 * static_cast<double>(g.nz - 1) * cell;
    return g;
}

namespace {

double fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }

// 2-D gradient noise in [−√½, √½] with gradients hashed from (key, lattice point).
double gradientNoise(uint64_t key, double x, double y) {
    const double fx = std::floor(x), fy = std::floor(y);
    const auto xi = static_cast<int64_t>(fx), yi = static_cast<int64_t>(fy);
    const double dx = x - fx, dy = y - fy;
    constexpr double s = 0.70710678118654752;
    static constexpr double kGx[8] = {1, -1, 0, 0, s, -s, s, -s};
    static constexpr double kGy[8] = {0, 0, 1, -1, s, s, -s, -s};
    auto grad = [&](int64_t i, int64_t j, double ox, double oy) {
        const uint64_t h =
            hashCombine(hashCombine(key, static_cast<uint64_t>(i)), static_cast<uint64_t>(j));
        const int k = static_cast<int>(h >> 61);
        return kGx[k] * ox + kGy[k] * oy;
    };
    const double n00 = grad(xi, yi, dx, dy), n10 = grad(xi + 1, yi, dx - 1, dy);
    const double n01 = grad(xi, yi + 1, dx, dy - 1), n11 = grad(xi + 1, yi + 1, dx - 1, dy - 1);
    const double u = fade(dx), v = fade(dy);
    return (1 - v) * ((1 - u) * n00 + u * n10) + v * ((1 - u) * n01 + u * n11);
}

}  // namespace

double noiseHeight(const TerrainOptions& o, uint64_t plotSeed, double x, double z) {
    const uint64_t key = Rng(plotSeed).derive("terrain/noise").seed();
    double sum = 0, weights = 0, weight = 1, wavelength = o.wavelength;
    for (int k = 0; k < o.octaves; ++k) {
        sum += weight * gradientNoise(hashCombine(key, static_cast<uint64_t>(k)), x / wavelength,
                                      z / wavelength);
        weights += weight;
        weight *= 0.5;
        wavelength *= 0.5;
    }
    // Each octave is at most √½ in magnitude: the sum over their weights, over √½, is in [−1, 1].
    return o.amplitude * sum / (weights * 0.70710678118654752);
}

double slopeHeight(const TerrainOptions& o, double x, double z) {
    // Downhill direction in (x, z): azimuth 0 → −z, 90° → +x.
    const double dx = std::sin(o.aspectRad), dz = -std::cos(o.aspectRad);
    return -std::tan(o.slopeRad) * (x * dx + z * dz);
}

DemPixels demPixelsNeeded(const TerrainGrid& grid, double cell, double metresPerPixel) {
    auto need = [&](int64_t n) {
        return static_cast<int64_t>(
                   std::ceil(static_cast<double>(n - 1) * cell / metresPerPixel - 1e-9)) +
               1;
    };
    return {need(grid.nx), need(grid.nz)};
}

DemImage readDem(const TerrainOptions& o) {
    const ImageFile img = readImageFile(o.demPath);
    if (img.channels != 1) {
        throw std::invalid_argument("the DEM " + o.demPath + " has " +
                                    std::to_string(img.channels) + " channels; expected 1");
    }
    DemImage dem;
    dem.width = img.width;
    dem.height = img.height;
    dem.heights.resize(img.pixels.size());
    for (size_t k = 0; k < img.pixels.size(); ++k) {
        double v = img.pixels[k];
        // Integer formats: the stored integer (the float read divided it by integerMax).
        if (img.integerMax > 0) v = std::round(v * img.integerMax);
        dem.heights[k] = v * o.heightScale + o.heightOffset;
    }
    return dem;
}

Terrain makeTerrain(const TerrainOptions& o, const PlotArea& area, double margin,
                    uint64_t plotSeed) {
    const TerrainGrid g = terrainGrid(area, margin, o.cell);
    if (g.samples() > kMaxTerrainSamples) {
        throw std::invalid_argument("makeTerrain: " + std::to_string(g.nx) + " × " +
                                    std::to_string(g.nz) + " samples, over kMaxTerrainSamples");
    }
    const int nx = static_cast<int>(g.nx), nz = static_cast<int>(g.nz);
    std::vector<float> h(static_cast<size_t>(g.samples()), 0.0f);
    auto xAt = [&](int i) { return g.x0 + i * o.cell; };
    auto zAt = [&](int j) { return g.z0 + j * o.cell; };
    switch (o.kind) {
        case TerrainOptions::Kind::kFlat:
            break;
        case TerrainOptions::Kind::kSlope:
            for (int j = 0; j < nz; ++j)
                for (int i = 0; i < nx; ++i)
                    h[size_t(j) * nx + i] = static_cast<float>(slopeHeight(o, xAt(i), zAt(j)));
            break;
        case TerrainOptions::Kind::kNoise:
            for (int j = 0; j < nz; ++j)
                for (int i = 0; i < nx; ++i)
                    h[size_t(j) * nx + i] =
                        static_cast<float>(noiseHeight(o, plotSeed, xAt(i), zAt(j)));
            break;
        case TerrainOptions::Kind::kDem: {
            const DemImage dem = readDem(o);
            const DemPixels need = demPixelsNeeded(g, o.cell, o.metresPerPixel);
            if (dem.width < need.width || dem.height < need.height) {
                throw std::invalid_argument("makeTerrain: the DEM does not cover the grid");
            }
            // Pixel (c, r) stands at x = (c − (W − 1)/2)·mpp, z = (r − (H − 1)/2)·mpp.
            const double cx = 0.5 * (dem.width - 1), cz = 0.5 * (dem.height - 1);
            auto px = [&](int c, int r) { return dem.heights[size_t(r) * dem.width + c]; };
            for (int j = 0; j < nz; ++j) {
                for (int i = 0; i < nx; ++i) {
                    const double u =
                        std::clamp(xAt(i) / o.metresPerPixel + cx, 0.0, dem.width - 1.0);
                    const double v =
                        std::clamp(zAt(j) / o.metresPerPixel + cz, 0.0, dem.height - 1.0);
                    const int c = std::min(static_cast<int>(u), std::max(dem.width - 2, 0));
                    const int r = std::min(static_cast<int>(v), std::max(dem.height - 2, 0));
                    const int c1 = std::min(c + 1, dem.width - 1);
                    const int r1 = std::min(r + 1, dem.height - 1);
                    const double fu = u - c, fv = v - r;
                    h[size_t(j) * nx + i] =
                        static_cast<float>((1 - fv) * ((1 - fu) * px(c, r) + fu * px(c1, r)) +
                                           fv * ((1 - fu) * px(c, r1) + fu * px(c1, r1)));
                }
            }
            break;
        }
    }
    return Terrain(g.x0, g.z0, o.cell, nx, nz, std::move(h));
}

}  // namespace sylva
