#include "pipeline/analysis/species_list.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <exception>
#include <stdexcept>

#include "core/params.h"
#include "pipeline/batch/dataset.h"
#include "species/spec/species.h"

namespace fs = std::filesystem;

namespace sylva {

namespace {

// A failure as one line (SpecError messages already are: file:line:col: key: message).
std::string oneLine(const std::exception& e) {
    std::string s = e.what();
    std::replace(s.begin(), s.end(), '\n', ' ');
    return s;
}

void loadEntry(const fs::path& file, SpeciesListEntry& e, bool& isDataset) {
    isDataset = false;
    e.path = file.string();
    e.name = file.stem().string();
    try {
        toml::table t = parseTomlFile(e.path);
        if (isDatasetFile(t)) {
            isDataset = true;
            return;
        }
        SpeciesFile s = loadSpecies(e.path);
        e.name = s.name;
        e.method = s.method;
        e.description = s.description;
        validateSpecies(s, nullptr);
    } catch (const std::exception& x) {  // SpecError, or an I/O or library failure
        e.error = oneLine(x);
    }
    if (!e.error.empty()) e.method.clear(), e.description.clear();
}

// Terminal columns of UTF-8 text (descriptions use ×, —, ≈): one per code point.
size_t columns(const std::string& s) {
    return static_cast<size_t>(std::count_if(
        s.begin(), s.end(), [](char c) { return (static_cast<unsigned char>(c) & 0xC0) != 0x80; }));
}

std::optional<fs::path> speciesDirAbove(fs::path dir) {
    std::error_code ec;
    for (; !dir.empty(); dir = dir.parent_path()) {
        fs::path candidate = dir / "species";
        if (fs::is_directory(candidate / "presets", ec)) return candidate;
        if (dir == dir.parent_path()) break;
    }
    return std::nullopt;
}

}  // namespace

std::vector<SpeciesListEntry> listSpecies(const fs::path& dir) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) {
        throw InputError(dir.string() + ": not a directory");
    }
    std::vector<fs::path> files;
    for (auto it =
             fs::recursive_directory_iterator(dir, fs::directory_options::skip_permission_denied);
         it != fs::recursive_directory_iterator(); ++it) {
        if (it->is_regular_file() && it->path().extension() == ".toml") files.push_back(it->path());
    }
    std::sort(files.begin(), files.end());  // a fixed order, whatever the directory's
    std::vector<SpeciesListEntry> entries(files.size());
    std::vector<char> dataset(files.size(), 0);
    // Validation builds crowns (level sets, CGAL surfaces): one file per task.
    tbb::parallel_for(size_t(0), files.size(), [&](size_t i) {
        bool isDataset = false;
        loadEntry(files[i], entries[i], isDataset);
        dataset[i] = isDataset;
    });
    std::vector<SpeciesListEntry> out;
    for (size_t i = 0; i < files.size(); ++i) {
        if (!dataset[i]) out.push_back(std::move(entries[i]));
    }
    // The library first, then the papers' reproductions (files under a `papers/` folder).
    auto inPapers = [&](const SpeciesListEntry& e) {
        const fs::path rel = fs::path(e.path).lexically_relative(dir);
        return std::any_of(rel.begin(), rel.end(), [](const fs::path& c) { return c == "papers"; });
    };
    std::stable_sort(out.begin(), out.end(), [&](const auto& a, const auto& b) {
        const bool pa = inPapers(a), pb = inPapers(b);
        if (pa != pb) return pb;
        return a.name != b.name ? a.name < b.name : a.path < b.path;
    });
    return out;
}

std::string formatSpeciesList(const std::vector<SpeciesListEntry>& entries) {
    struct Row {
        std::string cols[4];
    };
    std::vector<Row> rows;
    size_t width[3] = {0, 0, 0};
    for (const SpeciesListEntry& e : entries) {
        Row r{{e.name, e.error.empty() ? e.method : "-",
               e.error.empty() ? e.description : "error: " + e.error, e.path}};
        // An error row does not widen the description column (its message is long and names
        // the file already); it overflows it instead.
        const int counted = e.error.empty() ? 3 : 2;
        for (int c = 0; c < counted; ++c) width[c] = std::max(width[c], columns(r.cols[c]));
        rows.push_back(std::move(r));
    }
    std::string s;
    for (const Row& r : rows) {
        for (int c = 0; c < 3; ++c) {
            s += r.cols[c];
            s.append(width[c] - std::min(width[c], columns(r.cols[c])) + 2, ' ');
        }
        s += r.cols[3];
        s += '\n';
    }
    return s;
}

std::optional<fs::path> defaultSpeciesDir(const fs::path& executable) {
    std::error_code ec;
    fs::path exe = fs::weakly_canonical(executable, ec);
    if (!ec && !exe.empty()) {
        if (auto d = speciesDirAbove(exe.parent_path())) return d;
    }
    fs::path cwd = fs::current_path(ec);
    if (!ec) return speciesDirAbove(cwd);
    return std::nullopt;
}

}  // namespace sylva
