// Resume without a list of the dataset's instances: what a manifest records, as positions
// (InstanceSet), read line by line; and the temporaries a killed run left, found by listing what
// exists on disk rather than by walking the instance range.
#pragma once

#include <cstdint>
#include <filesystem>

#include "pipeline/batch/dataset.h"
#include "pipeline/batch/instance_set.h"

namespace sylva {

// The instances of `instances` that `manifest` records, by the "id" of each line. Lines are
// streamed (memory: one line and the set's runs, whatever the manifest's length); a line that
// is not a JSON object with an "id" of this dataset is ignored; a torn last line (a killed run's
// partial write) is truncated off the file, as AppendLog::readCompleteLines does. A missing file
// gives the empty set.
InstanceSet recordedInstances(const std::filesystem::path& manifest,
                              const DatasetInstances& instances);

// Whether the complete lines of `manifest` are records of instances of [lo, hi) in strictly
// increasing position (what a build appends), streamed; `last`: the highest position when they
// are. A manifest that is not (two builds at once before builds took a lock, or a kill while a
// rerun filled a gap) goes through repairManifest (manifest_repair.h) first.
struct ManifestOrder {
    bool inOrder = true;
    int64_t last = -1;
};
ManifestOrder scanManifestOrder(const std::filesystem::path& manifest,
                                const DatasetInstances& instances, int64_t lo, int64_t hi);

// Removes the "<file>.tmp.…" siblings a killed run left in the directories of the instances of
// [lo, hi) not in `recorded` (never another shard's instances: its process may be writing there
// now). Lists trees/<species>/ of each species with instances in [lo, hi): the cost follows what
// is on disk, not the size of the range.
void removeStaleTemporaries(const std::filesystem::path& out, const DatasetInstances& instances,
                            const InstanceSet& recorded, int64_t lo, int64_t hi);

}  // namespace sylva
