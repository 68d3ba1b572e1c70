// The one reader of a dataset's manifests and description that stats, gates, report and merge
// share: every field a command uses is checked for its type before use, names that become
// directories and paths that name files stay inside the dataset, and nesting is bounded.
#include "pipeline/analysis/dataset_reader.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "core/errors.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using namespace sylva;
using sylva::test::TempDir;

void spit(const fs::path& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary);
    out << bytes;
}

const std::string kGood =
    R"({"id":"oak-p000-00001","index":1,"species":"oak","habit":"tree","seed":"0x1f",)"
    R"("files":{"skeleton_ply":"trees/oak/oak-p000-00001/skeleton.ply"},"stats":{"height_m":9.5},)"
    R"("sweep":{},"timing":{"grow_ms":3}})";

// The error parseManifestRecord gives for `line`, "" when it is accepted.
std::string recordError(const std::string& line) {
    try {
        (void)parseManifestRecord(line, "m.jsonl:7");
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

// `kGood` with `from` replaced by `to`.
std::string with(const std::string& from, const std::string& to) {
    std::string s = kGood;
    const size_t at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
}

TEST(DatasetReader, AWellFormedRecordGivesItsFields) {
    const ManifestRecord r = parseManifestRecord(kGood, "m.jsonl:7");
    EXPECT_EQ(r.id, "oak-p000-00001");
    EXPECT_EQ(r.group, "oak");
    EXPECT_FALSE(r.plot);
    EXPECT_EQ(r.index, 1);
    EXPECT_EQ(r.where, "m.jsonl:7");
    const ManifestRecord p =
        parseManifestRecord(R"({"id":"p1","index":0,"plot":"stand","trees":40})", "x");
    EXPECT_TRUE(p.plot);
    EXPECT_EQ(p.group, "stand");
}

TEST(DatasetReader, EachWrongFieldIsNamedWithItsPlace) {
    EXPECT_EQ(
        recordError("\x89PNG garbage"),
        "m.jsonl:7: not a manifest record (a JSON object with id, index and species or plot)");
    EXPECT_EQ(recordError("[1, 2]"), recordError("\x89PNG garbage"));
    EXPECT_EQ(recordError(with(R"("species":"oak")", R"("species":5)")),
              "m.jsonl:7: species: expected a string (a record names its species, or its plot)");
    EXPECT_EQ(recordError(with(R"("index":1)", R"("index":"1")")),
              "m.jsonl:7: index: expected an integer >= 0");
    EXPECT_EQ(recordError(with(R"("index":1)", R"("index":-1)")),
              "m.jsonl:7: index: expected an integer >= 0");
    EXPECT_EQ(recordError(with(R"("stats":{"height_m":9.5})", R"("stats":[9.5])")),
              "m.jsonl:7: stats: expected an object");
    EXPECT_EQ(recordError(with(R"("habit":"tree")", R"("habit":null)")),
              "m.jsonl:7: habit: expected a string");
    EXPECT_EQ(recordError(with(R"("seed":"0x1f")", R"("seed":[1])")),
              "m.jsonl:7: seed: expected a string or an integer >= 0");
    EXPECT_EQ(recordError(with(R"("timing":{"grow_ms":3})", R"("timing":3)")),
              "m.jsonl:7: timing: expected an object");
    EXPECT_EQ(recordError(R"({"index":1,"species":"oak"})"), "m.jsonl:7: id: expected a string");
}

TEST(DatasetReader, NamesThatBecomeDirectoriesAndPathsStayInsideTheDataset) {
    for (const char* id : {R"("")", R"(".")", R"("..")", R"("../../etc")", R"("a/b")", R"("a\\b")",
                           R"("a\u0000b")", R"("a\nb")"}) {
        EXPECT_NE(recordError(with(R"("id":"oak-p000-00001")", std::string("\"id\":") + id))
                      .find("m.jsonl:7: id: expected one directory name"),
                  std::string::npos)
            << id;
    }
    EXPECT_NE(recordError(with(R"("species":"oak")", R"("species":"..")"))
                  .find("m.jsonl:7: species: expected one directory name"),
              std::string::npos);
    for (const char* path : {"/etc/passwd", "../x", "trees/../../x", "", "a\\\\b"}) {
        EXPECT_EQ(recordError(with("trees/oak/oak-p000-00001/skeleton.ply", path)),
                  "m.jsonl:7: files.skeleton_ply: expected a relative path inside the dataset "
                  "(no \"..\")")
            << path;
    }
    EXPECT_EQ(recordError(with(R"("files":{)", R"("files":{"x":3,)")),
              "m.jsonl:7: files.x: expected a relative path inside the dataset (no \"..\")");
    EXPECT_TRUE(isPathInside("trees/oak/a..b/skeleton.ply"));
}

TEST(DatasetReader, NestingBeyondTheLimitIsRefusedAtAnyPlace) {
    const std::string closed =
        std::string(kMaxRecordDepth + 2, '[') + std::string(kMaxRecordDepth + 2, ']');
    EXPECT_EQ(recordError(closed), "m.jsonl:7: nested more than 32 deep (not a manifest record)");
    // Inside an accepted field (stats is flattened recursively by sylva stats).
    EXPECT_EQ(recordError(with(
                  R"("stats":{"height_m":9.5})",
                  R"("stats":{"d":)" + std::string(200000, '[') + std::string(200000, ']') + "}")),
              "m.jsonl:7: nested more than 32 deep (not a manifest record)");
    const std::string ok(kMaxRecordDepth - 2, '[');
    EXPECT_EQ(
        recordError(with(R"("stats":{"height_m":9.5})",
                         R"("stats":{"d":)" + ok + std::string(kMaxRecordDepth - 2, ']') + "}")),
        "");
}

// Nesting is counted by the parser's own levels: brackets inside strings are text, and an array
// nested 33 deep (its innermost level holding no value) is the deepest accepted.
TEST(DatasetReader, NestingIsTheParsersAndBracketsInStringsAreText) {
    EXPECT_EQ(recordError(with(R"("stats":{"height_m":9.5})",
                               R"("stats":{"s":")" + std::string(200, '[') + R"(\"{"})")),
              "");
    auto nested = [](int levels) {
        return with(
            R"("stats":{"height_m":9.5})",
            R"("stats":{"d":)" + std::string(levels - 2, '[') + std::string(levels - 2, ']') + "}");
    };
    EXPECT_EQ(recordError(nested(kMaxRecordDepth + 1)), "");
    EXPECT_EQ(recordError(nested(kMaxRecordDepth + 2)),
              "m.jsonl:7: nested more than 32 deep (not a manifest record)");
    EXPECT_EQ(
        recordError(std::string(kMaxRecordDepth + 1, '[') + std::string(kMaxRecordDepth + 1, ']')),
        "m.jsonl:7: not a manifest record (a JSON object with id, index and species or plot)");
}

// A packed record's shard: a relative path inside the dataset whose last element ends in ".tar"
// after at least one other character (what std::filesystem::path's extension() says).
TEST(DatasetReader, APackIsARelativeTarPathInsideTheDataset) {
    const std::string pack = R"("timing":{"grow_ms":3})";
    for (const char* p : {"shards/000001.tar", "x.tar", "shards/..tar", "a//b/c.tar"}) {
        EXPECT_EQ(recordError(with(pack, pack + R"(,"pack":")" + p + "\"")), "") << p;
    }
    for (const char* p :
         {"shards/.tar", ".tar", "shards/x.tarx", "shards/x.TAR", "shards/", "shards/x.tar/",
          "/shards/x.tar", "../x.tar", "a//..//x.tar", "a/../x.tar", ""}) {
        EXPECT_EQ(recordError(with(pack, pack + R"(,"pack":")" + p + "\"")),
                  "m.jsonl:7: pack: expected a relative path inside the dataset to a .tar shard")
            << p;
    }
    EXPECT_TRUE(isPathInside("a/..b/c"));
    EXPECT_TRUE(isPathInside("a/"));
    EXPECT_FALSE(isPathInside("a/.."));
}

TEST(DatasetReader, ManifestsInShardOrderWithTornLastLinesCountedAndDuplicatesOnce) {
    TempDir t;
    spit(t / "manifest.shard-1-of-2.jsonl", with("oak-p000-00001", "b") + "\n" + "{\"id\":");
    spit(t / "manifest.shard-0-of-2.jsonl", kGood + "\n\n" + kGood + "\n");
    const ManifestRead r = readManifests(t.path());
    ASSERT_EQ(r.records.size(), 2u);
    EXPECT_EQ(r.records[0].id, "oak-p000-00001");
    EXPECT_EQ(r.records[1].id, "b");
    EXPECT_EQ(r.records[1].where, (t / "manifest.shard-1-of-2.jsonl").string() + ":1");
    EXPECT_EQ(r.tornLines, 1u);
    EXPECT_EQ(r.duplicates, 1u);
    EXPECT_EQ(r.files, (std::vector<std::string>{"manifest.shard-0-of-2.jsonl",
                                                 "manifest.shard-1-of-2.jsonl"}));
    // A bad line that is not the last is an error naming its file and line.
    spit(t / "manifest.shard-0-of-2.jsonl", kGood + "\nnot json\n" + kGood + "\n");
    try {
        (void)readManifests(t.path());
        FAIL() << "a bad middle line was accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(
            std::string(e.what()).rfind(
                (t / "manifest.shard-0-of-2.jsonl").string() + ":2: not a manifest record", 0),
            0u)
            << e.what();
    }
    TempDir empty;
    EXPECT_THROW((void)readManifests(empty.path()), InputError);
    EXPECT_THROW((void)readManifests(empty / "missing"), InputError);
}

TEST(DatasetReader, TheDescriptionIsAJsonObjectWithItsFieldsTyped) {
    TempDir t;
    auto descriptionError = [&](const std::string& text) -> std::string {
        spit(t / "dataset.json", text);
        try {
            (void)readDatasetDescription(t.path());
        } catch (const InputError& e) {
            return e.what();
        }
        return "";
    };
    const std::string where = (t / "dataset.json").string() + ": ";
    EXPECT_EQ(descriptionError(R"({"name":"d","counts":{"built":3},"species":[{"name":"oak"}],)"
                               R"("shard":{"index":1,"count":2},"seed":7})"),
              "");
    EXPECT_EQ(descriptionError("\x01\x02garbage"), where + "not JSON");
    EXPECT_EQ(descriptionError("[]"), where + "expected a JSON object (a dataset description)");
    EXPECT_EQ(descriptionError("{}"), where + "name: expected a string");
    EXPECT_EQ(descriptionError(R"({"name":"d","counts":{"built":"3"}})"),
              where + "counts.built: expected an integer >= 0");
    EXPECT_EQ(descriptionError(R"({"name":"d","species":[3]})"),
              where + "species[0]: expected an object with a string name");
    EXPECT_EQ(descriptionError(R"({"name":"d","shard":{"index":2,"count":2}})"),
              where + "shard: expected an object with integers 0 <= index < count");
    fs::remove(t / "dataset.json");
    try {
        (void)readDatasetDescription(t.path());
        FAIL() << "no description accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()),
                  t.path().string() + ": no dataset.json (not a dataset directory)");
    }
    // Shards built into one directory: each shard's description, all checked.
    spit(t / "dataset.shard-0-of-2.json", R"({"name":"d","shard":{"index":0,"count":2}})");
    spit(t / "dataset.shard-1-of-2.json", "[]");
    EXPECT_THROW((void)readDatasetDescription(t.path()), InputError);
    spit(t / "dataset.shard-1-of-2.json", R"({"name":"d","shard":{"index":1,"count":2}})");
    EXPECT_EQ(readDatasetDescription(t.path())["shard"]["index"], 0);
}

}  // namespace
