// Resume's reading of a manifest written by earlier runs, which may be damaged: a torn last
// line (a kill mid-append), or duplicate and interleaved records (two builds that once ran into
// one directory at the same time, before builds took a lock).
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace sylva {

struct ManifestRepair {
    std::vector<std::string> lines;  // the records kept, in job order
    std::vector<std::string> ids;    // their ids, in the same order
    size_t duplicates = 0;           // records of an id already recorded (dropped)
    size_t unreadable = 0;           // lines that are not a record, a torn last line included
    bool tornLast = false;           // the file ended in a partial line (a kill mid-append)
    bool reordered = false;          // records were out of job order
    bool rewritten = false;          // the file was replaced (atomically) by `lines`
};

// Reads `path` (a missing file: nothing recorded) and keeps the first complete record of each
// id, in job order (`position(id)`: its place in the shard's job list). When that is not the
// file as it is, the file is rewritten atomically. A record of an id that is not one of the
// shard's jobs (no position) is bad input: InputError naming the file and line.
ManifestRepair repairManifest(
    const std::filesystem::path& path,
    const std::function<std::optional<size_t>(const std::string& id)>& position);

}  // namespace sylva
