// `sylva grow`: one tree of a species, for a quick look before a build.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "species/model/tree_stats.h"

namespace sylva {

struct GrowOneResult {
    std::string species;
    std::filesystem::path dir;  // where the files went
    TreeStats stats;
    double growMs = 0.0;
};

constexpr int kGrowPreviewSize = 1024;  // pixels

// Validates the species, grows the tree of instance seed `seed` (threaded) and writes
// skeleton.ply, skeleton.swc, preview.png (one view in label colours, kGrowPreviewSize
// pixels square), preview_wood.png (the same view without leaves) and stats.json (the manifest's
// stats, method counters, drawn parameters and grow_ms) into `dir`, or out/grow/<species> when
// `dir` is empty. Throws SpecError on a bad species (one whose parameters certainly outgrow a
// budget too), and BudgetExceeded, before writing anything, when the tree outgrows one.
GrowOneResult growOne(const std::string& speciesPath, uint64_t seed,
                      const std::filesystem::path& dir);

}  // namespace sylva
