// The watertight wood mesh: the union of every branch segment's round cone (the convex hull
// of the spheres at its two nodes) as an OpenVDB narrow-band level set, meshed with
// volumeToMesh into one closed, manifold triangle mesh.
//
// Rasterisation is exact and deterministic: each segment is tested only against the 8³ leaf
// blocks near it; every block then takes, per voxel, the minimum of the exact signed
// distances of its segments (the union). A block depends only on its own voxels and its
// segments, so the grid (and hence the mesh and the .vdb) is identical for any thread count.
// Then: flood fill of the interior, enclosed cavities filled (fillCavities), values kept
// 0.001 voxel off zero (kZeroNudgeVoxels), volumeToMesh at isovalue 0 with adaptivity 0.
//
// Mesh conventions: triangles counter-clockwise seen from outside; per-vertex normals are
// area-weighted face normals (unit); order per vertex is the child node's order of the
// segment with the smallest signed distance at the vertex; colour 0; no uvs.
#include "species/geometry/watertight.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include "core/atomic_file.h"
#include "species/geometry/level_set_mesh.h"
#include "volumes/vdb_module.h"

namespace sylva {
namespace {

constexpr int kLeafDim = VdbBlock::kDim;  // 8 voxels per leaf edge

// Twigs are thickened to this many voxels of radius so that they survive sampling at voxel
// centres. √3/2, the covering radius of the voxel lattice, puts a voxel centre inside the
// capsule at every point of a segment's axis, which keeps twigs whole (at 0.75 about one thin
// diagonal twig in six broke into separate beads), but the dual-contoured surface of a twig one
// to five voxels long then passed as close as 0.03 voxel to its end nodes, and a library tree's
// tip fell outside. At 1 voxel every cell corner within √3/2 of a node lies inside and the
// shallowest of 3,000 random twig ends was 0.26 voxel deep.
constexpr double kMinRadiusVoxels = 1.0;

// Distances closer to zero than this many voxels are pushed to ± it: a surface through a
// voxel centre makes volumeToMesh emit coincident vertices and degenerate triangles (a
// sphere of radius 20 voxels centred on a voxel had 42 of them, all flagged as
// self-intersections). Moves the surface by at most 0.001 voxel.
constexpr double kZeroNudgeVoxels = 1e-3;

int floorDiv(int v, int d) { return static_cast<int>(std::floor(v / double(d))); }

// Exact signed distance to a round cone (Inigo Quilez's sdRoundCone for arbitrary
// endpoints): the convex hull of the spheres (a, r1) and (b, r2). When one sphere contains
// the other the hull is that sphere.
struct RoundCone {
    Vec3 a, ba;
    double r1 = 0, r2 = 0;
    double l2 = 0, rr = 0, a2 = 0, il2 = 0;
    bool sphere = false;
    int32_t node = 0;  // the segment's child node
    Vec3 lo, hi;       // bounds of the shape, metres

    RoundCone(const Vec3& pa, double ra, const Vec3& pb, double rb, int32_t child)
        : a(pa), ba(pb - pa), r1(ra), r2(rb), node(child) {
        l2 = length2(ba);
        rr = r1 - r2;
        a2 = l2 - rr * rr;
        // One sphere inside the other (or a zero-length segment): the bigger sphere.
        if (!(a2 > 1e-12 * std::max(l2, 1e-30)) || l2 < 1e-24) {
            sphere = true;
            if (r2 > r1) {
                a = pb;
                r1 = r2;
            }
            ba = Vec3{};
            il2 = 0;
        } else {
            il2 = 1.0 / l2;
        }
        if (sphere) {
            lo = a - Vec3{r1, r1, r1};
            hi = a + Vec3{r1, r1, r1};
        } else {
            lo = vmin(pa - Vec3{ra, ra, ra}, pb - Vec3{rb, rb, rb});
            hi = vmax(pa + Vec3{ra, ra, ra}, pb + Vec3{rb, rb, rb});
        }
    }

    double distance(const Vec3& p) const {
        const Vec3 pa = p - a;
        if (sphere) return length(pa) - r1;
        const double y = dot(pa, ba);
        const double z = y - l2;
        const double x2 = length2(pa * l2 - ba * y);
        const double y2 = y * y * l2;
        const double z2 = z * z * l2;
        const double k = (rr > 0 ? 1.0 : (rr < 0 ? -1.0 : 0.0)) * rr * rr * x2;
        const double sz = z > 0 ? 1.0 : (z < 0 ? -1.0 : 0.0);
        const double sy = y > 0 ? 1.0 : (y < 0 ? -1.0 : 0.0);
        if (sz * a2 * z2 > k) return std::sqrt(x2 + z2) * il2 - r2;
        if (sy * a2 * y2 < k) return std::sqrt(x2 + y2) * il2 - r1;
        return (std::sqrt(x2 * a2 * il2) + y * rr) * il2 - r1;
    }
};

// Index-space box of voxels whose centres can lie within `band` of the segment.
struct IndexBox {
    int lo[3], hi[3];
};

IndexBox voxelBox(const RoundCone& s, double inv, double band) {
    IndexBox b;
    for (int a = 0; a < 3; ++a) {
        b.lo[a] = static_cast<int>(std::ceil((s.lo[a] - band) * inv));
        b.hi[a] = static_cast<int>(std::floor((s.hi[a] + band) * inv));
    }
    return b;
}

// One (leaf block, segment) pair. Blocks are keyed by their block coordinates.
struct BlockRef {
    int32_t bx, by, bz;
    int32_t segment;
    bool interior;  // every voxel of the block is at least `band` inside this segment

    bool sameBlock(const BlockRef& o) const { return bx == o.bx && by == o.by && bz == o.bz; }
    bool operator<(const BlockRef& o) const {
        if (bx != o.bx) return bx < o.bx;
        if (by != o.by) return by < o.by;
        if (bz != o.bz) return bz < o.bz;
        return segment < o.segment;
    }
};

VdbGridPtr rasterise(const std::vector<RoundCone>& segments, double voxel, double band) {
    const float background = static_cast<float>(band);
    const float nudge = static_cast<float>(kZeroNudgeVoxels * voxel);
    const VdbModule& vdb = vdbModule();
    if (segments.empty()) return vdb.gridFromBlocks(voxel, background, 0, {});

    const double inv = 1.0 / voxel;
    // Block centre to its farthest voxel centre: 3.5 voxels along each axis.
    const double halfDiagonal = std::sqrt(3.0) * 0.5 * (kLeafDim - 1) * voxel;
    const double c = 0.5 * (kLeafDim - 1);

    // 1. Blocks near each segment (parallel per segment; concatenated in segment order).
    std::vector<std::vector<BlockRef>> perSegment(segments.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, segments.size()), [&](const auto& range) {
        for (size_t s = range.begin(); s != range.end(); ++s) {
            const RoundCone& seg = segments[s];
            const IndexBox box = voxelBox(seg, inv, band);
            int blo[3], bhi[3];
            for (int a = 0; a < 3; ++a) {
                blo[a] = floorDiv(box.lo[a], kLeafDim);
                bhi[a] = floorDiv(box.hi[a], kLeafDim);
            }
            auto& out = perSegment[s];
            for (int bx = blo[0]; bx <= bhi[0]; ++bx)
                for (int by = blo[1]; by <= bhi[1]; ++by)
                    for (int bz = blo[2]; bz <= bhi[2]; ++bz) {
                        const Vec3 centre{(bx * kLeafDim + c) * voxel, (by * kLeafDim + c) * voxel,
                                          (bz * kLeafDim + c) * voxel};
                        // The distance is exact, hence 1-Lipschitz: no voxel of a block whose
                        // centre is this far out can be within the band.
                        const double d = seg.distance(centre);
                        if (d >= halfDiagonal + band) continue;
                        out.push_back(
                            {bx, by, bz, static_cast<int32_t>(s), d <= -(halfDiagonal + band)});
                    }
        }
    });
    size_t total = 0;
    for (const auto& v : perSegment) total += v.size();
    std::vector<BlockRef> refs;
    refs.reserve(total);
    for (auto& v : perSegment) {
        refs.insert(refs.end(), v.begin(), v.end());
        std::vector<BlockRef>().swap(v);
    }
    std::sort(refs.begin(), refs.end());
    std::vector<size_t> starts;
    for (size_t i = 0; i < refs.size(); ++i)
        if (i == 0 || !refs[i].sameBlock(refs[i - 1])) starts.push_back(i);
    starts.push_back(refs.size());
    const size_t blocks = starts.size() - 1;

    // 2. Every block: the minimum over its segments, clamped to the band (parallel per block;
    // a block depends only on its own inputs, and the module keeps the blocks in this order).
    return vdb.gridFromBlocks(voxel, background, blocks, [&](size_t b, VdbBlock& block) {
        const size_t first = starts[b], last = starts[b + 1];
        for (size_t r = first; r < last; ++r)
            if (refs[r].interior) return false;  // no active voxel: flood fill makes it inside
        const int origin[3] = {refs[first].bx * kLeafDim, refs[first].by * kLeafDim,
                               refs[first].bz * kLeafDim};
        float* values = block.values;
        std::fill(values, values + VdbBlock::kSize, background);
        for (size_t r = first; r < last; ++r) {
            const RoundCone& seg = segments[refs[r].segment];
            const IndexBox box = voxelBox(seg, inv, band);
            int lo[3], hi[3];
            for (int a = 0; a < 3; ++a) {
                lo[a] = std::max(box.lo[a], origin[a]) - origin[a];
                hi[a] = std::min(box.hi[a], origin[a] + kLeafDim - 1) - origin[a];
            }
            for (int i = lo[0]; i <= hi[0]; ++i)
                for (int j = lo[1]; j <= hi[1]; ++j)
                    for (int k = lo[2]; k <= hi[2]; ++k) {
                        const Vec3 p{(origin[0] + i) * voxel, (origin[1] + j) * voxel,
                                     (origin[2] + k) * voxel};
                        const float d = static_cast<float>(
                            std::max(seg.distance(p), -band));  // union: keep the min
                        float& v = values[(i * kLeafDim + j) * kLeafDim + k];
                        if (d < v) v = d;
                    }
        }
        for (int a = 0; a < 3; ++a) block.origin[a] = origin[a];
        bool any = false;
        for (int n = 0; n < VdbBlock::kSize; ++n) {
            float v = values[n];
            // Keep values off zero (kZeroNudgeVoxels).
            if (std::abs(v) < nudge) v = v < 0 ? -nudge : nudge;
            if (v > -background && v < background) {
                block.set(n, v, true);
                any = true;
            } else {
                block.set(n, v < 0 ? -background : background, false);
            }
        }
        return any;
    });
}

// Segments bucketed on a coarse grid (cells of 8 voxels, larger if there would be more than
// about 2 million) for nearest-segment look-ups. Each segment is listed in every cell its
// bounds (+1 voxel) overlap.
struct SegmentBuckets {
    double cell = 1, inv = 1;
    int lo[3] = {0, 0, 0}, n[3] = {0, 0, 0};
    std::vector<uint32_t> offset;
    std::vector<int32_t> items;

    SegmentBuckets(const std::vector<RoundCone>& segments, double voxel) {
        if (segments.empty()) return;
        Aabb all;
        for (const auto& s : segments) {
            all.extend(s.lo);
            all.extend(s.hi);
        }
        const double pad = voxel;
        const Vec3 size = all.size() + Vec3{2 * pad, 2 * pad, 2 * pad};
        cell = std::max(8 * voxel, std::cbrt(size.x * size.y * size.z / 2e6));
        inv = 1.0 / cell;
        for (int a = 0; a < 3; ++a) {
            lo[a] = static_cast<int>(std::floor((all.lo[a] - pad) * inv));
            n[a] = static_cast<int>(std::floor((all.hi[a] + pad) * inv)) - lo[a] + 1;
        }
        const size_t cells = size_t(n[0]) * n[1] * n[2];
        offset.assign(cells + 1, 0);
        auto forCells = [&](const RoundCone& s, auto fn) {
            int clo[3], chi[3];
            for (int a = 0; a < 3; ++a) {
                clo[a] = static_cast<int>(std::floor((s.lo[a] - pad) * inv)) - lo[a];
                chi[a] = static_cast<int>(std::floor((s.hi[a] + pad) * inv)) - lo[a];
            }
            for (int x = clo[0]; x <= chi[0]; ++x)
                for (int y = clo[1]; y <= chi[1]; ++y)
                    for (int z = clo[2]; z <= chi[2]; ++z) fn(index(x, y, z));
        };
        for (const auto& s : segments) forCells(s, [&](size_t c) { ++offset[c + 1]; });
        for (size_t c = 0; c < cells; ++c) offset[c + 1] += offset[c];
        items.resize(offset[cells]);
        std::vector<uint32_t> fill(offset.begin(), offset.end() - 1);
        for (size_t i = 0; i < segments.size(); ++i)
            forCells(segments[i], [&](size_t c) { items[fill[c]++] = static_cast<int32_t>(i); });
    }

    size_t index(int x, int y, int z) const { return (size_t(z) * n[1] + y) * n[0] + x; }

    // The segment with the smallest signed distance at p among those listed in p's cell (ties
    // to the lower index), or the smallest over all segments if the cell is empty or outside.
    int32_t nearest(const std::vector<RoundCone>& segments, const Vec3& p) const {
        int c[3];
        bool inside = !offset.empty();
        for (int a = 0; a < 3 && inside; ++a) {
            c[a] = static_cast<int>(std::floor(p[a] * inv)) - lo[a];
            inside = c[a] >= 0 && c[a] < n[a];
        }
        int32_t best = -1;
        double bestD = std::numeric_limits<double>::infinity();
        if (inside) {
            const size_t cellIndex = index(c[0], c[1], c[2]);
            for (uint32_t k = offset[cellIndex]; k < offset[cellIndex + 1]; ++k) {
                const double d = segments[items[k]].distance(p);
                if (d < bestD || (d == bestD && items[k] < best)) {
                    bestD = d;
                    best = items[k];
                }
            }
        }
        if (best >= 0) return best;
        for (size_t i = 0; i < segments.size(); ++i) {
            const double d = segments[i].distance(p);
            if (d < bestD) {
                bestD = d;
                best = static_cast<int32_t>(i);
            }
        }
        return best;
    }
};

// The module serialises the grid into memory (openvdb::io::File::write ignores a failed stream:
// a full disk would leave a truncated .vdb and no error); writeFileAtomic writes the bytes with
// every write(2) checked.
void writeVdbAtomically(const VdbGrid& grid, const std::string& path) {
    writeFileAtomic(path, vdbModule().fileBytes(grid));
}

}  // namespace

Mesh watertightMesh(const Tree& tree, const WatertightOptions& options,
                    const std::string& vdbPath) {
    const double voxel = options.voxelSize;
    if (!(voxel > 0.0) || !std::isfinite(voxel))
        throw std::invalid_argument("watertightMesh: voxelSize must be finite and > 0");
    if (!(options.halfWidth >= 1.0) || !std::isfinite(options.halfWidth))
        throw std::invalid_argument("watertightMesh: halfWidth must be finite and >= 1 voxel");
    const double band = options.halfWidth * voxel;
    const double minRadius = kMinRadiusVoxels * voxel;

    // One round cone per segment (parent -> child), thin radii raised to minRadius.
    std::vector<RoundCone> segments;
    segments.reserve(tree.nodes.empty() ? 0 : tree.nodes.size() - 1);
    Aabb bounds;
    for (size_t i = 1; i < tree.nodes.size(); ++i) {
        const SkeletonNode& node = tree.nodes[i];
        if (node.parent < 0 || node.parent >= static_cast<int32_t>(i))
            throw std::invalid_argument("watertightMesh: node " + std::to_string(i) +
                                        " has invalid parent " + std::to_string(node.parent));
        const SkeletonNode& parent = tree.nodes[node.parent];
        for (const SkeletonNode* n : {&node, &parent})
            if (!std::isfinite(n->position.x) || !std::isfinite(n->position.y) ||
                !std::isfinite(n->position.z) || !std::isfinite(n->radius))
                throw std::invalid_argument("watertightMesh: node " + std::to_string(i) +
                                            " or its parent is not finite");
        segments.emplace_back(parent.position, std::max(parent.radius, minRadius), node.position,
                              std::max(node.radius, minRadius), static_cast<int32_t>(i));
        bounds.extend(segments.back().lo);
        bounds.extend(segments.back().hi);
    }
    if (!bounds.empty()) {
        const Vec3 extent = bounds.size() / voxel;
        const Vec3 far = vmax(vabs(bounds.lo), vabs(bounds.hi)) / voxel;
        if (!(std::max({extent.x, extent.y, extent.z}) < 1e7) ||
            !(std::max({far.x, far.y, far.z}) < 1e8))
            throw std::invalid_argument("watertightMesh: grid would be too large");
    }

    VdbGridPtr grid = rasterise(segments, voxel, band);
    const VdbModule& vdb = vdbModule();
    vdb.setName(*grid, "tree_sdf");
    vdb.setDoubleMeta(*grid, "voxel_size", voxel);
    vdb.fillCavities(*grid);
    if (!vdbPath.empty()) writeVdbAtomically(*grid, vdbPath);

    Mesh mesh;
    if (segments.empty()) return mesh;

    mesh = levelSetMesh(*grid);
    const size_t nv = mesh.vertexCount();

    // Branch order of the segment whose surface the vertex lies on (smallest distance).
    const SegmentBuckets buckets(segments, voxel);
    mesh.order.resize(nv);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv), [&](const auto& range) {
        for (size_t v = range.begin(); v != range.end(); ++v) {
            const Vec3 p{mesh.positions[3 * v], mesh.positions[3 * v + 1],
                         mesh.positions[3 * v + 2]};
            const int32_t s = buckets.nearest(segments, p);
            mesh.order[v] = tree.nodes[segments[s].node].order;
        }
    });
    mesh.colour.assign(nv, 0);
    return mesh;
}

}  // namespace sylva
