// Reading skeleton.ply back (pipeline/formats/skeleton_reader.cpp): what skeletonPly writes, a
// PLY of other scalar types written by hand, and every kind of malformed file.
#include "pipeline/formats/skeleton_reader.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <string>

#include "core/errors.h"
#include "pipeline/formats/skeleton_writers.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

Tree sample() {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.25);
    addNode(t, 0, {0.1, 1.5, -0.2}, 0.125, 0);
    addNode(t, 1, {0.5, 2.0, 0.3}, 0.0625, 1);
    addNode(t, 0, {0.0, -0.5, 0.1}, 0.03125, 0, kRootPart);
    addNode(t, 1, {-0.75, 2.25, 0.0}, 0.015625, 2);
    return t;
}

template <typename T>
void put(std::string& s, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));  // the tests run on little-endian hosts only
    s.append(b, sizeof(T));
}

std::string errorOf(const std::string& bytes) {
    try {
        readSkeletonPly(bytes, "x.ply");
    } catch (const InputError& e) {
        return e.what();
    }
    return "(no error)";
}

TEST(SkeletonReader, ReadsBackWhatSkeletonPlyWrites) {
    const Tree t = sample();
    const Tree r = readSkeletonPly(skeletonPly(t), "skeleton.ply");
    ASSERT_EQ(r.nodes.size(), t.nodes.size());
    for (size_t i = 0; i < t.nodes.size(); ++i) {
        // Stored as floats.
        EXPECT_EQ(r.nodes[i].position.x, double(float(t.nodes[i].position.x))) << i;
        EXPECT_EQ(r.nodes[i].position.y, double(float(t.nodes[i].position.y))) << i;
        EXPECT_EQ(r.nodes[i].position.z, double(float(t.nodes[i].position.z))) << i;
        EXPECT_EQ(r.nodes[i].radius, double(float(t.nodes[i].radius))) << i;
        EXPECT_EQ(r.nodes[i].parent, t.nodes[i].parent) << i;
        EXPECT_EQ(r.nodes[i].order, t.nodes[i].order) << i;
        EXPECT_EQ(r.nodes[i].part, t.nodes[i].part) << i;
    }
    EXPECT_EQ(skeletonPly(r), skeletonPly(t));
}

TEST(SkeletonReader, OtherScalarTypesExtraPropertiesAndDefaults) {
    // Doubles, an extra vertex property, no order or part (0: trunk, shoot), uchar edges with an
    // extra property between them.
    std::string s =
        "ply\nformat binary_little_endian 1.0\ncomment by hand\n"
        "element vertex 2\nproperty double x\nproperty double y\nproperty double z\n"
        "property short id\nproperty double radius\n"
        "element edge 1\nproperty uchar vertex1\nproperty float weight\nproperty uint vertex2\n"
        "end_header\n";
    put<double>(s, 1.0), put<double>(s, 2.0), put<double>(s, 3.0), put<int16_t>(s, -7);
    put<double>(s, 0.1);
    put<double>(s, 4.0), put<double>(s, 5.0), put<double>(s, 6.0), put<int16_t>(s, 9);
    put<double>(s, 0.05);
    put<uint8_t>(s, 0), put<float>(s, 1.5f), put<uint32_t>(s, 1);
    const Tree t = readSkeletonPly(s, "hand.ply");
    ASSERT_EQ(t.nodes.size(), 2u);
    EXPECT_EQ(t.nodes[1].position.z, 6.0);
    EXPECT_EQ(t.nodes[0].radius, 0.1);
    EXPECT_EQ(t.nodes[1].radius, 0.05);
    EXPECT_EQ(t.nodes[0].parent, -1);
    EXPECT_EQ(t.nodes[1].parent, 0);
    EXPECT_EQ(t.nodes[1].order, 0);
    EXPECT_EQ(t.nodes[1].part, kShootPart);
}

TEST(SkeletonReader, MalformedFilesAreInputErrorsNamingTheFile) {
    const std::string good = skeletonPly(sample());
    const size_t body = good.find("end_header\n") + 11;
    auto replaced = [&](const std::string& from, const std::string& to) {
        std::string s = good;
        s.replace(s.find(from), from.size(), to);
        return s;
    };
    EXPECT_EQ(errorOf("solid x\n"), "x.ply: not a PLY file (no \"ply\" line or no \"end_header\")");
    EXPECT_EQ(errorOf(replaced("binary_little_endian", "ascii")),
              "x.ply: expected format binary_little_endian, got ascii");
    EXPECT_EQ(errorOf(good.substr(0, good.size() - 1)),
              "x.ply: truncated: the header announces more data than there is");
    EXPECT_EQ(errorOf(replaced("property float radius\n", "property float r\n")),
              "x.ply: vertex has no property radius");
    EXPECT_EQ(errorOf(replaced("property int vertex1\n", "property list uchar int vertex1\n")),
              "x.ply: list property in \"property list uchar int vertex1\": expected scalars only");
    EXPECT_EQ(errorOf(replaced("element edge 4\n", "element edge 3\n")),
              "x.ply: expected one edge per vertex but the root");
    EXPECT_EQ(errorOf(replaced("element vertex 5\n", "element face 5\n")),
              "x.ply: expected element vertex, then element edge");
    // An edge whose parent is not below its child, and a node with two parents.
    std::string s = good;
    const size_t edges = body + 5 * 21;
    std::memcpy(&s[edges], "\x02\0\0\0", 4);  // edge 0: 2 -> 1
    EXPECT_EQ(errorOf(s),
              "x.ply: edge 0: expected a parent index below its child's, within the vertices");
    s = good;
    std::memcpy(&s[edges + 12], "\x01\0\0\0", 4);  // edge 1: 1 -> 1 (vertex2 of edge 1)
    EXPECT_EQ(errorOf(s).rfind("x.ply: edge 1: ", 0), 0u) << errorOf(s);
    s = good;
    std::memcpy(&s[edges + 8 + 4], "\x03\0\0\0", 4);  // edges 1 and 2 both end at vertex 3
    EXPECT_EQ(errorOf(s), "x.ply: vertex 3 has two parents");
}

}  // namespace
}  // namespace sylva
