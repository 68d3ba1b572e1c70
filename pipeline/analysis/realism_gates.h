// Issue 13's realism gates: what every species of the library (species/presets/) must show over
// its instances in a built dataset — nothing under the ground, botanical branch thickness and
// branching, variation between instances, leaves on wood, one stem, a straight leader, enough
// foliage. Read from the manifest's per-instance statistics (docs/metrics.md); the table of
// gates and each species' values is docs/metrics.md's "Realism gates" and the README's.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace sylva {

// One gate of one species: its measured value over the instances and whether it passes;
// `applies` is false where the gate does not hold for the species' habit or foliage.
struct GateResult {
    std::string gate;  // the gate's name (kGateNames)
    bool applies = true;
    bool pass = true;
    double value = 0;  // the measure (NaN when no instance defines it)
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

// Evaluates every species of the manifest records (objects with species, habit and stats),
// in the order species first appear.
std::vector<SpeciesGates> evaluateGates(const std::vector<nlohmann::json>& records);

// Reads the complete lines of DIR/manifest.jsonl and evaluates them. Throws InputError when
// the manifest is missing.
std::vector<SpeciesGates> evaluateGates(const std::filesystem::path& datasetDir);

// The results as a Markdown table: one row per species, one column per gate (value, ✗ when it
// fails, – where it does not apply).
std::string gatesMarkdown(const std::vector<SpeciesGates>& species);

}  // namespace sylva
