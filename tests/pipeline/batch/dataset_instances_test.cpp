// Lazy expansion (issue 15, item 2): instance i of a dataset computed from i equals the old eager
// expansion (kept here verbatim as the known answer) on small datasets with sweeps and several
// species; huge and largest datasets load without a list of instances; the count limit and id
// uniqueness are spec errors at their key; the set of recorded positions and the manifest scan
// of a resume.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "pipeline/batch/build.h"
#include "pipeline/batch/dataset.h"
#include "pipeline/batch/instance_set.h"
#include "pipeline/batch/resume.h"
#include "tests/test_support.h"

namespace fs = std::filesystem;
using namespace sylva;

namespace {

const fs::path kData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data";
const std::string kPalm = SYLVA_SOURCE_DIR "/species/papers/jain-2021/grammar-palm.toml";

void spit(const fs::path& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary);
    out << bytes;
}

// The expansion before issue 15 (dataset.cpp at b6fe85a), copied verbatim but for its name: the
// order, ids and seeds a lazy lookup must reproduce exactly (existing datasets resume on them).
std::vector<InstanceJob> eagerExpansion(const DatasetSpec& spec) {
    std::vector<InstanceJob> jobs;
    for (const SpeciesEntry& e : spec.species) {
        const bool swept = e.points.size() > 1 || !e.points[0].key.empty();
        for (size_t pi = 0; pi < e.points.size(); ++pi) {
            for (int64_t k = 0; k < e.count; ++k) {
                InstanceJob j;
                j.entry = &e;
                j.point = &e.points[pi];
                j.pointIndex = static_cast<int>(pi);
                j.index = k;
                j.seed = instanceSeed(spec.seed, e.species.name, e.points[pi].seedKey, k);
                char buf[64];
                if (swept) {
                    std::snprintf(buf, sizeof buf, "-p%03zu-%05lld", pi, static_cast<long long>(k));
                } else {
                    std::snprintf(buf, sizeof buf, "-%05lld", static_cast<long long>(k));
                }
                j.id = e.species.name + buf;
                jobs.push_back(std::move(j));
            }
        }
    }
    return jobs;
}

// A species file: tests/data/tiny.toml under another name.
void writeSpecies(const fs::path& dir, const std::string& name) {
    std::string text = test::slurp(kData / "tiny.toml");
    const std::string from = "name = \"tiny\"";
    text.replace(text.find(from), from.size(), "name = \"" + name + "\"");
    spit(dir / (name + ".toml"), text);
}

std::string entry(const std::string& file, const std::string& count) {
    return "[[species]]\nfile = \"" + file + "\"\ncount = " + count + "\n";
}

// Known answer: every position of several small datasets against the eager expansion.
TEST(DatasetInstances, EveryInstanceEqualsTheEagerExpansion) {
    test::TempDir t;
    for (const char* name : {"a", "b-x", "c", "a-p"}) writeSpecies(t.path(), name);
    const std::vector<std::string> specs = {
        // one species, no sweep
        "name = \"d1\"\nseed = 3\n" + entry("a.toml", "7"),
        // two species, one sweep over both (the CLI fixture's shape)
        "name = \"d2\"\nseed = 7\n" + entry("a.toml", "6") + entry("b-x.toml", "5") +
            "[[sweep]]\npath = \"levels[1].endpoints\"\nvalues = [2, 3]\n",
        // a species-specific sweep, a same_seed axis, a species without instances between two
        // with, a range sweep: 3 × 4 points for a, 4 for c, 1 for b-x
        "name = \"d3\"\nseed = 11\n" + entry("a.toml", "3") + entry("b-x.toml", "0") +
            entry("c.toml", "4") + entry("a-p.toml", "2") +
            "[[sweep]]\npath = \"levels[1].endpoints\"\nvalues = [2, 3, 4]\nspecies = [\"a\"]\n"
            "[[sweep]]\npath = \"levels[2].nodes\"\nrange = { from = 10, to = 40, steps = 4, "
            "integer = true }\nsame_seed = true\nspecies = [\"a\", \"c\"]\n",
        // over 1000 sweep points (point numbers grow a digit: a grammar species, which
        // validates in about 0.5 ms a point), a species with count 1 after it
        "name = \"d4\"\nseed = 5\n" + entry(kPalm, "2") + entry("a.toml", "1") +
            "[[sweep]]\npath = \"grammar.segment_length\"\nrange = { from = 0.1, to = 0.2, "
            "steps = 1001 }\nspecies = [\"grammar-palm\"]\n",
    };
    int datasets = 0;
    for (const std::string& text : specs) {
        const fs::path file = t / ("d" + std::to_string(datasets++) + ".toml");
        spit(file, text);
        const DatasetSpec spec = loadDataset(file.string());
        const std::vector<InstanceJob> want = eagerExpansion(spec);
        const DatasetInstances got(spec);
        ASSERT_EQ(got.size(), static_cast<int64_t>(want.size())) << text;
        ASSERT_GT(want.size(), 0u);
        std::set<std::string> ids;
        for (size_t i = 0; i < want.size(); ++i) {
            const InstanceJob g = got[static_cast<int64_t>(i)];
            SCOPED_TRACE(want[i].id);
            EXPECT_EQ(g.id, want[i].id);
            EXPECT_EQ(g.entry, want[i].entry);
            EXPECT_EQ(g.point, want[i].point);
            EXPECT_EQ(g.pointIndex, want[i].pointIndex);
            EXPECT_EQ(g.index, want[i].index);
            EXPECT_EQ(g.seed, want[i].seed);
            EXPECT_EQ(g.position, static_cast<int64_t>(i));
            EXPECT_EQ(got.find(want[i].id), std::optional<int64_t>(static_cast<int64_t>(i)));
            ids.insert(g.id);
        }
        if (datasets == 4) {  // the 1001st point of the first species, then the second species
            EXPECT_EQ(got[2001].id, "grammar-palm-p1000-00001");
            EXPECT_EQ(got[2002].id, "a-00000");
        }
        EXPECT_EQ(ids.size(), want.size()) << "ids unique";
        // expandJobs (kept for tools and tests) is the same list.
        const std::vector<InstanceJob> listed = expandJobs(spec);
        ASSERT_EQ(listed.size(), want.size());
        for (size_t i = 0; i < want.size(); ++i) EXPECT_EQ(listed[i].id, want[i].id);
    }
    EXPECT_EQ(datasets, 4);
}

// find() answers only for canonical ids of the dataset.
TEST(DatasetInstances, FindRejectsWhatIsNotAnIdOfTheDataset) {
    test::TempDir t;
    for (const char* name : {"a", "b-x"}) writeSpecies(t.path(), name);
    spit(t / "d.toml", "name = \"d\"\n" + entry("a.toml", "12") + entry("b-x.toml", "3") +
                           "[[sweep]]\npath = \"levels[1].endpoints\"\nvalues = [2, 3]\n"
                           "species = [\"a\"]\n");
    const DatasetSpec spec = loadDataset((t / "d.toml").string());
    const DatasetInstances d(spec);
    ASSERT_EQ(d.size(), 27);
    EXPECT_EQ(d.find("a-p000-00000"), 0);
    EXPECT_EQ(d.find("a-p001-00011"), 23);
    EXPECT_EQ(d.find("b-x-00002"), 26);
    for (const char* bad : {"a-00000",
                            "a-p1-00000",
                            "a-p0001-00000",
                            "a-p002-00000",
                            "a-p000-0000",
                            "a-p000-000000",
                            "a-p000-00012",
                            "a-p000-00000x",
                            "a-p000--0001",
                            "a-p000-+0001",
                            "b-x-p000-00000",
                            "b-x-00003",
                            "b-00000",
                            "x-00000",
                            "",
                            "-",
                            "a",
                            "a-",
                            "a-p000-",
                            "b-x-99999999999999999999"}) {
        EXPECT_EQ(d.find(bad), std::nullopt) << bad;
    }
    EXPECT_THROW(d[27], std::out_of_range);
    EXPECT_THROW(d[-1], std::out_of_range);
}

// 10⁹ instances and the largest dataset: loaded and placed without a list (the eager expansion
// of 10⁹ jobs needed over 8 GB; a test's memory would not hold it). Every known answer from the
// formula: the seed hash of (dataset seed, species, point key, index).
TEST(DatasetInstances, HugeAndLargestDatasetsWithoutAList) {
    test::TempDir t;
    writeSpecies(t.path(), "a");
    writeSpecies(t.path(), "c");
    spit(t / "g.toml", "name = \"g\"\nseed = 9\n" + entry("a.toml", "1000000000"));
    const DatasetSpec giga = loadDataset((t / "g.toml").string());
    const DatasetInstances g(giga);
    EXPECT_EQ(g.size(), 1'000'000'000);
    const InstanceJob last = g[999'999'999];
    EXPECT_EQ(last.id, "a-999999999");
    EXPECT_EQ(last.index, 999'999'999);
    EXPECT_EQ(last.seed, instanceSeed(9, "a", "", 999'999'999));
    EXPECT_EQ(g.find("a-999999999"), 999'999'999);
    EXPECT_EQ(g.find("a-1000000000"), std::nullopt);

    // Exactly kMaxInstances: two species, one swept over 4 points.
    spit(t / "max.toml", "name = \"max\"\n" + entry("a.toml", "1000000000000000") +
                             entry("c.toml", "2000000000000000") +
                             "[[sweep]]\npath = \"levels[1].endpoints\"\nvalues = [2, 3, 4, 5]\n"
                             "species = [\"c\"]\n");
    const DatasetSpec maxSpec = loadDataset((t / "max.toml").string());
    const DatasetInstances m(maxSpec);
    EXPECT_EQ(m.size(), kMaxInstances);
    EXPECT_EQ(m[kMaxInstances - 1].id, "c-p003-1999999999999999");
    EXPECT_EQ(m[kMaxInstances - 1].seed,
              instanceSeed(0, "c", "levels[1].endpoints=5", 1999999999999999));
    EXPECT_EQ(m[999'999'999'999'999].id, "a-999999999999999");
    EXPECT_EQ(m[1'000'000'000'000'000].id, "c-p000-00000");
    EXPECT_EQ(m.find("c-p001-1999999999999999"), 5'000'000'000'000'000 - 1);

    // Shards of the largest dataset: 128-bit arithmetic, contiguous, covering it exactly.
    const size_t total = static_cast<size_t>(kMaxInstances);
    const int n = 2'000'000'000;
    EXPECT_EQ(shardRange(total, 0, n).first, 0u);
    EXPECT_EQ(shardRange(total, n - 1, n).second, total);
    EXPECT_EQ(shardRange(total, n - 1, n).first, shardRange(total, n - 2, n).second);
    EXPECT_EQ(shardRange(total, 1, n).first, 4'500'000u);  // 9e15 / 2e9
    EXPECT_EQ(shardRange(1'000'000'000, 999'999'999, 1'000'000'000),
              (std::pair<size_t, size_t>{999'999'999, 1'000'000'000}));
}

// The count limit: one line at the `count` that crosses it (per species, and over the whole
// dataset with sweeps, where count × points would overflow 64 bits unchecked).
TEST(DatasetInstances, OverTheLargestDatasetIsASpecErrorAtCount) {
    test::TempDir t;
    writeSpecies(t.path(), "a");
    writeSpecies(t.path(), "c");
    auto error = [&](const std::string& text) -> std::string {
        spit(t / "over.toml", text);
        try {
            loadDataset((t / "over.toml").string());
        } catch (const SpecError& e) {
            return e.what();
        }
        return "(no error)";
    };
    const std::string sweep3 = "[[sweep]]\npath = \"levels[1].endpoints\"\nvalues = [2, 3, 4]\n";
    EXPECT_EQ(error("name = \"o\"\n" + entry("a.toml", "9000000000000001")),
              (t / "over.toml").string() +
                  ":4:9: species[0].count: expected an integer in [0, 9e+15] (the largest "
                  "dataset), got 9000000000000001");
    EXPECT_EQ(error("name = \"o\"\n" + entry("a.toml", "9223372036854775807")),
              (t / "over.toml").string() +
                  ":4:9: species[0].count: expected an integer in [0, 9e+15] (the largest "
                  "dataset), got 9223372036854775807");
    EXPECT_EQ(error("name = \"o\"\n" + entry("a.toml", "-1")),
              (t / "over.toml").string() +
                  ":4:9: species[0].count: expected an integer in [0, 9e+15], got -1");
    // 3 × 3e15 + 1 over the limit, at the second species' count.
    EXPECT_EQ(error("name = \"o\"\n" + entry("a.toml", "1") + entry("c.toml", "3000000000000000") +
                    sweep3),
              (t / "over.toml").string() +
                  ":7:9: species[1].count: expected at most 9e+15 instances in the dataset (Σ "
                  "count × sweep points: the largest dataset supported), got 9000000000000003");
    // count × points past 2⁶³ (1025 points of a grammar species, quick to validate): still
    // the count's error, with the exact total.
    EXPECT_EQ(error("name = \"o\"\n" + entry(kPalm, "9000000000000000") +
                    "[[sweep]]\npath = \"grammar.segment_length\"\nrange = { from = 0.1, to = "
                    "0.2, steps = 1025 }\n"),
              (t / "over.toml").string() +
                  ":4:9: species[0].count: expected at most 9e+15 instances in the dataset (Σ "
                  "count × sweep points: the largest dataset supported), got "
                  "9225000000000000000");
}

// Ids stay unique: an unswept species named like a swept one's sweep point is refused.
TEST(DatasetInstances, IdsThatWouldCollideAreASpecError) {
    test::TempDir t;
    for (const char* name : {"a", "a-p001", "a-p1", "a-p005"}) writeSpecies(t.path(), name);
    const std::string sweep2 =
        "[[sweep]]\npath = \"levels[1].endpoints\"\nvalues = [2, 3]\n"
        "species = [\"a\"]\n";
    spit(t / "clash.toml",
         "name = \"x\"\n" + entry("a.toml", "2") + entry("a-p001.toml", "2") + sweep2);
    try {
        loadDataset((t / "clash.toml").string());
        ADD_FAILURE() << "no error";
    } catch (const SpecError& e) {
        EXPECT_EQ(std::string(e.what()),
                  (t / "clash.toml").string() +
                      ":6:8: species[1].file: expected a species name that no instance id of "
                      "another species starts with, got \"a-p001\": \"a-p001-00000\" is also "
                      "sweep point 1 of species \"a\" (rename one)");
    }
    // No clash: a name that is not a canonical point, a point the sweep does not have, or a
    // species without instances.
    for (const std::string& other :
         {entry("a-p1.toml", "2"), entry("a-p005.toml", "2"), entry("a-p001.toml", "0")}) {
        spit(t / "ok.toml", "name = \"x\"\n" + entry("a.toml", "2") + other + sweep2);
        const DatasetSpec spec = loadDataset((t / "ok.toml").string());
        const std::vector<InstanceJob> jobs = expandJobs(spec);
        std::set<std::string> ids;
        for (const InstanceJob& j : jobs) ids.insert(j.id);
        EXPECT_EQ(ids.size(), jobs.size()) << other;
    }
}

// The run set against a brute-force std::set, through random inserts in runs and holes.
TEST(InstanceSet, AgreesWithAPlainSet) {
    std::mt19937_64 rng(15);
    for (int round = 0; round < 20; ++round) {
        InstanceSet s;
        std::set<int64_t> want;
        const int64_t span = 1 + static_cast<int64_t>(rng() % 300);
        for (int k = 0; k < 200; ++k) {
            const auto p = static_cast<int64_t>(rng() % static_cast<uint64_t>(span));
            s.insert(p);
            want.insert(p);
        }
        ASSERT_EQ(s.size(), static_cast<int64_t>(want.size()));
        size_t runs = 0;
        for (int64_t p = 0; p < span + 2; ++p) {
            ASSERT_EQ(s.contains(p), want.count(p) > 0) << p;
            if (want.count(p) && !want.count(p - 1)) ++runs;
        }
        EXPECT_EQ(s.runs(), runs);
        for (int q = 0; q < 100; ++q) {
            int64_t lo = static_cast<int64_t>(rng() % static_cast<uint64_t>(span + 2));
            int64_t hi = static_cast<int64_t>(rng() % static_cast<uint64_t>(span + 2));
            if (lo > hi) std::swap(lo, hi);
            int64_t count = 0, present = hi, missing = hi;
            for (int64_t p = hi - 1; p >= lo; --p) {
                if (want.count(p)) {
                    ++count;
                    present = p;
                } else {
                    missing = p;
                }
            }
            EXPECT_EQ(s.countIn(lo, hi), count) << lo << " " << hi;
            EXPECT_EQ(s.nextPresent(lo, hi), present) << lo << " " << hi;
            EXPECT_EQ(s.nextMissing(lo, hi), missing) << lo << " " << hi;
        }
    }
    // A build's pattern: a long run, a hole (a failed tree), a run; memory is the runs.
    InstanceSet b;
    for (int64_t p = 0; p < 1'000'000; ++p) {
        if (p != 500'000) b.insert(p);
    }
    EXPECT_EQ(b.runs(), 2u);
    EXPECT_EQ(b.countIn(0, 1'000'000), 999'999);
    EXPECT_EQ(b.nextMissing(0, 1'000'000), 500'000);
    b.insert(500'000);
    EXPECT_EQ(b.runs(), 1u);
    EXPECT_EQ(b.nextMissing(0, 2'000'000), 1'000'000);
}

// Resume's scan: ids of the dataset by position, whatever the order of the lines (a rerun
// appends the holes it fills after the earlier run's lines); other lines ignored; a torn last
// line cut off the file.
TEST(Resume, RecordedInstancesFromAManifest) {
    test::TempDir t;
    writeSpecies(t.path(), "a");
    spit(t / "d.toml", "name = \"d\"\n" + entry("a.toml", "1000000000"));
    const DatasetSpec spec = loadDataset((t / "d.toml").string());
    const DatasetInstances d(spec);
    const std::string complete =
        "{\"bytes_written\":1,\"files\":{\"id\":\"a-00007\"},\"id\":\"a-00000\",\"x\":[1]}\n"
        "{\"id\":\"a-00001\"}\n"
        "{\"id\":\"a-00003\",\"stats\":{\"a\":[{\"id\":\"a-00009\"}]}}\n"
        "{\"id\":\"a-00002\"}\n"      // a rerun filling the hole
        "{\"id\":\"a-999999999\"}\n"  // the last one
        "{\"id\":\"b-00004\"}\n"      // not an id of this dataset
        "{\"id\":\"a-00005\"\n"       // not JSON
        "[{\"id\":\"a-00006\"}]\n"    // not an object
        "{\"id\":8}\n"                // not a string
        "\n"
        "{\"id\":\"a-00001\"}\n";  // twice
    spit(t / "manifest.jsonl", complete + "{\"id\":\"a-00004\",\"fi");
    const InstanceSet r = recordedInstances(t / "manifest.jsonl", d);
    EXPECT_EQ(r.size(), 5);
    for (int64_t p : {0, 1, 2, 3, 999'999'999}) EXPECT_TRUE(r.contains(p)) << p;
    EXPECT_EQ(r.runs(), 2u);
    EXPECT_EQ(test::slurp(t / "manifest.jsonl"), complete);
    EXPECT_EQ(recordedInstances(t / "missing.jsonl", d).size(), 0);
}

// A manifest line over 64 MiB is refused with the file and line (the reader held it whole
// before), without reading it all; a FIFO in place of the manifest is refused at once.
TEST(Resume, AManifestLineOverTheLimitIsOneErrorAtItsLine) {
    test::TempDir t;
    writeSpecies(t.path(), "a");
    spit(t / "d.toml", "name = \"d\"\n" + entry("a.toml", "10"));
    const DatasetSpec spec = loadDataset((t / "d.toml").string());
    const DatasetInstances d(spec);
    spit(t / "manifest.jsonl", "{\"id\":\"a-00000\"}\n{\"id\":\"" +
                                   std::string(kMaxManifestLineBytes + 10, 'x') + "\"}\n");
    for (auto read :
         {+[](const fs::path&m, const DatasetInstances&d) { recordedInstances(m, d); },
          +[](const fs::path&m, const DatasetInstances&d) { scanManifestOrder(m, d, 0, 10); }}) {
        try {
            read(t / "manifest.jsonl", d);
            ADD_FAILURE() << "a 64 MiB line was read";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("manifest.jsonl:2: a line of more than"),
                      std::string::npos)
                << e.what();
        }
    }
    fs::remove(t / "manifest.jsonl");
    ASSERT_EQ(::mkfifo((t / "manifest.jsonl").c_str(), 0600), 0);
    EXPECT_THROW(recordedInstances(t / "manifest.jsonl", d), InputError);
}

// A shard's file names parse back to their shard; every other name — numbers out of range or
// too long for an int (std::stoi threw on them: build and merge exited 1 with "stoi"), I ≥ N,
// other stems, extensions or separators — is not a shard.
TEST(ShardNames, ParseBackAndOtherNamesAreNotShards) {
    for (auto [i, n] : {std::pair{0, 2},
                        {1, 2},
                        {7, 12},
                        {999'999'999, 1'000'000'000},
                        {1'999'999'999, 2'000'000'000}}) {
        const auto m = parseShardFileName(manifestName(i, n), "manifest", ".jsonl");
        ASSERT_TRUE(m) << manifestName(i, n);
        EXPECT_EQ(m->index, i);
        EXPECT_EQ(m->count, n);
        const auto d = parseShardFileName(datasetJsonName(i, n), "dataset", ".json");
        ASSERT_TRUE(d) << datasetJsonName(i, n);
        EXPECT_EQ(d->index, i);
        EXPECT_EQ(d->count, n);
    }
    const auto lock = parseShardFileName(".sylva.shard-3-of-4.lock", ".sylva", ".lock");
    ASSERT_TRUE(lock);
    EXPECT_EQ(lock->index, 3);
    EXPECT_EQ(lock->count, 4);
    const auto top =
        parseShardFileName("manifest.shard-2147483646-of-2147483647.jsonl", "manifest", ".jsonl");
    ASSERT_TRUE(top);
    EXPECT_EQ(top->count, 2147483647);
    for (const char* name :
         {"manifest.shard-99999999999-of-2.jsonl", "manifest.shard-1-of-99999999999.jsonl",
          "manifest.shard-0-of-2147483648.jsonl", "manifest.shard-3-of-2.jsonl",
          "manifest.shard-2-of-2.jsonl", "manifest.shard--1-of-2.jsonl",
          "manifest.shard-1-of-2.jsonl.tmp", "manifest.shard-1-of-.jsonl",
          "manifest.shard--of-2.jsonl", "manifest.shard-1-of-2x.jsonl",
          "manifest.shard-1of-2.jsonl", "manifest.shard-1-of-2.json", "manifest.jsonl",
          "dataset.shard-0-of-2.jsonl", "xmanifest.shard-0-of-2.jsonl", "manifest.shard-", ""}) {
        EXPECT_FALSE(parseShardFileName(name, "manifest", ".jsonl")) << name;
    }
}

}  // namespace
