// Tar shards (pipeline/formats/tar_pack.h) and the packed layout (pipeline/batch/pack.h): the
// writer's headers field by field, its archives indexed back, long names through pax records,
// malformed archives refused; member names, records, and --shard blocks of whole tar shards.
// GNU tar and Python's tarfile read the shards of a real build in tests/cli/pack_test.cpp and
// tests/python/.
#include "pipeline/formats/tar_pack.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "core/errors.h"
#include "pipeline/batch/build.h"
#include "pipeline/batch/pack.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using namespace sylva;
using sylva::test::slurp;
using sylva::test::TempDir;

std::string bytesOf(size_t n, char seed) {
    std::string s(n, '\0');
    for (size_t i = 0; i < n; ++i) s[i] = static_cast<char>(seed + 31 * i);
    return s;
}

// The octal number of a header field (NUL- or space-terminated).
uint64_t octal(const std::string& header, size_t at, size_t width) {
    return std::stoull(header.substr(at, width), nullptr, 8);
}

TEST(TarPack, HeadersAreFixedUstarAndTheArchiveEndsOnARecord) {
    TempDir t;
    const fs::path tar = t / "a.tar";
    TarWriter w(tar);
    const TarMember m = w.add("key.mesh.glb", bytesOf(700, 3));
    w.commit();
    const std::string a = slurp(tar);
    ASSERT_EQ(a.size() % 10240, 0u);
    const std::string h = a.substr(0, 512);
    EXPECT_EQ(std::string(h.c_str()), "key.mesh.glb");
    EXPECT_EQ(octal(h, 100, 8), 0644u);  // mode
    EXPECT_EQ(octal(h, 108, 8), 0u);     // uid
    EXPECT_EQ(octal(h, 116, 8), 0u);     // gid
    EXPECT_EQ(octal(h, 124, 12), 700u);  // size
    EXPECT_EQ(octal(h, 136, 12), 0u);    // mtime
    EXPECT_EQ(h[156], '0');              // a regular file
    EXPECT_EQ(h.substr(257, 8), std::string("ustar\0"
                                            "00",
                                            8));
    uint64_t sum = 0;
    for (size_t i = 0; i < 512; ++i) sum += (i >= 148 && i < 156) ? ' ' : uint8_t(h[i]);
    EXPECT_EQ(octal(h, 148, 7), sum);
    EXPECT_EQ(m.offset, 512u);
    EXPECT_EQ(a.substr(512, 700), bytesOf(700, 3));
    // Data padded to 512, then two zero blocks at least.
    EXPECT_EQ(a.substr(1212, 1024 + 300), std::string(1024 + 300, '\0'));
}

TEST(TarPack, IndexReadsBackEveryMemberWithLongNamesAndEdgeSizes) {
    TempDir t;
    const fs::path tar = t / "b.tar";
    std::vector<std::pair<std::string, std::string>> files = {
        {"s.json", ""},
        {std::string(100, 'n'), bytesOf(1, 5)},                    // exactly the ustar field
        {std::string(101, 'l'), bytesOf(511, 7)},                  // one past: a pax record
        {"k." + std::string(300, 'x') + ".png", bytesOf(512, 9)},  // long, block-sized data
        {"k.views.000_depth.exr", bytesOf(513, 11)},
    };
    std::vector<TarMember> written;
    TarWriter w(tar);
    for (const auto& [name, data] : files) written.push_back(w.add(name, data));
    w.commit();
    const std::vector<TarMember> read = indexTar(tar);
    ASSERT_EQ(read.size(), files.size());
    for (size_t i = 0; i < files.size(); ++i) {
        EXPECT_EQ(read[i].name, files[i].first);
        EXPECT_EQ(read[i].offset, written[i].offset);
        EXPECT_EQ(read[i].size, files[i].second.size());
        EXPECT_EQ(readTarMember(tar, read[i]), files[i].second);
    }
}

TEST(TarPack, MalformedArchivesAreRefusedWithTheByte) {
    TempDir t;
    const fs::path tar = t / "c.tar";
    TarWriter w(tar);
    w.add("a.txt", bytesOf(2000, 1));
    w.add("b.txt", bytesOf(10, 2));
    w.commit();
    std::string a = slurp(tar);

    std::string badSum = a;
    badSum[0] = 'z';  // the name changes, the stored checksum does not
    std::ofstream(t / "sum.tar", std::ios::binary) << badSum;
    try {
        indexTar(t / "sum.tar");
        FAIL() << "a bad checksum was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("byte 0: not a tar header"), std::string::npos)
            << e.what();
    }
    // Cut inside the first member's data: it runs past the end.
    std::ofstream(t / "cut.tar", std::ios::binary) << a.substr(0, 1500);
    EXPECT_THROW(indexTar(t / "cut.tar"), InputError);
    // Garbage where the second header is.
    std::string garbage = a;
    std::memset(&garbage[512 + 2048], 'q', 512);
    std::ofstream(t / "garbage.tar", std::ios::binary) << garbage;
    EXPECT_THROW(indexTar(t / "garbage.tar"), InputError);
}

TEST(PackLayout, MemberNamesRecordsAndShardFiles) {
    EXPECT_EQ(packMemberName("oak-00012", "mesh.glb"), "oak-00012.mesh.glb");
    EXPECT_EQ(packMemberName("oak-00012", "views/000_depth.exr"), "oak-00012.views.000_depth.exr");
    EXPECT_EQ(packMemberName("oak-00012", kPackRecordFile), "oak-00012.json");

    nlohmann::json r = {{"id", "oak-00012"},
                        {"files",
                         {{"mesh_glb", "trees/oak/oak-00012/mesh.glb"},
                          {"views", "trees/oak/oak-00012/views"},
                          {"elsewhere", "contact/oak.png"}}}};
    packRecordFiles(r, "oak-00012", "trees/oak/oak-00012", "shards/000002.tar");
    EXPECT_EQ(r["pack"], "shards/000002.tar");
    EXPECT_EQ(r["files"]["mesh_glb"], "oak-00012.mesh.glb");
    EXPECT_EQ(r["files"]["views"], "oak-00012.views");
    EXPECT_EQ(r["files"]["elsewhere"], "contact/oak.png");  // not the instance's: unchanged

    const PackLayout l = packLayout(1001, 10);
    EXPECT_EQ(l.shards, 101);
    EXPECT_EQ(l.shardOf(999), 99);
    EXPECT_EQ(l.tarPath(7), "shards/000007.tar");
    EXPECT_EQ(packLayout(int64_t{30'000'001}, 10).tarName(3), "0000003.tar");  // 3,000,001 shards
    EXPECT_FALSE(packLayout(1001, 0).packed());
}

TEST(PackLayout, ShardBlocksAreWholeTarShardsCoveringTheDataset) {
    for (const int64_t size :
         {int64_t{1}, int64_t{24}, int64_t{1001}, int64_t{9'000'000'000'000'000}}) {
        for (const int64_t m : {int64_t{1}, int64_t{5}, int64_t{256}}) {
            for (const int count : {1, 2, 3, 7}) {
                int64_t expect = 0;
                for (int i = 0; i < count; ++i) {
                    const auto [lo, hi] = shardPositions(size, i, count, m);
                    EXPECT_EQ(lo, expect) << size << " " << m << " " << i << "/" << count;
                    EXPECT_LE(lo, hi);
                    EXPECT_EQ(lo % m, 0);
                    EXPECT_TRUE(hi == size || hi % m == 0);
                    expect = hi;
                }
                EXPECT_EQ(expect, size);
            }
        }
    }
    // Unpacked: the plain blocks.
    const auto [lo, hi] = shardPositions(24, 1, 3, 0);
    EXPECT_EQ(lo, static_cast<int64_t>(shardRange(24, 1, 3).first));
    EXPECT_EQ(hi, static_cast<int64_t>(shardRange(24, 1, 3).second));
}

}  // namespace
