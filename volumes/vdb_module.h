// OpenVDB, loaded when first needed. libopenvdb is linked with immediate binding and carries
// about 61,000 symbol relocations, all resolved by the dynamic loader before main(): 64 ms of
// CPU for every process that links it (a one-line program: 64 ms with it, 1.7 ms without),
// whatever the command. Only level-set volumes (`voxel_size`, revolved envelopes), the
// watertight wood mesh and `sylva volume` need it. So its calls live in a module of their own,
// libsylva_vdb.so (volumes/vdb/), built beside the executable and opened with dlopen the first
// time one of them is needed. Copy it with the executable (docs/cluster.md).
//
// The table passes plain arrays and sylva types; a grid is an opaque VdbGrid (its definition,
// which holds the openvdb::FloatGrid, is volumes/vdb/grid.h, for the module and the tests). The
// module is compiled by the same build as its callers, so C++ types cross it safely.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace sylva {

struct VdbGrid;
using VdbGridPtr = std::shared_ptr<VdbGrid>;

// One 8³ block of voxels of a level set: its origin (index space, multiples of 8), the value of
// each voxel at offset x·64 + y·8 + z from the origin (OpenVDB's leaf order), and which voxels
// are active (bit n of `active[n / 64]`, n the same offset).
struct VdbBlock {
    static constexpr int kDim = 8;
    static constexpr int kSize = kDim * kDim * kDim;
    int32_t origin[3] = {0, 0, 0};
    float values[kSize];
    uint64_t active[kSize / 64];

    void set(int n, float value, bool on) {
        values[n] = value;
        if (on)
            active[n >> 6] |= uint64_t(1) << (n & 63);
        else
            active[n >> 6] &= ~(uint64_t(1) << (n & 63));
    }
};

struct VdbModule {
    // A FloatGrid of class GRID_LEVEL_SET with a linear transform of edge `voxel` (index
    // (i, j, k) is the point (i, j, k)·voxel) and `background`, built from `count` blocks:
    // fill(b, block) sets block b (its origin, every value, every active bit; the block comes
    // cleared) and returns whether to keep it. Blocks are filled in parallel and kept in the
    // order of b, so the grid does not depend on the thread count. Then every tile and
    // inactive voxel enclosed by the band becomes −background (signedFloodFill).
    VdbGridPtr (*gridFromBlocks)(double voxel, float background, size_t count,
                                 const std::function<bool(size_t, VdbBlock&)>& fill);
    // The closed triangle mesh (points xyz, metres; triangles as index triples) as a level set
    // of edge `voxel`, `halfWidth` voxels each side (openvdb::tools::meshToLevelSet).
    VdbGridPtr (*meshToLevelSet)(double voxel, const std::vector<float>& points,
                                 const std::vector<uint32_t>& triangles, float halfWidth);
    // The value at index-space point (x, y, z), trilinear (BoxSampler). Safe for concurrent
    // readers of a grid that is no longer modified.
    float (*sample)(const VdbGrid& grid, double x, double y, double z);
    // The voxels (tiles counted by their voxels) whose value is ≤ 0, and the active voxels.
    double (*interiorVoxelCount)(const VdbGrid& grid);
    size_t (*activeVoxelCount)(const VdbGrid& grid);
    // Enclosed pockets of outside (≥ 0) voxels made inside (species/geometry/watertight.cpp
    // says how); returns how many voxels changed.
    size_t (*fillCavities)(VdbGrid& grid);
    // A deep copy whose active values closer to zero than `nudge` are pushed to ±nudge (a value
    // of exactly 0 goes inwards).
    VdbGridPtr (*nudgedCopy)(const VdbGrid& grid, float nudge);
    // The zero level set by openvdb::tools::volumeToMesh (isovalue 0, adaptivity 0): points
    // xyz, triangles and quads as OpenVDB gives them (its winding).
    void (*volumeToMesh)(const VdbGrid& grid, std::vector<float>& points,
                         std::vector<uint32_t>& triangles, std::vector<uint32_t>& quads);
    // The grid's name and metadata (a string or a double under `key`).
    void (*setName)(VdbGrid& grid, const std::string& name);
    void (*setStringMeta)(VdbGrid& grid, const std::string& key, const std::string& value);
    void (*setDoubleMeta)(VdbGrid& grid, const std::string& key, double value);
    // The bytes of a .vdb file holding the grid, as openvdb::io::File::write writes them.
    std::string (*fileBytes)(const VdbGrid& grid);
};

// The module, opened on the first call (thread-safe); later calls return the same table.
// Opens the environment's SYLVA_VDB_MODULE (a path) when set, else libsylva_vdb.so beside the
// running executable. Throws std::runtime_error naming what it tried when it cannot load it.
const VdbModule& vdbModule();

}  // namespace sylva
