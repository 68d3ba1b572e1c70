#include "pipeline/analysis/dataset_reader.h"

#include <algorithm>
#include <array>
#include <string_view>
#include <system_error>
#include <unordered_set>
#include <utility>

#include "core/errors.h"
#include "core/input_file.h"
#include "pipeline/batch/pack.h"

namespace sylva {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

[[noreturn]] void fail(const std::string& where, const std::string& what) {
    throw InputError(where + ": " + what);
}

// The most arrays and objects open at once in `text`, brackets inside strings not counted (a
// bound for any text, JSON or not).
int bracketDepth(const std::string& text) {
    int depth = 0, deepest = 0;
    bool inString = false;
    for (size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (inString) {
            if (c == '\\')
                ++i;
            else if (c == '"')
                inString = false;
        } else if (c == '"') {
            inString = true;
        } else if (c == '[' || c == '{') {
            deepest = std::max(deepest, ++depth);
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
    return deepest;
}

// Parses `text` as JSON, refusing nesting deeper than kMaxRecordDepth (a deep array would take a
// reader that walks it recursively off its stack). Discarded on a syntax error. The parser's
// callback sees at most as many levels as brackets are open, so text no deeper than the limit
// by its brackets is parsed without the callback (a third of a record's parse), to the same value.
json parseBounded(const std::string& text, bool& tooDeep) {
    tooDeep = false;
    if (bracketDepth(text) <= kMaxRecordDepth) return json::parse(text, nullptr, false);
    json::parser_callback_t depthCheck = [&](int depth, json::parse_event_t, json&) {
        if (depth > kMaxRecordDepth) tooDeep = true;
        return !tooDeep;
    };
    return json::parse(text, depthCheck, false);
}

// One directory name: what a record's id and species become under trees/ or plots/.
bool isDirectoryName(const std::string& s) {
    if (s.empty() || s == "." || s == ".." || s.size() > 255) return false;
    return std::none_of(s.begin(), s.end(), [](char c) {
        return c == '/' || c == '\\' || static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
    });
}

}  // namespace

bool isPathInside(const std::string& s) {
    if (s.empty() || s.find('\0') != std::string::npos || s.find('\\') != std::string::npos)
        return false;
    // On POSIX a path is absolute, or has a root, exactly when it starts with '/', and '/' is the
    // only separator: the path's elements are the runs between slashes. Split by hand, not by
    // std::filesystem::path, which allocates every element (6 % of `sylva stats` on packed
    // records, which each name their shard).
    if (s.front() == '/') return false;
    for (size_t start = 0; start <= s.size();) {
        size_t end = s.find('/', start);
        if (end == std::string::npos) end = s.size();
        if (s.compare(start, end - start, "..") == 0) return false;
        start = end + 1;
    }
    return true;
}

namespace {

bool isCount(const json& v) { return v.is_number_unsigned() || (v.is_number_integer() && v >= 0); }

// Every key parseManifestRecord checks.
constexpr std::array<std::string_view, 17> kRecordKeys = {
    "id",     "index", "species", "plot",          "habit", "method", "kind",  "seed", "sweep",
    "params", "stats", "timing",  "bytes_written", "trees", "pack",   "files", "scan"};

void needs(bool ok, const std::string& where, const std::string& key, const char* expected) {
    if (!ok) fail(where, key + ": expected " + expected);
}

}  // namespace

ManifestRecord parseManifestRecord(const std::string& line, const std::string& where) {
    bool tooDeep = false;
    ManifestRecord r;
    r.json = parseBounded(line, tooDeep);
    r.where = where;
    if (tooDeep) {
        fail(where, "nested more than " + std::to_string(kMaxRecordDepth) +
                        " deep (not a manifest record)");
    }
    if (r.json.is_discarded() || !r.json.is_object()) {
        fail(where, "not a manifest record (a JSON object with id, index and species or plot)");
    }
    const json& j = r.json;
    // The keys a record may have, found in one pass over its members (a lookup by name each
    // was a fifth of `sylva stats` on large manifests); checked below in a fixed order.
    std::array<const json*, kRecordKeys.size()> found{};
    for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string& key = it.key();
        for (size_t k = 0; k < kRecordKeys.size(); ++k) {
            if (key == kRecordKeys[k]) {
                found[k] = &*it;
                break;
            }
        }
    }
    auto get = [&](std::string_view key) -> const json* {
        for (size_t k = 0; k < kRecordKeys.size(); ++k)
            if (kRecordKeys[k] == key) return found[k];
        return nullptr;
    };
    auto has = [&](std::string_view key) { return get(key) != nullptr; };
    const json* id = get("id");
    needs(id && id->is_string(), where, "id", "a string");
    r.id = id->get<std::string>();
    needs(isDirectoryName(r.id), where, "id",
          "one directory name (not empty, \".\" or \"..\", no '/', '\\' or control characters)");
    const json* index = get("index");
    needs(index && index->is_number_integer() && isCount(*index), where, "index",
          "an integer >= 0");
    r.index = index->get<int64_t>();
    r.plot = !has("species") && has("plot");
    const char* group = r.plot ? "plot" : "species";
    const json* groupValue = get(group);
    needs(groupValue && groupValue->is_string(), where, group,
          r.plot ? "a string" : "a string (a record names its species, or its plot)");
    r.group = groupValue->get<std::string>();
    needs(isDirectoryName(r.group), where, group, "one directory name");
    for (const char* key : {"habit", "method", "kind"}) {
        if (const json* v = get(key)) needs(v->is_string(), where, key, "a string");
    }
    if (const json* seed = get("seed")) {
        needs(seed->is_string() || isCount(*seed), where, "seed", "a string or an integer >= 0");
    }
    for (const char* key : {"sweep", "params", "stats", "timing", "scan"}) {
        if (const json* v = get(key)) needs(v->is_object(), where, key, "an object");
    }
    for (const char* key : {"bytes_written", "trees"}) {
        if (const json* v = get(key)) needs(isCount(*v), where, key, "an integer >= 0");
    }
    if (const json* pack = get("pack")) {
        if (pack->is_string()) r.pack = pack->get<std::string>();
        needs(pack->is_string() && isPathInside(r.pack) && hasTarExtension(r.pack), where, "pack",
              "a relative path inside the dataset to a .tar shard");
    }
    if (const json* files = get("files")) {
        needs(files->is_object(), where, "files", "an object");
        for (const auto& [k, v] : files->items()) {
            needs(v.is_string() && isPathInside(v.get<std::string>()), where, "files." + k,
                  "a relative path inside the dataset (no \"..\")");
        }
    }
    return r;
}

namespace {

// The files `<stem>.shard-I-of-N.<ext>` of `dir`, ordered by (N, I).
std::vector<fs::path> shardFiles(const fs::path& dir, const std::string& stem,
                                 const std::string& ext) {
    std::vector<std::pair<std::pair<int, int>, fs::path>> shards;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::string file = e.path().filename().string();
        if (const auto s = parseShardFileName(file, stem, "." + ext)) {
            shards.push_back({{s->count, s->index}, e.path()});
        }
    }
    std::sort(shards.begin(), shards.end());
    std::vector<fs::path> files;
    for (auto& s : shards) files.push_back(std::move(s.second));
    return files;
}

}  // namespace

std::vector<fs::path> manifestFiles(const fs::path& dir) {
    std::vector<fs::path> files;
    std::error_code ec;
    if (fs::exists(dir / "manifest.jsonl", ec)) files.push_back(dir / "manifest.jsonl");
    for (fs::path& f : shardFiles(dir, "manifest", "jsonl")) files.push_back(std::move(f));
    return files;
}

namespace {

// Every complete record of `dir`'s manifests to `f`, in file order. Ids are remembered (and a
// record of one already seen left out, counted in `duplicates`) when `everyId`, else only where
// a whole manifest lies beside shard manifests (a merge done in place: each record twice).
ManifestStream streamManifests(const fs::path& dir, bool everyId,
                               const std::function<void(ManifestRecord&)>& f, size_t& duplicates) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) throw InputError(dir.string() + ": not a directory");
    const std::vector<fs::path> files = manifestFiles(dir);
    if (files.empty()) {
        throw InputError(dir.string() +
                         ": no manifest.jsonl or manifest.shard-*.jsonl (not a dataset "
                         "directory)");
    }
    ManifestStream out;
    const bool remember =
        everyId || (files.size() > 1 && files.front().filename() == "manifest.jsonl");
    std::unordered_set<std::string> seen;
    for (const fs::path& file : files) {
        out.files.push_back(file.filename().string());
        InputFile in(file);
        std::string line;
        for (InputFile::Line got;
             (got = in.next(line, kMaxManifestLineBytes)) != InputFile::Line::end;) {
            if (got == InputFile::Line::torn) {
                ++out.tornLines;
                break;
            }
            if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
            ManifestRecord r =
                parseManifestRecord(line, file.string() + ":" + std::to_string(in.lineNumber()));
            if (remember && !seen.insert(r.id).second) {
                ++duplicates;
                continue;
            }
            ++out.records;
            f(r);
        }
    }
    return out;
}

}  // namespace

ManifestRead readManifests(const fs::path& dir) {
    ManifestRead out;
    const ManifestStream s = streamManifests(
        dir, true, [&](ManifestRecord& r) { out.records.push_back(std::move(r)); }, out.duplicates);
    out.files = s.files;
    out.tornLines = s.tornLines;
    return out;
}

ManifestStream forEachManifestRecord(const fs::path& dir,
                                     const std::function<void(ManifestRecord&)>& f) {
    size_t duplicates = 0;
    return streamManifests(dir, false, f, duplicates);
}

json readDatasetJsonFile(const fs::path& file) {
    const std::string where = file.string();
    bool tooDeep = false;
    const json j =
        parseBounded(readInputFile(file, kMaxDatasetJsonBytes, "a dataset description"), tooDeep);
    if (tooDeep) fail(where, "nested more than " + std::to_string(kMaxRecordDepth) + " deep");
    if (j.is_discarded()) fail(where, "not JSON");
    if (!j.is_object()) fail(where, "expected a JSON object (a dataset description)");
    auto has = [&](const char* key) { return j.contains(key); };
    needs(has("name") && j["name"].is_string(), where, "name", "a string");
    for (const char* key : {"description", "status", "fingerprint"}) {
        if (has(key)) needs(j[key].is_string(), where, key, "a string");
    }
    if (has("seed")) {
        needs(j["seed"].is_string() || j["seed"].is_number_integer(), where, "seed",
              "an integer or a string");
    }
    for (const char* key : {"versions", "spec"}) {
        if (has(key)) needs(j[key].is_object(), where, key, "an object");
    }
    if (has("counts")) {
        needs(j["counts"].is_object(), where, "counts", "an object");
        for (const auto& [k, v] : j["counts"].items()) {
            needs(isCount(v), where, "counts." + k, "an integer >= 0");
        }
    }
    if (has("species")) {
        needs(j["species"].is_array(), where, "species", "an array");
        for (size_t i = 0; i < j["species"].size(); ++i) {
            const json& s = j["species"][i];
            needs(s.is_object() && s.contains("name") && s["name"].is_string(), where,
                  "species[" + std::to_string(i) + "]", "an object with a string name");
        }
    }
    if (has("shard")) {
        const json& s = j["shard"];
        needs(s.is_object() && s.contains("index") && isCount(s["index"]) && s.contains("count") &&
                  s["count"].is_number_integer() && s["count"] >= 1 && s["index"] < s["count"],
              where, "shard", "an object with integers 0 <= index < count");
    }
    return j;
}

json readDatasetDescription(const fs::path& dir) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) throw InputError(dir.string() + ": not a directory");
    if (fs::exists(dir / "dataset.json", ec)) return readDatasetJsonFile(dir / "dataset.json");
    const std::vector<fs::path> shards = shardFiles(dir, "dataset", "json");
    if (shards.empty()) {
        throw InputError(dir.string() + ": no dataset.json (not a dataset directory)");
    }
    for (size_t i = 1; i < shards.size(); ++i) readDatasetJsonFile(shards[i]);
    return readDatasetJsonFile(shards.front());
}

}  // namespace sylva
