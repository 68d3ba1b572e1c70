#include "species/plot/terrain.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace sylva {

double PlotArea::area() const {
    return shape == Shape::kCircle ? kPi * radius * radius : width * depth;
}

bool PlotArea::contains(double x, double z) const {
    if (shape == Shape::kCircle) return x * x + z * z <= radius * radius;
    return std::abs(x) <= width * 0.5 && std::abs(z) <= depth * 0.5;
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
