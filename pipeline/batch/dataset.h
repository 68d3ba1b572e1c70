// Dataset specs and their instances: species × sweep point × index, each with a seed hashed
// from (dataset seed, species, sweep point, index) so any subset — a shard, a resumed run —
// draws the same trees. Instances are computed from their position (DatasetInstances), never
// expanded into a list, so a dataset's size costs no memory.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "pipeline/formats/scan_writers.h"
#include "pipeline/render/camera.h"
#include "pipeline/render/colour_render.h"
#include "pipeline/render/render.h"
#include "pipeline/scan/scan_options.h"
#include "species/geometry/tube_mesh.h"
#include "species/geometry/watertight.h"
#include "species/plot/plot.h"
#include "species/spec/species.h"

namespace sylva {

struct SweepAxis {
    std::string path;                  // parameter path, e.g. "levels[1].endpoints"
    std::vector<std::string> species;  // species it applies to (empty: all, unless `plots`)
    std::vector<std::string> plots;    // plots it applies to, instead of species (their keys)
    std::vector<toml::table> values;   // each value in holder["v"]
    std::vector<std::string> labels;   // value as text, for ids and the manifest
    SourcePos where;
    bool sameSeed = false;  // same_seed: instance seeds ignore this axis (growth stages)
};

struct SweepPoint {
    std::string key;      // "path=value;…" ("" without sweeps)
    std::string seedKey;  // key without the same_seed axes: what instance seeds hash
    std::shared_ptr<const Overrides> overrides;
    std::map<std::string, std::string> values;  // path -> value text
};

struct SpeciesEntry {
    SpeciesFile species;
    BudgetTable budget;  // the dataset's [budget], over the species' own
    int64_t count = 0;
    std::vector<SweepPoint> points;   // at least one (the empty point)
    SourcePos fileWhere, countWhere;  // its `file` and `count` keys, for errors (errors inside
    std::string fileKey;              // the species file name the `file` key too: fileKey is
    std::string keyPath;              // its path, "species[2].file"; keyPath "species[2]")
};

// The largest dataset: 9 × 10¹⁵ instances in all (Σ count × sweep points), a round number
// below 2⁵³. Positions and counts are int64 (no overflow below 2⁶³); every integer up to it is
// exact in a double, so the spec reader (which passes integers through a double) and JSON
// readers that hold numbers as doubles (JavaScript; dataset.json's counts, the manifest's
// `index`) see it exactly; ids print the index in decimal, so they stay unique and stable.
constexpr int64_t kMaxInstances = 9'000'000'000'000'000;

// [scan]: a simulated laser scan of every instance, tree or plot (docs/scanning.md).
struct ScanOutputs {
    bool enabled = false;  // the dataset has a [scan] table
    ScanOptions options;
    bool las = true;                      // scan.las (LAS 1.4)
    bool laz = false;                     // scan.laz (the same, LAZ-compressed)
    bool forestFormer = false;            // scan_forestformer.ply (ForestFormer3D / ForAINetV2)
    bool treeLearn = false;               // scan_treelearn.npy (TreeLearn)
    LasColour colour = LasColour::kNone;  // LAS point format 6, or 7 coloured by class / tree
    LasClasses classes = LasClasses::kForInstance;  // LAS classification: FOR-instance or ASPRS
};

struct OutputOptions {
    bool ply = true;       // skeleton.ply
    bool swc = false;      // skeleton.swc
    bool preview = false;  // preview.png per instance
    int previewSize = 512;
    std::vector<std::string> meshFormats;  // of "ply", "glb", "obj"; empty: no mesh
    bool textures = false;  // mesh.glb / mesh.obj textured with the species' look (needs either)
    // mesh_compression = "meshopt": every GLB quantised and compressed by meshoptimizer;
    // "draco": its meshes by Draco, its GPU instances by meshoptimizer (glb_meshopt.h); "none"
    // (the default): plain GLBs.
    std::string meshCompression = "none";
    // Leaves meshed and drawn as their shapes' outlines (true), or every leaf as its card, one
    // quad (false): a plot's level of detail (a compound leaf's outline is ~100 triangles).
    bool leafOutlines = true;
    // leaf_instances: the leaves of every tree's mesh.glb as GPU instances of one leaf per
    // shape and colour class (EXT_mesh_gpu_instancing; mesh_writers.h meshGlb).
    bool leafInstances = false;
    TubeOptions tubes;        // level of detail of branch tubes
    bool watertight = false;  // watertight.<format> (union of capsules)
    WatertightOptions watertightOptions;
    bool vdb = false;       // watertight.vdb (the level set itself)
    ViewOptions views;      // [views]
    RenderOptions render;   // [views] min_width_px
    ColourOptions colour;   // [views] colour, colour_*
    int speciesSheet = 16;  // first K instances per species in a sheet
    ScanOutputs scan;       // [scan]
    bool qsm = false;       // qsm.csv + qsm_treeqsm.txt per tree (default: with [scan])
    // pack = "tar": instances per tar shard (pack_instances; pack.h); 0: one directory each.
    int64_t packInstances = 0;
};

struct DatasetSpec {
    std::string path;
    std::string name;
    uint64_t seed = 0;
    std::string description;
    std::vector<SpeciesEntry> species;
    std::vector<PlotSpec> plots;  // [[plot]]: forest plots, each instance one plot
    std::vector<SweepAxis> sweeps;
    OutputOptions outputs;
    BudgetTable budget;       // [budget]: every tree's budgets, over the species' own
    std::string fingerprint;  // hash of the dataset and species files, for resume safety
    std::shared_ptr<const toml::table> table;
};

// Loads and fully validates a dataset file: every species file, every sweep point. With a
// KeyLog, the dataset file's keys are recorded (core/params.h).
DatasetSpec loadDataset(const std::string& path, KeyLog* keyLog = nullptr);

struct InstanceJob {
    std::string id;                       // "<species>[-p<point>]-<index>", or "<plot>-<index>"
    const SpeciesEntry* entry = nullptr;  // a tree of a species, or …
    const PlotSpec* plot = nullptr;       // … a plot (entry and point null)
    const BudgetTable* datasetBudget = nullptr;  // a plot's: the dataset's [budget]
    const SweepPoint* point = nullptr;
    int pointIndex = 0;
    int64_t index = 0;  // index within (species, point)
    uint64_t seed = 0;
    int64_t position = 0;  // place in the dataset's instance order, 0 … size − 1
};

// The instances of a dataset in their fixed order — species entries in spec order, within each
// its sweep points in order, within each point index 0 … count − 1; then the plots in spec
// order, each index 0 … count − 1 — computed from their
// position, never stored: the (species, point) blocks of one species have the same length, so
// a prefix sum per species and a binary search over it place any position (O(log species)).
// Memory: one integer and one name per species entry, whatever the count. `spec` must outlive
// it (jobs point into it).
class DatasetInstances {
  public:
    explicit DatasetInstances(const DatasetSpec& spec);

    int64_t size() const { return start_.back(); }
    // Instance `position` (0 ≤ position < size(); std::out_of_range otherwise).
    InstanceJob operator[](int64_t position) const;
    // The position of the instance with this id, if the dataset has one (the inverse of
    // operator[]: instance(find(id)).id == id).
    std::optional<int64_t> find(std::string_view id) const;
    // Positions [begin, end) of species entry `entry` (spec order); plot k is entry
    // speciesCount() + k.
    std::pair<int64_t, int64_t> speciesRange(size_t entry) const {
        return {start_[entry], start_[entry + 1]};
    }
    size_t speciesCount() const { return spec_->species.size(); }
    // The position of the first plot instance (size() without plots).
    int64_t plotStart() const { return start_[spec_->species.size()]; }
    const DatasetSpec& spec() const { return *spec_; }

  private:
    const DatasetSpec* spec_;
    std::vector<int64_t> start_;  // start_[s]: position of entry s's first instance; then size()
    std::map<std::string, size_t, std::less<>> byName_;  // species name -> entry
};

// Every instance at once, in order: for tests and small tools only (a build never lists them).
// Throws std::length_error above 10⁷ instances.
std::vector<InstanceJob> expandJobs(const DatasetSpec& spec);

// An instance's id: "<species>-<index>", or "<species>-p<point>-<index>" for a swept species
// (index at least 5 digits, point at least 3, zero-padded).
std::string instanceId(const std::string& species, bool swept, int pointIndex, int64_t index);

// Instance seed: a hash of (dataset seed, species name, sweep point key, index).
uint64_t instanceSeed(uint64_t datasetSeed, const std::string& species, const std::string& pointKey,
                      int64_t index);

// A plot instance's seed: a hash of (dataset seed, "plot:" + the [[plot]] name, the sweep
// point's seed key ("" unswept), index).
uint64_t plotSeed(uint64_t datasetSeed, const PlotSpec& plot, int64_t index);

// Whether a TOML file is a dataset (has [[species]]) rather than a species file.
bool isDatasetFile(const toml::table& t);

}  // namespace sylva
