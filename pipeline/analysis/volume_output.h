// `sylva volume`: a species' named crown volumes written for a look before a long build —
// each as an OpenVDB level set (<name>.vdb) and a triangle mesh (<name>.ply), all of them in
// one preview.png (front, side and top views), with a summary in volumes.json and on stdout.
// Frame: +y up, metres.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/math.h"
#include "species/geometry/mesh.h"

namespace sylva {

struct VolumeOutputOptions {
    uint64_t seed = 1;   // instance seed: volumes drawn per tree show this tree's draw
    double voxel = 0.0;  // voxel edge, metres; ≤ 0: each volume's largest bounds dimension / 128
    int tile = 512;      // preview pixels per view (square tiles)
};

// One named volume as written.
struct VolumeSummary {
    std::string name;               // "crown", "endpoints", "roots"; the grid and file name
    std::string kind;               // Volume::describe()
    Aabb bounds;                    // Volume::bounds(), metres
    double measure = 0;             // Volume::measure(), m³
    double voxel = 0;               // metres
    double levelSetMeasure = 0;     // voxels whose value is ≤ 0, times voxel³, m³
    double meshVolume = 0;          // enclosed by the mesh (divergence theorem), m³
    size_t activeVoxels = 0;        // narrow-band voxels
    size_t triangles = 0;           // in <name>.ply
    double gridMs = 0, meshMs = 0;  // level-set sampling and meshing times
};

struct VolumeOutputResult {
    std::string species;
    double parseMs = 0;  // parsing the species, volumes included (CGAL, masks, ...)
    std::vector<VolumeSummary> volumes;
    int previewWidth = 0, previewHeight = 0;
    double metresPerPixel = 0;  // preview scale, the same in every tile
};

// Parses the species (its draws seeded from options.seed as `sylva grow` does), realises
// every named volume of its growth method as a level set and a mesh, and only then writes,
// each file atomically, into `dir`: <name>.vdb, <name>.ply, preview.png and volumes.json.
// Bad input throws InputError before anything is written: a species error (SpecError), a
// voxel size that would give over 2·10⁹ voxels, a method without named volumes.
VolumeOutputResult writeSpeciesVolumes(const std::string& speciesPath,
                                       const std::filesystem::path& dir,
                                       const VolumeOutputOptions& options);

// One line for stdout: name, kind, bounds and extent, measure, voxel, times, triangles.
std::string summaryLine(const VolumeSummary& s);

// The preview raster: one row of three square `tile`-pixel views per mesh — front (from +z:
// x right, y up), side (from +x: −z right, y up), top (from +y: x right, −z up) —
// orthographic at one scale for the whole sheet (the largest mesh extent fills 92% of a
// tile), each view centred on the bounds of its mesh and the root point (the origin). Grey Lambert
// shading of the interpolated vertex normals (light from the upper left, in front), a 1-pixel dark
// outline at the silhouette and at depth steps, 2×2 supersampled, on white; a grey ground line (y =
// 0) in the front and side views and a cross at the root point (the origin) in the top view.
// Row-major greyscale, row 0 at the top. Deterministic.
struct VolumePreview {
    int width = 0, height = 0;
    double metresPerPixel = 0;
    std::vector<uint8_t> pixels;
};
VolumePreview renderVolumePreview(const std::vector<const Mesh*>& meshes, int tile);

}  // namespace sylva
