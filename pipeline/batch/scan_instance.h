// The scan stage of an instance (docs/scanning.md): a simulated laser scan of a tree (on a ground
// square) or of a plot (its terrain, trees and ground cover) with the dataset's [scan] options,
// its files, its statistics block, and the trees' QSM cylinder tables.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pipeline/batch/dataset.h"
#include "pipeline/scan/scan_point.h"
#include "pipeline/scan/scan_spool.h"
#include "pipeline/scan/scanner.h"
#include "species/geometry/mesh.h"
#include "species/model/tree.h"

namespace sylva {

struct PlotScene;

// A scan: its points (spooled to disk beyond a few MiB, pipeline/scan/scan_spool.h), its
// trajectory and pulse count (`result`, whose points stay empty) and its statistics block
// (ScanStats::json).
struct InstanceScan {
    std::unique_ptr<ScanPointSpool> points;
    ScanResult result;
    nlohmann::json stats;
    double sceneMs = 0;  // the scene and its BVH
    double totalMs = 0;  // the scene and the survey traced into the spool
};

// The ground square under a single tree: half its side in metres — the tree's horizontal reach
// (nodes and leaves) or the farthest TLS station, whichever is more, plus 2 m.
double treeGroundHalfSize(const Tree& tree, const ScanOptions& options);

// A single tree (its mesh as meshStage made it) on its ground square; the scanner's random
// streams are keyed by `seed` (the instance seed's "scan" stream). Points beyond the spool's
// memory go to an unnamed temporary file in `spoolDir` (the instance's directory: the disk the
// scan files are written to).
InstanceScan scanTree(const Tree& tree, const TreeMesh& mesh, const std::vector<int32_t>& woodNodes,
                      const ScanOutputs& scan, bool leafOutlines, uint64_t seed,
                      const std::filesystem::path& spoolDir);
// A plot: its scene (makePlotScene, with leaf meshes) on the plot's terrain.
InstanceScan scanPlot(const GrownPlot& plot, const PlotScene& scene, const ScanOutputs& scan,
                      uint64_t seed, const std::filesystem::path& spoolDir,
                      const ScanProgress& progress = {});

// Writes the scan's files into out/rel — scan.las, scan_forestformer.ply, scan_treelearn.npy
// (as [scan] formats asks), scan_trajectory.csv and, for TLS, scan_stations.json — adding each
// to `files` (manifest key → relative path) and its size to `bytes`.
void writeScanFiles(const InstanceScan& scan, const ScanOutputs& options,
                    const std::filesystem::path& out, const std::filesystem::path& rel,
                    nlohmann::json& files, uint64_t& bytes);

// qsm.csv and qsm_treeqsm.txt of a tree in out/rel, with `prefix` before both names
// ("" for a single tree, "trees/tree-0007_" in a plot).
void writeQsmFiles(const Tree& tree, const std::filesystem::path& out,
                   const std::filesystem::path& rel, const std::string& prefix,
                   nlohmann::json& files, uint64_t& bytes);

}  // namespace sylva
