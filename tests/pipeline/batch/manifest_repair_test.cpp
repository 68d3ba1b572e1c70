// repairManifest: the first complete record of each id, in job order, whatever an old
// concurrent or killed run left; the file rewritten only when that changes it.
#include "pipeline/batch/manifest_repair.h"

#include <gtest/gtest.h>

#include <fstream>
#include <map>

#include "core/errors.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;
using test::slurp;
using test::TempDir;

void spit(const fs::path& p, const std::string& s) { std::ofstream(p, std::ios::binary) << s; }

std::string rec(const std::string& id, int version = 0) {
    return "{\"id\":\"" + id + "\",\"v\":" + std::to_string(version) + "}";
}

const std::map<std::string, size_t> kJobs = {{"a", 0}, {"b", 1}, {"c", 2}, {"d", 3}};

std::optional<size_t> position(const std::string& id) {
    auto it = kJobs.find(id);
    if (it == kJobs.end()) return std::nullopt;
    return it->second;
}

TEST(ManifestRepair, KeepsTheFirstCompleteRecordPerIdInJobOrder) {
    TempDir t;
    const fs::path m = t / "manifest.jsonl";
    spit(m, rec("c") + "\n" + rec("a") + "\n{\"id\":\"b" + rec("b") + "\n" + rec("c", 1) + "\n" +
                rec("a", 1) + "\nnot json\n" + rec("d") + "\n{\"id\":\"tor");
    const ManifestRepair r = repairManifest(m, position);
    EXPECT_EQ(r.ids, (std::vector<std::string>{"a", "c", "d"}));
    EXPECT_EQ(r.duplicates, 2u);
    EXPECT_EQ(r.unreadable, 3u);  // the torn line in the middle, "not json", the torn tail
    EXPECT_TRUE(r.reordered);
    EXPECT_TRUE(r.rewritten);
    EXPECT_EQ(slurp(m), rec("a") + "\n" + rec("c") + "\n" + rec("d") + "\n");
    // Sound now: read again, nothing changes.
    const ManifestRepair again = repairManifest(m, position);
    EXPECT_FALSE(again.rewritten);
    EXPECT_EQ(again.lines, r.lines);
}

TEST(ManifestRepair, MissingOrSoundFileIsLeftAlone) {
    TempDir t;
    EXPECT_TRUE(repairManifest(t / "none.jsonl", position).ids.empty());
    EXPECT_FALSE(fs::exists(t / "none.jsonl"));
    const std::string sound = rec("a") + "\n" + rec("b") + "\n";
    spit(t / "m.jsonl", sound);
    const auto before = fs::last_write_time(t / "m.jsonl");
    const ManifestRepair r = repairManifest(t / "m.jsonl", position);
    EXPECT_FALSE(r.rewritten);
    EXPECT_EQ(slurp(t / "m.jsonl"), sound);
    EXPECT_EQ(fs::last_write_time(t / "m.jsonl"), before);
}

TEST(ManifestRepair, ARecordOfAnotherDatasetIsBadInput) {
    TempDir t;
    spit(t / "m.jsonl", rec("a") + "\n" + rec("zz") + "\n");
    try {
        repairManifest(t / "m.jsonl", position);
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("m.jsonl:2: instance zz is not one this build makes"),
                  std::string::npos)
            << e.what();
    }
    EXPECT_EQ(slurp(t / "m.jsonl"), rec("a") + "\n" + rec("zz") + "\n");
}

}  // namespace
}  // namespace sylva
