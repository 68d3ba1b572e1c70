#include "pipeline/batch/manifest_repair.h"

#include <algorithm>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <unordered_set>

#include "core/atomic_file.h"
#include "core/errors.h"

namespace sylva {

namespace fs = std::filesystem;

ManifestRepair repairManifest(
    const fs::path& path,
    const std::function<std::optional<size_t>(const std::string& id)>& position) {
    ManifestRepair r;
    std::error_code ec;
    if (!fs::exists(path, ec)) return r;
    std::string data;
    {
        std::ifstream in(path, std::ios::binary);
        if (!in) throw std::runtime_error("cannot read '" + path.string() + "'");
        data.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    struct Kept {
        size_t pos;
        std::string id, line;
    };
    std::vector<Kept> kept;
    std::unordered_set<std::string> seen;
    size_t start = 0, lineNo = 0;
    for (size_t nl; (nl = data.find('\n', start)) != std::string::npos; start = nl + 1) {
        ++lineNo;
        std::string line = data.substr(start, nl - start);
        auto j = nlohmann::json::parse(line, nullptr, false);
        if (j.is_discarded() || !j.is_object() || !j.contains("id") || !j["id"].is_string()) {
            ++r.unreadable;  // e.g. a torn line another run appended after
            continue;
        }
        std::string id = j["id"].get<std::string>();
        const std::optional<size_t> pos = position(id);
        if (!pos) {
            throw InputError(path.string() + ":" + std::to_string(lineNo) + ": instance " + id +
                             " is not one this build makes (a manifest of another dataset or "
                             "shard); use another --out");
        }
        if (!seen.insert(id).second) {
            ++r.duplicates;
            continue;
        }
        kept.push_back({*pos, std::move(id), std::move(line)});
    }
    if (start < data.size()) {
        ++r.unreadable;
        r.tornLast = true;
    }
    r.reordered = !std::is_sorted(kept.begin(), kept.end(),
                                  [](const Kept& a, const Kept& b) { return a.pos < b.pos; });
    if (r.reordered) {
        std::stable_sort(kept.begin(), kept.end(),
                         [](const Kept& a, const Kept& b) { return a.pos < b.pos; });
    }
    r.lines.reserve(kept.size());
    r.ids.reserve(kept.size());
    std::string repaired;
    for (Kept& k : kept) {
        repaired += k.line;
        repaired += '\n';
        r.ids.push_back(std::move(k.id));
        r.lines.push_back(std::move(k.line));
    }
    if (repaired != data) {
        writeFileAtomic(path, repaired);
        r.rewritten = true;
    }
    return r;
}

}  // namespace sylva
