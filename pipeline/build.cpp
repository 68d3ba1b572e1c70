#include "pipeline/build.h"

#include <OpenImageIO/oiioversion.h>
#include <openvdb/version.h>
#include <tbb/flow_graph.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/version.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>

#include "pipeline/atomic_file.h"
#include "pipeline/preview.h"
#include "pipeline/progress.h"
#include "pipeline/skeleton_writers.h"
#include "pipeline/stats_json.h"
#include "species/tree_stats.h"

namespace sylva {

namespace fs = std::filesystem;

std::pair<size_t, size_t> shardRange(size_t jobs, int index, int count) {
    size_t lo = jobs * static_cast<size_t>(index) / static_cast<size_t>(count);
    size_t hi = jobs * static_cast<size_t>(index + 1) / static_cast<size_t>(count);
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

std::string cgalVersion();  // species/tree_stats.cpp

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

static std::string hex64(uint64_t v) {
    char buf[20];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
    return buf;
}

nlohmann::json buildInstance(const InstanceJob& job, const OutputOptions& outputs,
                             const fs::path& out) {
    using Clock = std::chrono::steady_clock;
    auto t0 = Clock::now();
    const SpeciesFile& species = job.entry->species;
    GrownTree grown = growSpecies(species, job.seed, job.point->overrides.get(), true);
    auto t1 = Clock::now();
    TreeStats stats = computeStats(grown.tree);

    // Files first (each atomically); the caller appends the manifest line afterwards.
    const fs::path rel = fs::path("trees") / species.name / job.id;
    nlohmann::json files = nlohmann::json::object();
    if (outputs.ply) {
        writeFileAtomic(out / rel / "skeleton.ply", skeletonPly(grown.tree));
        files["skeleton_ply"] = (rel / "skeleton.ply").generic_string();
    }
    if (outputs.swc) {
        writeFileAtomic(out / rel / "skeleton.swc", skeletonSwc(grown.tree));
        files["skeleton_swc"] = (rel / "skeleton.swc").generic_string();
    }
    if (outputs.preview) {
        writePreviewPng(grown.tree, out / rel / "preview.png", outputs.previewSize);
        files["preview_png"] = (rel / "preview.png").generic_string();
    }
    auto t2 = Clock::now();

    nlohmann::json rec;
    rec["id"] = job.id;
    rec["species"] = species.name;
    rec["method"] = species.method;
    rec["index"] = job.index;
    rec["seed"] = hex64(job.seed);
    rec["sweep"] = job.point->values;
    rec["params"] = grown.sampled;
    rec["files"] = files;
    nlohmann::json st = toJson(stats);
    for (const auto& [k, v] : grown.methodStats) st[k] = v;
    rec["stats"] = st;
    // The only fields that differ between identical builds.
    rec["timing"] = {{"grow_ms", std::chrono::duration<double, std::milli>(t1 - t0).count()},
                     {"write_ms", std::chrono::duration<double, std::milli>(t2 - t1).count()}};
    return rec;
}

namespace {

struct Message {
    size_t seq = 0;  // position among the jobs run now (sequencer order)
    const InstanceJob* job = nullptr;
    std::shared_ptr<nlohmann::json> record;  // null on failure
    std::string error;
};

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
    const int threads = o.threads > 0 ? o.threads : tbb::info::default_concurrency();
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);

    std::vector<InstanceJob> all = expandJobs(spec);
    auto [lo, hi] = shardRange(all.size(), o.shardIndex, o.shardCount);

    fs::create_directories(o.out);
    const fs::path manifestPath = o.out / manifestName(o.shardIndex, o.shardCount);
    const fs::path datasetPath = o.out / datasetJsonName(o.shardIndex, o.shardCount);

    // Resume: the ids already recorded (a partial last line from a kill is dropped).
    std::set<std::string> done;
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
        for (const std::string& line : AppendLog::readCompleteLines(manifestPath)) {
            auto j = nlohmann::json::parse(line, nullptr, false);
            if (!j.is_discarded() && j.contains("id")) done.insert(j["id"].get<std::string>());
        }
    }
    std::vector<const InstanceJob*> todo;
    BuildSummary summary;
    summary.total = static_cast<int64_t>(hi - lo);
    for (size_t k = lo; k < hi; ++k) {
        if (done.count(all[k].id))
            ++summary.skipped;
        else
            todo.push_back(&all[k]);
    }
    if (resuming) {
        // A kill mid-write leaves "<file>.tmp.<pid>.…" siblings in the directories of the
        // instances not yet recorded: remove those of this shard's remaining instances (never
        // another shard's, whose process may be writing there right now).
        for (const InstanceJob* j : todo) {
            const fs::path dir = o.out / "trees" / j->entry->species.name / j->id;
            std::error_code ec;
            for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
                if (it->path().filename().string().find(".tmp.") != std::string::npos) {
                    std::error_code ignored;
                    fs::remove(it->path(), ignored);
                }
            }
        }
    }
    writeDatasetJson(spec, o, datasetPath, "running", summary, threads, all.size());

    AppendLog manifest(manifestPath);
    Progress progress(static_cast<int64_t>(todo.size()), o.progress);
    const int64_t abortAfter = [] {
        const char* e = std::getenv("SYLVA_TEST_ABORT_AFTER");  // tests: simulate a kill
        return e ? std::atoll(e) : -1;
    }();

    using namespace tbb::flow;
    graph g;
    size_t next = 0;
    input_node<Message> source(g, [&](tbb::flow_control& fc) -> Message {
        if (next >= todo.size()) {
            fc.stop();
            return {};
        }
        Message m;
        m.seq = next;
        m.job = todo[next++];
        return m;
    });
    const size_t inFlight = o.maxInFlight > 0 ? o.maxInFlight : 4 * static_cast<size_t>(threads);
    limiter_node<Message> limiter(g, inFlight);
    function_node<Message, Message> work(g, unlimited, [&](Message m) {
        try {
            m.record = std::make_shared<nlohmann::json>(buildInstance(*m.job, spec.outputs, o.out));
        } catch (const std::exception& e) {
            m.error = e.what();
        }
        return m;
    });
    sequencer_node<Message> order(g, [](const Message& m) { return m.seq; });
    int64_t failed = 0;
    function_node<Message, continue_msg> record(g, serial, [&](const Message& m) {
        if (m.record) {
            manifest.append(m.record->dump());
            ++summary.built;
            if (abortAfter >= 0 && summary.built >= abortAfter) std::_Exit(137);
        } else {
            ++failed;
            std::fprintf(stderr, "%ssylva: %s: %s\n", isatty(2) ? "\r\033[K" : "",
                         m.job->id.c_str(), m.error.c_str());
        }
        progress.tick(summary.built + failed, failed);
        return continue_msg();
    });
    make_edge(source, limiter);
    make_edge(limiter, work);
    make_edge(work, order);
    make_edge(order, record);
    make_edge(record, limiter.decrementer());
    source.activate();
    g.wait_for_all();

    summary.failed = failed;
    summary.wallSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    progress.finish(summary.built + failed, failed);
    writeDatasetJson(spec, o, datasetPath, failed ? "incomplete" : "complete", summary, threads,
                     all.size());
    return summary;
}

}  // namespace sylva
