// The foresters' ground truth of a grown plot: a tree table (one row per stem) and the plot
// statistics (stems/ha, basal area, Clark–Evans index, canopy cover, height distribution, LAI,
// counts per species). Definitions and references: docs/plots.md, "Outputs".
// Frame: plot-local metres, +y up, +x east, −z north (plot.h).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "species/plot/plot.h"

namespace sylva {

// The crown-radius sectors, clockwise from north: N, NE, E, SE, S, SW, W, NW.
extern const std::array<const char*, 8> kCrownSectors;

struct TreeRecord {
    int32_t id = 0;       // PlotStem::id
    std::string name;     // "tree-0007"
    std::string species;  // the species' name
    Vec3 base;            // x, y (terrain height), z of the stem base, metres
    double height = 0;    // top above the base: highest shoot node or leaf centre, metres
    // Diameter at breast height (1.3 m above the base), metres: twice the radius of the order-0
    // path from the root node up, linearly interpolated between the two nodes around 1.3 m;
    // 0 when that path does not reach 1.3 m. A fork below 1.3 m: only the leader (the child the
    // order-0 path follows, the one with the longest path above it) is measured.
    double dbh = 0;
    // Crown base height above the base, metres: the lower of the lowest leaf centre and the
    // attachment (fork node) of the lowest first-order branch whose subtree carries leaves. NaN
    // for a tree without leaves.
    double crownBase = 0;
    // Per sector (kCrownSectors), the largest horizontal distance from the stem axis (base x, z)
    // of a leaf centre or shoot node in that 45° sector (centred on its direction), metres; 0
    // for an empty sector.
    std::array<double, 8> crownRadius{};
    double nearestNeighbour = 0;  // metres, stem base to stem base in x–z; +∞ for a lone tree
    double leafArea = 0;          // m², one side
};

struct HeightDistribution {
    double min = 0, q1 = 0, median = 0, q3 = 0, max = 0, mean = 0;  // metres (NaN: no trees)
    double binWidth = 2.0;                                          // metres
    std::vector<int64_t> histogram;  // bin k: heights in [k·binWidth, (k+1)·binWidth)
};

struct PlotStatistics {
    int64_t trees = 0;
    double areaM2 = 0;
    double stemsPerHa = 0;        // trees / area · 10⁴
    double basalAreaM2PerHa = 0;  // Σ π DBH²/4 / area · 10⁴
    double clarkEvans = 0;        // point_process.h clarkEvans of the stem bases (NaN: < 2)
    double canopyCover = 0;       // fraction of the plot area under leaves or wood, from above
    double canopyCellM = 0.1;     // metres: the raster cell canopyCover was measured on
    HeightDistribution heights;
    double lai = 0;                             // GrownPlot::lai (the growth stage's value)
    double leafAreaIndex = 0;                   // Σ one-sided leaf area of the trees / plot area
    double meanNearestNeighbour = 0;            // metres (NaN: < 2 trees)
    std::map<std::string, int64_t> perSpecies;  // trees per species name
};

// The species name of a stem: plot.spec's species entry, or "species-<index>" without a spec.
std::string plotSpeciesName(const GrownPlot& plot, int32_t speciesIndex);
// "tree-0007": the tree's id, zero-padded to 4 digits (more when the id needs them).
std::string treeName(int32_t id);

// One record per tree, in the plot's tree order.
std::vector<TreeRecord> treeTable(const GrownPlot& plot);
// A single tree's measurements, base given (the tree in the same metres as the base).
TreeRecord measureTree(const Tree& tree, const Vec3& base);

// Plot statistics from the table; canopy cover rasterised from the plot's leaves (outline
// triangles) and wood (segments as discs of their radius swept between nodes) seen from
// above, on cells of canopyCoverCell(area, `cell`) metres whose centres lie inside the plot area.
PlotStatistics plotStatistics(const GrownPlot& plot, const std::vector<TreeRecord>& table,
                              double cell = 0.1);

// The canopy raster's cell: `cell` metres, or coarser where the area would need more than
// kMaxCoverCells cells at it (a 10 km square at 0.1 m is 10¹⁰ cells: 10 GB), so that the raster's
// memory is bounded whatever the plot's size (plots up to 40 ha keep 0.1 m).
inline constexpr double kMaxCoverCells = 4e7;
double canopyCoverCell(const PlotArea& area, double cell);

// Fraction of the area's cells (centres inside `area`, of canopyCoverCell(area, `cell`) metres)
// covered from above by the trees.
double canopyCover(const std::vector<const Tree*>& trees, const PlotArea& area, double cell);

}  // namespace sylva
