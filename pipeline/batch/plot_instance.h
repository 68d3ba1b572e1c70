// Writing one grown plot instance: scene meshes, per-tree files, views with instance ids, the
// tree table and the plot statistics (file list and formats: docs/plots.md, "Outputs").
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "pipeline/batch/dataset.h"
#include "pipeline/scan/scanner.h"
#include "species/plot/plot.h"

namespace sylva {

// Relative directory of a plot instance's files: plots/<plot name>/<id> ("plot" without a
// spec).
std::filesystem::path plotInstanceDir(const GrownPlot& plot, const std::string& id);

// Writes the plot into out/plots/<plot name>/<id>/, every file atomically (temp + rename):
//   scene.glb, scene.ply                when outputs.meshFormats is not empty;
//   trees/<tree>/skeleton.ply (.swc)    as outputs.ply / outputs.swc;
//   trees/<tree>/mesh.<format>          per outputs.meshFormats (obj with its mtl);
//   trees/<tree>/stats.json             always;
//   views/<view>.png, <view>_depth.exr, <view>_depth.png, <view>_label.png, <view>_id.png and
//     transforms.json                   when outputs.views.count > 0 (the [views] size, depth,
//                                       depth_png and labels options; ids always);
//   trees.csv, trees.json, plot.json    always.
// Returns the manifest record: id, kind "plot", plot, seed (16 hex digits), trees, files
// (key → path relative to `out`), bytes_written, stats (plot.json's statistics).
// `scanProgress`: the plot's scan's progress (scanner.h), when set.
nlohmann::json writePlot(const GrownPlot& plot, const OutputOptions& outputs,
                         const std::filesystem::path& out, const std::string& id,
                         const ScanProgress& scanProgress = {});

}  // namespace sylva
