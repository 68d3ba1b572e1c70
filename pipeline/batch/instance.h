// One instance through the stages of the flow graph: grow → mesh → render (+ scan) → write.
// Each stage is a function of the work item; only write() touches the disk (besides the
// optional watertight .vdb, which the mesh stage writes atomically as it is made).
#pragma once

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pipeline/batch/dataset.h"
#include "pipeline/batch/progress.h"
#include "pipeline/batch/scan_instance.h"
#include "pipeline/formats/mesh_writers.h"
#include "pipeline/render/colour_render.h"
#include "pipeline/render/render.h"
#include "species/geometry/mesh.h"
#include "species/spec/species.h"

namespace sylva {

struct InstanceWork {
    InstanceJob job;  // computed from its position as the source reaches it (no list of jobs)
    GrownTree grown;
    TreeMesh mesh;                   // tubes + leaf cards (when a mesh format is asked for)
    std::vector<int32_t> woodNodes;  // per tube triangle, its skeleton node (tubeMesh)
    Mesh watertight;                 // when asked for
    std::vector<Camera> cameras;
    BoundingSphere sphere;  // the tree's, which the cameras frame (render stage)
    std::vector<ViewImage> views;
    std::vector<ColourImage> colours;  // [views] colour: one per view
    double growMs = 0, meshMs = 0, renderMs = 0, writeMs = 0;
    std::shared_ptr<GrownPlot> plot;     // a plot instance's trees (job.plot), instead of grown
    std::shared_ptr<InstanceScan> scan;  // [scan]: the scan of a tree (a plot's: writePlot)
    double scanMs = 0;
    // A plot's progress lines (its trees growing, its scan), when the build shows progress.
    std::optional<InstanceProgress> progress;
    std::string packTar;    // [outputs] pack: its tar shard ("shards/000003.tar"), else ""
    nlohmann::json record;  // the manifest line, made by write()
    std::string error;      // set by the first stage that fails; later stages skip
};

void growStage(InstanceWork& w);
void meshStage(InstanceWork& w, const OutputOptions& outputs, const std::filesystem::path& out);
void renderStage(InstanceWork& w, const OutputOptions& outputs);
// [scan]: scans a tree (after its mesh); a plot is scanned by writePlot.
void scanStage(InstanceWork& w, const OutputOptions& outputs, const std::filesystem::path& out);
void writeStage(InstanceWork& w, const OutputOptions& outputs, const std::filesystem::path& out);

// A mesh as a "glb" (compressed as `compression` says, "none", "meshopt" or "draco":
// glb_meshopt.h; textured with `look`; its leaves as GPU instances of `instances`, the leaves
// m.leaves was made from: mesh_writers.h) or "ply" file's bytes (OBJ, with its MTL beside it,
// is written by the callers).
std::string meshBytes(const TreeMesh& m, const std::string& format, const MeshLook* look,
                      const std::string& compression, const std::vector<Leaf>* instances = nullptr);

// Relative directory of an instance's files: trees/<species>/<id>, or plots/<plot>/<id>.
std::filesystem::path instanceDir(const InstanceJob& job);

}  // namespace sylva
