#include "pipeline/batch/pack.h"

#include <algorithm>
#include <cstdio>
#include <set>

#include "core/atomic_file.h"
#include "core/errors.h"
#include "core/input_file.h"
#include "pipeline/batch/build.h"
#include "pipeline/batch/instance.h"

namespace sylva {

namespace fs = std::filesystem;

namespace {

constexpr char kIndexFormat[] = "sylva-tar-index-1";
// The largest shard index read back (about 100 bytes per member).
constexpr uint64_t kMaxIndexBytes = uint64_t(1) << 30;
// The largest instance file packed (a plot's scene meshes can take a few GB).
constexpr uint64_t kMaxMemberBytes = uint64_t(64) << 30;

// Calls f on every string in `v` (objects and arrays walked), which it may replace.
void forEachString(nlohmann::json& v, const std::function<void(nlohmann::json&)>& f) {
    if (v.is_object() || v.is_array()) {
        for (auto& e : v) forEachString(e, f);
    } else if (v.is_string()) {
        f(v);
    }
}

// The shard number a file of shards/ starts with ("000003.tar", "000003.index.json.tmp.…"),
// if it is one of the tar shards of positions [lo, hi).
std::optional<int64_t> shardInRange(const std::string& name, const PackLayout& layout, int64_t lo,
                                    int64_t hi) {
    const std::string digits = name.substr(0, name.find('.'));
    if (digits.empty() || digits.size() > 18 ||
        digits.find_first_not_of("0123456789") != std::string::npos) {
        return std::nullopt;
    }
    const int64_t k = std::atoll(digits.c_str());
    if (k * layout.perShard < lo || k * layout.perShard >= hi) return std::nullopt;
    return k;
}

// Every regular file under `dir`, as paths relative to it ('/'-separated), sorted; temp files
// of interrupted writes ("<name>.tmp.<pid>…") left out.
std::vector<std::string> filesUnder(const fs::path& dir) {
    std::vector<std::string> files;
    for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator();
         ++it) {
        if (!it->is_regular_file()) continue;
        const std::string rel = it->path().lexically_relative(dir).generic_string();
        if (it->path().filename().string().find(".tmp.") != std::string::npos) continue;
        files.push_back(rel);
    }
    std::sort(files.begin(), files.end());
    return files;
}

// The references between an instance's files, renamed to member names (in the tar the files
// are siblings): in a JSON file (transforms.json's frames, a plot's files) every string naming
// a file of the instance relative to the JSON's directory; in an OBJ its `mtllib`, in an MTL
// its texture maps (`map_*`). Other files are returned as they are.
std::string rewriteReferences(std::string bytes, const std::string& id, const std::string& relPath,
                              const std::set<std::string>& files) {
    const fs::path base = fs::path(relPath).parent_path();
    auto member = [&](const std::string& ref) -> std::optional<std::string> {
        const std::string target = (base / ref).lexically_normal().generic_string();
        if (!files.count(target)) return std::nullopt;
        return packMemberName(id, target);
    };
    const std::string ext = fs::path(relPath).extension().string();
    if (ext == ".json" && relPath != kPackRecordFile) {
        nlohmann::json j = nlohmann::json::parse(bytes, nullptr, false);
        if (j.is_discarded()) return bytes;
        bool changed = false;
        forEachString(j, [&](nlohmann::json& v) {
            if (auto m = member(v.get<std::string>())) {
                v = *m;
                changed = true;
            }
        });
        return changed ? j.dump(2) + "\n" : bytes;
    }
    if (ext != ".obj" && ext != ".mtl") return bytes;
    // Line by line: "<keyword> <file>" with the file the rest of the line.
    std::string out;
    out.reserve(bytes.size() + 64);
    for (size_t at = 0; at < bytes.size();) {
        size_t end = bytes.find('\n', at);
        end = end == std::string::npos ? bytes.size() : end + 1;
        const std::string_view line(bytes.data() + at, end - at);
        const size_t space = line.find(' ');
        const std::string_view key = line.substr(0, space);
        if (space != std::string_view::npos &&
            (ext == ".obj" ? key == "mtllib" : key.rfind("map_", 0) == 0)) {
            std::string_view ref = line.substr(space + 1);
            while (!ref.empty() && (ref.back() == '\n' || ref.back() == '\r')) ref.remove_suffix(1);
            if (auto m = member(std::string(ref))) {
                out.append(key).append(" ").append(*m).append(line.substr(space + 1 + ref.size()));
                at = end;
                continue;
            }
        }
        out.append(line);
        at = end;
    }
    return out;
}

// Writes the shard's index beside it.
void writeIndex(const fs::path& tar, uint64_t bytes, const nlohmann::json& samples) {
    nlohmann::json j;
    j["format"] = kIndexFormat;
    j["tar"] = tar.filename().string();
    j["bytes"] = bytes;
    j["samples"] = samples;
    writeFileAtomic(packIndexPath(tar), j.dump() + "\n");
}

}  // namespace

fs::path packIndexPath(const fs::path& tar) {
    fs::path p = tar;
    p.replace_extension(".index.json");
    return p;
}

std::string PackLayout::tarName(int64_t shard) const {
    char buf[48];
    std::snprintf(buf, sizeof buf, "%0*lld.tar", width, static_cast<long long>(shard));
    return buf;
}

PackLayout packLayout(int64_t datasetSize, int64_t perShard) {
    PackLayout l;
    if (perShard <= 0) return l;
    l.perShard = perShard;
    l.shards = (datasetSize + perShard - 1) / perShard;
    l.width = std::max<int>(
        6, static_cast<int>(std::to_string(std::max<int64_t>(l.shards - 1, 0)).size()));
    return l;
}

std::pair<int64_t, int64_t> shardPositions(int64_t datasetSize, int index, int count,
                                           int64_t perShard) {
    if (perShard <= 0) {
        const auto [lo, hi] = shardRange(static_cast<size_t>(datasetSize), index, count);
        return {static_cast<int64_t>(lo), static_cast<int64_t>(hi)};
    }
    const int64_t units = (datasetSize + perShard - 1) / perShard;
    const auto [ulo, uhi] = shardRange(static_cast<size_t>(units), index, count);
    return {std::min(static_cast<int64_t>(ulo) * perShard, datasetSize),
            std::min(static_cast<int64_t>(uhi) * perShard, datasetSize)};
}

bool hasTarExtension(std::string_view path) {
    const std::string_view name = path.substr(path.rfind('/') + 1);  // npos + 1 is 0
    return name.size() > 4 && name.substr(name.size() - 4) == ".tar";
}

std::string packMemberName(std::string_view id, std::string_view relPath) {
    if (relPath == kPackRecordFile) return std::string(id) + ".json";
    std::string name = std::string(id) + "." + std::string(relPath);
    std::replace(name.begin() + static_cast<std::ptrdiff_t>(id.size()), name.end(), '/', '.');
    return name;
}

void packRecordFiles(nlohmann::json& record, const std::string& id, const std::string& rel,
                     const std::string& tarPath) {
    record["pack"] = tarPath;
    const std::string prefix = rel + "/";
    if (!record.contains("files")) return;
    forEachString(record["files"], [&](nlohmann::json& v) {
        const std::string s = v.get<std::string>();
        if (s.rfind(prefix, 0) == 0) v = packMemberName(id, s.substr(prefix.size()));
    });
}

std::vector<PackSample> readPackSamples(const fs::path& tar) {
    std::error_code ec;
    const uint64_t size = fs::file_size(tar, ec);
    if (ec) return {};
    const fs::path index = packIndexPath(tar);
    if (fs::exists(index, ec)) {
        const nlohmann::json j = nlohmann::json::parse(
            readInputFile(index, kMaxIndexBytes, "a tar shard index"), nullptr, false);
        if (j.is_object() && j.value("format", "") == kIndexFormat &&
            j.value("bytes", uint64_t{0}) == size && j.contains("samples") &&
            j["samples"].is_array()) {
            std::vector<PackSample> samples;
            bool ok = true;
            for (const auto& s : j["samples"]) {
                PackSample p;
                p.key = s.value("key", "");
                p.position = s.value("position", int64_t{-1});
                for (const auto& m : s.value("members", nlohmann::json::array())) {
                    if (!m.is_array() || m.size() != 3) {
                        ok = false;
                        break;
                    }
                    TarMember t{m[0].get<std::string>(), m[1].get<uint64_t>(),
                                m[2].get<uint64_t>()};
                    if (t.offset > size || t.size > size - t.offset) ok = false;
                    p.members.push_back(std::move(t));
                }
                samples.push_back(std::move(p));
            }
            if (ok) return samples;
        }
    }
    std::vector<PackSample> samples;
    for (TarMember& m : indexTar(tar)) {
        const std::string key = m.name.substr(0, m.name.find('.'));
        if (samples.empty() || samples.back().key != key) samples.push_back({key, -1, {}});
        samples.back().members.push_back(std::move(m));
    }
    return samples;
}

void writePackStage(const fs::path& dir,
                    const std::vector<std::pair<std::string, std::string>>& files) {
    TarWriter writer(dir / kPackStageFile);
    for (const auto& [name, bytes] : files) writer.add(name, bytes);
    writer.commit();
}

std::vector<std::pair<std::string, std::string>> readInstanceFiles(const fs::path& dir) {
    std::vector<std::pair<std::string, std::string>> out;
    for (const std::string& f : filesUnder(dir)) {
        if (f != kPackStageFile) {
            out.emplace_back(f, readInputFile(dir / f, kMaxMemberBytes, "an instance file"));
            continue;
        }
        const fs::path staged = dir / f;
        const std::string archive = readInputFile(staged, kMaxMemberBytes, "a staged instance");
        for (const TarMember& m : indexTar(staged)) {
            out.emplace_back(m.name, archive.substr(m.offset, m.size));
        }
    }
    std::sort(out.begin(), out.end());
    return out;
}

void sealPackShard(const fs::path& out, const DatasetInstances& instances, const PackLayout& layout,
                   int64_t shard, const std::vector<int64_t>& positions) {
    const fs::path tar = out / layout.tarPath(shard);
    std::map<std::string, PackSample> old;
    for (PackSample& s : readPackSamples(tar)) old.emplace(s.key, std::move(s));
    TarWriter writer(tar);
    nlohmann::json samples = nlohmann::json::array();
    std::vector<fs::path> packedDirs;
    for (const int64_t p : positions) {
        const InstanceJob job = instances[p];
        const fs::path dir = out / instanceDir(job);
        nlohmann::json members = nlohmann::json::array();
        std::error_code ec;
        if (auto it = old.find(job.id); it != old.end()) {
            // The shard already holds it: a run killed while removing the packed directories
            // may have left this one partly removed, so the tar's copy is the one to keep.
            for (const TarMember& from : it->second.members) {
                const TarMember m = writer.add(from.name, readTarMember(tar, from));
                members.push_back({m.name, m.offset, m.size});
            }
            if (fs::exists(dir, ec)) packedDirs.push_back(dir);
        } else if (fs::is_directory(dir, ec)) {
            std::vector<std::pair<std::string, std::string>> files = readInstanceFiles(dir);
            std::set<std::string> fileSet;
            for (const auto& [f, bytes] : files) fileSet.insert(f);
            std::vector<std::pair<std::string, std::string>> named;
            for (auto& [f, bytes] : files) {
                named.emplace_back(packMemberName(job.id, f),
                                   rewriteReferences(std::move(bytes), job.id, f, fileSet));
            }
            std::sort(named.begin(), named.end());
            for (const auto& [name, bytes] : named) {
                const TarMember m = writer.add(name, bytes);
                members.push_back({m.name, m.offset, m.size});
            }
            packedDirs.push_back(dir);
        } else {
            std::fprintf(stderr,
                         "sylva: %s: recorded, but neither %s nor %s holds it (rebuild it: "
                         "remove its line from the manifest and rerun)\n",
                         job.id.c_str(), dir.string().c_str(), tar.string().c_str());
            continue;
        }
        samples.push_back({{"key", job.id}, {"position", p}, {"members", members}});
    }
    if (samples.empty()) return;
    writer.commit();
    writeIndex(tar, fs::file_size(tar), samples);
    for (const fs::path& d : packedDirs) fs::remove_all(d);
}

namespace {

// Calls f(position, dir) for each instance directory of [lo, hi) on disk.
template <class F>
void forEachInstanceDir(const fs::path& out, const DatasetInstances& instances, int64_t lo,
                        int64_t hi, F f) {
    const DatasetSpec& spec = instances.spec();
    const size_t groups = instances.speciesCount() + spec.plots.size();
    std::set<fs::path> parents;
    for (size_t g = 0; g < groups; ++g) {
        const auto [begin, end] = instances.speciesRange(g);
        if (std::max(begin, lo) >= std::min(end, hi)) continue;
        parents.insert(g < instances.speciesCount()
                           ? fs::path("trees") / spec.species[g].species.name
                           : fs::path("plots") / spec.plots[g - instances.speciesCount()].name);
    }
    for (const fs::path& parent : parents) {
        std::error_code ec;
        std::vector<std::pair<int64_t, fs::path>> found;
        for (fs::directory_iterator it(out / parent, ec), end; !ec && it != end; it.increment(ec)) {
            if (!it->is_directory()) continue;
            const std::optional<int64_t> p = instances.find(it->path().filename().string());
            if (p && *p >= lo && *p < hi) found.emplace_back(*p, it->path());
        }
        for (const auto& [p, dir] : found) f(p, dir);
    }
}

}  // namespace

std::vector<int64_t> unsealedPackShards(const fs::path& out, const DatasetInstances& instances,
                                        const PackLayout& layout, int64_t lo, int64_t hi) {
    std::set<int64_t> shards;
    forEachInstanceDir(out, instances, lo, hi,
                       [&](int64_t p, const fs::path&) { shards.insert(layout.shardOf(p)); });
    return {shards.begin(), shards.end()};
}

void removeStalePackFiles(const fs::path& out, const DatasetInstances& instances,
                          const PackLayout& layout, int64_t lo, int64_t hi,
                          const std::function<bool(int64_t)>& recorded) {
    std::error_code ec;
    std::vector<fs::path> stale;
    for (fs::directory_iterator it(out / "shards", ec), end; !ec && it != end; it.increment(ec)) {
        // "<digits>.tar.tmp.…" or "<digits>.index.json.tmp.…" of a shard in [lo, hi).
        const std::string name = it->path().filename().string();
        if (name.find(".tmp.") != std::string::npos && shardInRange(name, layout, lo, hi)) {
            stale.push_back(it->path());
        }
    }
    for (const fs::path& p : stale) fs::remove(p, ec);
    std::vector<fs::path> failed;
    forEachInstanceDir(out, instances, lo, hi, [&](int64_t p, const fs::path& dir) {
        if (!recorded(p)) failed.push_back(dir);
    });
    for (const fs::path& d : failed) fs::remove_all(d, ec);
}

void writePackIndex(const fs::path& out, const std::string& datasetName, const std::string& suffix,
                    const PackLayout& layout, int64_t lo, int64_t hi) {
    std::vector<std::pair<int64_t, fs::path>> tars;
    std::error_code ec;
    for (fs::directory_iterator it(out / "shards", ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (!hasTarExtension(name)) continue;
        if (const auto k = shardInRange(name, layout, lo, hi)) tars.emplace_back(*k, it->path());
    }
    std::sort(tars.begin(), tars.end());
    nlohmann::json list = nlohmann::json::array();
    for (const auto& [k, tar] : tars) {
        list.push_back({{"url", tar.filename().string()},
                        {"nsamples", readPackSamples(tar).size()},
                        {"filesize", fs::file_size(tar)}});
    }
    nlohmann::json j;
    j["__kind__"] = "wids-shard-index-v1";
    j["wids_version"] = 1;
    j["name"] = datasetName;
    j["shardlist"] = list;
    writeFileAtomic(out / "shards" / ("index" + suffix + ".json"), j.dump(2) + "\n");
}

std::optional<std::string> DatasetFiles::member(const std::string& tarPath,
                                                const std::string& name) {
    const fs::path tar = dir_ / tarPath;
    TarMember m;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        auto it = tars_.find(tarPath);
        if (it == tars_.end()) {
            std::map<std::string, TarMember, std::less<>> byName;
            std::error_code ec;
            if (fs::exists(tar, ec)) {
                for (PackSample& s : readPackSamples(tar)) {
                    for (TarMember& t : s.members) byName.emplace(t.name, std::move(t));
                }
            }
            it = tars_.emplace(tarPath, std::move(byName)).first;
        }
        auto found = it->second.find(name);
        if (found == it->second.end()) return std::nullopt;
        m = found->second;
    }
    if (m.size > kMaxMemberBytes) {
        throw InputError(tar.string() + ": member " + name + " larger than " +
                         std::to_string(kMaxMemberBytes >> 30) + " GiB");
    }
    return readTarMember(tar, m);
}

std::optional<std::string> DatasetFiles::read(const std::string& pack, const std::string& file) {
    if (!pack.empty()) return member(pack, file);
    std::error_code ec;
    const fs::path p = dir_ / file;
    if (!fs::is_regular_file(p, ec)) return std::nullopt;
    return readInputFile(p, kMaxMemberBytes, "an instance file");
}

std::optional<std::string> DatasetFiles::readInstanceFile(const std::string& id,
                                                          const std::string& tarPath,
                                                          const std::string& instanceDir,
                                                          const std::string& relPath) {
    std::error_code ec;
    const fs::path p = dir_ / instanceDir / relPath;
    if (fs::is_regular_file(p, ec)) return readInputFile(p, kMaxMemberBytes, "an instance file");
    const fs::path staged = dir_ / instanceDir / kPackStageFile;
    if (fs::is_regular_file(staged, ec)) {
        for (const TarMember& m : indexTar(staged)) {
            if (m.name == relPath) return readTarMember(staged, m);
        }
    }
    if (tarPath.empty()) return std::nullopt;
    return member(tarPath, packMemberName(id, relPath));
}

}  // namespace sylva
