#include "pipeline/batch/grow_one.h"

#include <chrono>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "pipeline/batch/output_lock.h"
#include "pipeline/formats/skeleton_writers.h"
#include "pipeline/formats/stats_json.h"
#include "pipeline/formats/view_writers.h"
#include "species/geometry/tube_mesh.h"
#include "species/spec/species.h"

namespace sylva {

namespace fs = std::filesystem;

GrowOneResult growOne(const std::string& speciesPath, uint64_t seed, const fs::path& dir) {
    SpeciesFile species = loadSpecies(speciesPath);
    validateSpecies(species, nullptr);
    GrowOneResult r;
    r.species = species.name;
    r.dir = dir.empty() ? fs::path("out") / "grow" / species.name : dir;
    checkOutputDir(r.dir, "--out");  // one clear line before anything is grown or written
    const auto t0 = std::chrono::steady_clock::now();
    GrownTree g;
    try {
        g = growSpecies(species, seed, nullptr, true);
    } catch (const BudgetExceeded& e) {  // which tree, for the one line the command prints
        throw BudgetExceeded(species.name + " seed " + std::to_string(seed) + ": " + e.what());
    }
    r.growMs =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    r.stats = computeStats(g.tree);
    writeFileAtomic(r.dir / "skeleton.ply", skeletonPly(g.tree));
    writeFileAtomic(r.dir / "skeleton.swc", skeletonSwc(g.tree));
    // The tubes once for the three previews (they do not depend on the leaves).
    std::vector<int32_t> nodes;
    const Mesh tubes = tubeMesh(g.tree, TubeOptions{}, &nodes);
    writeLabelPreviewPng(g.tree, tubes, nodes, r.dir / "preview.png", kGrowPreviewSize);
    Tree wood = g.tree;  // the branching, which leaves hide
    wood.leaves.clear();
    writeLabelPreviewPng(wood, tubes, nodes, r.dir / "preview_wood.png", kGrowPreviewSize);
    writeColourPreviewPng(g.tree, tubes, nodes, *species.look, seed, r.dir / "preview_rgb.png",
                          kGrowPreviewSize);
    nlohmann::json j = toJson(r.stats);
    for (const auto& [k, v] : g.methodStats) j[k] = v;
    const nlohmann::json rec = {{"species", species.name},
                                {"seed", seed},
                                {"stats", j},
                                {"params", g.sampled},
                                {"grow_ms", r.growMs}};
    writeFileAtomic(r.dir / "stats.json", rec.dump(2) + "\n");
    return r;
}

}  // namespace sylva
