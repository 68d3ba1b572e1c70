// Issue 13's realism gates: what every species of the library (species/presets/) must show over
// its instances in a built dataset — nothing under the ground, botanical branch thickness and
// branching, variation between instances, leaves on wood, one stem, a straight leader, enough
// foliage. Read from the manifest's per-instance statistics (docs/metrics.md); the table of
// gates and each species' values is docs/metrics.md's "Realism gates" and the README's.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "species/model/reference_metrics.h"

namespace sylva {

// One gate of one species: its measured value over the instances and whether it passes;
// `applies` is false where the gate does not hold for the species' habit or foliage.
struct GateResult {
    std::string gate;  // the gate's name (kGateNames)
    bool applies = true;
    bool pass = true;
    double value = 0;    // the measure (NaN when no instance defines it)
    std::string detail;  // what decided it, where the gate takes the worst of several
};

struct SpeciesGates {
    std::string species;
    std::string habit;
    int instances = 0;
    std::vector<GateResult> gates;  // in kGateNames' order
    bool pass() const;
};

// The gates, in the order of the table: the measure over the instances, and what it needs.
struct GateSpec {
    const char* name;
    const char* measure;
    const char* required;
};
const std::vector<GateSpec>& realismGates();

// What the spread and seed gates read of an instance beyond its statistics: the reference
// distributions of its skeleton, and its first view's mask with that view's azimuth.
struct InstanceShape {
    ReferenceValues reference;  // all empty when the instance has no skeleton.ply
    int maskWidth = 0, maskHeight = 0;
    std::vector<uint8_t> mask;  // views/000.png, row-major, non-zero = tree; empty when none
    double azimuthDeg = 0;      // of that view
};

// The interquartile range of the reference's distributions (treeqsm-broadleaf.json: its 75 %
// minus its 25 % quantile), in kReferenceDistributionNames' order; the spread gate holds a
// species' pooled interquartile range to at least half of it. 0: not gated (tip paths, order-3
// lengths).
extern const std::array<double, kReferenceDistributions> kSpreadGateIqr;

// Evaluates every species of the manifest records (objects with species, habit and stats),
// in the order species first appear. `shapes` (one per record, or null) feeds the spread and
// seed gates; without it they do not apply.
std::vector<SpeciesGates> evaluateGates(const std::vector<nlohmann::json>& records,
                                        const std::vector<InstanceShape>* shapes = nullptr);

// Reads the dataset's description and the records of its manifests (dataset_reader.h; plots are
// left out), each instance's skeleton.ply and first view (as its transforms.json lists it), and
// evaluates them. Throws InputError when the dataset is not one, a record is malformed or a listed
// file cannot be read.
std::vector<SpeciesGates> evaluateGates(const std::filesystem::path& datasetDir);

// The results as a Markdown table: one row per species, one column per gate (value, ✗ when it
// fails, – where it does not apply).
std::string gatesMarkdown(const std::vector<SpeciesGates>& species);

}  // namespace sylva
