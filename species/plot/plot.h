// Forest plots: many trees of several species standing on terrain, grown together.
// The types every stage of a plot shares: the plot's spec (plot_spec.h reads it from a dataset
// file's [[plot]] tables), its layout (terrain + stems; layout.h), the grown plot (trees in
// plot-local metres; plot_growth.h) and its inventory (inventory.h).
//
// Frame: plot-local metres, +y up, the ground plane x–z; the plot's centre is x = z = 0 (a
// rectangle spans [−width/2, width/2] × [−depth/2, depth/2], a circle has radius `radius`).
// Terrain heights are y values in the same metres (flat terrain: y = 0). +x is east, −z north
// (so an aspect azimuth of 0° faces −z, 90° faces +x).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/math.h"
#include "core/params.h"
#include "species/spec/species.h"

namespace sylva {

// The plot's outline on the ground.
struct PlotArea {
    enum class Shape : uint8_t { kRectangle, kCircle };
    Shape shape = Shape::kRectangle;
    double width = 50.0, depth = 50.0;  // metres along x and z (rectangle)
    double radius = 0.0;                // metres (circle)
    double area() const;                // m²
    bool contains(double x, double z) const;
    // Half the extent of its bounding box along x and along z (metres; the centre is x = z = 0).
    double halfX() const { return shape == Shape::kCircle ? radius : 0.5 * width; }
    double halfZ() const { return shape == Shape::kCircle ? radius : 0.5 * depth; }
};

// The ground: a heightfield over the plot (with a margin, so crowns at the edge stand on it).
struct TerrainOptions {
    enum class Kind : uint8_t { kFlat, kSlope, kNoise, kDem };
    Kind kind = Kind::kFlat;
    double slopeRad = 0.0;        // slope: inclination
    double aspectRad = 0.0;       // slope: the azimuth the slope faces (downhill direction)
    double amplitude = 0.0;       // noise: metres, peak height of the smooth noise
    double wavelength = 30;       // noise: metres, its largest feature
    int octaves = 3;              // noise: fBm octaves, each half the wavelength and amplitude
    std::string demPath;          // dem: a single-channel PNG/TIFF read through OpenImageIO
    double metresPerPixel = 1.0;  // dem: ground distance between pixel centres
    double heightScale = 1.0;     // dem: metres per pixel value (8/16-bit: per integer step)
    double heightOffset = 0.0;    // dem: metres added to every height
    double cell = 1.0;            // metres between heightfield samples (and terrain mesh cells)
};

// Spatial point processes for stem positions (inside the plot area).
struct PointProcessOptions {
    enum class Kind : uint8_t { kPoisson, kHardCore, kStrauss, kThomas, kRows };
    Kind kind = Kind::kPoisson;
    double minSpacing = 0.0;     // hard-core (Matérn): no pair closer; strauss: interaction r
    double interaction = 0.0;    // strauss: γ ∈ [0, 1] (0 = hard core, 1 = Poisson)
    double parentDensity = 0.0;  // thomas: cluster centres per hectare
    double clusterSigma = 0.0;   // thomas: metres, sd of a cluster's Gaussian spread
    double rowSpacing = 0.0;     // rows: metres between rows
    double stemSpacing = 0.0;    // rows: metres between stems along a row
    double rowAzimuthRad = 0.0;  // rows: direction the rows run
    double jitter = 0.0;         // rows: metres, sd of each stem's offset from its grid place
};

// One species of a plot's mix.
struct PlotSpecies {
    SpeciesFile species;
    std::string keyPath;  // "plot[0].species[2]", for errors
    SourcePos where;
    bool understory = false;  // [[plot.understory]]: shrubs/saplings, own Poisson process
    double density = 0.0;     // stems per hectare (expected), or …
    int64_t count = -1;       // … an exact count (−1: use density)
    // Size distribution: the tree is scaled uniformly about its base so its height is this
    // draw (metres); ≤ 0: the height it grew to.
    toml::table height;  // holder["v"]: a number or a distribution, drawn per stem
    bool hasHeight = false;
    // Stand slenderness: height / DBH (m/m; number or distribution, drawn per stem). The stem's
    // radii are scaled (every node by one factor, so the pipe model's proportions stay) to give
    // DBH = height / slenderness; absent: the grown tree's (open-grown) proportions.
    toml::table slenderness;
    bool hasSlenderness = false;
    double lai = -1;            // this species' share of the plot's LAI (m²/m²); < 0: none
    double crownShyness = 0.1;  // gap between crowns, fraction of the crown radius
    double maxOverlap = 0.05;   // crown overlap threshold (fraction of crown projection area)
};

struct GroundCoverOptions {
    double density = 0.0;  // cards per m² (0: none)
    double height = 0.3;   // metres, tallest card
    double width = 0.15;   // metres, card width
};

struct PlotSpec {
    std::string name;
    std::string keyPath;  // "plot[0]"
    SourcePos where;
    int64_t count = 0;  // plot instances
    PlotArea area;
    double margin = 5.0;  // metres of terrain beyond the area on every side
    TerrainOptions terrain;
    PointProcessOptions process;       // of the canopy trees (understory: Poisson)
    std::vector<PlotSpecies> species;  // canopy species, then understory
    GroundCoverOptions groundCover;
    double lai = -1;  // the plot's leaf area index target (m² one-sided leaf / m² ground); < 0
    bool neighbours = true;  // grow in a shared environment (false: each tree alone)
    // A sweep point of a swept plot ([[sweep]] with `plots`): `name` is "<plot>-p<point>", the
    // [[plot]] table's name is `sweptFrom`; all three empty for a plot no axis sweeps.
    std::string sweptFrom;
    std::string seedKey;                       // "path=value;…" of the axes that change seeds
    std::map<std::string, std::string> sweep;  // swept key path -> value text (the manifest's)
};

// The terrain as a heightfield (terrain.h builds it from TerrainOptions and the plot's seed).
class Terrain {
  public:
    Terrain() = default;
    Terrain(double x0, double z0, double cell, int nx, int nz, std::vector<float> heights);
    double height(double x, double z) const;  // bilinear; clamped outside the grid
    Vec3 normal(double x, double z) const;    // unit, +y side
    double x0() const { return x0_; }
    double z0() const { return z0_; }
    double cell() const { return cell_; }
    int nx() const { return nx_; }
    int nz() const { return nz_; }
    const std::vector<float>& heights() const { return heights_; }  // row-major, z rows

  private:
    double x0_ = 0, z0_ = 0, cell_ = 1;
    int nx_ = 0, nz_ = 0;
    std::vector<float> heights_;
};

// One stem of a plot's layout.
struct PlotStem {
    int32_t id = 0;           // tree id within the plot, 1 … N (0 = terrain/background in ids)
    int32_t species = 0;      // index into PlotSpec::species
    Vec3 base;                // x, terrain height, z
    double targetHeight = 0;  // metres; ≤ 0: as grown
    double slenderness = 0;   // height / DBH to give the stem; ≤ 0: as grown
    uint64_t seed = 0;        // the tree's own seed (hashed from the plot seed and id)
};

struct PlotLayout {
    Terrain terrain;
    std::vector<PlotStem> stems;    // canopy stems first, then understory; ids in order
    std::vector<Leaf> groundCover;  // low-vegetation cards standing on the terrain
};

// A grown tree in the plot: its skeleton and leaves in plot-local metres (standing vertical at
// its base), and what was drawn for it.
struct PlotTree {
    PlotStem stem;
    GrownTree grown;          // grown.tree is in plot-local metres
    double leafScale = 1.0;   // factor applied to leaf sizes (areas: its square) for the LAI
    int64_t leavesGrown = 0;  // leaves before the LAI thinning (grown.tree.leaves: those kept)
};

struct GrownPlot {
    const PlotSpec* spec = nullptr;
    PlotLayout layout;
    std::vector<PlotTree> trees;    // in stem order
    std::vector<Leaf> groundCover;  // low-vegetation cards on the terrain
    double lai = 0;                 // reached (m²/m²), over the plot area
    uint64_t seed = 0;              // the plot instance's seed (the manifest record's "seed")
};

}  // namespace sylva
