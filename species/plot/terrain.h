// The ground of a plot: heightfields made from the spec's terrain options, and its mesh.
#pragma once

#include "core/rng.h"
#include "species/geometry/mesh.h"
#include "species/plot/plot.h"

namespace sylva {

// The heightfield's sample grid: it covers the plot's bounding box (a circle's: 2r × 2r) plus
// `margin` on every side, at `cell` metres, centred on the plot (x0 = −(nx − 1)·cell / 2).
struct TerrainGrid {
    double x0 = 0, z0 = 0;
    int64_t nx = 0, nz = 0;
    int64_t samples() const { return nx * nz; }
};
TerrainGrid terrainGrid(const PlotArea& area, double margin, double cell);

// The most heightfield samples a plot may have (4096²: 64 MiB of float heights).
constexpr int64_t kMaxTerrainSamples = int64_t(4096) * 4096;

// The smooth-noise height at (x, z): fractional Brownian motion of `octaves` octaves of 2-D
// gradient noise (Perlin 1985/2002: quintic fade, 8 gradient directions hashed from the lattice
// point and the seed — no <random>, the same on every platform), octave k with wavelength
// wavelength / 2^k and weight 2^−k, scaled so that |height| ≤ amplitude. `plotSeed` is the
// plot instance's seed (the noise stream is keyed "terrain/noise" from it).
double noiseHeight(const TerrainOptions& options, uint64_t plotSeed, double x, double z);

// The slope's plane: through the plot centre at height 0, inclined by slopeRad, falling
// towards the azimuth aspectRad (0° faces −z, north; 90° faces +x, east).
double slopeHeight(const TerrainOptions& options, double x, double z);

// A DEM's size in pixels needed to cover `grid` at metresPerPixel (its pixel centres span
// (pixels − 1) · metresPerPixel, centred on the plot).
struct DemPixels {
    int64_t width = 0, height = 0;
};
DemPixels demPixelsNeeded(const TerrainGrid& grid, double cell, double metresPerPixel);

// The DEM of `options` (demPath) as heights in metres: heightScale × stored value (the
// integer for 8/16-bit images, the float otherwise) + heightOffset, row-major, top row first
// (the top row is north, −z; the first column west, −x). Throws ImageError for an unreadable
// file, std::invalid_argument for more than one channel.
struct DemImage {
    int width = 0, height = 0;
    std::vector<double> heights;
};
DemImage readDem(const TerrainOptions& options);

// The plot's terrain: its heightfield over terrainGrid(area, margin, options.cell), flat
// (y = 0), a slope, smooth noise keyed by `plotSeed`, or the DEM resampled (bilinear) onto the
// grid. Throws std::invalid_argument when the grid is over kMaxTerrainSamples or the DEM does
// not cover it (the spec reader refuses both first).
Terrain makeTerrain(const TerrainOptions& options, const PlotArea& area, double margin,
                    uint64_t plotSeed);

// The terrain mesh: two triangles per heightfield cell, counter-clockwise seen from above
// (normals +y side), every vertex with order −1 and colour 0.
Mesh terrainMesh(const Terrain& terrain);

}  // namespace sylva
