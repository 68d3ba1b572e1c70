// Dataset specs and their expansion into instance jobs:
// species × sweep point × index, each with a seed hashed from (dataset seed, species,
// sweep point, index) so any subset — a shard, a resumed run — draws the same trees.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "pipeline/render/camera.h"
#include "pipeline/render/render.h"
#include "species/geometry/tube_mesh.h"
#include "species/geometry/watertight.h"
#include "species/spec/species.h"

namespace sylva {

struct SweepAxis {
    std::string path;                  // parameter path, e.g. "levels[1].endpoints"
    std::vector<std::string> species;  // species it applies to (empty: all)
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
    BudgetTable budget;   // the dataset's [budget], over the species' own
    SourcePos fileWhere;  // the entry's `file` key, and its path ("species[2].file"): errors
    std::string fileKey;  // inside the species file are reported there too
    int64_t count = 0;
    std::vector<SweepPoint> points;  // at least one (the empty point)
};

struct OutputOptions {
    bool ply = true;       // skeleton.ply
    bool swc = false;      // skeleton.swc
    bool preview = false;  // preview.png per instance
    int previewSize = 512;
    std::vector<std::string> meshFormats;  // of "ply", "glb", "obj"; empty: no mesh
    TubeOptions tubes;                     // level of detail of branch tubes
    bool watertight = false;               // watertight.<format> (union of capsules)
    WatertightOptions watertightOptions;
    bool vdb = false;       // watertight.vdb (the level set itself)
    ViewOptions views;      // [views]
    RenderOptions render;   // [views] min_width_px
    int speciesSheet = 16;  // first K instances per species in a sheet
};

struct DatasetSpec {
    std::string path;
    std::string name;
    uint64_t seed = 0;
    std::string description;
    std::vector<SpeciesEntry> species;
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
    std::string id;  // "<species>[-p<point>]-<index>"
    const SpeciesEntry* entry = nullptr;
    const SweepPoint* point = nullptr;
    int pointIndex = 0;
    int64_t index = 0;  // index within (species, point)
    uint64_t seed = 0;
};

std::vector<InstanceJob> expandJobs(const DatasetSpec& spec);

// Instance seed: a hash of (dataset seed, species name, sweep point key, index).
uint64_t instanceSeed(uint64_t datasetSeed, const std::string& species, const std::string& pointKey,
                      int64_t index);

// Whether a TOML file is a dataset (has [[species]]) rather than a species file.
bool isDatasetFile(const toml::table& t);

}  // namespace sylva
