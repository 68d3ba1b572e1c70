// Textured meshes (mesh_writers.h, MeshLook): the GLB read back with tinygltf — the embedded
// image decodes to barkTexture's pixels, the sampler wraps, COLOR_0 holds the look's leaf
// colours on both faces —, the OBJ's vertex colours and the MTL's map_Kd, and the untextured
// bytes when no look is given.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <map>
#include <sstream>
#include <stdexcept>

#include "pipeline/formats/mesh_writers.h"
#include "species/geometry/leaf_mesh.h"
#include "species/geometry/tube_mesh.h"
#include "species/model/leaf_shape.h"
#include "tests/gltf_support.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

using test::addNode;

// A small tree: three tubes and leaves of several shapes and colour classes.
Tree sampleTree() {
    Tree t;
    addNode(t, -1, {0, 0, 0}, 0.08, 0);
    addNode(t, 0, {0, 0.6, 0}, 0.06, 0);
    addNode(t, 1, {0.05, 1.2, 0}, 0.04, 0);
    addNode(t, 1, {0.4, 0.9, 0.1}, 0.02, 1);
    const LeafShape shapes[] = {LeafShape::kCard, LeafShape::kSimple, LeafShape::kCompound,
                                LeafShape::kPalmate, LeafShape::kCard};
    const uint8_t classes[] = {0, 2, 3, 5, 9};
    for (int k = 0; k < 5; ++k) {
        Leaf leaf;
        leaf.position = {0.1 * k, 1.0 + 0.05 * k, 0.02 * k};
        leaf.normal = k % 2 ? Vec3{0, 0, 1} : Vec3{0, 1, 0};
        leaf.tangent = k % 2 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
        leaf.shape = shapes[k];
        leaf.colour = classes[k];
        t.leaves.push_back(leaf);
    }
    return t;
}

TreeMesh sampleMesh(const Tree& t) {
    TreeMesh m;
    m.wood = tubeMesh(t, TubeOptions{});
    m.leaves = leafMesh(t);
    return m;
}

// A look unlike the default one: plated bark, three leaf colours, a set underside.
Look sampleLook() {
    Look look;
    EXPECT_TRUE(parseHexColour("#8a7a66", look.bark));
    EXPECT_TRUE(parseHexColour("#302820", look.barkDark));
    look.pattern = BarkPattern::kPlated;
    look.barkRepeat = 5;
    look.barkRoughness = 0.8;
    look.leafRoughness = 0.35;
    look.leaf.assign(3, LinearRgb{});
    EXPECT_TRUE(parseHexColour("#204010", look.leaf[0]));
    EXPECT_TRUE(parseHexColour("#3c6a22", look.leaf[1]));
    EXPECT_TRUE(parseHexColour("#a03020", look.leaf[2]));
    EXPECT_TRUE(parseHexColour("#a0b090", look.leafBack));
    look.leafBackSet = true;
    return look;
}

using test::loadGlb;

// The elements of a tightly packed float accessor.
std::vector<float> floats(const tinygltf::Model& model, int index) {
    const tinygltf::Accessor& acc = model.accessors.at(index);
    EXPECT_EQ(acc.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
    const tinygltf::BufferView& view = model.bufferViews.at(acc.bufferView);
    const size_t n = acc.count * tinygltf::GetNumComponentsInType(acc.type);
    EXPECT_EQ(view.byteLength, n * sizeof(float));
    std::vector<float> out(n);
    std::memcpy(out.data(), model.buffers.at(view.buffer).data.data() + view.byteOffset, 4 * n);
    return out;
}

// An 8-bit RGB PNG decoded by OpenImageIO (not sylva's code).
std::vector<uint8_t> decodePng(const std::string& png, int& width, int& height) {
    OIIO::Filesystem::IOMemReader proxy(png.data(), png.size());
    auto in = OIIO::ImageInput::open("bark.png", nullptr, &proxy);
    EXPECT_TRUE(in) << OIIO::geterror();
    if (!in) return {};
    const OIIO::ImageSpec& spec = in->spec();
    width = spec.width;
    height = spec.height;
    EXPECT_EQ(spec.nchannels, 3);
    std::vector<uint8_t> rgb(static_cast<size_t>(width) * height * spec.nchannels);
    EXPECT_TRUE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, rgb.data()));
    return rgb;
}

// The colour, linear, of vertex i of leaf k (of the tree the mesh was made from) on `side`.
LinearRgb expectedLeafColour(const Look& look, const Leaf& leaf, uint64_t seed, uint32_t k,
                             bool back) {
    const double f = leafLightness(seed, k, look.leafVariation);
    const LinearRgb c = back ? look.leafUnderside(leaf.colour) : look.leafFront(leaf.colour);
    return {static_cast<float>(std::clamp(c.r * f, 0.0, 1.0)),
            static_cast<float>(std::clamp(c.g * f, 0.0, 1.0)),
            static_cast<float>(std::clamp(c.b * f, 0.0, 1.0))};
}

TEST(TexturedMesh, LeafSpansAreTheTreesLeaves) {
    const Tree t = sampleTree();
    const Mesh leaves = leafMesh(t);
    const std::vector<LeafSpan> spans = leafSpans(leaves);
    ASSERT_EQ(spans.size(), t.leaves.size());
    uint32_t first = 0;
    for (size_t k = 0; k < spans.size(); ++k) {
        EXPECT_EQ(spans[k].first, first) << k;
        EXPECT_EQ(spans[k].count, leafOutline(t.leaves[k].shape).points.size()) << k;
        first += 2 * spans[k].count;
    }
    EXPECT_EQ(first, leaves.vertexCount());
    EXPECT_TRUE(leafSpans(Mesh{}).empty());

    // Not leafMesh's layout: a back vertex moved, the back face missing, no normals.
    Mesh moved = leaves;
    moved.positions[3 * (spans[1].first + spans[1].count)] += 0.01f;
    EXPECT_THROW(leafSpans(moved), std::invalid_argument);
    Tree one;
    one.leaves = {t.leaves[0]};
    Mesh frontOnly = leafMesh(one);
    const size_t n = frontOnly.vertexCount() / 2;
    frontOnly.positions.resize(3 * n);
    frontOnly.normals.resize(3 * n);
    EXPECT_THROW(leafSpans(frontOnly), std::invalid_argument);
    Mesh noNormals = leaves;
    noNormals.normals.clear();
    EXPECT_THROW(leafSpans(noNormals), std::invalid_argument);
}

TEST(TexturedMesh, GlbCarriesTheBarkTileAndTheLeafColours) {
    const Tree t = sampleTree();
    const TreeMesh tm = sampleMesh(t);
    const Look look = sampleLook();
    const uint64_t seed = 0x5eed1234abcdull;
    const MeshLook ml{&look, seed};
    const tinygltf::Model model = loadGlb(meshGlb(tm, &ml));

    // Materials: white, the look's roughness; the bark's texture is the tile.
    ASSERT_EQ(model.materials.size(), 2u);
    const tinygltf::Material& bark = model.materials[0];
    const tinygltf::Material& leaf = model.materials[1];
    EXPECT_EQ(bark.name, "bark");
    EXPECT_EQ(leaf.name, "leaf");
    for (const tinygltf::Material* m : {&bark, &leaf}) {
        EXPECT_EQ(m->pbrMetallicRoughness.baseColorFactor, (std::vector<double>{1, 1, 1, 1}));
        EXPECT_EQ(m->pbrMetallicRoughness.metallicFactor, 0.0);
    }
    EXPECT_EQ(bark.pbrMetallicRoughness.roughnessFactor, look.barkRoughness);
    EXPECT_EQ(leaf.pbrMetallicRoughness.roughnessFactor, look.leafRoughness);
    EXPECT_FALSE(bark.doubleSided);
    EXPECT_FALSE(leaf.doubleSided);  // each face its own triangles, each seen from its side
    EXPECT_EQ(leaf.pbrMetallicRoughness.baseColorTexture.index, -1);
    const tinygltf::TextureInfo& info = bark.pbrMetallicRoughness.baseColorTexture;
    ASSERT_EQ(info.index, 0);
    EXPECT_EQ(info.texCoord, 0);  // TEXCOORD_0: the tube's UVs
    ASSERT_EQ(model.textures.size(), 1u);
    ASSERT_EQ(model.samplers.size(), 1u);
    ASSERT_EQ(model.images.size(), 1u);
    const tinygltf::Texture& texture = model.textures[0];
    ASSERT_EQ(texture.sampler, 0);
    ASSERT_EQ(texture.source, 0);
    const tinygltf::Sampler& sampler = model.samplers[0];
    EXPECT_EQ(sampler.wrapS, TINYGLTF_TEXTURE_WRAP_REPEAT);
    EXPECT_EQ(sampler.wrapT, TINYGLTF_TEXTURE_WRAP_REPEAT);
    EXPECT_EQ(sampler.magFilter, TINYGLTF_TEXTURE_FILTER_LINEAR);
    EXPECT_EQ(sampler.minFilter, TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR);

    // The image: a PNG in a buffer view, decoding (OpenImageIO, and tinygltf's own decoder) to
    // barkTexture's pixels, row 0 first.
    const tinygltf::Image& image = model.images[0];
    EXPECT_EQ(image.mimeType, "image/png");
    EXPECT_TRUE(image.uri.empty());
    ASSERT_GE(image.bufferView, 0);
    const tinygltf::BufferView& view = model.bufferViews.at(image.bufferView);
    EXPECT_EQ(view.target, 0);
    const std::string png(
        reinterpret_cast<const char*>(model.buffers.at(view.buffer).data.data()) + view.byteOffset,
        view.byteLength);
    EXPECT_EQ(png, barkPng(ml));
    const std::vector<uint8_t> tile = barkTexture(look, 256);
    int w = 0, h = 0;
    EXPECT_EQ(decodePng(png, w, h), tile);
    EXPECT_EQ(w, 256);
    EXPECT_EQ(h, 256);
    ASSERT_EQ(image.width, 256);
    ASSERT_EQ(image.height, 256);
    ASSERT_EQ(image.image.size(), size_t(256) * 256 * image.component);
    size_t differing = 0;
    for (size_t i = 0; i < size_t(256) * 256; ++i) {
        for (int c = 0; c < 3; ++c)
            differing += image.image[i * image.component + c] != tile[3 * i + c];
    }
    EXPECT_EQ(differing, 0u);

    // The wood keeps its plain attributes; the leaves gain COLOR_0.
    ASSERT_EQ(model.meshes.size(), 2u);
    const auto& woodAttrs = model.meshes[0].primitives.at(0).attributes;
    EXPECT_EQ(woodAttrs.count("COLOR_0"), 0u);
    EXPECT_EQ(floats(model, woodAttrs.at("TEXCOORD_0")), tm.wood.uvs);
    const auto& leafAttrs = model.meshes[1].primitives.at(0).attributes;
    ASSERT_EQ(leafAttrs.count("COLOR_0"), 1u);
    EXPECT_EQ(model.accessors[leafAttrs.at("COLOR_0")].type, TINYGLTF_TYPE_VEC3);
    const std::vector<float> rgb = floats(model, leafAttrs.at("COLOR_0"));
    ASSERT_EQ(rgb.size(), 3 * tm.leaves.vertexCount());
    EXPECT_EQ(rgb, leafVertexColours(tm.leaves, ml));
    // Leaf k's front vertices then its back ones (counted from the tree, not the mesh).
    uint32_t v = 0;
    for (uint32_t k = 0; k < t.leaves.size(); ++k) {
        const uint32_t n = static_cast<uint32_t>(leafOutline(t.leaves[k].shape).points.size());
        for (int back = 0; back < 2; ++back) {
            const LinearRgb want = expectedLeafColour(look, t.leaves[k], seed, k, back);
            for (uint32_t i = 0; i < n; ++i, ++v) {
                EXPECT_EQ(rgb[3 * v], want.r) << "leaf " << k << " vertex " << v;
                EXPECT_EQ(rgb[3 * v + 1], want.g) << "leaf " << k << " vertex " << v;
                EXPECT_EQ(rgb[3 * v + 2], want.b) << "leaf " << k << " vertex " << v;
            }
        }
    }
    EXPECT_EQ(v, tm.leaves.vertexCount());
}

TEST(TexturedMesh, LeafColoursAreTheLooksForAKnownClass) {
    // No variation: every leaf of class 1 shows exactly leaf_colours[1] in front and the set
    // underside behind; class 5 (past the palette's end) the last colour on both faces.
    Look look = sampleLook();
    look.leafVariation = 0;
    Tree t = sampleTree();
    for (Leaf& leaf : t.leaves) leaf.colour = 1;
    t.leaves.back().colour = 5;
    const Mesh leaves = leafMesh(t);
    const MeshLook ml{&look, 7};
    const tinygltf::Model model = loadGlb(meshGlb(TreeMesh{Mesh{}, leaves}, &ml));
    const std::vector<float> rgb =
        floats(model, model.meshes.at(0).primitives.at(0).attributes.at("COLOR_0"));
    const std::vector<LeafSpan> spans = leafSpans(leaves);
    ASSERT_EQ(spans.size(), t.leaves.size());
    auto at = [&](uint32_t v) { return LinearRgb{rgb[3 * v], rgb[3 * v + 1], rgb[3 * v + 2]}; };
    auto same = [](const LinearRgb& a, const LinearRgb& b) {
        return a.r == b.r && a.g == b.g && a.b == b.b;
    };
    for (size_t k = 0; k < spans.size(); ++k) {
        const bool last = k + 1 == spans.size();
        const LinearRgb front = last ? look.leaf[2] : look.leaf[1];
        const LinearRgb back = last ? look.leaf[2] : look.leafBack;
        for (uint32_t i = 0; i < spans[k].count; ++i) {
            EXPECT_TRUE(same(at(spans[k].first + i), front)) << k;
            EXPECT_TRUE(same(at(spans[k].first + spans[k].count + i), back)) << k;
        }
    }
    // No bark, no texture (nothing unused).
    EXPECT_TRUE(model.images.empty());
    EXPECT_TRUE(model.textures.empty());
    EXPECT_TRUE(model.samplers.empty());
}

// OBJ "v" lines' numbers, per object ("o wood", "o leaves").
std::map<std::string, std::vector<std::vector<float>>> objVertices(const std::string& obj) {
    std::map<std::string, std::vector<std::vector<float>>> out;
    std::istringstream in(obj);
    std::string line, object;
    while (std::getline(in, line)) {
        if (line.rfind("o ", 0) == 0) object = line.substr(2);
        if (line.rfind("v ", 0) != 0) continue;
        std::vector<float> values;
        std::istringstream fields(line.substr(2));
        std::string f;
        while (fields >> f) {
            float x = 0;
            const auto res = std::from_chars(f.data(), f.data() + f.size(), x);
            EXPECT_EQ(res.ptr, f.data() + f.size()) << f;
            values.push_back(x);
        }
        out[object].push_back(values);
    }
    return out;
}

TEST(TexturedMesh, ObjHasVertexColoursAndTheMtlTheBarkMap) {
    const Tree t = sampleTree();
    const TreeMesh tm = sampleMesh(t);
    const Look look = sampleLook();
    const MeshLook ml{&look, 99};
    const std::string obj = meshObj(tm, "mesh.mtl", &ml);
    const auto vertices = objVertices(obj);
    ASSERT_EQ(vertices.at("wood").size(), tm.wood.vertexCount());
    ASSERT_EQ(vertices.at("leaves").size(), tm.leaves.vertexCount());
    for (const auto& v : vertices.at("wood")) EXPECT_EQ(v.size(), 3u);
    const std::vector<float> rgb = leafVertexColours(tm.leaves, ml);
    for (size_t i = 0; i < tm.leaves.vertexCount(); ++i) {
        const std::vector<float>& v = vertices.at("leaves")[i];
        ASSERT_EQ(v.size(), 6u);
        for (int c = 0; c < 3; ++c) {
            EXPECT_EQ(v[c], tm.leaves.positions[3 * i + c]);
            EXPECT_EQ(v[3 + c], static_cast<float>(linearToSrgb(rgb[3 * i + c]))) << i;
            EXPECT_NEAR(srgbToLinear(v[3 + c]), rgb[3 * i + c], 1e-6) << i;
        }
    }
    // Remove the colours and it is the plain OBJ, byte for byte.
    std::istringstream in(obj);
    std::string line, stripped;
    while (std::getline(in, line)) {
        if (line.rfind("v ", 0) == 0) {
            size_t cut = 0;
            for (int spaces = 0; cut != std::string::npos && spaces < 4; ++spaces) {
                cut = line.find(' ', cut + (spaces > 0));
            }
            if (cut != std::string::npos) line.resize(cut);
        }
        stripped += line + "\n";
    }
    EXPECT_EQ(stripped, meshObj(tm, "mesh.mtl"));

    // The MTL: white materials with the look's roughness, the bark mapped.
    const std::string mtl = meshMtl(tm, &ml, "mesh_bark.png");
    EXPECT_NE(mtl.find("\nnewmtl bark\nKa 0 0 0\nKd 1 1 1\n"), std::string::npos) << mtl;
    EXPECT_NE(mtl.find("\nnewmtl leaf\nKa 0 0 0\nKd 1 1 1\n"), std::string::npos) << mtl;
    EXPECT_NE(mtl.find("Pr 0.8\nPm 0\nmap_Kd mesh_bark.png\n"), std::string::npos) << mtl;
    EXPECT_NE(mtl.find("Pr 0.35\nPm 0\n"), std::string::npos) << mtl;
    EXPECT_EQ(mtl.find("map_Kd"), mtl.rfind("map_Kd"));     // the leaves have none
    EXPECT_THROW(meshMtl(tm, &ml), std::invalid_argument);  // a map with no name
    TreeMesh leavesOnly = tm;
    leavesOnly.wood = Mesh{};
    EXPECT_EQ(meshMtl(leavesOnly, &ml).find("map_Kd"), std::string::npos);

    // The OBJ's tile is the GLB's upside down (OBJ's v = 0 is the image's bottom row).
    int w = 0, h = 0;
    const std::vector<uint8_t> flipped = decodePng(objBarkPng(ml), w, h);
    const std::vector<uint8_t> tile = barkTexture(look, 256);
    ASSERT_EQ(w, 256);
    ASSERT_EQ(h, 256);
    ASSERT_EQ(flipped.size(), tile.size());
    for (int y = 0; y < 256; ++y) {
        ASSERT_EQ(
            std::memcmp(&flipped[size_t(y) * 256 * 3], &tile[size_t(255 - y) * 256 * 3], 256 * 3),
            0)
            << y;
    }
}

TEST(TexturedMesh, WithoutALookTheBytesArePlain) {
    const TreeMesh tm = sampleMesh(sampleTree());
    const Look look = sampleLook();
    const MeshLook ml{&look, 1};
    EXPECT_EQ(meshGlb(tm, nullptr), meshGlb(tm));
    EXPECT_EQ(meshObj(tm, "mesh.mtl", nullptr), meshObj(tm, "mesh.mtl"));
    EXPECT_EQ(meshMtl(tm, nullptr, "ignored.png"), meshMtl(tm));
    // … and the plain files carry nothing of a texture, the textured ones differ.
    const std::string plain = meshGlb(tm), textured = meshGlb(tm, &ml);
    for (const char* word : {"COLOR_0", "images", "samplers", "textures", "image/png"}) {
        EXPECT_EQ(plain.find(word), std::string::npos) << word;
        EXPECT_NE(textured.find(word), std::string::npos) << word;
    }
    EXPECT_EQ(meshMtl(tm).find("map_Kd"), std::string::npos);
    // Deterministic: the same look and seed give the same bytes; another seed other colours.
    EXPECT_EQ(meshGlb(tm, &ml), textured);
    const MeshLook other{&look, 2};
    EXPECT_NE(meshGlb(tm, &other), textured);
    const MeshLook none{};
    EXPECT_THROW(meshGlb(tm, &none), std::invalid_argument);  // a MeshLook needs a look
    const MeshLook odd{&look, 1, 100};
    EXPECT_THROW(meshGlb(tm, &odd), std::invalid_argument);  // the tile: a power of 2
    const MeshLook small{&look, 1, 32};
    EXPECT_EQ(loadGlb(meshGlb(tm, &small)).images.at(0).width, 32);
}

// The shared bark tiles: the bytes barkTexture makes; one tile for one bark whoever asks
// (however the look differs elsewhere), another for another bark or size.
TEST(TexturedMesh, SharedBarkTilesAreTheTilesAndOnePerBark) {
    Look oak;
    oak.pattern = BarkPattern::kFurrowed;
    Look oakOtherLeaves = oak;
    oakOtherLeaves.leafTranslucency = 0.9;
    oakOtherLeaves.leaf.assign(1, LinearRgb{0.1f, 0.5f, 0.1f});
    Look birch = oak;
    birch.pattern = BarkPattern::kBanded;
    const auto a = sharedBarkTexture(oak, 64);
    EXPECT_EQ(*a, barkTexture(oak, 64));
    EXPECT_EQ(sharedBarkTexture(oakOtherLeaves, 64), a);
    const auto b = sharedBarkTexture(birch, 64);
    EXPECT_NE(b, a);
    EXPECT_EQ(*b, barkTexture(birch, 64));
    EXPECT_NE(*b, *a);
    EXPECT_EQ(sharedBarkTexture(oak, 32)->size(), 32u * 32u * 3u);
    // The tile: linear texels of the same bytes, shared likewise.
    const auto tile = sharedBarkTile(oak, 64);
    EXPECT_EQ(sharedBarkTile(oakOtherLeaves, 64), tile);
    const BarkTile fresh(oak, 64);
    ASSERT_EQ(tile->texels.size(), fresh.texels.size());
    for (size_t k = 0; k < fresh.texels.size(); ++k) {
        ASSERT_EQ(tile->texels[k].r, fresh.texels[k].r) << k;
        ASSERT_EQ(tile->texels[k].b, fresh.texels[k].b) << k;
    }
}

}  // namespace
}  // namespace sylva
