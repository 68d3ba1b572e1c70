#include "pipeline/analysis/merge.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string_view>

#include "core/atomic_file.h"
#include "core/input_file.h"
#include "pipeline/analysis/dataset_reader.h"
#include "pipeline/batch/build.h"
#include "pipeline/batch/output_lock.h"
#include "pipeline/batch/pack.h"
#include "pipeline/batch/run_log.h"
#include "pipeline/formats/view_writers.h"

namespace sylva {

namespace fs = std::filesystem;

namespace {

struct Shard {
    fs::path dir;
    int index = 0;
    int count = 1;
    nlohmann::json dataset;  // its dataset.shard-I-of-N.json
};

// A record as the species sheets need it (the first K of each species are kept).
struct Record {
    std::string id, species;    // species: the plot's name for a plot
    std::string pack;           // a packed instance's tar ("shards/000003.tar"), else ""
    std::filesystem::path dir;  // trees/<species>/<id> or plots/<plot>/<id>
};

// Instance ids back to their positions in the dataset's order, from its description: species
// entries in order, each `count` × `sweep_points` ("<species>-<index>", swept
// "<species>-p<point>-<index>"), then the plots ("<plot>-<index>"). The shards' records must be
// their blocks' positions in increasing order — which makes them unique without remembering
// the ids.
class IdPositions {
  public:
    explicit IdPositions(const nlohmann::json& dataset) {
        int64_t start = 0;
        for (const char* list : {"species", "plots"}) {
            for (const auto& e : dataset.value(list, nlohmann::json::array())) {
                Group g{e.value("name", ""), start, e.value("count", int64_t{0}),
                        std::string(list) == "species" ? e.value("sweep_points", int64_t{1}) : 1};
                start += g.count * g.points;
                groups_.push_back(std::move(g));
            }
        }
    }
    std::optional<int64_t> operator()(const std::string& id) const {
        std::optional<int64_t> best;
        size_t bestName = 0;
        for (const Group& g : groups_) {
            if (id.size() <= g.name.size() + 1 || id.compare(0, g.name.size(), g.name) != 0 ||
                id[g.name.size()] != '-' || (best && g.name.size() <= bestName)) {
                continue;
            }
            std::string_view rest(id);
            rest.remove_prefix(g.name.size() + 1);
            int64_t point = 0;
            if (!rest.empty() && rest[0] == 'p') {
                const size_t dash = rest.find('-');
                if (dash == std::string_view::npos || !digits(rest.substr(1, dash - 1), point)) {
                    continue;
                }
                rest.remove_prefix(dash + 1);
            }
            int64_t index = 0;
            if (!digits(rest, index) || point >= g.points || index >= g.count) continue;
            best = g.start + point * g.count + index;
            bestName = g.name.size();
        }
        return best;
    }

  private:
    struct Group {
        std::string name;
        int64_t start = 0, count = 0, points = 1;
    };
    static bool digits(std::string_view s, int64_t& v) {
        if (s.empty() || s.size() > 18) return false;
        v = 0;
        for (char c : s) {
            if (c < '0' || c > '9') return false;
            v = v * 10 + (c - '0');
        }
        return true;
    }
    std::vector<Group> groups_;
};

[[noreturn]] void fail(const std::string& what) { throw MergeError(what); }

// A shard's description, checked as every command checks one (dataset_reader.h).
nlohmann::json readJson(const fs::path& p) {
    try {
        return readDatasetJsonFile(p);
    } catch (const MergeError&) {
        throw;
    } catch (const InputError& e) {
        fail(e.what());
    }
}

// The shards a directory holds: every dataset.shard-I-of-N.json in it (several shards may share
// one --out), or its dataset.json as shard 0 of 1.
std::vector<Shard> findShards(const fs::path& dir) {
    if (!fs::is_directory(dir)) fail(dir.string() + ": not a directory");
    std::vector<Shard> found;
    for (const auto& e : fs::directory_iterator(dir)) {
        const std::string f = e.path().filename().string();
        if (f == "dataset.json") {
            found.push_back({dir, 0, 1, readJson(e.path())});
        } else if (const auto s = parseShardFileName(f, "dataset", ".json")) {
            found.push_back({dir, s->index, s->count, readJson(e.path())});
        }
    }
    if (found.empty()) {
        fail(dir.string() + ": no dataset.shard-I-of-N.json (not the --out of a sharded build)");
    }
    return found;
}

int64_t countOf(const Shard& s, const char* key) {
    return s.dataset.value("counts", nlohmann::json::object()).value(key, int64_t{0});
}

std::string shardName(const Shard& s) {
    return (s.dir / datasetJsonName(s.index, s.count)).string();
}

// Moves (rename, or copy + remove across file systems) or copies a directory tree.
void transfer(const fs::path& from, const fs::path& to, bool move) {
    fs::create_directories(to.parent_path());
    if (move) {
        std::error_code ec;
        fs::rename(from, to, ec);
        if (!ec) return;
    }
    fs::copy(from, to, fs::copy_options::recursive);
    if (move) fs::remove_all(from);
}

}  // namespace

MergeSummary mergeShards(const MergeOptions& o) {
    const auto start = std::chrono::steady_clock::now();
    nlohmann::json run = runLine("merge");
    if (o.shards.empty()) fail("no shard directories given");

    // --move takes the instances out of the shards: no build may run there meanwhile.
    std::vector<std::unique_ptr<OutputLock>> shardLocks;
    if (o.move) {
        std::set<fs::path> dirs;
        for (const fs::path& d : o.shards) {
            std::error_code ec;
            if (!fs::is_directory(d, ec)) continue;  // findShards says so below
            if (dirs.insert(fs::canonical(d)).second) {
                shardLocks.push_back(std::make_unique<OutputLock>(d, "sylva merge --move"));
            }
        }
    }

    // --- Check everything before writing anything ----------------------------------------
    std::vector<Shard> shards;
    for (const fs::path& d : o.shards) {
        for (Shard& s : findShards(d)) shards.push_back(std::move(s));
    }
    const Shard& first = shards.front();
    const std::string fingerprint = first.dataset.value("fingerprint", "");
    const int n = first.count;
    const int64_t total = countOf(first, "instances_in_dataset");
    std::vector<const Shard*> byIndex(static_cast<size_t>(n), nullptr);
    for (const Shard& s : shards) {
        if (s.dataset.value("fingerprint", "") != fingerprint) {
            fail(shardName(s) + ": dataset fingerprint " + s.dataset.value("fingerprint", "?") +
                 " ≠ " + fingerprint + " of " + shardName(first) + " (a build of another spec)");
        }
        if (s.count != n) {
            fail(shardName(s) + ": shard of " + std::to_string(s.count) + ", but " +
                 shardName(first) + " is a shard of " + std::to_string(n));
        }
        if (s.dataset.value("versions", nlohmann::json()) != first.dataset["versions"]) {
            fail(shardName(s) + ": built by other library versions than " + shardName(first));
        }
        if (s.dataset.value("status", "") != "complete") {
            fail(shardName(s) + ": status \"" + s.dataset.value("status", "?") +
                 "\" (rerun its build to complete it)");
        }
        if (s.index < 0 || s.index >= n) fail(shardName(s) + ": shard index out of range");
        if (byIndex[static_cast<size_t>(s.index)]) {
            fail("shard " + std::to_string(s.index) + " of " + std::to_string(n) +
                 " given twice: " + shardName(*byIndex[static_cast<size_t>(s.index)]) + " and " +
                 shardName(s));
        }
        byIndex[static_cast<size_t>(s.index)] = &s;
    }
    for (int i = 0; i < n; ++i) {
        if (!byIndex[static_cast<size_t>(i)]) {
            fail("shard " + std::to_string(i) + " of " + std::to_string(n) + " missing (no " +
                 datasetJsonName(i, n) + " in the directories given)");
        }
    }

    // Manifest lines. Shard manifests concatenated in shard order are the unsharded manifest
    // (contiguous blocks, see shardRange), so that is the merged order; each shard must record
    // exactly its block's hi - lo instances, and no id may appear twice.
    // A packed dataset's shards are blocks of whole tar shards (pack.h shardPositions).
    const nlohmann::json outputs = first.dataset.value("spec", nlohmann::json::object())
                                       .value("outputs", nlohmann::json::object());
    const int64_t perShard = outputs.value("pack", std::string("none")) == "tar"
                                 ? outputs.value("pack_instances", int64_t{256})
                                 : 0;
    const PackLayout pack = packLayout(total, perShard);
    // Checked a line at a time (nothing held per record): every line a record of the shard's
    // block, in increasing position — so none twice — and the block complete; per species the
    // first K records, for the sheets.
    const IdPositions positionOf(first.dataset);
    const nlohmann::json& specJson = first.dataset.value("spec", nlohmann::json::object());
    const int64_t sheetCount = specJson.value("outputs", nlohmann::json::object())
                                   .value("species_sheet", int64_t{16});  // dataset.cpp's default
    std::map<std::string, std::vector<Record>> sheetRecords;
    auto forEachLine =
        [&](const Shard& s,
            const std::function<void(const std::string&, const ManifestRecord&)>& f) {
            const fs::path mpath = s.dir / manifestName(s.index, s.count);
            if (!fs::exists(mpath)) fail(mpath.string() + ": missing");
            try {
                InputFile in(mpath);
                for (std::string line;;) {
                    const InputFile::Line got = in.next(line, kMaxManifestLineBytes);
                    if (got == InputFile::Line::end) break;
                    const std::string where =
                        mpath.string() + ":" + std::to_string(in.lineNumber());
                    if (got == InputFile::Line::torn) {
                        fail(where + ": torn last line (rerun the shard's build)");
                    }
                    f(line, parseManifestRecord(line, where));
                }
            } catch (const MergeError&) {
                throw;
            } catch (const InputError& e) {
                fail(e.what());
            }
            return mpath;
        };
    for (const Shard* s : byIndex) {
        const auto [lo, hi] = shardPositions(total, s->index, s->count, perShard);
        const int64_t end = hi;  // C++17 lambdas cannot capture a structured binding
        int64_t next = lo;       // the position the next record must have
        std::string packSeen;    // the last tar found (a tar shard's records are consecutive)
        const fs::path mpath = forEachLine(*s, [&](const std::string&, const ManifestRecord& m) {
            const std::string& where = m.where;
            const std::optional<int64_t> p = positionOf(m.id);
            if (!p) fail(where + ": instance " + m.id + " is not one of this dataset's");
            if (*p < next) {
                fail(where + ": instance " + m.id + " recorded twice, or out of order");
            }
            if (*p >= end) fail(where + ": instance " + m.id + " is not in this shard's block");
            if (*p > next) {
                fail(where + ": " + std::to_string(*p - next) + " instance(s) before " + m.id +
                     " not recorded (failed trees: rerun that shard's build)");
            }
            next = *p + 1;
            Record r;
            r.id = m.id;
            r.species = m.group;
            r.dir = fs::path(m.plot ? "plots" : "trees") / r.species / r.id;
            r.pack = m.pack;
            if (pack.packed() != !r.pack.empty()) {
                fail(where + ": instance " + m.id +
                     (pack.packed() ? " not packed in a packed dataset"
                                    : " packed, unlike its dataset"));
            }
            if (r.pack.empty() ? !fs::is_directory(s->dir / r.dir)
                               : r.pack != packSeen && !fs::is_regular_file(s->dir / r.pack)) {
                fail(where + ": " +
                     (s->dir / (r.pack.empty() ? r.dir : fs::path(r.pack))).string() + " missing");
            }
            packSeen = r.pack;
            std::vector<Record>& firstK = sheetRecords[r.species];
            if (!m.plot && static_cast<int64_t>(firstK.size()) < sheetCount) {
                firstK.push_back(std::move(r));
            }
        });
        if (next != hi) {
            fail(mpath.string() + ": " + std::to_string(next - lo) + " of the shard's " +
                 std::to_string(hi - lo) +
                 " instances recorded (failed trees: rerun that shard's build)");
        }
    }
    // The shards' run logs, in shard order (read before anything is written: they are files a
    // dataset supplies, each a regular file of bounded lines).
    std::string runs;
    for (const Shard* s : byIndex) {
        const fs::path log = s->dir / runLogName(s->index, s->count);
        std::error_code missing;
        if (!fs::exists(log, missing)) continue;
        try {
            InputFile in(log);
            for (std::string line; in.next(line, kMaxRunLogBytes) != InputFile::Line::end;) {
                if (!line.empty()) runs += line + "\n";
                if (runs.size() > kMaxRunLogBytes) {
                    fail(log.string() + ": the shards' run logs hold more than " +
                         formatBytes(kMaxRunLogBytes));
                }
            }
        } catch (const InputError& e) {
            fail(e.what());
        }
    }
    std::error_code ec;
    if (fs::exists(o.out) && !fs::is_directory(o.out)) {
        fail(o.out.string() + ": exists and is not an empty directory");
    }
    checkOutputDir(o.out, "OUT");

    // --- Lock OUT, assemble in a temporary sibling, then rename onto `out` ------------------
    createOutputDir(o.out, "OUT");
    auto outLock = std::make_unique<OutputLock>(o.out, "sylva merge");
    for (const auto& e : fs::directory_iterator(o.out)) {
        if (e.path() != outLock->file()) {
            fail(o.out.string() + ": exists and is not an empty directory");
        }
    }
    const fs::path out = fs::absolute(o.out).lexically_normal();
    const fs::path stage =
        out.parent_path() / ("." + out.filename().string() + ".merge." + std::to_string(getpid()));
    fs::remove_all(stage);
    fs::create_directories(stage);
    try {
        // The merged manifest, streamed: each shard's lines in shard order, each instance's
        // directory (or, packed, each tar shard with its index, once) moved or copied.
        AtomicFileWriter manifest(stage / manifestName(0, 1));
        for (const Shard* s : byIndex) {
            if (pack.packed()) {
                // The block's tar shards by number, and the manifest's bytes as they are: its
                // lines were checked above (complete, each a record).
                const auto [lo, hi] = shardPositions(total, s->index, s->count, perShard);
                for (int64_t k = lo / perShard; k * perShard < hi; ++k) {
                    const fs::path tar = pack.tarPath(k), index = packIndexPath(tar);
                    if (fs::exists(s->dir / tar)) transfer(s->dir / tar, stage / tar, o.move);
                    if (fs::exists(s->dir / index)) transfer(s->dir / index, stage / index, o.move);
                }
                std::ifstream in(s->dir / manifestName(s->index, s->count), std::ios::binary);
                std::string chunk(size_t(1) << 20, '\0');
                while (in.read(chunk.data(), static_cast<std::streamsize>(chunk.size())) ||
                       in.gcount() > 0) {
                    manifest.write(
                        std::string_view(chunk.data(), static_cast<size_t>(in.gcount())));
                }
                continue;
            }
            forEachLine(*s, [&](const std::string& line, const ManifestRecord& m) {
                const fs::path dir = fs::path(m.plot ? "plots" : "trees") / m.group / m.id;
                transfer(s->dir / dir, stage / dir, o.move);
                manifest.write(line);
                manifest.write("\n");
            });
        }
        manifest.commit();
        if (pack.packed()) {
            writePackIndex(stage, first.dataset.value("name", ""), "", pack, 0, total);
        }

        // Species sheets as buildDataset's writeSpeciesSheets: per species in spec order, its
        // first K instances' contact.png (views/000.png when contact_sheet = false).
        MergeSummary summary;
        DatasetFiles files(stage);
        for (const auto& e : first.dataset.value("species", nlohmann::json::array())) {
            const std::string name = e.value("name", "");
            std::vector<InstanceFileReader> views;
            for (const Record& r : sheetRecords[name]) {
                InstanceFileReader read = [&files, &r](const std::string& f) {
                    return files.readInstanceFile(r.id, r.pack, r.dir.string(), f);
                };
                if (read("views/000.png")) views.push_back(std::move(read));
            }
            if (views.empty()) continue;
            writeSpeciesSheet(stage / "contact" / (name + ".png"), views);
            ++summary.sheets;
        }

        // dataset.json exactly as an unsharded build writes it (the timing fields of older
        // builds' shards dropped: they are in the run logs now).
        nlohmann::json d = first.dataset;
        d["shard"] = {{"index", 0}, {"count", 1}};
        d["status"] = "complete";
        d["counts"] = {{"instances_in_dataset", total},
                       {"instances_in_shard", total},
                       {"built", total},
                       {"missing", 0}};
        for (const char* k : {"threads", "wall_seconds", "trees_per_second"}) d.erase(k);
        writeFileAtomic(stage / datasetJsonName(0, 1), d.dump(2) + "\n");

        // runs.jsonl: every shard's runs (read above), in shard order, then this merge's.
        run["status"] = "complete";
        run["shards"] = n;
        run["instances"] = total;
        run["moved"] = o.move;
        run["wall_seconds"] =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        runs += run.dump() + "\n";
        writeFileAtomic(stage / runLogName(0, 1), runs);

        // The stage takes its own lock before OUT's is given up, and keeps it as OUT.
        OutputLock stageLock(stage, "sylva merge");
        outLock.reset();
        fs::remove(out);  // empty again
        fs::rename(stage, out);
        stageLock.movedTo(out);
        summary.shardCount = n;
        summary.instances = total;
        summary.wallSeconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return summary;
    } catch (const std::exception& e) {
        if (!o.move) {
            fs::remove_all(stage, ec);
            throw;
        }
        // Moved instance directories are only in the stage now: keep it.
        throw std::runtime_error(std::string(e.what()) + " (moved instances kept in " +
                                 stage.string() + ")");
    }
}

}  // namespace sylva
