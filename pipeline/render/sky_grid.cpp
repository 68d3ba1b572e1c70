#include "pipeline/render/sky_grid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace sylva {

SkyGrid::SkyGrid(const Vec3& lo, const Vec3& hi, int cells, double clumping) : clumping_(clumping) {
    if (cells < 1 || !(clumping > 0.0 && clumping <= 1.0)) {
        throw std::invalid_argument("SkyGrid: cells ≥ 1 and clumping in (0, 1]");
    }
    const Vec3 size = hi - lo;
    const double longest = std::max({size.x, size.y, size.z, 1e-3});
    h_ = longest / cells;
    // A cell of margin each side: the box's surfaces lie inside the grid.
    origin_ = lo - Vec3{h_, h_, h_};
    nx_ = static_cast<int>(std::ceil(std::max(size.x, 0.0) / h_)) + 2;
    ny_ = static_cast<int>(std::ceil(std::max(size.y, 0.0) / h_)) + 2;
    nz_ = static_cast<int>(std::ceil(std::max(size.z, 0.0) / h_)) + 2;
    area_.assign(size_t(nx_) * ny_ * nz_, 0.0f);
    const double golden = kPi * (3.0 - std::sqrt(5.0));
    for (int k = 0; k < kDirections; ++k) {
        const double y = 1.0 - (2.0 * k + 1.0) / kDirections;
        const double r = std::sqrt(std::max(0.0, 1.0 - y * y));
        directions_[k] = {r * std::cos(golden * k), y, r * std::sin(golden * k)};
    }
}

void SkyGrid::addArea(const Vec3& p, double projectedArea) {
    const Vec3 u = (p - origin_) / h_ - Vec3{0.5, 0.5, 0.5};
    const int i0 = static_cast<int>(std::floor(u.x)), j0 = static_cast<int>(std::floor(u.y)),
              k0 = static_cast<int>(std::floor(u.z));
    const double fx = u.x - i0, fy = u.y - j0, fz = u.z - k0;
    for (int c = 0; c < 8; ++c) {
        const int i = i0 + (c & 1), j = j0 + ((c >> 1) & 1), k = k0 + ((c >> 2) & 1);
        if (i < 0 || j < 0 || k < 0 || i >= nx_ || j >= ny_ || k >= nz_) continue;
        const double w = ((c & 1) ? fx : 1 - fx) * (((c >> 1) & 1) ? fy : 1 - fy) *
                         (((c >> 2) & 1) ? fz : 1 - fz);
        area_[cell(i, j, k)] += static_cast<float>(w * projectedArea);
    }
}

void SkyGrid::finish() {
    const double perVolume = clumping_ / (h_ * h_ * h_);
    for (float& a : area_) a = static_cast<float>(a * perVolume);  // σ, 1/m
    trans_.assign(area_.size() * kDirections, 0);
    for (int d = 0; d < kDirections; ++d) sweep(d);
}

// One direction's transmittance for every cell. The direction's major axis `a` (its largest
// component) orders the cells in slices; a cell's step towards the direction ends in the next
// slice, offset across it by the other components / |d_a| cells (at most one), where the
// transmittance and extinction are interpolated bilinearly (1 and 0 off the grid).
void SkyGrid::sweep(int direction) {
    const Vec3& d = directions_[direction];
    const int n[3] = {nx_, ny_, nz_};
    int a = 0;
    for (int c = 1; c < 3; ++c) {
        if (std::abs(d[c]) > std::abs(d[a])) a = c;
    }
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const double da = std::abs(d[a]);
    const int dir = d[a] > 0 ? 1 : -1;
    const double step = h_ / da;  // metres from a cell centre to the next slice
    const double ob = d[b] / da, oc = d[c] / da;
    const int ib = static_cast<int>(std::floor(ob)), ic = static_cast<int>(std::floor(oc));
    const double fb = ob - ib, fc = oc - ic;
    std::vector<float> t(area_.size(), 1.0f);
    auto at = [&](int sa, int sb, int sc) {
        int idx[3];
        idx[a] = sa, idx[b] = sb, idx[c] = sc;
        return cell(idx[0], idx[1], idx[2]);
    };
    const int first = dir > 0 ? n[a] - 1 : 0, last = dir > 0 ? -1 : n[a];
    for (int s = first; s != last; s -= dir) {
        const int up = s + dir;
        const bool upInside = up >= 0 && up < n[a];
        for (int pc = 0; pc < n[c]; ++pc) {
            for (int pb = 0; pb < n[b]; ++pb) {
                double tq = 0.0, sq = 0.0;
                for (int q = 0; q < 4; ++q) {
                    const int qb = pb + ib + (q & 1), qc = pc + ic + (q >> 1);
                    const double w = ((q & 1) ? fb : 1 - fb) * ((q >> 1) ? fc : 1 - fc);
                    if (upInside && qb >= 0 && qc >= 0 && qb < n[b] && qc < n[c]) {
                        const size_t i = at(up, qb, qc);
                        tq += w * t[i];
                        sq += w * area_[i];
                    } else {
                        tq += w;  // open sky beyond the grid
                    }
                }
                const size_t i = at(s, pb, pc);
                t[i] = static_cast<float>(tq * std::exp(-0.5 * step * (area_[i] + sq)));
            }
        }
    }
    for (size_t i = 0; i < t.size(); ++i) {
        trans_[i * kDirections + direction] =
            static_cast<uint16_t>(std::lround(std::clamp(t[i], 0.0f, 1.0f) * 65535.0f));
    }
}

void SkyGrid::transmittance(const Vec3& p, float* t) const {
    const Vec3 u = (p - origin_) / h_ - Vec3{0.5, 0.5, 0.5};
    const int i0 = static_cast<int>(std::floor(u.x)), j0 = static_cast<int>(std::floor(u.y)),
              k0 = static_cast<int>(std::floor(u.z));
    const double fx = u.x - i0, fy = u.y - j0, fz = u.z - k0;
    double sum[kDirections] = {};
    for (int c = 0; c < 8; ++c) {
        const int i = i0 + (c & 1), j = j0 + ((c >> 1) & 1), k = k0 + ((c >> 2) & 1);
        const double w = ((c & 1) ? fx : 1 - fx) * (((c >> 1) & 1) ? fy : 1 - fy) *
                         (((c >> 2) & 1) ? fz : 1 - fz);
        if (w == 0.0) continue;
        if (i < 0 || j < 0 || k < 0 || i >= nx_ || j >= ny_ || k >= nz_) {
            for (double& s : sum) s += w;  // open sky off the grid
            continue;
        }
        const uint16_t* q = &trans_[cell(i, j, k) * kDirections];
        for (int d = 0; d < kDirections; ++d) sum[d] += w * q[d] * (1.0 / 65535.0);
    }
    for (int d = 0; d < kDirections; ++d) t[d] = static_cast<float>(sum[d]);
}

double SkyGrid::extinction(const Vec3& p) const {
    const Vec3 u = (p - origin_) / h_;
    const int i = static_cast<int>(std::floor(u.x)), j = static_cast<int>(std::floor(u.y)),
              k = static_cast<int>(std::floor(u.z));
    if (i < 0 || j < 0 || k < 0 || i >= nx_ || j >= ny_ || k >= nz_) return 0.0;
    return area_[cell(i, j, k)];
}

}  // namespace sylva
