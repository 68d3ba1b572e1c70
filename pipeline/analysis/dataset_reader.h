// What the commands that read a built dataset (stats, gates, report, merge) take from it: the
// manifest records and the dataset description, read once here and checked before any command
// uses a field. A record or description of the wrong shape is bad input (InputError, exit 2) with
// one line naming the file and line; nothing a dataset holds is trusted to be what its name says
// (a record's id and species become directory names, its files paths under the dataset).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pipeline/batch/build.h"

namespace sylva {

// kMaxManifestLineBytes and kMaxDatasetJsonBytes: pipeline/batch/build.h.
inline constexpr int kMaxRecordDepth = 32;  // nesting of arrays and objects in one record

// One manifest line, checked: a JSON object, at most kMaxRecordDepth deep, with
//   id       a string usable as one directory name (not empty, ".", ".." or with '/', '\', NUL
//            or control characters);
//   index    an integer ≥ 0;
//   species  (a tree) or plot (a plot): a string usable as one directory name;
// and, where present: habit, method a string; seed a string or an integer ≥ 0; sweep, params,
// stats, timing, scan an object; files an object of strings, each a relative path inside the
// dataset (no "..", not absolute); bytes_written an integer ≥ 0.
struct ManifestRecord {
    nlohmann::json json;
    std::string id;
    std::string group;  // the species, or the plot's name
    bool plot = false;
    int64_t index = 0;
    std::string pack;   // a packed instance's tar ("shards/000003.tar"); "" unpacked
    std::string where;  // "manifest.jsonl:12", for messages
};

// Whether `path` is relative and stays inside the directory it is relative to (no "..", no
// root, no NUL or backslash): how a dataset's files name each other.
bool isPathInside(const std::string& path);

// Parses and checks one line; InputError "WHERE: …" naming the first thing wrong.
ManifestRecord parseManifestRecord(const std::string& line, const std::string& where);

// The manifests of a dataset directory in record order: manifest.jsonl, then every shard's
// manifest.shard-I-of-N.jsonl by (N, I). Empty when there is none.
std::vector<std::filesystem::path> manifestFiles(const std::filesystem::path& dir);

struct ManifestRead {
    std::vector<ManifestRecord> records;  // file order; an id seen before is left out
    std::vector<std::string> files;       // the manifests read, by file name
    size_t tornLines = 0;                 // last lines without '\n' (a build killed or writing)
    size_t duplicates = 0;                // records of an id already read from another file
};

// Every complete record of every manifest of `dir` (regular files, lines of at most
// kMaxManifestLineBytes). InputError when there is no manifest or a complete line is not a
// record; a torn last line is counted, not an error.
ManifestRead readManifests(const std::filesystem::path& dir);

// The same records one at a time, for readers whose memory must not grow with the manifests'
// length (`sylva stats`): `f` sees each checked record in file order. Shard manifests are
// disjoint; only where a whole manifest lies beside them (a merge done in place) are the ids
// kept, to see each record once.
struct ManifestStream {
    std::vector<std::string> files;  // the manifests read, by file name
    size_t tornLines = 0;
    size_t records = 0;
};
ManifestStream forEachManifestRecord(const std::filesystem::path& dir,
                                     const std::function<void(ManifestRecord&)>& f);

// The dataset's description: dataset.json, or where shards were built into one directory,
// every dataset.shard-I-of-N.json (the first by (N, I) returned, the others checked). A regular
// file of at most kMaxDatasetJsonBytes holding a JSON object with a string name; where present,
// description and status strings, seed an integer or string, counts an object of integers ≥ 0,
// species an array of objects with a string name, shard an object with integers index ≥ 0 and
// count ≥ 1, versions and spec objects. InputError otherwise, or when there is none ("not a
// dataset directory").
nlohmann::json readDatasetDescription(const std::filesystem::path& dir);

// The same checks on a description already named (merge reads each shard's).
nlohmann::json readDatasetJsonFile(const std::filesystem::path& file);

}  // namespace sylva
