#include "pipeline/batch/estimate.h"

#include <sys/resource.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>

#include "core/errors.h"
#include "pipeline/batch/build.h"
#include "pipeline/batch/instance.h"
#include "pipeline/batch/pack.h"

namespace sylva {

namespace fs = std::filesystem;

namespace {

// User + system CPU time of the whole process (every thread, Embree's included), seconds.
double processCpuSeconds() {
    rusage u{};
    ::getrusage(RUSAGE_SELF, &u);
    auto seconds = [](const timeval& t) { return t.tv_sec + 1e-6 * t.tv_usec; };
    return seconds(u.ru_utime) + seconds(u.ru_stime);
}

// The scratch directory the samples are written into: made with mkdtemp, removed with what is
// in it when the estimate ends, however it ends.
class ScratchDir {
  public:
    explicit ScratchDir(const fs::path& parent) {
        std::error_code ec;
        fs::path base = parent.empty() ? fs::temp_directory_path(ec) : parent;
        if (base.empty()) base = "/tmp";
        std::string pattern = (base / "sylva-estimate-XXXXXX").string();
        if (!::mkdtemp(pattern.data())) {
            throw InputError("--estimate: cannot make a scratch directory in " + base.string() +
                             " (set TMPDIR to a writable directory)");
        }
        dir_ = pattern;
    }
    ~ScratchDir() {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    ScratchDir(const ScratchDir&) = delete;
    ScratchDir& operator=(const ScratchDir&) = delete;
    const fs::path& path() const { return dir_; }

  private:
    fs::path dir_;
};

bool startsWith(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }
bool endsWith(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() &&
           s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Grows, meshes, renders, scans and writes one instance into `scratch`, as the build's stages
// do, and measures it; the instance's directory is removed afterwards.
EstimateSample measureInstance(const InstanceJob& job, const OutputOptions& outputs,
                               const fs::path& scratch) {
    EstimateSample s;
    s.id = job.id;
    InstanceWork w;
    w.job = job;
    const double cpu0 = processCpuSeconds();
    const auto wall0 = std::chrono::steady_clock::now();
    try {
        growStage(w);
        meshStage(w, outputs, scratch);
        renderStage(w, outputs);
        scanStage(w, outputs, scratch);
        writeStage(w, outputs, scratch);
    } catch (const ResourceError&) {  // the scratch disk is full: no estimate
        throw;
    } catch (const std::bad_alloc&) {
        throw;
    } catch (const std::exception& e) {  // what the build would report as a failed instance
        s.error = e.what();
    }
    s.cpuSeconds = processCpuSeconds() - cpu0;
    s.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    const fs::path dir = scratch / instanceDir(job);
    std::error_code ec;
    if (s.error.empty()) {
        for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end;
             it.increment(ec)) {
            if (!it->is_regular_file(ec)) continue;
            const uint64_t size = it->file_size(ec);
            s.bytes += size;
            ++s.files;
            s.byKind[estimateFileKind(it->path().lexically_relative(dir))] += size;
        }
        if (ec) throw std::runtime_error("--estimate: cannot list " + dir.string());
        nlohmann::json record = w.record;
        record.erase("timing");  // the only part that differs between identical builds
        s.manifestBytes = record.dump().size() + 1;
    }
    fs::remove_all(dir, ec);
    return s;
}

void averageSamples(EstimateRow& row) {
    for (const EstimateSample& s : row.samples) {
        if (!s.error.empty()) continue;
        ++row.ok;
        row.cpuSeconds += s.cpuSeconds;
        row.wallSeconds += s.wallSeconds;
        row.bytes += static_cast<double>(s.bytes);
        row.files += static_cast<double>(s.files);
        row.manifestBytes += static_cast<double>(s.manifestBytes);
        for (const auto& [kind, b] : s.byKind) row.byKind[kind] += static_cast<double>(b);
    }
    if (row.ok == 0) return;
    const double n = row.ok;
    row.cpuSeconds /= n;
    row.wallSeconds /= n;
    row.bytes /= n;
    row.files /= n;
    row.manifestBytes /= n;
    for (auto& [kind, b] : row.byKind) b /= n;
}

// Instances of [lo, hi) in row r's positions [begin, end).
int64_t overlap(std::pair<int64_t, int64_t> range, int64_t lo, int64_t hi) {
    return std::max<int64_t>(0, std::min(range.second, hi) - std::max(range.first, lo));
}

// Free bytes on the file system that would hold `out` (its nearest existing ancestor), or −1.
int64_t freeBytesFor(const fs::path& out) {
    std::error_code ec;
    fs::path p = fs::absolute(out, ec);
    if (ec) return -1;
    while (!p.empty() && !fs::exists(p, ec)) {
        if (p == p.parent_path()) return -1;
        p = p.parent_path();
    }
    const fs::space_info s = fs::space(p, ec);
    return ec ? -1 : static_cast<int64_t>(s.available);
}

struct Totals {
    int64_t instances = 0;
    double cpuSeconds = 0, bytes = 0, manifestBytes = 0, files = 0;
};

// The totals over `count(row)` instances of each row.
template <class Count>
Totals totalsOf(const EstimateResult& r, Count count) {
    Totals t;
    for (const EstimateRow& row : r.rows) {
        const auto n = static_cast<double>(count(row));
        t.instances += count(row);
        t.cpuSeconds += n * row.cpuSeconds;
        t.bytes += n * row.bytes;
        t.manifestBytes += n * row.manifestBytes;
        t.files += n * row.files;
    }
    return t;
}

// 3 significant digits with an SI prefix: "812 B", "24.5 kB", "1.20 TB" (10³ steps).
std::string humanBytes(double b) {
    const char* units[] = {"B", "kB", "MB", "GB", "TB", "PB", "EB"};
    int u = 0;
    while (b >= 999.5 && u < 6) {
        b /= 1000.0;
        ++u;
    }
    char buf[32];
    if (u == 0) {
        std::snprintf(buf, sizeof buf, "%.0f B", b);
    } else {
        std::snprintf(buf, sizeof buf,
                      b < 9.995   ? "%.2f %s"
                      : b < 99.95 ? "%.1f %s"
                                  : "%.0f %s",
                      b, units[u]);
    }
    return buf;
}

// A duration: "0.42 s", "3.5 min", "2.1 h", "4.3 d".
std::string humanSeconds(double s) {
    char buf[32];
    if (s < 60) {
        std::snprintf(buf, sizeof buf, s < 10 ? "%.3f s" : "%.1f s", s);
    } else if (s < 3600) {
        std::snprintf(buf, sizeof buf, "%.1f min", s / 60);
    } else if (s < 86400 * 2) {
        std::snprintf(buf, sizeof buf, "%.1f h", s / 3600);
    } else {
        std::snprintf(buf, sizeof buf, "%.1f d", s / 86400);
    }
    return buf;
}

// CPU hours to 3 significant digits without an exponent: "0.0000276", "1.25", "167", "12345".
std::string hours(double h) {
    char buf[48];
    if (h >= 100) {
        std::snprintf(buf, sizeof buf, "%.0f", h);
    } else {
        const int decimals =
            h > 0 ? std::max(0, 2 - static_cast<int>(std::floor(std::log10(h)))) : 0;
        std::snprintf(buf, sizeof buf, "%.*f", std::min(decimals, 12), h);
    }
    return buf;
}

std::string humanCount(double v) {
    char buf[48];
    std::snprintf(buf, sizeof buf, v == std::floor(v) || v >= 1e6 ? "%.0f" : "%.1f", v);
    return buf;
}

}  // namespace

std::string estimateFileKind(const fs::path& relative) {
    const std::string path = relative.generic_string();
    const std::string name = relative.filename().string();
    if (startsWith(path, "views/")) {
        if (name.find("_depth.") != std::string::npos) return "depth";
        if (endsWith(name, "_label.png")) return "labels";
        if (endsWith(name, "_id.png")) return "ids";
        if (name.find("_rgb.") != std::string::npos) return "colour";
        return "views";
    }
    if (name == "transforms.json" || name == "transforms_top.json") return "views";
    if (startsWith(name, "scan")) return "scan";
    if (startsWith(name, "qsm")) return "qsm";
    if (startsWith(name, "skeleton.")) return "skeleton";
    if (startsWith(name, "watertight")) return "watertight";
    if (startsWith(name, "mesh") || startsWith(name, "scene.")) return "mesh";
    if (name == "points.ply") return "points";
    if (name == "preview.png" || name == "contact.png") return "previews";
    if (name == "stats.json" || name == "plot.json" || startsWith(name, "trees.")) return "stats";
    return "other";
}

EstimateResult estimateDataset(const DatasetSpec& spec, const EstimateOptions& o) {
    if (o.samples < 1) throw InputError("--estimate-samples: expected an integer ≥ 1");
    const auto start = std::chrono::steady_clock::now();
    EstimateResult r;
    r.dataset = spec.name;
    r.spec = spec.path;
    r.samples = o.samples;
    r.cores = o.threads > 0 ? o.threads : tbb::info::default_concurrency();
    r.shardIndex = o.shardIndex;
    r.shardCount = o.shardCount;
    r.out = o.out;

    const DatasetInstances instances(spec);
    const auto [lo, hi] =
        shardPositions(instances.size(), o.shardIndex, o.shardCount, spec.outputs.packInstances);
    const size_t rows = spec.species.size() + spec.plots.size();

    ScratchDir scratch(o.scratch);
    {
        // One worker: a sample's CPU time is then the work of one tree, as when the build runs
        // a tree per core (a plot, grown one at a time by the build, spreads over the cores).
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        for (size_t k = 0; k < rows; ++k) {
            EstimateRow row;
            row.plot = k >= spec.species.size();
            row.name =
                row.plot ? spec.plots[k - spec.species.size()].name : spec.species[k].species.name;
            if (!row.plot) row.sweepPoints = spec.species[k].points.size();
            const auto range = instances.speciesRange(k);
            row.count = range.second - range.first;
            row.inShard = overlap(range, lo, hi);
            const int64_t n = std::min<int64_t>(o.samples, row.count);
            for (int64_t p = range.first; p < range.first + n; ++p) {
                row.samples.push_back(measureInstance(instances[p], spec.outputs, scratch.path()));
            }
            averageSamples(row);
            r.rows.push_back(std::move(row));
        }
    }

    if (o.shardCount > 1 && o.shardCount <= EstimateResult::kMaxShardsScanned) {
        for (int s = 0; s < o.shardCount; ++s) {
            const auto [a, b] =
                shardPositions(instances.size(), s, o.shardCount, spec.outputs.packInstances);
            double cpu = 0;
            for (size_t k = 0; k < rows; ++k) {
                cpu += static_cast<double>(overlap(instances.speciesRange(k), a, b)) *
                       r.rows[k].cpuSeconds;
            }
            if (r.heaviestShard < 0 || cpu > r.heaviestShardCpuSeconds) {
                r.heaviestShard = s;
                r.heaviestShardCpuSeconds = cpu;
            }
        }
    }
    r.outFreeBytes = freeBytesFor(o.out);

    // What the numbers leave out, said rather than guessed.
    for (const EstimateRow& row : r.rows) {
        const std::string what = (row.plot ? "plot " : "species ") + row.name;
        size_t failed = row.samples.size() - static_cast<size_t>(row.ok);
        if (failed > 0) {
            std::string first;
            for (const EstimateSample& s : row.samples) {
                if (!s.error.empty()) {
                    first = s.id + ": " + s.error;
                    break;
                }
            }
            r.notes.push_back(what + ": " + std::to_string(failed) + " of " +
                              std::to_string(row.samples.size()) +
                              " samples failed as the build would fail them (" + first + ")" +
                              (row.ok == 0 ? "; its instances are left out of the totals" : ""));
        }
        if (row.sweepPoints > 1) {
            r.notes.push_back(what + ": sampled from its first sweep point only (" +
                              std::to_string(row.sweepPoints) +
                              " points); swept values that change the trees' size change "
                              "their time and bytes");
        }
    }
    if (o.shardCount > EstimateResult::kMaxShardsScanned) {
        r.notes.push_back("heaviest shard: not computed for more than " +
                          std::to_string(EstimateResult::kMaxShardsScanned) + " shards");
    }
    std::string perDataset =
        "the manifest lines' timing blocks (about 100 B each; their length varies from run to "
        "run), dataset.json, runs.jsonl";
    if (spec.outputs.speciesSheet > 0 && spec.outputs.views.count > 0 && !spec.species.empty()) {
        perDataset += ", contact/<species>.png (one sheet per species)";
    }
    r.notes.push_back("not counted: " + perDataset);
    if (!spec.plots.empty()) {
        r.notes.push_back(
            "plots: a build grows one plot at a time, spread over the cores by the plot's own "
            "parallel loops; their wall time assumes those keep every core busy, which the "
            "scene meshes and files written at the end of a plot do not");
    }

    rusage u{};
    ::getrusage(RUSAGE_SELF, &u);
    r.peakRssKiB = u.ru_maxrss;
    r.measuredSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return r;
}

std::string estimateTable(const EstimateResult& r) {
    std::string t;
    char line[512];
    auto add = [&t](const std::string& s) { t += s + "\n"; };
    const bool sharded = r.shardCount > 1;
    std::snprintf(line, sizeof line,
                  "%s (%s): %d sample(s) per species and plot, measured in %s (peak RSS %s)",
                  r.dataset.c_str(), r.spec.c_str(), r.samples,
                  humanSeconds(r.measuredSeconds).c_str(),
                  humanBytes(r.peakRssKiB * 1024.0).c_str());
    add(line);
    add("");

    size_t nameWidth = 7;  // "species"
    for (const EstimateRow& row : r.rows) nameWidth = std::max(nameWidth, row.name.size());
    const int w = static_cast<int>(nameWidth);
    std::snprintf(line, sizeof line, "%-5s %-*s %12s %7s %10s %10s %10s %13s %11s %10s %12s",
                  "kind", w, "name", sharded ? "in shard" : "instances", "sampled", "CPU s/inst",
                  "bytes/inst", "files/inst", "manifest/inst", "CPU time", "bytes", "files");
    add(line);
    for (const EstimateRow& row : r.rows) {
        const int64_t n = sharded ? row.inShard : row.count;
        const double dn = static_cast<double>(n);
        std::snprintf(line, sizeof line,
                      "%-5s %-*s %12lld %3d/%-3zu %10.3f %10s %10s %13s %11s %10s %12s",
                      row.plot ? "plot" : "tree", w, row.name.c_str(), static_cast<long long>(n),
                      row.ok, row.samples.size(), row.cpuSeconds, humanBytes(row.bytes).c_str(),
                      humanCount(row.files).c_str(), humanBytes(row.manifestBytes).c_str(),
                      humanSeconds(dn * row.cpuSeconds).c_str(),
                      humanBytes(dn * (row.bytes + row.manifestBytes)).c_str(),
                      humanCount(dn * row.files).c_str());
        add(line);
    }

    // Bytes per instance by kind: the columns of the kinds any row writes.
    std::set<std::string> kinds;
    for (const EstimateRow& row : r.rows) {
        for (const auto& [k, b] : row.byKind) kinds.insert(k);
    }
    if (!kinds.empty()) {
        add("");
        add("bytes per instance, by kind of file:");
        std::snprintf(line, sizeof line, "%-5s %-*s", "kind", w, "name");
        std::string head = line;
        for (const std::string& k : kinds) {
            std::snprintf(line, sizeof line, " %10s", k.c_str());
            head += line;
        }
        add(head);
        for (const EstimateRow& row : r.rows) {
            std::snprintf(line, sizeof line, "%-5s %-*s", row.plot ? "plot" : "tree", w,
                          row.name.c_str());
            std::string s = line;
            for (const std::string& k : kinds) {
                auto it = row.byKind.find(k);
                std::snprintf(line, sizeof line, " %10s",
                              it == row.byKind.end() ? "-" : humanBytes(it->second).c_str());
                s += line;
            }
            add(s);
        }
    }

    add("");
    auto totalLine = [&](const std::string& label, const Totals& tt) {
        std::snprintf(line, sizeof line,
                      "%s: %lld instances, %s CPU hours, %s (%.0f bytes: files %.0f, "
                      "manifest %.0f), %s files; wall on %d core(s) ≈ %s",
                      label.c_str(), static_cast<long long>(tt.instances),
                      hours(tt.cpuSeconds / 3600.0).c_str(),
                      humanBytes(tt.bytes + tt.manifestBytes).c_str(),
                      std::round(tt.bytes + tt.manifestBytes), std::round(tt.bytes),
                      std::round(tt.manifestBytes), humanCount(std::round(tt.files)).c_str(),
                      r.cores, humanSeconds(tt.cpuSeconds / r.cores).c_str());
        add(line);
    };
    const Totals all = totalsOf(r, [](const EstimateRow& row) { return row.count; });
    totalLine("dataset", all);
    if (sharded) {
        totalLine("shard " + std::to_string(r.shardIndex) + "/" + std::to_string(r.shardCount),
                  totalsOf(r, [](const EstimateRow& row) { return row.inShard; }));
        if (r.heaviestShard >= 0) {
            std::snprintf(
                line, sizeof line, "heaviest shard: %d/%d, %s CPU hours; wall on %d core(s) ≈ %s",
                r.heaviestShard, r.shardCount, hours(r.heaviestShardCpuSeconds / 3600.0).c_str(),
                r.cores, humanSeconds(r.heaviestShardCpuSeconds / r.cores).c_str());
            add(line);
        }
    }
    if (r.outFreeBytes >= 0) {
        const Totals t =
            sharded ? totalsOf(r, [](const EstimateRow& row) { return row.inShard; }) : all;
        const double need = t.bytes + t.manifestBytes;
        std::snprintf(line, sizeof line, "disk: %s needed, %s free where --out %s would be%s",
                      humanBytes(need).c_str(),
                      humanBytes(static_cast<double>(r.outFreeBytes)).c_str(),
                      r.out.string().c_str(),
                      need > static_cast<double>(r.outFreeBytes) ? " — NOT ENOUGH" : "");
        add(line);
    }
    add("");
    add("CPU s/inst: process CPU time (user + system) of each sample grown alone on one worker "
        "thread; wall = CPU time / cores, as if the build keeps every core busy.");
    for (const std::string& n : r.notes) add("note: " + n);
    return t;
}

nlohmann::json estimateJson(const EstimateResult& r) {
    nlohmann::json j;
    j["dataset"] = r.dataset;
    j["spec"] = r.spec;
    j["samples_per_row"] = r.samples;
    j["cpu_time"] =
        "process CPU time (user + system) of each sample grown alone on one worker thread";
    j["cores"] = r.cores;
    nlohmann::json rows = nlohmann::json::array();
    for (const EstimateRow& row : r.rows) {
        nlohmann::json x;
        x["kind"] = row.plot ? "plot" : "species";
        x["name"] = row.name;
        x["instances"] = row.count;
        x["instances_in_shard"] = row.inShard;
        x["sweep_points"] = row.sweepPoints;
        x["samples_measured"] = row.ok;
        x["samples_failed"] = row.samples.size() - static_cast<size_t>(row.ok);
        x["cpu_seconds_per_instance"] = row.cpuSeconds;
        x["wall_seconds_per_instance"] = row.wallSeconds;
        x["bytes_per_instance"] = row.bytes;
        x["files_per_instance"] = row.files;
        x["manifest_bytes_per_instance"] = row.manifestBytes;
        x["bytes_per_instance_by_kind"] = row.byKind;
        const auto n = static_cast<double>(row.count);
        x["cpu_hours"] = n * row.cpuSeconds / 3600.0;
        x["bytes"] = std::llround(n * row.bytes);
        x["manifest_bytes"] = std::llround(n * row.manifestBytes);
        x["files"] = std::llround(n * row.files);
        nlohmann::json samples = nlohmann::json::array();
        for (const EstimateSample& s : row.samples) {
            nlohmann::json y = {
                {"id", s.id}, {"cpu_seconds", s.cpuSeconds}, {"wall_seconds", s.wallSeconds}};
            if (s.error.empty()) {
                y["bytes"] = s.bytes;
                y["files"] = s.files;
                y["manifest_bytes"] = s.manifestBytes;
                y["bytes_by_kind"] = s.byKind;
            } else {
                y["error"] = s.error;
            }
            samples.push_back(y);
        }
        x["samples"] = samples;
        rows.push_back(x);
    }
    j["rows"] = rows;
    auto totalJson = [&](const Totals& t) {
        return nlohmann::json{{"instances", t.instances},
                              {"cpu_hours", t.cpuSeconds / 3600.0},
                              {"bytes", std::llround(t.bytes + t.manifestBytes)},
                              {"instance_bytes", std::llround(t.bytes)},
                              {"manifest_bytes", std::llround(t.manifestBytes)},
                              {"files", std::llround(t.files)},
                              {"wall_hours", t.cpuSeconds / r.cores / 3600.0}};
    };
    j["totals"] = totalJson(totalsOf(r, [](const EstimateRow& row) { return row.count; }));
    if (r.shardCount > 1) {
        nlohmann::json s =
            totalJson(totalsOf(r, [](const EstimateRow& row) { return row.inShard; }));
        s["index"] = r.shardIndex;
        s["count"] = r.shardCount;
        j["shard"] = s;
        if (r.heaviestShard >= 0) {
            j["heaviest_shard"] = {{"index", r.heaviestShard},
                                   {"cpu_hours", r.heaviestShardCpuSeconds / 3600.0},
                                   {"wall_hours", r.heaviestShardCpuSeconds / r.cores / 3600.0}};
        }
    }
    j["disk"] = {{"out", r.out.string()},
                 {"free_bytes",
                  r.outFreeBytes >= 0 ? nlohmann::json(r.outFreeBytes) : nlohmann::json(nullptr)}};
    j["measured_seconds"] = r.measuredSeconds;
    j["peak_rss_kib"] = r.peakRssKiB;
    j["notes"] = r.notes;
    return j;
}

}  // namespace sylva
