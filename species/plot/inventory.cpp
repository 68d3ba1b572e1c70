#include "species/plot/inventory.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "species/model/leaf_shape.h"
#include "species/model/tree_metrics.h"
#include "species/plot/point_process.h"

namespace sylva {

namespace {

constexpr double kBreastHeight = 1.3;  // metres above the base
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Sector of a horizontal offset: azimuth clockwise from north (−z) towards east (+x), sectors
// of 45° centred on N, NE, … (N covers [−22.5°, 22.5°)).
int sectorOf(double dx, double dz) {
    double az = std::atan2(dx, -dz) * 180.0 / kPi;  // (−180, 180]
    if (az < 0) az += 360.0;
    return static_cast<int>(std::floor((az + 22.5) / 45.0)) % 8;
}

}  // namespace

const std::array<const char*, 8> kCrownSectors = {"n", "ne", "e", "se", "s", "sw", "w", "nw"};

std::string treeName(int32_t id) {
    char buf[24];
    std::snprintf(buf, sizeof buf, "tree-%04d", static_cast<int>(id));
    return buf;
}

std::string plotSpeciesName(const GrownPlot& plot, int32_t speciesIndex) {
    if (plot.spec && speciesIndex >= 0 &&
        static_cast<size_t>(speciesIndex) < plot.spec->species.size()) {
        return plot.spec->species[speciesIndex].species.name;
    }
    return "species-" + std::to_string(speciesIndex);
}

TreeRecord measureTree(const Tree& tree, const Vec3& base) {
    TreeRecord r;
    r.base = base;
    const auto& nodes = tree.nodes;
    double top = -std::numeric_limits<double>::infinity();
    for (const SkeletonNode& n : nodes) {
        if (n.part == kShootPart) top = std::max(top, n.position.y);
    }
    for (const Leaf& leaf : tree.leaves) {
        top = std::max(top, leaf.position.y);
        r.leafArea += leafArea(leaf);
    }
    r.height = std::isfinite(top) ? std::max(0.0, top - base.y) : 0.0;

    if (!nodes.empty()) {
        const ChildIndex children(tree);
        // DBH along the order-0 path of the shoot from the root node.
        int cur = 0;
        while (true) {
            int next = -1;
            for (int k = children.offset[cur]; k < children.offset[cur + 1]; ++k) {
                const int c = children.child[k];
                if (nodes[c].part == kShootPart && nodes[c].order == 0) {
                    next = c;
                    break;
                }
            }
            if (next < 0) break;
            const double h0 = nodes[cur].position.y - base.y, h1 = nodes[next].position.y - base.y;
            if (h0 <= kBreastHeight && h1 >= kBreastHeight) {
                const double t = h1 > h0 ? (kBreastHeight - h0) / (h1 - h0) : 0.0;
                r.dbh = 2.0 * (nodes[cur].radius + t * (nodes[next].radius - nodes[cur].radius));
                break;
            }
            cur = next;
        }

        // Crown base: lowest leaf, or the attachment of the lowest leaf-carrying first-order
        // branch.
        std::vector<uint8_t> carries(nodes.size(), 0);
        for (const Leaf& leaf : tree.leaves) {
            if (leaf.node >= 0 && static_cast<size_t>(leaf.node) < nodes.size())
                carries[leaf.node] = 1;
        }
        for (size_t i = nodes.size(); i-- > 1;) {
            const int32_t p = nodes[i].parent;
            if (carries[i] && p >= 0) carries[p] = 1;
        }
        double cb = std::numeric_limits<double>::infinity();
        for (const Leaf& leaf : tree.leaves) cb = std::min(cb, leaf.position.y - base.y);
        for (size_t i = 1; i < nodes.size(); ++i) {
            const int32_t p = nodes[i].parent;
            if (p < 0 || !carries[i] || nodes[i].part != kShootPart) continue;
            if (nodes[i].order == 1 && nodes[p].order == 0) {
                cb = std::min(cb, nodes[p].position.y - base.y);
            }
        }
        r.crownBase = tree.leaves.empty() ? kNaN : std::max(0.0, cb);
    } else {
        r.crownBase = kNaN;
    }

    auto extend = [&](const Vec3& p) {
        const double dx = p.x - base.x, dz = p.z - base.z;
        const double d = std::sqrt(dx * dx + dz * dz);
        if (!(d > 1e-9)) return;
        double& s = r.crownRadius[sectorOf(dx, dz)];
        s = std::max(s, d);
    };
    for (const SkeletonNode& n : nodes) {
        if (n.part == kShootPart) extend(n.position);
    }
    for (const Leaf& leaf : tree.leaves) extend(leaf.position);
    return r;
}

std::vector<TreeRecord> treeTable(const GrownPlot& plot) {
    std::vector<TreeRecord> table;
    table.reserve(plot.trees.size());
    std::vector<Vec2> points;
    for (const PlotTree& t : plot.trees) {
        TreeRecord r = measureTree(t.grown.tree, t.stem.base);
        r.id = t.stem.id;
        r.name = treeName(t.stem.id);
        r.species = plotSpeciesName(plot, t.stem.species);
        table.push_back(std::move(r));
        points.push_back({t.stem.base.x, t.stem.base.z});
    }
    const std::vector<double> nn = nearestNeighbourDistances(points);
    for (size_t i = 0; i < table.size(); ++i) table[i].nearestNeighbour = nn[i];
    return table;
}

double canopyCoverCell(const PlotArea& area, double cell) {
    const double w = 2 * area.halfX(), d = 2 * area.halfZ();
    // ⌈w/c⌉·⌈d/c⌉ ≤ (w/c + 1)(d/c + 1): solve (w/c + 1)(d/c + 1) = N for the smallest c that fits.
    const double n = kMaxCoverCells;
    const double a = n - 1, b = -(w + d), c0 = -w * d;  // a·c² + b·c + c0 = 0
    const double fits = (-b + std::sqrt(b * b - 4 * a * c0)) / (2 * a);
    return std::max(cell, fits);
}

double canopyCover(const std::vector<const Tree*>& trees, const PlotArea& area, double cell) {
    if (!(cell > 0)) return kNaN;
    cell = canopyCoverCell(area, cell);
    const double hx = area.halfX(), hz = area.halfZ();
    const int nx = std::max(1, static_cast<int>(std::ceil(2 * hx / cell)));
    const int nz = std::max(1, static_cast<int>(std::ceil(2 * hz / cell)));
    const double x0 = -hx, z0 = -hz;  // cell (i, j) centre: x0 + (i + ½)·cell
    std::vector<uint8_t> covered(static_cast<size_t>(nx) * nz, 0);
    // Cell index range whose centres lie in [lo, hi].
    auto range = [cell](double lo, double hi, double origin, int n, int& a, int& b) {
        a = std::max(0, static_cast<int>(std::ceil((lo - origin) / cell - 0.5)));
        b = std::min(n - 1, static_cast<int>(std::floor((hi - origin) / cell - 0.5)));
        return a <= b;
    };
    auto fillTriangle = [&](const Vec2& a, const Vec2& b, const Vec2& c) {
        const double area2 = cross(b - a, c - a);
        if (area2 == 0.0 || !std::isfinite(area2)) return;
        int i0, i1, j0, j1;
        if (!range(std::min({a.x, b.x, c.x}), std::max({a.x, b.x, c.x}), x0, nx, i0, i1) ||
            !range(std::min({a.y, b.y, c.y}), std::max({a.y, b.y, c.y}), z0, nz, j0, j1)) {
            return;
        }
        const double s = area2 > 0 ? 1.0 : -1.0;
        for (int j = j0; j <= j1; ++j) {
            for (int i = i0; i <= i1; ++i) {
                const Vec2 p{x0 + (i + 0.5) * cell, z0 + (j + 0.5) * cell};
                if (s * cross(b - a, p - a) >= 0 && s * cross(c - b, p - b) >= 0 &&
                    s * cross(a - c, p - c) >= 0) {
                    covered[size_t(j) * nx + i] = 1;
                }
            }
        }
    };
    auto fillSegment = [&](const Vec2& a, const Vec2& b, double ra, double rb) {
        const double rmax = std::max(ra, rb);
        int i0, i1, j0, j1;
        if (!range(std::min(a.x, b.x) - rmax, std::max(a.x, b.x) + rmax, x0, nx, i0, i1) ||
            !range(std::min(a.y, b.y) - rmax, std::max(a.y, b.y) + rmax, z0, nz, j0, j1)) {
            return;
        }
        const Vec2 d = b - a;
        const double len2 = dot(d, d);
        for (int j = j0; j <= j1; ++j) {
            for (int i = i0; i <= i1; ++i) {
                const Vec2 p{x0 + (i + 0.5) * cell, z0 + (j + 0.5) * cell};
                const double t = len2 > 0 ? std::clamp(dot(p - a, d) / len2, 0.0, 1.0) : 0.0;
                const Vec2 e = p - (a + d * t);
                const double r = ra + t * (rb - ra);
                if (dot(e, e) <= r * r) covered[size_t(j) * nx + i] = 1;
            }
        }
    };
    std::vector<Vec3> pts;
    for (const Tree* tree : trees) {
        for (const SkeletonNode& n : tree->nodes) {
            if (n.parent < 0 || n.part != kShootPart) continue;
            const SkeletonNode& p = tree->nodes[n.parent];
            fillSegment({p.position.x, p.position.z}, {n.position.x, n.position.z},
                        std::max(0.0, p.radius), std::max(0.0, n.radius));
        }
        for (const Leaf& leaf : tree->leaves) {
            const LeafOutline& outline = leafOutline(leaf.shape);
            leafPoints(leaf, leafFrame(leaf), outline, pts);
            for (size_t k = 0; k + 2 < outline.triangles.size(); k += 3) {
                const Vec3 &a = pts[outline.triangles[k]], &b = pts[outline.triangles[k + 1]],
                           &c = pts[outline.triangles[k + 2]];
                fillTriangle({a.x, a.z}, {b.x, b.z}, {c.x, c.z});
            }
        }
    }
    int64_t inside = 0, hit = 0;
    for (int j = 0; j < nz; ++j) {
        for (int i = 0; i < nx; ++i) {
            if (!area.contains(x0 + (i + 0.5) * cell, z0 + (j + 0.5) * cell)) continue;
            ++inside;
            hit += covered[size_t(j) * nx + i];
        }
    }
    return inside > 0 ? static_cast<double>(hit) / static_cast<double>(inside) : kNaN;
}

PlotStatistics plotStatistics(const GrownPlot& plot, const std::vector<TreeRecord>& table,
                              double cell) {
    PlotStatistics s;
    const PlotArea area = plot.spec ? plot.spec->area : PlotArea{};
    s.areaM2 = area.area();
    s.trees = static_cast<int64_t>(table.size());
    const double perHa = s.areaM2 > 0 ? 1e4 / s.areaM2 : kNaN;
    s.stemsPerHa = static_cast<double>(table.size()) * perHa;
    double basal = 0, leaf = 0, nnSum = 0;
    std::vector<double> heights;
    std::vector<Vec2> points;
    for (const TreeRecord& r : table) {
        basal += kPi * r.dbh * r.dbh / 4.0;
        leaf += r.leafArea;
        heights.push_back(r.height);
        points.push_back({r.base.x, r.base.z});
        nnSum += r.nearestNeighbour;
        ++s.perSpecies[r.species];
    }
    s.basalAreaM2PerHa = basal * perHa;
    s.leafAreaIndex = s.areaM2 > 0 ? leaf / s.areaM2 : kNaN;
    s.lai = plot.lai;
    s.clarkEvans = clarkEvans(points, area);
    s.meanNearestNeighbour = table.size() >= 2 ? nnSum / static_cast<double>(table.size()) : kNaN;
    std::vector<const Tree*> trees;
    for (const PlotTree& t : plot.trees) trees.push_back(&t.grown.tree);
    s.canopyCellM = canopyCoverCell(area, cell);
    s.canopyCover = canopyCover(trees, area, s.canopyCellM);

    HeightDistribution& h = s.heights;
    if (heights.empty()) {
        h.min = h.q1 = h.median = h.q3 = h.max = h.mean = kNaN;
    } else {
        h.min = *std::min_element(heights.begin(), heights.end());
        h.max = *std::max_element(heights.begin(), heights.end());
        h.q1 = quantile(heights, 0.25);
        h.median = quantile(heights, 0.5);
        h.q3 = quantile(heights, 0.75);
        double sum = 0;
        for (double v : heights) sum += v;
        h.mean = sum / static_cast<double>(heights.size());
        h.histogram.assign(static_cast<size_t>(std::floor(h.max / h.binWidth)) + 1, 0);
        for (double v : heights) {
            const size_t k =
                std::min(h.histogram.size() - 1,
                         static_cast<size_t>(std::max(0.0, std::floor(v / h.binWidth))));
            ++h.histogram[k];
        }
    }
    return s;
}

}  // namespace sylva
