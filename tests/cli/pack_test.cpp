// [outputs] pack = "tar" end to end: the same shard bytes on 1 and 2 threads, from three
// --shard builds merged, and after a kill and a rerun; GNU tar (an independent reader) lists
// and extracts the members, which are the unpacked build's files byte for byte except the
// references renamed to member names; stats --reference and the gates read the packed build
// as the unpacked one. The Python package's reading of the same shards: tests/python/.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::CliResult;
using sylva::test::describeRun;
using sylva::test::runSylva;
using sylva::test::slurp;
using sylva::test::TempDir;

const fs::path kData = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data";
const fs::path kPacked = kData / "tiny_dataset_packed.toml";  // 24 trees, shards of 5
const fs::path kUnpacked = kData / "tiny_dataset.toml";       // the same trees, unpacked
constexpr int kShards = 5;

void buildOk(const fs::path& spec, const fs::path& out, const fs::path& cwd,
             std::vector<std::string> extra = {}, std::vector<std::string> env = {}) {
    std::vector<std::string> args = {"build", spec.string(), "--out", out.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    sylva::test::CliOptions o;
    o.env = std::move(env);
    const CliResult r = runSylva(args, cwd, o);
    ASSERT_EQ(r.code, 0) << describeRun(r);
}

// Every file under `dir`, by path relative to it, with its bytes.
std::map<std::string, std::string> filesUnder(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (e.is_regular_file())
            files[e.path().lexically_relative(dir).generic_string()] = slurp(e.path());
    }
    return files;
}

void expectSameShards(const fs::path& a, const fs::path& b, const std::string& what) {
    const auto fa = filesUnder(a / "shards"), fb = filesUnder(b / "shards");
    ASSERT_EQ(fa.size(), fb.size()) << what;
    for (const auto& [name, bytes] : fa) {
        ASSERT_TRUE(fb.count(name)) << what << ": " << name;
        EXPECT_TRUE(bytes == fb.at(name)) << what << ": " << name << " differs";
    }
}

// A command's standard output (GNU tar, run in `dir`).
std::string shell(const std::string& command, const fs::path& dir) {
    const std::string full = "cd '" + dir.string() + "' && " + command;
    std::FILE* p = ::popen(full.c_str(), "r");
    std::string out;
    char buf[4096];
    for (size_t n; p && (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
    const int status = p ? ::pclose(p) : -1;
    EXPECT_EQ(status, 0) << command;
    return out;
}

std::vector<nlohmann::json> records(const fs::path& manifest) {
    std::vector<nlohmann::json> r;
    std::ifstream in(manifest);
    for (std::string line; std::getline(in, line);) r.push_back(nlohmann::json::parse(line));
    return r;
}

TEST(CliPack, SameShardsOnAnyThreadCountShardingAndAfterAKill) {
    TempDir t;
    buildOk(kPacked, t / "t1", t.path(), {"--threads", "1"});
    const fs::path ref = t / "t1";
    for (int k = 0; k < kShards; ++k) {
        char name[32];
        std::snprintf(name, sizeof name, "shards/%06d.tar", k);
        EXPECT_TRUE(fs::is_regular_file(ref / name)) << name;
    }
    EXPECT_FALSE(fs::exists(ref / "trees")) << "instance directories left after packing";
    const nlohmann::json index = nlohmann::json::parse(slurp(ref / "shards" / "index.json"));
    EXPECT_EQ(index["__kind__"], "wids-shard-index-v1");
    ASSERT_EQ(index["shardlist"].size(), static_cast<size_t>(kShards));
    EXPECT_EQ(index["shardlist"][4]["nsamples"], 4);  // 24 = 5 + 5 + 5 + 5 + 4
    EXPECT_EQ(index["shardlist"][0]["filesize"], fs::file_size(ref / "shards" / "000000.tar"));
    for (const nlohmann::json& r : records(ref / "manifest.jsonl")) {
        EXPECT_EQ(r["pack"].get<std::string>().rfind("shards/00000", 0), 0u) << r["id"];
    }

    buildOk(kPacked, t / "t2", t.path(), {"--threads", "2"});
    expectSameShards(ref, t / "t2", "2 threads");

    // Three --shard builds into one directory: blocks of whole tar shards (5 + 10 + 9), merged.
    for (const char* s : {"0/3", "1/3", "2/3"})
        buildOk(kPacked, t / "sharded", t.path(), {"--shard", s});
    EXPECT_TRUE(fs::exists(t / "sharded" / "shards" / "index.shard-1-of-3.json"));
    const CliResult merged =
        runSylva({"merge", (t / "merged").string(), (t / "sharded").string()}, t.path());
    ASSERT_EQ(merged.code, 0) << describeRun(merged);
    expectSameShards(ref, t / "merged", "3 shards merged");
    EXPECT_EQ(slurp(t / "merged" / "contact" / "tiny.png"), slurp(ref / "contact" / "tiny.png"));

    // Killed after 7 records (shard 0 sealed or not, shard 1 staged), then rerun.
    sylva::test::CliOptions killAt;
    killAt.env = {"SYLVA_TEST_ABORT_AFTER=7"};
    const CliResult killed =
        runSylva({"build", kPacked.string(), "--out", (t / "resumed").string()}, t.path(), killAt);
    EXPECT_EQ(killed.code, 137) << describeRun(killed);
    EXPECT_TRUE(fs::exists(t / "resumed" / "trees")) << "nothing staged at the kill";
    buildOk(kPacked, t / "resumed", t.path());
    expectSameShards(ref, t / "resumed", "killed and rerun");
    EXPECT_FALSE(fs::exists(t / "resumed" / "trees"));

    // A kill while the sealed shard's directories were being removed leaves one partly there:
    // the rerun keeps the shard's copy of that instance, and removes the rest.
    const std::string id = records(ref / "manifest.jsonl")[2]["id"];
    const fs::path partial = t / "resumed" / "trees" / "tiny" / id;
    fs::create_directories(partial / "views");
    std::ofstream(partial / "views" / "000.png") << "half";
    buildOk(kPacked, t / "resumed", t.path());
    expectSameShards(ref, t / "resumed", "rerun over a partly removed directory");
    EXPECT_FALSE(fs::exists(partial));
}

TEST(CliPack, GnuTarReadsTheMembersAndTheyAreTheUnpackedFiles) {
    TempDir t;
    buildOk(kPacked, t / "packed", t.path());
    buildOk(kUnpacked, t / "plain", t.path());
    const std::vector<nlohmann::json> packed = records(t / "packed" / "manifest.jsonl");
    std::map<std::string, nlohmann::json> byId;
    for (const nlohmann::json& r : packed) byId[r["id"]] = r;

    size_t compared = 0, renamed = 0;
    for (int k = 0; k < kShards; ++k) {
        char tar[32];
        std::snprintf(tar, sizeof tar, "%06d.tar", k);
        const fs::path x = t / ("x" + std::to_string(k));
        fs::create_directories(x);
        // GNU tar's listing: samples contiguous, each member "<id>.<path with / as .>".
        std::istringstream list(shell("tar -tf " + (t / "packed" / "shards" / tar).string(), x));
        std::vector<std::string> names;
        for (std::string n; std::getline(list, n);) names.push_back(n);
        std::set<std::string> keysDone;
        std::string key;
        for (const std::string& n : names) {
            const std::string k2 = n.substr(0, n.find('.'));
            if (k2 != key) {
                EXPECT_TRUE(keysDone.insert(k2).second) << n << ": sample " << k2 << " split";
                key = k2;
            }
        }
        shell("tar -xf " + (t / "packed" / "shards" / tar).string(), x);
        for (const std::string& n : names) {
            const std::string id = n.substr(0, n.find('.'));
            const std::string rest = n.substr(id.size() + 1);
            ASSERT_TRUE(byId.count(id)) << n;
            const std::string bytes = slurp(x / n);
            if (rest == "json") {  // the record without timing
                nlohmann::json r = byId[id];
                r.erase("timing");
                EXPECT_EQ(nlohmann::json::parse(bytes), r) << n;
                continue;
            }
            // The unpacked file: the member's path with "." back to "/" where a directory was.
            const fs::path dir =
                t / "plain" / "trees" / byId[id]["species"].get<std::string>() / id;
            fs::path file = dir / rest;
            if (rest.rfind("views.", 0) == 0) file = dir / "views" / rest.substr(6);
            ASSERT_TRUE(fs::is_regular_file(file)) << n << " has no unpacked file " << file;
            const std::string plain = slurp(file);
            if (rest == "transforms.json") {  // frame files renamed to their members
                const nlohmann::json a = nlohmann::json::parse(bytes),
                                     b = nlohmann::json::parse(plain);
                ASSERT_EQ(a["frames"].size(), b["frames"].size());
                for (size_t f = 0; f < a["frames"].size(); ++f) {
                    const std::string member = a["frames"][f]["file_path"];
                    EXPECT_EQ(
                        member,
                        id + "." + std::string(b["frames"][f]["file_path"]).replace(5, 1, "."));
                    EXPECT_TRUE(fs::is_regular_file(x / member)) << member;
                    EXPECT_EQ(a["frames"][f]["transform_matrix"],
                              b["frames"][f]["transform_matrix"]);
                }
                ++renamed;
            } else if (fs::path(rest).extension() == ".obj") {  // mtllib renamed
                const std::string stem = fs::path(rest).stem().string();
                std::string expect = plain;
                const std::string from = "mtllib " + stem + ".mtl";
                expect.replace(expect.find(from), from.size(),
                               "mtllib " + id + "." + stem + ".mtl");
                EXPECT_TRUE(bytes == expect) << n;
                ++renamed;
            } else {
                EXPECT_TRUE(bytes == plain) << n << " differs from " << file;
                ++compared;
            }
        }
    }
    EXPECT_EQ(renamed, 24u * 3);  // transforms.json, mesh.obj, watertight.obj per tree
    EXPECT_GT(compared, 24u * 20);

    // The record's files name members of its tar.
    const nlohmann::json& r = packed.front();
    EXPECT_EQ(r["files"]["mesh_glb"], r["id"].get<std::string>() + ".mesh.glb");
    EXPECT_EQ(r["files"]["views"], r["id"].get<std::string>() + ".views");

    // Read back by stats --reference and the realism gates as the unpacked build.
    const std::string ref =
        (fs::path(SYLVA_SOURCE_DIR) / "species" / "reference" / "treeqsm-broadleaf.json").string();
    for (const char* d : {"packed", "plain"}) {
        const CliResult s = runSylva({"stats", (t / d).string(), "--reference", ref}, t.path());
        ASSERT_EQ(s.code, 0) << describeRun(s);
    }
    EXPECT_EQ(slurp(t / "packed" / "stats" / "reference.csv"),
              slurp(t / "plain" / "stats" / "reference.csv"));
    const CliResult ga = runSylva({"gates", (t / "packed").string()}, t.path());
    const CliResult gb = runSylva({"gates", (t / "plain").string()}, t.path());
    EXPECT_EQ(ga.out, gb.out) << describeRun(ga);
    EXPECT_EQ(slurp(t / "packed" / "contact" / "tiny-var.png"),
              slurp(t / "plain" / "contact" / "tiny-var.png"));
}

TEST(CliPack, PackInstancesWithoutPackIsOneLine) {
    TempDir t;
    std::string spec = slurp(kUnpacked);
    spec.replace(spec.find("[outputs]\n"), 10, "[outputs]\npack_instances = 5\n");
    for (const char* f : {"tiny.toml", "tiny_var.toml"}) fs::copy_file(kData / f, t / f);
    const fs::path file = t / "alone.toml";
    std::ofstream(file) << spec;
    const CliResult r = runSylva({"build", file.string(), "--out", (t / "out").string()}, t.path());
    EXPECT_EQ(r.code, 2) << describeRun(r);
    EXPECT_NE(r.err.find("pack_instances"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("pack = \"tar\""), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(t / "out"));
}

}  // namespace
