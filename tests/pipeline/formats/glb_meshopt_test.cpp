// The meshopt-compressed GLB: decoded with meshoptimizer's own decoders, every position within
// the stated error of the plain file's, normals within 1/127, the other attributes and the
// triangles as they were; smaller, the same bytes every time, and bad input refused.
#include "pipeline/formats/glb_meshopt.h"

#include <gtest/gtest.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <cstring>
#include <nlohmann/json.hpp>

#include "pipeline/formats/mesh_writers.h"
#include "species/geometry/leaf_mesh.h"
#include "species/geometry/tube_mesh.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using nlohmann::json;

TreeMesh sampleMesh() {
    Tree t;
    test::addNode(t, -1, {0, 0, 0}, 0.3, 0);
    test::addNode(t, 0, {0.2, 6.0, -0.1}, 0.2, 0);
    test::addNode(t, 1, {2.5, 8.0, 1.0}, 0.08, 1);
    for (int i = 0; i < 40; ++i) {
        Leaf l;
        l.position = {2.5 - 0.05 * i, 8.0 + 0.02 * i, 1.0 - 0.03 * i};
        l.colour = static_cast<uint8_t>(i % 3);
        l.shape = i % 2 ? LeafShape::kCompound : LeafShape::kCard;
        t.leaves.push_back(l);
    }
    TreeMesh m;
    m.wood = tubeMesh(t, TubeOptions{});
    m.leaves = leafMesh(t);
    return m;
}

struct Glb {
    json doc;
    std::string bin;
};
Glb parse(const std::string& glb) {
    auto u32 = [&](size_t at) {
        uint32_t v;
        std::memcpy(&v, glb.data() + at, 4);
        return v;
    };
    Glb g;
    const uint32_t jsonLength = u32(12);
    g.doc = json::parse(glb.substr(20, jsonLength));
    g.bin = glb.substr(20 + jsonLength + 8, u32(20 + jsonLength));
    return g;
}

// The decoded bytes of an accessor of the compressed file.
std::vector<unsigned char> decoded(const Glb& g, int accessor) {
    const json& acc = g.doc["accessors"][accessor];
    const json& view = g.doc["bufferViews"][acc["bufferView"].get<int>()];
    const json& ext = view["extensions"]["EXT_meshopt_compression"];
    const size_t count = ext["count"], stride = ext["byteStride"];
    const auto* src =
        reinterpret_cast<const unsigned char*>(g.bin.data()) + ext["byteOffset"].get<size_t>();
    const size_t length = ext["byteLength"];
    std::vector<unsigned char> out(count * stride);
    const int rc = ext["mode"] == "TRIANGLES"
                       ? meshopt_decodeIndexBuffer(out.data(), count, stride, src, length)
                       : meshopt_decodeVertexBuffer(out.data(), count, stride, src, length);
    EXPECT_EQ(rc, 0);
    EXPECT_EQ(view["buffer"], 1);  // the fallback buffer's view
    return out;
}

std::vector<float> plainFloats(const Glb& g, int accessor) {
    const json& acc = g.doc["accessors"][accessor];
    const json& view = g.doc["bufferViews"][acc["bufferView"].get<int>()];
    std::vector<float> out(view["byteLength"].get<size_t>() / 4);
    std::memcpy(out.data(), g.bin.data() + view.value("byteOffset", size_t(0)), 4 * out.size());
    return out;
}

TEST(GlbMeshopt, DecodesToThePlainMeshWithinTheStatedError) {
    const std::string plainBytes = meshGlb(sampleMesh());
    GlbCompression report;
    const std::string packedBytes = compressGlbMeshopt(plainBytes, &report);
    EXPECT_EQ(report.bytesBefore, plainBytes.size());
    EXPECT_EQ(report.bytesAfter, packedBytes.size());
    EXPECT_LT(packedBytes.size(), plainBytes.size() / 2);
    // The positions span 8 m and a bit: the step is ~0.13 mm, the error half of it.
    EXPECT_GT(report.positionError, 0.0);
    EXPECT_LT(report.positionError, 1e-4);
    EXPECT_EQ(compressGlbMeshopt(plainBytes), packedBytes);  // the same bytes every time

    const Glb plain = parse(plainBytes), packed = parse(packedBytes);
    for (const char* list : {"extensionsUsed", "extensionsRequired"}) {
        EXPECT_NE(
            std::find(packed.doc[list].begin(), packed.doc[list].end(), "EXT_meshopt_compression"),
            packed.doc[list].end());
        EXPECT_NE(
            std::find(packed.doc[list].begin(), packed.doc[list].end(), "KHR_mesh_quantization"),
            packed.doc[list].end());
    }
    EXPECT_EQ(packed.doc["buffers"][1]["extensions"]["EXT_meshopt_compression"]["fallback"], true);
    ASSERT_EQ(packed.doc["meshes"].size(), 2u);
    int nodes = 0;
    for (const json& node : packed.doc["nodes"]) {
        const json& mesh = packed.doc["meshes"][node["mesh"].get<int>()];
        const json& prim = mesh["primitives"][0];
        const json& refPrim = plain.doc["meshes"][node["mesh"].get<int>()]["primitives"][0];
        const double s = node["scale"][0];
        EXPECT_DOUBLE_EQ(report.positionError, s / 2);
        const int pos = prim["attributes"]["POSITION"];
        EXPECT_EQ(packed.doc["accessors"][pos]["componentType"], 5122);  // SHORT
        const std::vector<unsigned char> q = decoded(packed, pos);
        const std::vector<float> p = plainFloats(plain, refPrim["attributes"]["POSITION"]);
        ASSERT_EQ(q.size() / 8, p.size() / 3);
        double worst = 0;
        for (size_t i = 0; i < p.size() / 3; ++i) {
            for (int c = 0; c < 3; ++c) {
                int16_t v;
                std::memcpy(&v, &q[8 * i + 2 * c], 2);
                const double world = node["translation"][c].get<double>() + s * v;
                worst = std::max(worst, std::abs(world - p[3 * i + c]));
            }
        }
        EXPECT_LE(worst, report.positionError + 1e-6);
        EXPECT_GT(worst, 0.0);  // quantised: not the floats themselves
        const std::vector<unsigned char> nq = decoded(packed, prim["attributes"]["NORMAL"]);
        const std::vector<float> n = plainFloats(plain, refPrim["attributes"]["NORMAL"]);
        for (size_t i = 0; i < n.size() / 3; ++i) {
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(static_cast<int8_t>(nq[4 * i + c]) / 127.0, n[3 * i + c],
                            0.5 / 127 + 1e-6);
            }
        }
        // UVs: the leaves' (in [0, 1]) as 16-bit fractions, the tubes' (past 1) as they were.
        const int uvAccessor = prim["attributes"]["TEXCOORD_0"];
        const std::vector<unsigned char> uv = decoded(packed, uvAccessor);
        const std::vector<float> refUv = plainFloats(plain, refPrim["attributes"]["TEXCOORD_0"]);
        const bool leaves = mesh["name"] == "leaves";
        EXPECT_EQ(packed.doc["accessors"][uvAccessor]["componentType"], leaves ? 5123 : 5126);
        ASSERT_EQ(uv.size(), 4 * refUv.size() / (leaves ? 2 : 1));
        if (leaves) {
            for (size_t k = 0; k < refUv.size(); ++k) {
                uint16_t u;
                std::memcpy(&u, &uv[2 * k], 2);
                EXPECT_NEAR(u / 65535.0, refUv[k], 0.5 / 65535 + 1e-7);
            }
        } else {
            EXPECT_EQ(std::memcmp(uv.data(), refUv.data(), uv.size()), 0);
        }
        const std::vector<unsigned char> idx = decoded(packed, prim["indices"]);
        const std::vector<float> refIdxBits = plainFloats(plain, refPrim["indices"]);
        std::vector<uint32_t> a(idx.size() / 4), b(refIdxBits.size());
        std::memcpy(a.data(), idx.data(), idx.size());
        std::memcpy(b.data(), refIdxBits.data(), 4 * b.size());
        ASSERT_EQ(a.size(), b.size());
        for (size_t t = 0; t < a.size() / 3; ++t) {  // the same triangle, perhaps rotated
            const uint32_t* x = &a[3 * t];
            const uint32_t* y = &b[3 * t];
            const bool same = (x[0] == y[0] && x[1] == y[1] && x[2] == y[2]) ||
                              (x[0] == y[1] && x[1] == y[2] && x[2] == y[0]) ||
                              (x[0] == y[2] && x[1] == y[0] && x[2] == y[1]);
            ASSERT_TRUE(same) << "triangle " << t;
        }
        ++nodes;
    }
    EXPECT_EQ(nodes, 2);
}

TEST(GlbMeshopt, RefusesWhatItCannotTake) {
    EXPECT_THROW(compressGlbMeshopt("not a glb at all, not at all"), std::invalid_argument);
    std::string glb = meshGlb(sampleMesh());
    // A node with a transform of its own.
    Glb g = parse(glb);
    g.doc["nodes"][0]["scale"] = {2, 2, 2};
    std::string text = g.doc.dump();
    while (text.size() % 4) text.push_back(' ');
    std::string bad = glb.substr(0, 12);
    const uint32_t jl = static_cast<uint32_t>(text.size());
    bad.append(reinterpret_cast<const char*>(&jl), 4);
    bad += glb.substr(16, 4);
    bad += text;
    uint32_t oldJson;
    std::memcpy(&oldJson, glb.data() + 12, 4);
    bad = bad.substr(0, 20 + text.size()) + glb.substr(20 + oldJson);
    EXPECT_THROW(compressGlbMeshopt(bad), std::invalid_argument);
}

// The build compresses meshGlb's parts without writing the plain file: the parts are that
// file, byte for byte, and compress to the same bytes, plain or textured, with empty parts.
TEST(GlbMeshopt, PartsAreThePlainFileAndCompressAlike) {
    const TreeMesh full = sampleMesh();
    TreeMesh wood = full, leaves = full;
    wood.leaves = Mesh{};
    leaves.wood = Mesh{};
    const TreeMesh woodOnly = wood, leavesOnly = leaves, none;
    Look birch;
    birch.pattern = BarkPattern::kBanded;
    birch.barkRoughness = 1.0;  // the default roughness, which a writer leaves out
    const MeshLook look{&birch, 42, 64};
    for (const TreeMesh* m : {&full, &woodOnly, &leavesOnly, &none}) {
        for (const MeshLook* ml : {static_cast<const MeshLook*>(nullptr), &look}) {
            const std::string plain = meshGlb(*m, ml);
            const GlbParts parts = meshGlbParts(*m, ml);
            EXPECT_TRUE(glbFromParts(parts) == plain)
                << m->wood.empty() << m->leaves.empty() << !!ml;
            if (m->wood.empty() && m->leaves.empty()) continue;  // (nothing to compress)
            GlbCompression a, b;
            EXPECT_TRUE(compressGlbMeshopt(parts, &a) == compressGlbMeshopt(plain, &b));
            EXPECT_EQ(a.bytesBefore, b.bytesBefore);
            EXPECT_EQ(a.bytesAfter, b.bytesAfter);
            EXPECT_EQ(a.positionError, b.positionError);
        }
    }
}

}  // namespace
}  // namespace sylva
