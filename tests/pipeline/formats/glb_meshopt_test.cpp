// The meshopt-compressed GLB: decoded with meshoptimizer's own decoders, every position within
// the stated error of the plain file's, normals within 1/127, the other attributes and the
// triangles as they were; smaller, the same bytes every time, and bad input refused. The
// Draco-compressed GLB: decoded with Draco's decoder, every vertex one of the plain file's within
// the stated quantisation, every triangle one of its triangles.
#include "pipeline/formats/glb_meshopt.h"

#include <draco/compression/decode.h>
#include <draco/mesh/mesh.h>
#include <gtest/gtest.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <cstring>
#include <map>
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

// The Draco file of the sample mesh: its primitives Draco's (their accessors without views and
// with the decoded counts), no node transform, and what Draco decodes is the plain mesh within
// the stated quantisation: each decoded vertex a plain vertex (position within
// report.positionError, normal within 1.1°, UVs within 1/1024, _ORDER and _COLOUR exact as
// integers), each decoded triangle a plain triangle with its winding, each plain triangle
// with area decoded. Smaller than the meshopt file; the same bytes every time and from parts.
TEST(GlbDraco, DecodesToThePlainMeshWithinTheStatedQuantisation) {
    const TreeMesh mesh = sampleMesh();
    const std::string plainBytes = meshGlb(mesh);
    GlbCompression report;
    const std::string bytes = compressGlbDraco(plainBytes, &report);
    EXPECT_EQ(report.bytesBefore, plainBytes.size());
    EXPECT_EQ(report.bytesAfter, bytes.size());
    EXPECT_LT(bytes.size(), compressGlbMeshopt(plainBytes).size());
    EXPECT_EQ(compressGlbDraco(plainBytes), bytes);
    EXPECT_EQ(compressGlbDraco(meshGlbParts(mesh)), bytes);
    // 16 bits over the largest extent (the tube reaches 8 m and a bit): ≈ 0.06 mm.
    EXPECT_GT(report.positionError, 0.0);
    EXPECT_LT(report.positionError, 1e-4);

    const Glb plain = parse(plainBytes), packed = parse(bytes);
    for (const char* list : {"extensionsUsed", "extensionsRequired"}) {
        EXPECT_EQ(packed.doc[list], json::array({"KHR_draco_mesh_compression"})) << list;
    }
    EXPECT_EQ(packed.doc["buffers"].size(), 1u);  // no meshopt fallback buffer
    ASSERT_EQ(packed.doc["meshes"].size(), 2u);
    for (const json& node : packed.doc["nodes"]) {
        EXPECT_FALSE(node.contains("translation") || node.contains("scale"));
        const int m = node["mesh"];
        const json& prim = packed.doc["meshes"][m]["primitives"][0];
        const json& refPrim = plain.doc["meshes"][m]["primitives"][0];
        const json& ext = prim["extensions"]["KHR_draco_mesh_compression"];
        const json& view = packed.doc["bufferViews"][ext["bufferView"].get<int>()];
        draco::DecoderBuffer in;
        in.Init(packed.bin.data() + view.value("byteOffset", size_t(0)),
                view["byteLength"].get<size_t>());
        draco::Decoder decoder;
        auto result = decoder.DecodeMeshFromBuffer(&in);
        ASSERT_TRUE(result.ok());
        const draco::Mesh& back = *result.value();
        EXPECT_EQ(packed.doc["accessors"][prim["indices"].get<int>()]["count"],
                  3 * back.num_faces());
        std::map<std::string, std::vector<float>> ref, got;
        for (const auto& [name, index] : prim["attributes"].items()) {
            const json& acc = packed.doc["accessors"][index.get<int>()];
            EXPECT_FALSE(acc.contains("bufferView")) << name;
            EXPECT_EQ(acc["count"], back.num_points()) << name;
            ref[name] = plainFloats(plain, refPrim["attributes"][name]);
            const draco::PointAttribute* a = back.GetAttributeByUniqueId(ext["attributes"][name]);
            ASSERT_NE(a, nullptr) << name;
            const int n = a->num_components();
            std::vector<float> values(n * back.num_points()), one(n);
            for (uint32_t i = 0; i < back.num_points(); ++i) {
                a->ConvertValue<float>(a->mapped_index(draco::PointIndex(i)), n, one.data());
                std::copy(one.begin(), one.end(), values.begin() + n * i);
            }
            got[name] = values;
            if (name[0] == '_') {  // whole numbers: UNSIGNED_BYTE, or SHORT (a leaf's order −1)
                EXPECT_TRUE(acc["componentType"] == 5121 || acc["componentType"] == 5122) << name;
            }
        }
        ASSERT_TRUE(got.count("POSITION") && got.count("NORMAL") && got.count("TEXCOORD_0"));
        const size_t nRef = ref["POSITION"].size() / 3, nGot = back.num_points();
        EXPECT_GE(nGot, nRef);  // (Draco may split a vertex, never merge two)
        auto matches = [&](size_t i, size_t j) {
            for (int c = 0; c < 3; ++c) {
                if (std::abs(got["POSITION"][3 * i + c] - ref["POSITION"][3 * j + c]) >
                    report.positionError + 1e-6) {
                    return false;
                }
            }
            double dot = 0;
            for (int c = 0; c < 3; ++c) dot += got["NORMAL"][3 * i + c] * ref["NORMAL"][3 * j + c];
            if (dot < std::cos(1.1 * 3.14159265358979 / 180)) return false;
            for (int c = 0; c < 2; ++c) {
                if (std::abs(got["TEXCOORD_0"][2 * i + c] - ref["TEXCOORD_0"][2 * j + c]) >
                    1.0 / 1024 + 1e-6) {
                    return false;
                }
            }
            for (const auto& [name, values] : got) {
                if (name[0] == '_' && values[i] != ref[name][j]) return false;
            }
            return true;
        };
        std::vector<std::vector<uint32_t>> plainOf(nGot);
        for (size_t i = 0; i < nGot; ++i) {
            for (size_t j = 0; j < nRef; ++j) {
                if (matches(i, j)) plainOf[i].push_back(static_cast<uint32_t>(j));
            }
            ASSERT_FALSE(plainOf[i].empty()) << "decoded vertex " << i << " of mesh " << m;
        }
        // Triangles, each as its rotation with the smallest index first (the winding kept).
        auto key = [](uint32_t a, uint32_t b, uint32_t c) {
            if (a <= b && a <= c) return std::array<uint32_t, 3>{a, b, c};
            if (b <= a && b <= c) return std::array<uint32_t, 3>{b, c, a};
            return std::array<uint32_t, 3>{c, a, b};
        };
        std::map<std::array<uint32_t, 3>, int> left;
        const std::vector<float> refIdxBits = plainFloats(plain, refPrim["indices"]);
        std::vector<uint32_t> refIdx(refIdxBits.size());
        std::memcpy(refIdx.data(), refIdxBits.data(), 4 * refIdx.size());
        for (size_t t = 0; t < refIdx.size() / 3; ++t) {
            ++left[key(refIdx[3 * t], refIdx[3 * t + 1], refIdx[3 * t + 2])];
        }
        for (uint32_t f = 0; f < back.num_faces(); ++f) {
            const draco::Mesh::Face& face = back.face(draco::FaceIndex(f));
            bool found = false;
            for (uint32_t a : plainOf[face[0].value()]) {
                for (uint32_t b : plainOf[face[1].value()]) {
                    for (uint32_t c : plainOf[face[2].value()]) {
                        auto it = left.find(key(a, b, c));
                        if (!found && it != left.end() && it->second > 0) {
                            --it->second;
                            found = true;
                        }
                    }
                }
            }
            ASSERT_TRUE(found) << "decoded triangle " << f << " of mesh " << m;
        }
        for (const auto& [k, count] : left) {
            if (count == 0) continue;
            const float* p[3];
            for (int c = 0; c < 3; ++c) p[c] = &ref["POSITION"][3 * k[c]];
            const Vec3 e1{p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
            const Vec3 e2{p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
            EXPECT_LT(length(cross(e1, e2)), 1e-12) << "a plain triangle with area lost";
        }
    }
}

// The GLB of a parsed document and its BIN chunk.
std::string glbOf(const Glb& g) {
    std::string text = g.doc.dump();
    while (text.size() % 4) text.push_back(' ');
    std::string glb;
    auto u32 = [&](uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
    u32(0x46546C67u);
    u32(2);
    u32(static_cast<uint32_t>(12 + 8 + text.size() + 8 + g.bin.size()));
    u32(static_cast<uint32_t>(text.size()));
    u32(0x4E4F534Au);
    glb += text;
    u32(static_cast<uint32_t>(g.bin.size()));
    u32(0x004E4942u);
    glb += g.bin;
    return glb;
}

TEST(GlbDraco, RefusesWhatItCannotTake) {
    EXPECT_THROW(compressGlbDraco("not a glb at all, not at all"), std::invalid_argument);
    const Glb plain = parse(meshGlb(sampleMesh()));
    auto refusal = [](const Glb& g) {
        try {
            compressGlbDraco(glbOf(g));
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("taken");
    };
    Glb lines = plain;
    lines.doc["meshes"][0]["primitives"][0]["mode"] = 1;
    EXPECT_EQ(refusal(lines), "compressGlbDraco: a primitive that is not an indexed triangle list");
    Glb shared = plain;  // the leaves drawn with the wood's positions
    shared.doc["meshes"][1]["primitives"][0]["attributes"]["POSITION"] =
        shared.doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"];
    EXPECT_EQ(refusal(shared), "compressGlbDraco: an accessor shared by primitives");
    EXPECT_EQ(refusal(plain), "taken");
}

}  // namespace
}  // namespace sylva
