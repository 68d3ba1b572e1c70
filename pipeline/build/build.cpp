#include "pipeline/build/build.h"

#include <OpenImageIO/oiioversion.h>
#include <malloc.h>
#include <openvdb/version.h>
#include <tbb/flow_graph.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/version.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <sstream>

#include "pipeline/build/instance.h"
#include "pipeline/build/progress.h"
#include "pipeline/build/resume.h"
#include "pipeline/formats/atomic_file.h"
#include "pipeline/formats/view_writers.h"
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

static std::string shardSuffix(int index, int count) {
    if (count <= 1) return "";
    int width = static_cast<int>(std::to_string(count).size());
    char buf[64];
    std::snprintf(buf, sizeof buf, ".shard-%0*d-of-%d", width, index, count);
    return buf;
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

struct Message {
    size_t seq = 0;  // position among the jobs run now (sequencer order)
    std::shared_ptr<InstanceWork> work;
};

// A stage as a flow-graph body: runs `stage` unless an earlier one failed.
template <class F>
auto stageBody(F stage) {
    return [stage](Message m) {
        if (m.work->error.empty()) {
            try {
                stage(*m.work);
            } catch (const std::exception& e) {
                m.work->error = e.what();
            }
        }
        return m;
    };
}

// Per species, a sheet of the first views of its first K recorded instances of [lo, hi).
void writeSpeciesSheets(const DatasetSpec& spec, const DatasetInstances& instances,
                        const InstanceSet& recorded, int64_t lo, int64_t hi, const fs::path& out) {
    const int k = spec.outputs.speciesSheet;
    if (k <= 0 || spec.outputs.views.count <= 0) return;
    for (size_t s = 0; s < spec.species.size(); ++s) {
        const auto [begin, end] = instances.speciesRange(s);
        const int64_t stop = std::min(hi, end);
        std::vector<fs::path> dirs;
        for (int64_t i = recorded.nextPresent(std::max(lo, begin), stop); i < stop;
             i = recorded.nextPresent(i + 1, stop)) {
            const fs::path dir = out / instanceDir(instances[i]);
            if (fs::exists(dir / "views" / "000.png")) dirs.push_back(dir);
            if (static_cast<int>(dirs.size()) >= k) break;
        }
        if (dirs.empty()) continue;
        writeSpeciesSheet(out / "contact" / (spec.species[s].species.name + ".png"), dirs);
    }
}

void writeDatasetJson(const DatasetSpec& spec, const BuildOptions& o, const fs::path& file,
                      const std::string& status, const BuildSummary& s, int threads,
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
    d["versions"] = versionInfo();
    d["shard"] = {{"index", o.shardIndex}, {"count", o.shardCount}};
    d["counts"] = {{"instances_in_dataset", allJobs},
                   {"instances_in_shard", s.total},
                   {"skipped_already_built", s.skipped},
                   {"built", s.built},
                   {"failed", s.failed}};
    d["threads"] = threads;
    d["wall_seconds"] = s.wallSeconds;
    d["trees_per_second"] = s.wallSeconds > 0 ? s.built / s.wallSeconds : 0.0;
    writeFileAtomic(file, d.dump(2) + "\n");
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
    const auto [shardLo, shardHi] =
        shardRange(static_cast<size_t>(instances.size()), o.shardIndex, o.shardCount);
    const auto lo = static_cast<int64_t>(shardLo), hi = static_cast<int64_t>(shardHi);

    fs::create_directories(o.out);
    const fs::path manifestPath = o.out / manifestName(o.shardIndex, o.shardCount);
    const fs::path datasetPath = o.out / datasetJsonName(o.shardIndex, o.shardCount);

    // Resume: the instances already recorded (a partial last line from a kill is dropped).
    InstanceSet done;
    const bool resuming = fs::exists(manifestPath);
    if (resuming) {
        if (fs::exists(datasetPath)) {
            auto old = nlohmann::json::parse(std::ifstream(datasetPath), nullptr, false);
            if (!old.is_discarded() && old.value("fingerprint", "") != spec.fingerprint) {
                throw SpecError(SourcePos{spec.path, 0, 0}, "",
                                "output directory " + o.out.string() +
                                    " holds a build of a different spec (fingerprint " +
                                    old.value("fingerprint", "?") + " ≠ " + spec.fingerprint +
                                    "); use another --out");
            }
        }
        done = recordedInstances(manifestPath, instances);
    }
    BuildSummary summary;
    summary.total = hi - lo;
    summary.skipped = done.countIn(lo, hi);
    // A kill mid-write leaves "<file>.tmp.<pid>.…" siblings in the directories of the instances
    // not yet recorded: remove those of this shard's remaining instances.
    if (resuming) removeStaleTemporaries(o.out, instances, done, lo, hi);
    writeDatasetJson(spec, o, datasetPath, "running", summary, threads,
                     static_cast<size_t>(instances.size()));

    AppendLog manifest(manifestPath);
    Progress progress(summary.total - summary.skipped, o.progress);
    const int64_t abortAfter = [] {
        const char* e = std::getenv("SYLVA_TEST_ABORT_AFTER");  // tests: simulate a kill
        return e ? std::atoll(e) : -1;
    }();

    using namespace tbb::flow;
    graph g;
    int64_t next = lo;  // the next position to consider
    size_t seq = 0;
    input_node<Message> source(g, [&](tbb::flow_control& fc) -> Message {
        next = done.nextMissing(next, hi);  // skip what is recorded, a run at a time
        if (next >= hi) {
            fc.stop();
            return {};
        }
        Message m;
        m.seq = seq++;
        m.work = std::make_shared<InstanceWork>();
        m.work->job = instances[next++];
        return m;
    });
    const size_t inFlight = o.maxInFlight > 0 ? o.maxInFlight : 4 * static_cast<size_t>(threads);
    limiter_node<Message> limiter(g, inFlight);
    function_node<Message, Message> grow(g, unlimited,
                                         stageBody([](InstanceWork& w) { growStage(w); }));
    function_node<Message, Message> mesh(
        g, unlimited, stageBody([&](InstanceWork& w) { meshStage(w, spec.outputs, o.out); }));
    function_node<Message, Message> render(
        g, unlimited, stageBody([&](InstanceWork& w) { renderStage(w, spec.outputs); }));
    function_node<Message, Message> write(g, unlimited, [&](Message m) {
        stageBody([&](InstanceWork& w) { writeStage(w, spec.outputs, o.out); })(m);
        // Free the heavy parts before the message waits in the sequencer.
        InstanceWork& w = *m.work;
        w.grown = GrownTree{};
        w.mesh = TreeMesh{};
        w.watertight = Mesh{};
        w.views.clear();
        return m;
    });
    sequencer_node<Message> order(g, [](const Message& m) { return m.seq; });
    int64_t failed = 0;
    function_node<Message, continue_msg> record(g, serial, [&](const Message& m) {
        const InstanceWork& w = *m.work;
        if (w.error.empty()) {
            manifest.append(w.record.dump());
            done.insert(w.job.position);
            ++summary.built;
            if (abortAfter >= 0 && summary.built >= abortAfter) std::_Exit(137);
        } else {
            ++failed;
            std::fprintf(stderr, "%ssylva: %s: %s\n", isatty(2) ? "\r\033[K" : "", w.job.id.c_str(),
                         w.error.c_str());
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

    writeSpeciesSheets(spec, instances, done, lo, hi, o.out);
    summary.failed = failed;
    summary.wallSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    progress.finish(summary.built + failed, failed);
    writeDatasetJson(spec, o, datasetPath, failed ? "incomplete" : "complete", summary, threads,
                     static_cast<size_t>(instances.size()));
    return summary;
}

}  // namespace sylva
