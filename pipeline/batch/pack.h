// Packed datasets ([outputs] pack = "tar"): instances in WebDataset tar shards, shard k holding
// the recorded instances at positions k·M … (k + 1)·M − 1 (M = pack_instances) in position
// order, so a shard's bytes depend on the spec alone — not on threads, --shard blocks (whole
// tar shards when packing) or resumed runs. An instance is staged first (its directory holding
// its files as one archive, kPackStageFile, with record.json) and packed when its tar shard is
// sealed. Layout and member names: docs/outputs.md "Packed datasets".
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "pipeline/batch/dataset.h"
#include "pipeline/formats/tar_pack.h"

namespace sylva {

// The largest pack_instances: a shard's index stays a few tens of MB.
constexpr int64_t kMaxPackInstances = 1'000'000;

// An instance's record without `timing`, staged in its directory and packed as "<id>.json".
inline constexpr char kPackRecordFile[] = "record.json";

// A packed build's instance waits for its shard as one archive in its directory: its files
// (record.json among them), each a member named by its path in the directory — one file to
// create, write and remove per instance where each output was one (28 for 8 views with depth and
// labels). What writers that take a path write (contact sheets, previews, scans, QSMs, VDB
// grids) stays beside it as files.
inline constexpr char kPackStageFile[] = "staged.tar";
// Writes `files` (path in the instance directory, bytes) as `dir`/staged.tar (temp + rename).
void writePackStage(const std::filesystem::path& dir,
                    const std::vector<std::pair<std::string, std::string>>& files);
// An instance directory's files as paths in it and bytes: the staged archive's members and the
// files beside it, by path (temp files of interrupted writes left out).
std::vector<std::pair<std::string, std::string>> readInstanceFiles(
    const std::filesystem::path& dir);

struct PackLayout {
    int64_t perShard = 0;  // M; 0: unpacked
    int64_t shards = 0;    // ⌈dataset size / M⌉
    int width = 6;         // digits of a shard's file name: at least 6, enough for the last
    bool packed() const { return perShard > 0; }
    int64_t shardOf(int64_t position) const { return position / perShard; }
    // "shards/000003.tar", and the file name alone.
    std::string tarPath(int64_t shard) const { return "shards/" + tarName(shard); }
    std::string tarName(int64_t shard) const;
};
PackLayout packLayout(int64_t datasetSize, int64_t perShard);

// A tar shard's member index: "shards/000003.tar" → "shards/000003.index.json".
std::filesystem::path packIndexPath(const std::filesystem::path& tar);

// The positions [lo, hi) build shard `index` of `count` covers: contiguous blocks of about
// equal size (shardRange, build.h) — of whole tar shards when `perShard` > 0.
std::pair<int64_t, int64_t> shardPositions(int64_t datasetSize, int index, int count,
                                           int64_t perShard);

// Whether `path`'s last element (after its last '/') ends in ".tar" after at least one other
// character: what std::filesystem::path(path).extension() == ".tar" says, without making a path.
bool hasTarExtension(std::string_view path);

// The member a file of an instance becomes: "<id>." + its path in the instance directory with
// "/" as "." ("views/000.png" → "<id>.views.000.png"); record.json becomes "<id>.json".
std::string packMemberName(std::string_view id, std::string_view relPath);

// A record of an instance to be packed into `tarPath`: "pack" set, and every string of its
// "files" under the instance directory `rel` renamed to its member name ("rel/views" →
// "<id>.views").
void packRecordFiles(nlohmann::json& record, const std::string& id, const std::string& rel,
                     const std::string& tarPath);

// Writes tar shard `shard` (temp + rename) with the instances at `positions` (recorded, sorted):
// each from its instance directory when it is on disk (then removed), else as the existing
// shard holds it; writes its index (shards/NNNNNN.index.json) after the tar. Throws
// ResourceError on a full disk, std::runtime_error on other I/O errors.
void sealPackShard(const std::filesystem::path& out, const DatasetInstances& instances,
                   const PackLayout& layout, int64_t shard, const std::vector<int64_t>& positions);

// The tar shards of [lo, hi) with instance directories on disk (a run's unsealed instances,
// or a killed run's), from listing trees/<species>/ and plots/<plot>/ of the species and
// plots with instances there.
std::vector<int64_t> unsealedPackShards(const std::filesystem::path& out,
                                        const DatasetInstances& instances, const PackLayout& layout,
                                        int64_t lo, int64_t hi);

// Removes what a killed run left of shard writes in [lo, hi) (shards/<name>.tmp.*), and the
// directories of instances of [lo, hi) that are on disk but not recorded (failed ones), so that
// they are not sealed.
void removeStalePackFiles(const std::filesystem::path& out, const DatasetInstances& instances,
                          const PackLayout& layout, int64_t lo, int64_t hi,
                          const std::function<bool(int64_t)>& recorded);

// shards/index<suffix>.json: the wids-shard-index-v1 list of the tar shards of [lo, hi) that
// exist, with their sample counts and sizes.
void writePackIndex(const std::filesystem::path& out, const std::string& datasetName,
                    const std::string& suffix, const PackLayout& layout, int64_t lo, int64_t hi);

// A tar shard's samples: from its index file when that matches the tar's size, else from the
// tar's headers (members grouped by the key before their first dot; positions −1).
struct PackSample {
    std::string key;
    int64_t position = -1;
    std::vector<TarMember> members;
};
std::vector<PackSample> readPackSamples(const std::filesystem::path& tar);

// Reads the files of a dataset's instances, packed or not, by the strings their records'
// "files" hold: a path under the dataset directory, or (a record with "pack") a member of that
// tar. Tar indexes are read once and kept. Thread-safe.
class DatasetFiles {
  public:
    explicit DatasetFiles(std::filesystem::path datasetDir) : dir_(std::move(datasetDir)) {}
    // The file's bytes, or nullopt when there is no such file or member: `file` is a path under
    // the dataset directory, or with `pack` ("shards/000003.tar", a record's "pack") a member.
    std::optional<std::string> read(const std::string& pack, const std::string& file);
    std::optional<std::string> read(const nlohmann::json& record, const std::string& file) {
        return read(record.value("pack", std::string()), file);
    }
    // The same for an instance's file by its path in the instance directory ("views/000.png"),
    // unpacked at `instanceDir` (relative to the dataset) or packed as `id` in `tarPath`.
    std::optional<std::string> readInstanceFile(const std::string& id, const std::string& tarPath,
                                                const std::string& instanceDir,
                                                const std::string& relPath);

  private:
    std::optional<std::string> member(const std::string& tarPath, const std::string& name);
    std::filesystem::path dir_;
    std::mutex mutex_;
    std::map<std::string, std::map<std::string, TarMember, std::less<>>> tars_;
};

}  // namespace sylva
