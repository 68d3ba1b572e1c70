#include "pipeline/batch/build.h"

#include <OpenImageIO/oiioversion.h>
#include <fcntl.h>
#include <malloc.h>
#include <openvdb/version.h>
#include <tbb/flow_graph.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/version.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>
#include <tuple>
#include <unordered_map>

#include "core/atomic_file.h"
#include "core/input_file.h"
#include "pipeline/batch/instance.h"
#include "pipeline/batch/manifest_repair.h"
#include "pipeline/batch/output_lock.h"
#include "pipeline/batch/pack.h"
#include "pipeline/batch/progress.h"
#include "pipeline/batch/resume.h"
#include "pipeline/batch/run_log.h"
#include "pipeline/formats/view_writers.h"
#include "volumes/oiio_module.h"
#include "volumes/vdb_module.h"
#include "volumes/versions.h"

namespace sylva {

namespace fs = std::filesystem;

std::pair<size_t, size_t> shardRange(size_t jobs, int index, int count) {
    // In 128 bits: jobs (≤ kMaxInstances) × index (< 2³¹) overflows 64.
    using Wide = unsigned __int128;
    const auto lo =
        static_cast<size_t>(Wide{jobs} * static_cast<Wide>(index) / static_cast<Wide>(count));
    const auto hi =
        static_cast<size_t>(Wide{jobs} * static_cast<Wide>(index + 1) / static_cast<Wide>(count));
    return {lo, hi};
}

std::string shardSuffix(int index, int count) {
    if (count <= 1) return "";
    int width = static_cast<int>(std::to_string(count).size());
    char buf[64];
    std::snprintf(buf, sizeof buf, ".shard-%0*d-of-%d", width, index, count);
    return buf;
}

std::optional<ShardOf> parseShardFileName(std::string_view name, std::string_view stem,
                                          std::string_view ext) {
    const std::string_view mark = ".shard-", of = "-of-";
    if (name.size() < stem.size() + mark.size() + ext.size() ||
        name.substr(0, stem.size()) != stem || name.substr(stem.size(), mark.size()) != mark ||
        name.substr(name.size() - ext.size()) != ext) {
        return std::nullopt;
    }
    std::string_view rest = name.substr(stem.size() + mark.size());
    rest.remove_suffix(ext.size());
    // A decimal number of at most 10 digits (2³¹ − 1 has 10) at the front of `rest`, consumed.
    auto number = [&rest](int64_t& v) {
        size_t n = 0;
        v = 0;
        while (n < rest.size() && rest[n] >= '0' && rest[n] <= '9') {
            if (++n > 10) return false;
            v = v * 10 + (rest[n - 1] - '0');
        }
        rest.remove_prefix(n);
        return n > 0;
    };
    int64_t index = 0, count = 0;
    if (!number(index) || rest.substr(0, of.size()) != of) return std::nullopt;
    rest.remove_prefix(of.size());
    if (!number(count) || !rest.empty()) return std::nullopt;
    if (index >= count || count > std::numeric_limits<int>::max()) return std::nullopt;
    return ShardOf{static_cast<int>(index), static_cast<int>(count)};
}

std::string manifestName(int index, int count) {
    return "manifest" + shardSuffix(index, count) + ".jsonl";
}
std::string datasetJsonName(int index, int count) {
    return "dataset" + shardSuffix(index, count) + ".json";
}

nlohmann::json versionInfo() {
    nlohmann::json v;
    v["sylva"] = SYLVA_VERSION;
    v["onetbb"] = std::to_string(TBB_VERSION_MAJOR) + "." + std::to_string(TBB_VERSION_MINOR);
    v["openvdb"] = OPENVDB_LIBRARY_VERSION_STRING;
    v["openimageio"] = OIIO_VERSION_STRING;
    v["cgal"] = cgalVersion();
    v["tomlplusplus"] = std::to_string(TOML_LIB_MAJOR) + "." + std::to_string(TOML_LIB_MINOR) +
                        "." + std::to_string(TOML_LIB_PATCH);
    return v;
}

static nlohmann::json tomlToJson(const toml::table& t) {
    std::ostringstream s;
    s << toml::json_formatter{t};
    return nlohmann::json::parse(s.str());
}

namespace {

// Seconds between the progress lines of one long instance (a plot's growth or scan), and before
// the first. Tests only: SYLVA_TEST_PROGRESS_EVERY=<seconds> shortens it, so that a test sees
// the lines of a small plot.
double instanceProgressEvery() {
    const char* e = std::getenv("SYLVA_TEST_PROGRESS_EVERY");
    return e ? std::max(0.0, std::atof(e)) : 10.0;
}

// Tests only: SYLVA_TEST_PAUSE_AT="<n>:<file>" holds the build (its lock taken) once it has
// recorded n instances in this run (0: right after taking the lock) until <file> exists, at
// most 10 minutes, so that a CLI test can act while a build is certainly running without
// depending on how fast the machine is.
struct TestPause {
    int64_t at = -1;
    fs::path release;
    TestPause() {
        const char* e = std::getenv("SYLVA_TEST_PAUSE_AT");
        if (!e) return;
        const char* colon = std::strchr(e, ':');
        if (!colon) return;
        at = std::atoll(e);
        release = colon + 1;
    }
    void reached(int64_t recorded) const {
        if (recorded != at) return;
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(10);
        std::error_code ec;
        while (!fs::exists(release, ec) && std::chrono::steady_clock::now() < deadline) {
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
    }
};

struct Message {
    size_t seq = 0;  // position among the jobs run now (sequencer order)
    std::shared_ptr<InstanceWork> work;
    bool discarded = false;  // dropped unfinished: the build is stopping (resource exhausted)
};

// The first resource that ran out (core/errors.h ResourceError, or std::bad_alloc): from then
// on the build takes no new instance, drops the unfinished ones and records nothing more.
struct StopState {
    std::atomic<bool> requested{false};
    std::mutex mutex;
    std::string reason;  // "disk full while writing <path>"
    int error = 0;       // its errno

    void note(int err, const std::string& why) {
        std::lock_guard<std::mutex> lock(mutex);
        if (reason.empty()) {
            reason = why;
            error = err;
        }
        requested = true;
    }
    void note(const ResourceError& e) {
        note(e.error(), e.whatRanOut() + " while writing " + e.path());
    }
};

// What to do about a resource that ran out, for the stop line.
std::string stopAdvice(int error) {
    switch (error) {
        case ENOSPC:
            return "free space and rerun to resume";
        case EDQUOT:
            return "free space (or raise the quota) and rerun to resume";
        case EFBIG:
            return "raise the file size limit (ulimit -f) and rerun to resume";
        case EIO:
            return "rerun to resume";
        default:
            return "free memory (or use fewer --threads) and rerun to resume";
    }
}

// A stage as a flow-graph body: runs `stage` unless an earlier one failed or the build is
// stopping; a resource that runs out stops the build instead of failing the instance.
template <class F>
auto stageBody(F stage, StopState& stop) {
    return [stage, &stop](Message m) {
        if (!m.work->error.empty() || m.discarded) return m;
        if (stop.requested) {
            m.discarded = true;
            return m;
        }
        try {
            stage(*m.work);
        } catch (const ResourceError& e) {
            m.discarded = true;
            stop.note(e);
        } catch (const std::bad_alloc&) {
            m.discarded = true;
            stop.note(ENOMEM, "out of memory while building " + m.work->job.id);
        } catch (const std::exception& e) {
            m.work->error = e.what();
        }
        return m;
    };
}

// Tar shards sealed one after another on a thread of their own, in the order queued: the work
// is mostly I/O, so it overlaps the flow graph without taking one of its threads (and with
// --threads 1 a TBB task could not run before the graph is done). The destructor waits for
// the queue to empty.
class Sealer {
  public:
    explicit Sealer(std::function<void(int64_t)> seal) : seal_(std::move(seal)) {
        thread_ = std::thread([this] { run(); });
    }
    ~Sealer() {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            closed_ = true;
        }
        wake_.notify_one();
        thread_.join();
    }
    void push(int64_t shard) {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            queue_.push_back(shard);
        }
        wake_.notify_one();
    }

  private:
    void run() {
        for (;;) {
            int64_t shard = 0;
            {
                std::unique_lock<std::mutex> lock(mutex_);
                wake_.wait(lock, [this] { return closed_ || !queue_.empty(); });
                if (queue_.empty()) return;
                shard = queue_.front();
                queue_.pop_front();
            }
            seal_(shard);  // catches what it throws (noted as the build's stop)
        }
    }
    std::function<void(int64_t)> seal_;
    std::mutex mutex_;
    std::condition_variable wake_;
    std::deque<int64_t> queue_;
    bool closed_ = false;
    std::thread thread_;
};

// Per species, a sheet of the first views of its first K recorded instances
// (contact/<species>.png; contact/<species>.shard-I-of-N.png for a shard, whose instances are
// only a block of the dataset's).
void writeSpeciesSheets(const DatasetSpec& spec, const DatasetInstances& instances,
                        const InstanceSet& recorded, int64_t lo, int64_t hi, const fs::path& out,
                        const std::string& suffix, const PackLayout& pack) {
    const int k = spec.outputs.speciesSheet;
    if (k <= 0 || spec.outputs.views.count <= 0) return;
    DatasetFiles files(out);
    for (size_t s = 0; s < spec.species.size(); ++s) {
        const auto [begin, end] = instances.speciesRange(s);
        const int64_t stop = std::min(hi, end);
        std::vector<InstanceFileReader> views;
        for (int64_t i = recorded.nextPresent(std::max(lo, begin), stop); i < stop;
             i = recorded.nextPresent(i + 1, stop)) {
            const InstanceJob job = instances[i];
            InstanceFileReader read = [&files, id = job.id, dir = instanceDir(job).string(),
                                       tar = pack.packed() ? pack.tarPath(pack.shardOf(i))
                                                           : std::string()](const std::string& f) {
                return files.readInstanceFile(id, tar, dir, f);
            };
            if (read("views/000.png")) views.push_back(std::move(read));
            if (static_cast<int>(views.size()) >= k) break;
        }
        if (views.empty()) continue;
        writeSpeciesSheet(out / "contact" / (spec.species[s].species.name + suffix + ".png"),
                          views);
    }
}

// dataset.json describes the dataset, the same bytes however many runs, threads or machines
// made it: what is recorded (`built`: instances in the manifest) and what is not (`missing`).
// What differs per run goes into the run log (run_log.h).
void writeDatasetJson(const DatasetSpec& spec, const BuildOptions& o, const fs::path& file,
                      const std::string& status, int64_t inShard, int64_t recorded,
                      size_t allJobs) {
    nlohmann::json d;
    d["name"] = spec.name;
    d["description"] = spec.description;
    d["seed"] = spec.seed;
    d["fingerprint"] = spec.fingerprint;
    d["status"] = status;
    d["spec"] = tomlToJson(*spec.table);
    nlohmann::json sp = nlohmann::json::array();
    for (const auto& e : spec.species) {
        nlohmann::json j;
        j["name"] = e.species.name;
        j["file"] = e.species.path;
        j["method"] = e.species.method;
        j["description"] = e.species.description;
        if (!e.species.habit.empty()) j["habit"] = e.species.habit;
        j["count"] = e.count;
        j["sweep_points"] = e.points.size();
        j["spec"] = tomlToJson(*e.species.table);
        sp.push_back(j);
    }
    d["species"] = sp;
    if (!spec.plots.empty()) {
        nlohmann::json plots = nlohmann::json::array();
        for (const PlotSpec& p : spec.plots) {
            nlohmann::json j;
            j["name"] = p.name;
            if (!p.sweptFrom.empty()) {
                j["swept_from"] = p.sweptFrom;
                j["sweep"] = p.sweep;
            }
            j["count"] = p.count;
            j["area_m2"] = p.area.area();
            nlohmann::json mix = nlohmann::json::array();
            for (const PlotSpecies& s : p.species) {
                mix.push_back({{"name", s.species.name},
                               {"file", s.species.path},
                               {"layer", s.understory ? "understory" : "canopy"}});
            }
            j["species"] = mix;
            plots.push_back(j);
        }
        d["plots"] = plots;
    }
    d["versions"] = versionInfo();
    d["shard"] = {{"index", o.shardIndex}, {"count", o.shardCount}};
    d["counts"] = {{"instances_in_dataset", allJobs},
                   {"instances_in_shard", inShard},
                   {"built", recorded},
                   {"missing", inShard - recorded}};
    writeFileAtomic(file, d.dump(2) + "\n");
}

// Removes the temp siblings ("<file>.tmp.<pid>.…") of the shard's own top-level files that a
// killed run left (those in the instance directories: removeStaleTemporaries, resume.h). Under
// the shard's lock no other process writes there, so every such file is stale.
void removeStaleOwnTempFiles(const fs::path& out, const std::vector<std::string>& ownFiles) {
    std::error_code ec;
    for (const std::string& f : ownFiles) {
        const fs::path target = out / f;
        std::vector<fs::path> stale;
        for (fs::directory_iterator it(target.parent_path(), ec), end; !ec && it != end;
             it.increment(ec)) {
            const std::string name = it->path().filename().string();
            if (name.rfind(target.filename().string() + ".tmp.", 0) == 0) {
                stale.push_back(it->path());
            }
        }
        for (const fs::path& p : stale) fs::remove(p, ec);
    }
}

// Room for the last writes of a run that a full disk stops (dataset.json and the run log, both
// rewritten through a temp file): a file allocated when the run starts and deleted to give its
// space back. Best effort: without room for it the run goes on without.
class SpaceReserve {
  public:
    SpaceReserve(const fs::path& file, off_t bytes) : file_(file) {
        ::unlink(file_.c_str());  // a killed run's
        const int fd = ::open(file_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0) return;
        const bool ok = ::posix_fallocate(fd, 0, bytes) == 0;
        ::close(fd);
        if (!ok) ::unlink(file_.c_str());
        unlinkOnSignal(file_);
    }
    ~SpaceReserve() { release(); }
    void release() {
        ::unlink(file_.c_str());
        keepOnSignal(file_);
    }

  private:
    fs::path file_;
};

// The largest dataset.json a rerun reads back (it is a few kB).

// A directory holds builds of one sharding: the unsharded build, or shards of one count. A shard
// built beside the unsharded build (or a shard of another count) would grow its instances again
// under other file names, as docs/cluster.md warns; refused before anything is read or written.
void checkNoOtherSharding(const BuildOptions& o) {
    const bool sharded = o.shardCount > 1;
    std::map<std::string, std::string> others;  // file name → the build it belongs to (sorted)
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(o.out, ec)) {
        const std::string name = e.path().filename().string();
        if (name == "dataset.json" || name == "manifest.jsonl") {
            if (sharded) others[name] = "the unsharded build";
            continue;
        }
        std::optional<ShardOf> shard = parseShardFileName(name, "dataset", ".json");
        if (!shard) shard = parseShardFileName(name, "manifest", ".jsonl");
        if (shard && (!sharded || shard->count != o.shardCount)) {
            others[name] = "shards of " + std::to_string(shard->count);
        }
    }
    if (others.empty()) return;
    const auto& [name, other] = *others.begin();
    throw InputError(
        "--out " + o.out.string() + ": holds " + other + " (" + name + "); build " +
        (sharded ? "shard " + std::to_string(o.shardIndex) + "/" + std::to_string(o.shardCount)
                 : std::string("the unsharded dataset")) +
        " into another directory");
}

// The shard's own files that a rerun reads back (manifest, description, run log) are regular
// files where they exist: a FIFO in their place would block the build forever, a directory or
// device would fail it with a library's message.
void checkOwnFilesAreRegular(const BuildOptions& o) {
    for (const std::string& name :
         {manifestName(o.shardIndex, o.shardCount), datasetJsonName(o.shardIndex, o.shardCount),
          runLogName(o.shardIndex, o.shardCount)}) {
        std::error_code ec;
        const fs::file_status st = fs::status(o.out / name, ec);
        if (ec || !fs::exists(st) || fs::is_regular_file(st)) continue;
        throw InputError("--out " + o.out.string() + ": " + name +
                         " is not a regular file (a build reads it back and appends to it)");
    }
}

// What the steps of a build share, so that a stop anywhere can still be reported.
struct BuildState {
    BuildSummary summary;
    int64_t failed = 0;
    StopState stop;
    nlohmann::json run;  // this run's line in the run log
    bool runStarted = false;
    int64_t recorded() const { return summary.skipped + summary.built; }
};

// The build of one shard into its locked directory; a ResourceError anywhere (or one noted by
// a stage) leaves st.stop set for buildDataset to report.
void buildShard(const DatasetSpec& spec, const BuildOptions& o, const DatasetInstances& instances,
                int64_t lo, int64_t hi, int threads, RunLog& runs, BuildState& st) {
    BuildSummary& summary = st.summary;
    StopState& stop = st.stop;
    int64_t& failed = st.failed;
    nlohmann::json& run = st.run;
    const fs::path manifestPath = o.out / manifestName(o.shardIndex, o.shardCount);
    const fs::path datasetPath = o.out / datasetJsonName(o.shardIndex, o.shardCount);
    const std::string suffix = shardSuffix(o.shardIndex, o.shardCount);
    auto recorded = [&] { return st.recorded(); };
    checkNoOtherSharding(o);
    if (fs::exists(datasetPath)) {
        auto old = nlohmann::json::parse(
            readInputFile(datasetPath, kMaxDatasetJsonBytes, "a dataset description"), nullptr,
            false);
        if (!old.is_discarded() && old.value("fingerprint", "") != spec.fingerprint) {
            throw SpecError(SourcePos{spec.path, 0, 0}, "",
                            "output directory " + o.out.string() +
                                " holds a build of a different spec (fingerprint " +
                                old.value("fingerprint", "?") + " ≠ " + spec.fingerprint +
                                "); use another --out");
        }
    }
    // Resume: the instances already recorded, streamed from the manifest into runs of
    // positions (nothing held per instance). A manifest that is not a list of this shard's
    // records in job order — duplicate or out-of-order records (two builds at once, before
    // builds took a lock), or a kill while a rerun filled a gap — is repaired first: the first
    // complete record of each id, in job order (held in memory, once).
    auto positionOf = [&](const std::string& id) -> std::optional<size_t> {
        const std::optional<int64_t> p = instances.find(id);
        if (!p || *p < lo || *p >= hi) return std::nullopt;
        return static_cast<size_t>(*p - lo);
    };
    ManifestOrder scanned = scanManifestOrder(manifestPath, instances, lo, hi);
    if (!scanned.inOrder) {
        const ManifestRepair repair = repairManifest(manifestPath, positionOf);
        std::fprintf(stderr,
                     "sylva: build: repaired %s: %zu records kept, %zu duplicates and %zu "
                     "unreadable lines dropped%s\n",
                     manifestPath.string().c_str(), repair.ids.size(), repair.duplicates,
                     repair.unreadable, repair.reordered ? ", put back in job order" : "");
        scanned.last =
            repair.ids.empty() ? -1 : lo + static_cast<int64_t>(*positionOf(repair.ids.back()));
    }
    // Records appended now land after the recorded ones: out of job order when an earlier
    // run left a gap (a failed instance) that this run fills.
    const int64_t lastRecorded = scanned.last;
    bool fillsAGap = false;
    InstanceSet done = recordedInstances(manifestPath, instances);  // (cuts a torn last line)
    std::mutex doneMutex;  // the source reads `done` while the recorder adds to it
    summary.skipped = done.countIn(lo, hi);
    removeStaleTemporaries(o.out, instances, done, lo, hi);
    const PackLayout pack = packLayout(instances.size(), spec.outputs.packInstances);
    if (pack.packed()) {
        removeStalePackFiles(o.out, instances, pack, lo, hi,
                             [&done](int64_t p) { return done.contains(p); });
    }
    std::vector<std::string> ownFiles = {manifestName(o.shardIndex, o.shardCount),
                                         datasetJsonName(o.shardIndex, o.shardCount),
                                         runLogName(o.shardIndex, o.shardCount)};
    for (const SpeciesEntry& e : spec.species) {
        ownFiles.push_back("contact/" + e.species.name + suffix + ".png");
    }
    if (pack.packed()) ownFiles.push_back("shards/index" + suffix + ".json");
    removeStaleOwnTempFiles(o.out, ownFiles);

    run["shard"] = {{"index", o.shardIndex}, {"count", o.shardCount}};
    run["threads"] = threads;
    run["status"] = "running";
    run["instances_in_shard"] = summary.total;
    run["already_built"] = summary.skipped;
    runs.start(run, summary.skipped);
    st.runStarted = true;
    writeDatasetJson(spec, o, datasetPath, "running", summary.total, recorded(),
                     static_cast<size_t>(instances.size()));

    AppendLog manifest(manifestPath);
    Progress progress(summary.total - summary.skipped, o.progress);
    const int64_t abortAfter = [] {
        const char* e = std::getenv("SYLVA_TEST_ABORT_AFTER");  // tests: simulate a kill
        return e ? std::atoll(e) : -1;
    }();
    const TestPause pause;
    const double progressEvery = instanceProgressEvery();

    // [outputs] pack: a tar shard is sealed (written, its instance directories removed) in the
    // background once every instance of it this run builds has finished, whatever the result.
    const InstanceSet doneBefore = done;
    std::map<int64_t, int64_t> unfinished;  // tar shard → its instances this run has yet to finish
    std::optional<Sealer> sealing;
    auto seal = [&](int64_t k) {
        std::vector<int64_t> positions;
        const int64_t a = std::max(k * pack.perShard, lo),
                      b = std::min((k + 1) * pack.perShard, hi);
        {
            std::lock_guard<std::mutex> hold(doneMutex);
            for (int64_t p = done.nextPresent(a, b); p < b; p = done.nextPresent(p + 1, b)) {
                positions.push_back(p);
            }
        }
        try {
            sealPackShard(o.out, instances, pack, k, positions);
        } catch (const ResourceError& e) {
            stop.note(e);
        } catch (const std::bad_alloc&) {
            stop.note(ENOMEM, "out of memory while writing " + pack.tarPath(k));
        } catch (const std::exception& e) {
            stop.note(EIO, std::string(e.what()) + " (writing " + pack.tarPath(k) + ")");
        }
    };
    auto finished = [&](int64_t position) {
        if (!pack.packed()) return;
        const int64_t k = pack.shardOf(position);
        auto it = unfinished.find(k);
        if (it == unfinished.end()) {
            const int64_t a = std::max(k * pack.perShard, lo);
            const int64_t b = std::min((k + 1) * pack.perShard, hi);
            it = unfinished.emplace(k, (b - a) - doneBefore.countIn(a, b)).first;
        }
        if (--it->second > 0) return;
        unfinished.erase(it);
        if (!sealing) sealing.emplace(seal);
        sealing->push(k);
    };

    // Two phases, in job order: the trees of the species, many in flight; then the plots, one
    // at a time — a plot holds hundreds of trees and grows, meshes and renders them in parallel
    // itself, so memory stays that of one plot whatever the dataset's number of plots.
    bool recording = true;             // until the first instance dropped by a stop, in job order
    std::vector<InstanceJob> dropped;  // at most the instances in flight
    const int64_t plotStart = instances.plotStart();
    const size_t treesInFlight =
        o.maxInFlight > 0 ? o.maxInFlight : 4 * static_cast<size_t>(threads);
    for (const auto& [from, to, inFlight] :
         {std::tuple<int64_t, int64_t, size_t>{lo, std::min(hi, plotStart), treesInFlight},
          std::tuple<int64_t, int64_t, size_t>{std::max(lo, plotStart), hi, 1}}) {
        if (from >= to || stop.requested) continue;
        using namespace tbb::flow;
        graph g;
        int64_t next = from;  // the next position to consider
        const int64_t end = to;
        size_t seq = 0;
        input_node<Message> source(g, [&](tbb::flow_control& fc) -> Message {
            if (!stop.requested) {
                std::lock_guard<std::mutex> hold(doneMutex);
                next = done.nextMissing(next, end);  // skip what is recorded, a run at a time
            }
            if (next >= end || stop.requested) {
                fc.stop();
                return {};
            }
            Message m;
            m.seq = seq++;
            m.work = std::make_shared<InstanceWork>();
            m.work->job = instances[next++];
            if (pack.packed()) m.work->packTar = pack.tarPath(pack.shardOf(m.work->job.position));
            if (o.progress && m.work->job.plot) {
                m.work->progress.emplace(m.work->job.id, progressEvery);
            }
            return m;
        });
        limiter_node<Message> limiter(g, inFlight);
        function_node<Message, Message> grow(
            g, unlimited, stageBody([](InstanceWork& w) { growStage(w); }, stop));
        function_node<Message, Message> mesh(
            g, unlimited,
            stageBody([&](InstanceWork& w) { meshStage(w, spec.outputs, o.out); }, stop));
        function_node<Message, Message> render(g, unlimited,
                                               stageBody(
                                                   [&](InstanceWork& w) {
                                                       renderStage(w, spec.outputs);
                                                       scanStage(w, spec.outputs, o.out);
                                                   },
                                                   stop));
        function_node<Message, Message> write(g, unlimited, [&](Message m) {
            m = stageBody([&](InstanceWork& w) { writeStage(w, spec.outputs, o.out); }, stop)(m);
            // Free the heavy parts before the message waits in the sequencer.
            InstanceWork& w = *m.work;
            w.grown = GrownTree{};
            w.mesh = TreeMesh{};
            w.watertight = Mesh{};
            w.views.clear();
            w.plot.reset();
            return m;
        });
        sequencer_node<Message> order(g, [](const Message& m) { return m.seq; });
        function_node<Message, continue_msg> record(g, serial, [&](const Message& m) {
            const InstanceWork& w = *m.work;
            if (!recording || m.discarded) {
                recording = false;  // the manifest stays a prefix of the job order
                dropped.push_back(w.job);
                return continue_msg();
            }
            if (w.error.empty()) {
                try {
                    manifest.append(w.record.dump());
                } catch (const ResourceError& e) {
                    stop.note(e);
                    recording = false;
                    dropped.push_back(w.job);
                    return continue_msg();
                }
                {
                    std::lock_guard<std::mutex> hold(doneMutex);
                    done.insert(w.job.position);
                }
                if (w.job.position < lastRecorded) fillsAGap = true;
                ++summary.built;
                finished(w.job.position);
                if (abortAfter >= 0 && summary.built >= abortAfter) std::_Exit(137);
                pause.reached(summary.built);
            } else {
                ++failed;
                finished(w.job.position);
                if (summary.failedIds.size() < BuildSummary::kMaxFailedIds) {
                    summary.failedIds.push_back(w.job.id);
                }
                std::fprintf(stderr, "%ssylva: %s: %s\n", isatty(2) ? "\r\033[K" : "",
                             w.job.id.c_str(), w.error.c_str());
            }
            progress.tick(summary.built + failed, failed);
            return continue_msg();
        });
        make_edge(source, limiter);
        make_edge(limiter, grow);
        make_edge(grow, mesh);
        make_edge(mesh, render);
        make_edge(render, write);
        make_edge(write, order);
        make_edge(order, record);
        make_edge(record, limiter.decrementer());
        source.activate();
        g.wait_for_all();
    }

    sealing.reset();  // every shard queued is sealed
    if (pack.packed() && !stop.requested) {
        // Failed instances' directories go; shards left unsealed (a killed run's) are sealed.
        removeStalePackFiles(o.out, instances, pack, lo, hi,
                             [&done](int64_t p) { return done.contains(p); });
        for (const int64_t k : unsealedPackShards(o.out, instances, pack, lo, hi)) seal(k);
        if (!stop.requested) writePackIndex(o.out, spec.name, suffix, pack, lo, hi);
        // The emptied trees/<species>/ and plots/<plot>/ directories go too — unsharded only:
        // another shard sharing the directory may be about to write into one.
        if (o.shardCount == 1 && !stop.requested) {
            std::error_code ec;
            for (const SpeciesEntry& e : spec.species)
                fs::remove(o.out / "trees" / e.species.name, ec);
            for (const PlotSpec& p : spec.plots) fs::remove(o.out / "plots" / p.name, ec);
            fs::remove(o.out / "trees", ec);
            fs::remove(o.out / "plots", ec);
        }
    }
    if (stop.requested) {
        // What the dropped instances wrote is not part of the dataset (a rerun makes them
        // again): removed, which also gives back the space dataset.json and the run log need.
        std::error_code ec;
        for (const InstanceJob& j : dropped) fs::remove_all(o.out / instanceDir(j), ec);
    } else {
        if (fillsAGap) repairManifest(manifestPath, positionOf);  // back in job order
        writeSpeciesSheets(spec, instances, done, lo, hi, o.out, suffix, pack);
        progress.finish(summary.built + failed, failed);
    }
}

}  // namespace

BuildSummary buildDataset(const DatasetSpec& spec, const BuildOptions& o) {
    auto start = std::chrono::steady_clock::now();
    // Every instance allocates and frees blocks of a few hundred KiB within milliseconds
    // (z-buffers, encoders' scratch, mesh buffers). Above glibc's default threshold those are
    // mmap'd and unmapped each time, a page fault per 4 KiB on every use; kept on the heap
    // they are reused (the process keeps at most the trim threshold idle).
    static std::once_flag heapTuned;
    std::call_once(heapTuned, [] {
        mallopt(M_MMAP_THRESHOLD, 64 << 20);
        mallopt(M_TRIM_THRESHOLD, 256 << 20);
    });
    const int threads = o.threads > 0 ? o.threads : tbb::info::default_concurrency();
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);

    // Instances are computed from their position as the source reaches them: nothing here is
    // sized by the dataset's count (resume holds runs of recorded positions, InstanceSet).
    const DatasetInstances instances(spec);
    // Contiguous blocks of the instance order; of whole tar shards when packing.
    const auto [lo, hi] =
        shardPositions(instances.size(), o.shardIndex, o.shardCount, spec.outputs.packInstances);

    // The modules these outputs need, opened before anything is written: without one the build
    // is one line, not a failure per tree.
    if (spec.outputs.watertight) vdbModule();
    if (spec.outputs.colour.enabled && spec.outputs.colour.jpeg) oiioModule();

    // --out: checked before anything is written and created only once every check passed;
    // then this shard of it is locked for the whole build (another build, merge, stats or
    // report there gets one line naming the holder).
    checkOutputDir(o.out, "--out");
    createOutputDir(o.out, "--out");
    const std::string command =
        "sylva build" + (o.shardCount > 1 ? " --shard " + std::to_string(o.shardIndex) + "/" +
                                                std::to_string(o.shardCount)
                                          : std::string());
    OutputLock lock(o.out, command, o.shardIndex, o.shardCount);
    TestPause().reached(0);
    checkOwnFilesAreRegular(o);
    const fs::path datasetPath = o.out / datasetJsonName(o.shardIndex, o.shardCount);
    RunLog runs(o.out / runLogName(o.shardIndex, o.shardCount));
    SpaceReserve reserve(o.out / (".sylva" + shardSuffix(o.shardIndex, o.shardCount) + ".reserve"),
                         off_t{1} << 20);

    BuildState st;
    BuildSummary& summary = st.summary;
    summary.total = static_cast<int64_t>(hi - lo);
    st.run = runLine("build");
    try {
        buildShard(spec, o, instances, lo, hi, threads, runs, st);
    } catch (const ResourceError& e) {
        st.stop.note(e);
    } catch (const std::bad_alloc&) {  // outside a stage (the manifest, the species sheets)
        st.stop.note(ENOMEM, "out of memory while building " + spec.name);
    }
    summary.failed = st.failed;
    summary.wallSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    auto finishRun = [&](const std::string& status) {
        if (!st.runStarted) return;
        nlohmann::json& run = st.run;
        run["status"] = status;
        run["built"] = summary.built;
        run["failed"] = summary.failed;
        run["left"] = summary.total - st.recorded();
        run["wall_seconds"] = summary.wallSeconds;
        run["trees_per_second"] =
            summary.wallSeconds > 0 ? summary.built / summary.wallSeconds : 0.0;
        if (!summary.stopped.empty()) run["stop"] = summary.stopped;
        runs.finish(run);
    };
    if (st.stop.requested) {
        // One line instead of one error per remaining instance; what was recorded stays (the
        // manifest ends with a complete record) and a rerun resumes from it.
        summary.stopped = st.stop.reason + ": " + std::to_string(st.recorded()) +
                          " instances built, " + std::to_string(summary.total - st.recorded()) +
                          " left; " + stopAdvice(st.stop.error);
        reserve.release();
        try {  // best effort: the disk may still be full
            writeDatasetJson(spec, o, datasetPath, "incomplete", summary.total, st.recorded(),
                             static_cast<size_t>(instances.size()));
        } catch (const ResourceError&) {
        }
        try {
            finishRun("stopped");
        } catch (const ResourceError&) {
        }
        return summary;
    }
    const bool complete = st.recorded() == summary.total;
    writeDatasetJson(spec, o, datasetPath, complete ? "complete" : "incomplete", summary.total,
                     st.recorded(), static_cast<size_t>(instances.size()));
    finishRun(complete ? "complete" : "incomplete");
    return summary;
}

}  // namespace sylva
