// Reading a dataset file's [[plot]] tables (docs/plots.md): the plot's area, terrain, stem
// process, species mix (each species file loaded and validated like a dataset's species),
// understory and ground cover. Every bad value is a SpecError at its key; the checks that need
// several keys (a spacing that cannot fit the stems, rows too few for them, a DEM that does not
// cover the plot) are made here too, so a plot that loads can be laid out.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "core/budget.h"
#include "core/params.h"
#include "species/plot/plot.h"

namespace sylva {

// Limits of one plot (a larger value is an error at its key).
constexpr int64_t kMaxPlotCount = 1000000;  // plot instances per [[plot]]
constexpr int64_t kMaxPlotStems = 100000;   // expected stems per plot instance, all species
constexpr double kMaxPlotSide = 10000;      // metres: width, depth, 2 × radius
constexpr double kMinPlotSide = 1;          // metres: a plot smaller than a tree's footprint
                                            // reports nonsense densities (3 × 10^16 stems/ha)
constexpr double kMaxPlotLai = 15;          // m²/m²
constexpr double kMaxGroundCards = 1e7;     // ground-cover cards per plot instance

// What reading a plot learns from its files (a species file loaded and validated, a DEM's size
// and channels), kept by path so that the sweep points of one plot, read again with other
// values, do not load and validate every file again (a point took 79 ms with five species and a
// DEM; 10⁴ points took minutes). Only valid for one budget and `meshed`.
struct PlotFileCache {
    std::map<std::string, SpeciesFile> species;  // by the species file's normalised path
    struct Dem {
        int width = 0, height = 0, channels = 0;
    };
    std::map<std::string, Dem> dems;  // by the DEM's path, read without error
    struct Grown {
        double leafArea = 0, height = 0;  // m², m: one tree grown alone (the LAI estimate)
    };
    std::map<std::string, Grown> grown;  // by the species file's path as loaded
};

// One [[plot]] table, `p` (its keys are recorded under the documentation context "plot").
// Species files are relative to the dataset file; each is loaded and validated with the
// dataset's `budget` (`meshed`: whether the dataset meshes its instances), or taken from `cache`
// when given and read before. The bytes of every file it names (species files, the DEM) are
// appended to `fingerprintBytes` when given.
PlotSpec readPlot(Params& p, const BudgetTable& budget, bool meshed, std::string* fingerprintBytes,
                  PlotFileCache* cache = nullptr);

// The expected number of stems of one species in the plot (its count, or density × area).
double expectedStems(const PlotSpecies& species, const PlotArea& area);

// A plot instance's id: "<plot name>-<index>" (index zero-padded to 5 digits).
std::string plotInstanceId(const std::string& plotName, int64_t index);

}  // namespace sylva
