// libsylva_vdb.so: OpenVDB behind volumes/vdb_module.h's table.
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <array>
#include <cmath>
#include <memory>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "volumes/vdb/grid.h"
#include "volumes/vdb_module.h"

namespace sylva {
namespace {

using LeafT = openvdb::FloatTree::LeafNodeType;
constexpr int kLeafDim = static_cast<int>(LeafT::DIM);  // 8 voxels per leaf edge
static_assert(kLeafDim == VdbBlock::kDim && int(LeafT::SIZE) == VdbBlock::kSize);

VdbGridPtr wrap(openvdb::FloatGrid::Ptr grid) {
    auto g = std::make_shared<VdbGrid>();
    g->grid = std::move(grid);
    return g;
}

VdbGridPtr gridFromBlocks(double voxel, float background, size_t count,
                          const std::function<bool(size_t, VdbBlock&)>& fill) {
    auto grid = openvdb::FloatGrid::create(background);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    std::vector<std::unique_ptr<LeafT>> leaves(count);
    // Each block depends only on its own inputs, so the result does not depend on the thread
    // count or scheduling.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count), [&](const auto& range) {
        auto block = std::make_unique<VdbBlock>();
        for (size_t b = range.begin(); b != range.end(); ++b) {
            std::fill(std::begin(block->active), std::end(block->active), uint64_t(0));
            if (!fill(b, *block)) continue;
            const openvdb::Coord origin(block->origin[0], block->origin[1], block->origin[2]);
            auto leaf = std::make_unique<LeafT>(origin, background, false);
            for (openvdb::Index n = 0; n < LeafT::SIZE; ++n) {
                if (block->active[n >> 6] >> (n & 63) & 1)
                    leaf->setValueOn(n, block->values[n]);
                else
                    leaf->setValueOff(n, block->values[n]);
            }
            leaves[b] = std::move(leaf);
        }
    });
    openvdb::FloatTree& tree = grid->tree();
    for (auto& leaf : leaves)
        if (leaf) tree.addLeaf(leaf.release());  // the tree takes ownership
    // Tiles and inactive voxels enclosed by the band become −background.
    openvdb::tools::signedFloodFill(tree);
    return wrap(std::move(grid));
}

VdbGridPtr meshToLevelSet(double voxel, const std::vector<float>& points,
                          const std::vector<uint32_t>& triangles, float halfWidth) {
    std::vector<openvdb::Vec3s> p(points.size() / 3);
    for (size_t i = 0; i < p.size(); ++i)
        p[i] = {points[3 * i], points[3 * i + 1], points[3 * i + 2]};
    std::vector<openvdb::Vec3I> t(triangles.size() / 3);
    for (size_t i = 0; i < t.size(); ++i)
        t[i] = {triangles[3 * i], triangles[3 * i + 1], triangles[3 * i + 2]};
    const auto xform = openvdb::math::Transform::createLinearTransform(voxel);
    return wrap(openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*xform, p, t, halfWidth));
}

float sample(const VdbGrid& g, double x, double y, double z) {
    // An unregistered accessor per call: cheap, and safe for concurrent readers because the
    // tree is never modified after construction.
    openvdb::tree::ValueAccessor<const openvdb::FloatTree, false> acc(g.grid->constTree());
    float value = 0.0f;
    openvdb::tools::BoxSampler::sample(acc, openvdb::Vec3R(x, y, z), value);
    return value;
}

double interiorVoxelCount(const VdbGrid& g) {
    double n = 0;
    for (auto it = g.grid->constTree().cbeginValueAll(); it; ++it)
        if (*it <= 0.0f) n += static_cast<double>(it.getVoxelCount());
    return n;
}

size_t activeVoxelCount(const VdbGrid& g) {
    return static_cast<size_t>(g.grid->activeVoxelCount());
}

// Fills enclosed cavities: pockets of outside (>= 0) voxels that merging capsules cap off
// from the exterior. They would become extra inward-facing shells (often tiny, degenerate
// ones around a single voxel). A flood fill over the leaf voxels, 6-connected through
// outside values, starts from every outside voxel next to an outside tile (the exterior);
// outside voxels it does not reach become inside (−background, inactive). Outside voxels
// reached only through a diagonal count as cavities, which only closes hairline pockets.
// Cavities wide enough to hold outside tiles (more than about 2·halfWidth + 8 voxels across)
// are left as they are. The visited set does not depend on visiting order: deterministic.
size_t fillCavities(VdbGrid& g) {
    openvdb::FloatGrid& grid = *g.grid;
    openvdb::FloatTree& tree = grid.tree();
    const float background = tree.background();
    std::vector<LeafT*> leaves;
    tree.getNodes(leaves);
    if (leaves.empty()) return 0;
    constexpr int32_t kOutsideTile = -1, kInsideTile = -2;
    auto outside = [](float v) { return v >= 0.0f; };

    // Face neighbours of every leaf: another leaf (its index) or a tile (a whole 8³ block
    // lies in one tile, so one probe per face tells its side).
    std::vector<std::array<int32_t, 6>> neighbour(leaves.size());
    {
        std::unordered_map<const LeafT*, int32_t> leafIndex;
        leafIndex.reserve(leaves.size());
        for (size_t i = 0; i < leaves.size(); ++i) leafIndex.emplace(leaves[i], int32_t(i));
        openvdb::tree::ValueAccessor<const openvdb::FloatTree> acc(tree);
        for (size_t l = 0; l < leaves.size(); ++l)
            for (int f = 0; f < 6; ++f) {
                openvdb::Coord ijk = leaves[l]->origin();
                ijk[f / 2] += (f % 2 == 0) ? kLeafDim : -kLeafDim;
                if (const LeafT* other = acc.probeConstLeaf(ijk))
                    neighbour[l][f] = leafIndex.at(other);
                else
                    neighbour[l][f] = outside(acc.getValue(ijk)) ? kOutsideTile : kInsideTile;
            }
    }

    // Bit masks per leaf: word x holds the 8×8 (y, z) slab, bit y·8 + z (OpenVDB's voxel
    // offset is x·64 + y·8 + z). `open`: outside voxels; `reach`: those reached so far.
    using Slabs = std::array<uint64_t, kLeafDim>;
    std::vector<Slabs> open(leaves.size()), reach(leaves.size());
    for (size_t l = 0; l < leaves.size(); ++l)
        for (int x = 0; x < kLeafDim; ++x) {
            uint64_t bits = 0;
            for (int b = 0; b < 64; ++b)
                if (outside(leaves[l]->getValue(uint32_t(x * 64 + b)))) bits |= uint64_t(1) << b;
            open[l][x] = bits;
            reach[l][x] = 0;
        }
    constexpr uint64_t kZ0 = 0x0101010101010101ull, kZ7 = kZ0 << 7;  // z = 0, z = 7 rows
    constexpr uint64_t kY0 = 0xFFull, kY7 = kY0 << 56;               // y = 0, y = 7 rows
    const Slabs full = [] {
        Slabs f;
        f.fill(~uint64_t(0));
        return f;
    }();
    // Face f of a leaf as the bits that enter the neighbour across it (in the neighbour's
    // layout): 0 +x, 1 −x, 2 +y, 3 −y, 4 +z, 5 −z.
    auto across = [&](const Slabs& r, int f) {
        Slabs out{};
        switch (f) {
            case 0:
                out[0] = r[kLeafDim - 1];
                break;
            case 1:
                out[kLeafDim - 1] = r[0];
                break;
            case 2:
                for (int x = 0; x < kLeafDim; ++x) out[x] = (r[x] & kY7) >> 56;
                break;
            case 3:
                for (int x = 0; x < kLeafDim; ++x) out[x] = (r[x] & kY0) << 56;
                break;
            case 4:
                for (int x = 0; x < kLeafDim; ++x) out[x] = (r[x] & kZ7) >> 7;
                break;
            default:
                for (int x = 0; x < kLeafDim; ++x) out[x] = (r[x] & kZ0) << 7;
                break;
        }
        return out;
    };

    std::vector<int32_t> work;
    std::vector<uint8_t> queued(leaves.size(), 0);
    // Adds bits to a leaf's reached set (within its open voxels); queues it if any are new.
    auto add = [&](int32_t l, const Slabs& bits) {
        bool grew = false;
        for (int x = 0; x < kLeafDim; ++x) {
            const uint64_t more = bits[x] & open[l][x] & ~reach[l][x];
            if (more) {
                reach[l][x] |= more;
                grew = true;
            }
        }
        if (grew && !queued[l]) {
            queued[l] = 1;
            work.push_back(l);
        }
    };
    // Seeds: open voxels on a face next to an outside tile (the tile's face, seen from the
    // leaf, is the leaf's own face layer: the opposite face of a full neighbour).
    for (size_t l = 0; l < leaves.size(); ++l)
        for (int f = 0; f < 6; ++f)
            if (neighbour[l][f] == kOutsideTile) add(int32_t(l), across(full, f ^ 1));
    while (!work.empty()) {
        const int32_t l = work.back();
        work.pop_back();
        queued[l] = 0;
        // Grow inside the leaf to a fixed point (6-connected, through open voxels).
        Slabs& r = reach[l];
        for (bool grew = true; grew;) {
            grew = false;
            Slabs next;
            for (int x = 0; x < kLeafDim; ++x) {
                uint64_t g =
                    r[x] | ((r[x] << 1) & ~kZ0) | ((r[x] >> 1) & ~kZ7) | (r[x] << 8) | (r[x] >> 8);
                if (x > 0) g |= r[x - 1];
                if (x < kLeafDim - 1) g |= r[x + 1];
                next[x] = g & open[l][x];
                grew |= next[x] != r[x];
            }
            r = next;
        }
        for (int f = 0; f < 6; ++f)
            if (neighbour[l][f] >= 0) add(neighbour[l][f], across(r, f));
    }
    size_t filled = 0;
    for (size_t l = 0; l < leaves.size(); ++l)
        for (int x = 0; x < kLeafDim; ++x) {
            const uint64_t cavity = open[l][x] & ~reach[l][x];
            if (!cavity) continue;
            for (int b = 0; b < 64; ++b)
                if (cavity >> b & 1) {
                    leaves[l]->setValueOff(uint32_t(x * 64 + b), -background);
                    ++filled;
                }
        }
    return filled;
}

VdbGridPtr nudgedCopy(const VdbGrid& g, float nudge) {
    openvdb::FloatGrid::Ptr copy = g.grid->deepCopy();
    for (auto it = copy->tree().beginValueOn(); it; ++it) {
        // ≤ 0 is inside (Volume::inside), so a value of exactly 0 goes inwards.
        if (std::abs(*it) < nudge) it.setValue(*it <= 0.0f ? -nudge : nudge);
    }
    return wrap(std::move(copy));
}

void volumeToMesh(const VdbGrid& g, std::vector<float>& points, std::vector<uint32_t>& triangles,
                  std::vector<uint32_t>& quads) {
    std::vector<openvdb::Vec3s> p;
    std::vector<openvdb::Vec3I> t;
    std::vector<openvdb::Vec4I> q;
    openvdb::tools::volumeToMesh(*g.grid, p, t, q, 0.0, 0.0);
    points.resize(3 * p.size());
    for (size_t i = 0; i < p.size(); ++i)
        for (int a = 0; a < 3; ++a) points[3 * i + a] = p[i][a];
    triangles.resize(3 * t.size());
    for (size_t i = 0; i < t.size(); ++i)
        for (int a = 0; a < 3; ++a) triangles[3 * i + a] = t[i][a];
    quads.resize(4 * q.size());
    for (size_t i = 0; i < q.size(); ++i)
        for (int a = 0; a < 4; ++a) quads[4 * i + a] = q[i][a];
}

void setName(VdbGrid& g, const std::string& name) { g.grid->setName(name); }

void setStringMeta(VdbGrid& g, const std::string& key, const std::string& value) {
    g.grid->insertMeta(key, openvdb::StringMetadata(value));
}

void setDoubleMeta(VdbGrid& g, const std::string& key, double value) {
    g.grid->insertMeta(key, openvdb::DoubleMetadata(value));
}

// io::File::write ignores a failed stream (a full disk leaves a truncated .vdb and no error), so
// the grid is serialised exactly as it does (Archive::write, seekable) into memory, for the
// caller to write with every error checked.
class VdbSerialiser : public openvdb::io::File {
  public:
    VdbSerialiser() : openvdb::io::File("") {}
    std::string bytes(const openvdb::GridCPtrVec& grids) const {
        std::ostringstream os(std::ios_base::out | std::ios_base::binary);
        Archive::write(os, grids, /*seekable=*/true, openvdb::MetaMap());
        return os.str();
    }
};

std::string fileBytes(const VdbGrid& g) { return VdbSerialiser().bytes({g.grid}); }

}  // namespace
}  // namespace sylva

extern "C" __attribute__((visibility("default"))) const void* sylva_vdb_module() {
    static const sylva::VdbModule table = [] {
        openvdb::initialize();
        return sylva::VdbModule{
            sylva::gridFromBlocks,     sylva::meshToLevelSet,   sylva::sample,
            sylva::interiorVoxelCount, sylva::activeVoxelCount, sylva::fillCavities,
            sylva::nudgedCopy,         sylva::volumeToMesh,     sylva::setName,
            sylva::setStringMeta,      sylva::setDoubleMeta,    sylva::fileBytes};
    }();
    return &table;
}
