#include "pipeline/render/preview.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace sylva {

namespace {

constexpr double kMargin = 0.04;      // fraction of the image on each side
constexpr double kMinRadiusPx = 0.5;  // so sub-pixel twigs still leave a visible line
constexpr double kGroundInk = 0.45;   // grey level of the ground line (0 none .. 1 black)
constexpr int kBandRows = 16;         // rows per parallel task; each band owns its rows

// A segment in pixel space (x right, y down), with its clipped pixel bounding box.
struct PxSegment {
    double ax, ay, bx, by, ra, rb;
    int x0, x1, y0, y1;  // inclusive pixel ranges
};

double coverage(const PxSegment& s, double px, double py) {
    double dx = s.bx - s.ax, dy = s.by - s.ay;
    double len2 = dx * dx + dy * dy;
    double t = len2 > 0 ? std::clamp(((px - s.ax) * dx + (py - s.ay) * dy) / len2, 0.0, 1.0) : 0;
    double ex = px - (s.ax + t * dx), ey = py - (s.ay + t * dy);
    double r = s.ra + t * (s.rb - s.ra);
    return std::clamp(r + 0.5 - std::sqrt(ex * ex + ey * ey), 0.0, 1.0);
}

}  // namespace

std::vector<uint8_t> renderPreview(const Tree& tree, int sizePixels) {
    if (sizePixels <= 0) {
        throw std::invalid_argument("renderPreview: size must be positive, got " +
                                    std::to_string(sizePixels));
    }
    const int size = sizePixels;
    const auto& nodes = tree.nodes;
    std::vector<uint8_t> image(static_cast<size_t>(size) * size, 255);
    if (nodes.empty()) return image;

    // Frame: x-y bounding box including radii, centred, uniform scale (px per m).
    double lox = 1e300, hix = -1e300, loy = 1e300, hiy = -1e300;
    bool hasRoots = false;
    for (const SkeletonNode& n : nodes) {
        double r = std::max(0.0, n.radius);
        lox = std::min(lox, n.position.x - r);
        hix = std::max(hix, n.position.x + r);
        loy = std::min(loy, n.position.y - r);
        hiy = std::max(hiy, n.position.y + r);
        hasRoots |= n.part == kRootPart;
    }
    double span = std::max(hix - lox, hiy - loy);
    if (!(span > 0) || !std::isfinite(span)) span = 1.0;
    const double scale = size * (1.0 - 2.0 * kMargin) / span;
    const double cx = 0.5 * (lox + hix), cy = 0.5 * (loy + hiy);
    auto toPxX = [&](double x) { return (x - cx) * scale + 0.5 * size; };
    auto toPxY = [&](double y) { return 0.5 * size - (y - cy) * scale; };

    // Project the segments and bucket them by row band (serial, so deterministic).
    const int bands = (size + kBandRows - 1) / kBandRows;
    std::vector<PxSegment> segs;
    segs.reserve(nodes.size());
    std::vector<std::vector<int32_t>> bandSegs(bands);
    for (size_t i = 1; i < nodes.size(); ++i) {
        const SkeletonNode& a = nodes[nodes[i].parent];
        const SkeletonNode& b = nodes[i];
        PxSegment s;
        s.ax = toPxX(a.position.x);
        s.ay = toPxY(a.position.y);
        s.bx = toPxX(b.position.x);
        s.by = toPxY(b.position.y);
        s.ra = std::max(kMinRadiusPx, a.radius * scale);
        s.rb = std::max(kMinRadiusPx, b.radius * scale);
        double reach = std::max(s.ra, s.rb) + 1.0;  // covers the 0.5 px anti-alias fringe
        double fx0 = std::min(s.ax, s.bx) - reach, fx1 = std::max(s.ax, s.bx) + reach;
        double fy0 = std::min(s.ay, s.by) - reach, fy1 = std::max(s.ay, s.by) + reach;
        if (!(fx1 >= 0 && fy1 >= 0 && fx0 < size && fy0 < size)) continue;  // also drops NaN
        s.x0 = std::max(0, static_cast<int>(std::floor(fx0)));
        s.x1 = std::min(size - 1, static_cast<int>(std::floor(fx1)));
        s.y0 = std::max(0, static_cast<int>(std::floor(fy0)));
        s.y1 = std::min(size - 1, static_cast<int>(std::floor(fy1)));
        int32_t id = static_cast<int32_t>(segs.size());
        segs.push_back(s);
        for (int band = s.y0 / kBandRows; band <= s.y1 / kBandRows; ++band) {
            bandSegs[band].push_back(id);
        }
    }
    const double groundY = toPxY(0.0);

    // Each band is written by exactly one task and max() is order-independent, so the raster
    // is the same for any scheduling.
    tbb::parallel_for(tbb::blocked_range<int>(0, bands), [&](const tbb::blocked_range<int>& r) {
        std::vector<double> cov;
        for (int band = r.begin(); band != r.end(); ++band) {
            const int row0 = band * kBandRows, row1 = std::min(size, row0 + kBandRows);
            cov.assign(static_cast<size_t>(row1 - row0) * size, 0.0);
            if (hasRoots) {
                for (int y = row0; y < row1; ++y) {
                    double c = kGroundInk * std::clamp(1.0 - std::abs(y + 0.5 - groundY), 0.0, 1.0);
                    if (c > 0) std::fill_n(cov.begin() + (y - row0) * size, size, c);
                }
            }
            for (int32_t id : bandSegs[band]) {
                const PxSegment& s = segs[id];
                const double reach = std::max(s.ra, s.rb) + 1.0;
                const double dy = s.by - s.ay;
                for (int y = std::max(s.y0, row0); y <= std::min(s.y1, row1 - 1); ++y) {
                    // Only the part of the segment within `reach` rows of this one can cover
                    // it; clipping to it keeps long diagonal segments from scanning their
                    // whole bounding box.
                    int xa = s.x0, xb = s.x1;
                    if (std::abs(dy) > 1e-9) {
                        double ta = (y + 0.5 - reach - s.ay) / dy,
                               tb = (y + 0.5 + reach - s.ay) / dy;
                        ta = std::clamp(ta, 0.0, 1.0);
                        tb = std::clamp(tb, 0.0, 1.0);
                        double xta = s.ax + ta * (s.bx - s.ax), xtb = s.ax + tb * (s.bx - s.ax);
                        xa = std::max(xa, static_cast<int>(std::floor(std::min(xta, xtb) - reach)));
                        xb = std::min(xb, static_cast<int>(std::floor(std::max(xta, xtb) + reach)));
                    }
                    double* rowCov = cov.data() + static_cast<size_t>(y - row0) * size;
                    for (int x = xa; x <= xb; ++x) {
                        if (rowCov[x] < 1.0) {  // already solid ink: nothing to add
                            rowCov[x] = std::max(rowCov[x], coverage(s, x + 0.5, y + 0.5));
                        }
                    }
                }
            }
            uint8_t* out = image.data() + static_cast<size_t>(row0) * size;
            for (size_t k = 0; k < cov.size(); ++k) {
                out[k] = static_cast<uint8_t>(std::lround(255.0 * (1.0 - cov[k])));
            }
        }
    });
    return image;
}

}  // namespace sylva
