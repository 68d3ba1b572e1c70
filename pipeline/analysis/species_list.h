// @brief `sylva species list`: every species file under a directory, with its method and
// description, checked the way `sylva validate` checks it.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace sylva {

// One species file found by listSpecies.
struct SpeciesListEntry {
    std::string name;         // the species' `name` (the file stem when it did not load)
    std::string method;       // `method` ("" when it did not load)
    std::string description;  // `description` ("" when absent or it did not load)
    std::string path;         // the file, as found under the listed directory
    std::string error;        // "" when the species loaded and validated; else the one-line error
};

// Every *.toml under `dir`, recursively, that is not a dataset file (one with [[species]]).
// Each is loaded and validated (all keys and values checked, volumes built, as `sylva
// validate` does), in parallel; a file that fails is listed with its one-line error instead
// of its method and description. The library first, then the papers' reproductions (files
// in a `papers/` folder below `dir`), each sorted by name, then path. Throws InputError when
// `dir` is not a directory.
std::vector<SpeciesListEntry> listSpecies(const std::filesystem::path& dir);

// The entries as text, one line each: name, method, description, path in columns padded to
// the widest value (the last column unpadded); a failed file shows "-" as its method and
// "error: <message>" as its description, which does not widen that column.
std::string formatSpeciesList(const std::vector<SpeciesListEntry>& entries);

// The default directory of `sylva species list`: the first `species/` directory holding a
// `presets/` folder found walking up from the executable's directory (so build/sylva finds
// the source tree's species/), then from the current directory. nullopt when neither has one.
std::optional<std::filesystem::path> defaultSpeciesDir(const std::filesystem::path& executable);

}  // namespace sylva
