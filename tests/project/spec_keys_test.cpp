// The spec-key documentation cannot go stale: every key the readers accept is documented in
// docs/, and every documented key is accepted.
//
// Accepted keys come from the readers themselves: the parameter reader records every key a
// reader asks for (core/params.h, KeyLog) while every species and dataset file of the
// repository is read — the presets, the shipped datasets, the test specs, and the specs in
// tests/data/keys/ that exist to reach the keys no other file uses. Documented keys are the
// first-column keys of the tables that follow a `<!-- spec-keys: CONTEXT -->` line in any
// docs/**/*.md file. A key is written as a path relative to CONTEXT: `graph.linking`,
// `[crown]` or `[[levels]]` (brackets around a whole table name are dropped), `levels[i].nodes`
// (any index becomes `[]`), `rules.<state>` (any `<name>` is a name the user chooses, `*`).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "core/params.h"
#include "pipeline/analysis/fit.h"
#include "pipeline/batch/dataset.h"
#include "pipeline/scan/scan_options.h"
#include "species/spec/species.h"
#include "tests/test_support.h"

namespace fs = std::filesystem;
using namespace sylva;

namespace {

const fs::path kSource = SYLVA_SOURCE_DIR;

// A documented key in the form KeyLog records.
std::string normaliseKey(std::string key) {
    if (key.size() > 4 && key.rfind("[[", 0) == 0 && key.substr(key.size() - 2) == "]]") {
        key = key.substr(2, key.size() - 4);
    } else if (key.size() > 2 && key.front() == '[' && key.back() == ']') {
        key = key.substr(1, key.size() - 2);
    }
    key = std::regex_replace(key, std::regex(R"(\[[^\]]*\])"), "[]");
    key = std::regex_replace(key, std::regex(R"(<[^>]*>)"), "*");
    return key;
}

struct DocKeys {
    std::set<std::string> keys;  // "<context>.<key>"
    int tables = 0;
    std::vector<std::string> problems;
};

// Keys of the marked tables in one Markdown file.
void readDocKeys(const fs::path& file, DocKeys& out) {
    std::ifstream in(file);
    std::string line, context;
    int lineNo = 0;
    enum { kOutside, kBeforeTable, kInTable } state = kOutside;
    static const std::regex kMarker(R"(^<!--\s*spec-keys:\s*(\S+)\s*-->\s*$)");
    static const std::regex kTick("`([^`]+)`");
    int rows = 0;
    auto endTable = [&] {
        if (state != kOutside && rows == 0) {
            out.problems.push_back(file.string() + ": the table after spec-keys " + context +
                                   " has no key rows");
        }
        state = kOutside;
    };
    while (std::getline(in, line)) {
        ++lineNo;
        std::smatch m;
        if (std::regex_match(line, m, kMarker)) {
            endTable();
            context = m[1];
            state = kBeforeTable;
            rows = 0;
            ++out.tables;
            continue;
        }
        const bool tableLine = !line.empty() && line[0] == '|';
        if (state == kBeforeTable) {
            if (tableLine) {
                state = kInTable;  // this is the header row
            } else if (line.find_first_not_of(" \t") != std::string::npos) {
                out.problems.push_back(file.string() + ":" + std::to_string(lineNo) +
                                       ": expected a table after the spec-keys marker");
                state = kOutside;
            }
            continue;
        }
        if (state != kInTable) continue;
        if (!tableLine) {
            endTable();
            continue;
        }
        static const std::regex kSeparator(R"(^\|[\s:|-]+$)");
        if (std::regex_match(line, kSeparator)) continue;
        // The first cell (a '|' inside backticks is not a cell border).
        size_t end = 1;
        bool inTick = false;
        for (; end < line.size(); ++end) {
            if (line[end] == '`') inTick = !inTick;
            if (line[end] == '|' && !inTick && line[end - 1] != '\\') break;
        }
        const std::string cell = line.substr(1, end - 1);
        int found = 0;
        for (std::sregex_iterator it(cell.begin(), cell.end(), kTick), e; it != e; ++it) {
            out.keys.insert(context + "." + normaliseKey((*it)[1]));
            ++found;
        }
        if (found == 0) {
            out.problems.push_back(file.string() + ":" + std::to_string(lineNo) +
                                   ": a key row without a `key` in its first cell");
        }
        ++rows;
    }
    endTable();
}

DocKeys documentedKeys() {
    DocKeys d;
    for (const auto& e : fs::recursive_directory_iterator(kSource / "docs")) {
        if (e.is_regular_file() && e.path().extension() == ".md") readDocKeys(e.path(), d);
    }
    return d;
}

// Every species and dataset file of the repository (bad and hostile specs excluded), read with
// a KeyLog.
KeyLog acceptedKeys(int& speciesFiles, int& datasetFiles) {
    std::vector<fs::path> files;
    for (const char* dir : {"species", "datasets", "bench", "tests/data"}) {
        for (const auto& e : fs::recursive_directory_iterator(kSource / dir)) {
            if (!e.is_regular_file() || e.path().extension() != ".toml") continue;
            const fs::path folder = e.path().parent_path().filename();
            if (folder == "bad" || folder == "bad_datasets" || folder == "hostile") continue;
            files.push_back(e.path());
        }
    }
    std::sort(files.begin(), files.end());
    KeyLog log;
    for (const fs::path& f : files) {
        SCOPED_TRACE(f.string());
        const toml::table t = parseTomlFile(f.string());
        if (isDatasetFile(t)) {
            loadDataset(f.string(), &log);
            ++datasetFiles;
        } else if (t.contains("scan")) {
            loadScanSpec(f.string(), &log);  // a [scan] table alone (tests/data/scan/scan-*.toml)
        } else {
            SpeciesFile s = loadSpecies(f.string());
            DrawContext draw;
            draw.draw = false;
            draw.keyLog = &log;
            instantiateSpecies(s, draw, nullptr);
            if (t.contains("fit")) readFitSpec(f.string(), &log);  // `sylva fit`'s [fit]
            ++speciesFiles;
        }
    }
    return log;
}

}  // namespace

TEST(SpecKeys, NormalisedAsTheReaderRecordsThem) {
    EXPECT_EQ(normaliseKey("[crown]"), "crown");
    EXPECT_EQ(normaliseKey("[[levels]]"), "levels");
    EXPECT_EQ(normaliseKey("levels[i].nodes"), "levels[].nodes");
    EXPECT_EQ(normaliseKey("[[guides.strokes]]"), "guides.strokes");
    EXPECT_EQ(normaliseKey("geometry.<name>.length"), "geometry.*.length");
    EXPECT_EQ(normaliseKey("rules.<state>[i].out"), "rules.*[].out");
}

TEST(SpecKeys, TheReaderRecordsEveryKeyItAsksForInItsContext) {
    toml::table t = toml::parse(R"(
        a = 1
        [crown]
        type = "sphere"
        radius = 2
        [[levels]]
        nodes = 3
        [rules]
        s = [{ out = ["t"] }]
    )");
    KeyLog log;
    DrawContext draw;
    draw.draw = false;
    draw.keyLog = &log;
    Params p(t, "x.toml", "", &draw);
    p.documentAs("m");
    p.number("a", Range::any());
    p.number("absent", 1.0, Range::any());  // optional keys are accepted keys too
    {
        Params c = p.table("crown");
        DocumentAs shared(c, "volume");
        c.string("type");
        c.number("radius", Range::any());
    }
    for (Params& l : p.tableArray("levels")) l.integer("nodes", Range::any());
    Params r = p.table("rules");
    r.keysAreUserNames();
    for (Params& alt : r.tableArray("s")) alt.stringArray("out");
    const KeyLog expected = {"m.a",           "m.absent",       "m.crown",          "volume.type",
                             "volume.radius", "m.levels",       "m.levels[].nodes", "m.rules",
                             "m.rules.*",     "m.rules.*[].out"};
    EXPECT_EQ(log, expected);
}

TEST(SpecKeys, EveryAcceptedKeyIsDocumentedAndEveryDocumentedKeyIsAccepted) {
    ASSERT_TRUE(fs::is_directory(kSource / "docs"));
    int speciesFiles = 0, datasetFiles = 0;
    const KeyLog accepted = acceptedKeys(speciesFiles, datasetFiles);
    const DocKeys documented = documentedKeys();
    for (const std::string& p : documented.problems) ADD_FAILURE() << p;
    // Not vacuous: the whole library was read, and the docs have their tables.
    EXPECT_GE(speciesFiles, 48);
    EXPECT_GE(datasetFiles, 5);
    EXPECT_GT(accepted.size(), 300u);
    EXPECT_GE(documented.tables, 10);

    std::string undocumented, unaccepted;
    for (const std::string& k : accepted) {
        if (!documented.keys.count(k)) undocumented += "\n  " + k;
    }
    for (const std::string& k : documented.keys) {
        if (!accepted.count(k)) unaccepted += "\n  " + k;
    }
    EXPECT_TRUE(undocumented.empty())
        << "keys the readers accept but docs/ does not list (add a row under the matching "
           "<!-- spec-keys: CONTEXT --> table):"
        << undocumented;
    EXPECT_TRUE(unaccepted.empty())
        << "keys docs/ lists that no reader accepts (a typo, a removed key, or a key no spec "
           "in the repository uses: add one to tests/data/keys/):"
        << unaccepted;
}
