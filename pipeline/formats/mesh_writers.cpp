#include "pipeline/formats/mesh_writers.h"

#include <tiny_gltf.h>  // compiled library (Debian libtinygltf): no TINYGLTF_IMPLEMENTATION here

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stdexcept>
#include <streambuf>
#include <string_view>
#include <vector>

#include "core/atomic_file.h"
#include "pipeline/formats/image_codecs.h"
#include "pipeline/formats/little_endian.h"
#include "species/geometry/leaf_mesh.h"
#include "species/model/leaf_shape.h"

namespace sylva {

namespace {

// Attribute i of a per-vertex array with `width` components, 0 if the array is absent.
float attr(const std::vector<float>& a, size_t i, int width, int c) {
    return a.empty() ? 0.0f : a[i * width + c];
}

// Shortest text that reads back to the same float; locale-independent; −0 written as 0.
void putNumber(std::string& out, float v) {
    char buf[32];
    auto res = std::to_chars(buf, buf + sizeof buf, v + 0.0f);
    out.append(buf, res.ptr);
}

// The same, for a double (material constants, written to MTL exactly as to the GLB's JSON).
void putNumber(std::string& out, double v) {
    char buf[32];
    auto res = std::to_chars(buf, buf + sizeof buf, v + 0.0);
    out.append(buf, res.ptr);
}

// A part's material, shared by GLB and MTL. Base colours are linear RGB (glTF's
// baseColorFactor); metallic 0.
struct PartMaterial {
    const char* name;
    double rgb[3];
    double roughness;
    bool doubleSided;
};
constexpr PartMaterial kBark = {"bark", {0.30, 0.20, 0.12}, 0.9, false};
constexpr PartMaterial kLeaf = {"leaf", {0.18, 0.42, 0.10}, 0.6, true};

// The mesh's parts in file order, each with its object name and material.
struct Part {
    const Mesh* mesh;
    const char* object;
    const PartMaterial* material;
};
std::vector<Part> parts(const TreeMesh& mesh) {
    return {{&mesh.wood, "wood", &kBark}, {&mesh.leaves, "leaves", &kLeaf}};
}

// A part's material as written: its own, or under a look white (the texture or the vertex
// colours carry the colour) with the look's roughness, and single-sided: a leaf's two faces
// are triangles of their own (leaf_mesh.h), and drawn double-sided the back face, coplanar
// and drawn after the front, wins the depth test from either side (three.js showed every
// leaf's underside), so each side must be culled from behind to show its own colour.
PartMaterial partMaterial(const Part& part, const MeshLook* look) {
    PartMaterial m = *part.material;
    if (look) {
        m.rgb[0] = m.rgb[1] = m.rgb[2] = 1.0;
        m.doubleSided = false;
        m.roughness =
            part.material == &kBark ? look->look->barkRoughness : look->look->leafRoughness;
    }
    return m;
}

const Look& requireLook(const MeshLook& look, const char* who) {
    if (!look.look) throw std::invalid_argument(std::string(who) + ": a MeshLook without a look");
    return *look.look;
}

std::string encodeBark(const MeshLook& ml, bool flipRows, const char* who) {
    const Look& look = requireLook(ml, who);
    const int size = ml.barkTextureSize;
    if (size < 16 || (size & (size - 1)) != 0 || size > 8192) {
        throw std::invalid_argument(std::string(who) + ": bark texture size " +
                                    std::to_string(size) + " is not a power of 2 in [16, 8192]");
    }
    std::vector<uint8_t> rgb = *sharedBarkTexture(look, size);
    if (flipRows) {
        const size_t row = 3 * static_cast<size_t>(size);
        for (int y = 0; y < size / 2; ++y) {
            std::swap_ranges(rgb.begin() + y * row, rgb.begin() + (y + 1) * row,
                             rgb.begin() + (size - 1 - y) * row);
        }
    }
    return encodeRgbPng(size, size, rgb.data());
}

}  // namespace

std::vector<float> leafVertexColours(const Mesh& leaves, const MeshLook& ml) {
    const Look& look = requireLook(ml, "leafVertexColours");
    std::vector<float> rgb(3 * leaves.vertexCount());
    const std::vector<LeafSpan> spans = leafSpans(leaves);
    for (size_t k = 0; k < spans.size(); ++k) {
        const double f = leafLightness(ml.treeSeed, static_cast<uint32_t>(k), look.leafVariation);
        const LeafSpan& span = spans[k];
        for (uint32_t i = span.first; i < span.first + 2 * span.count; ++i) {
            const uint8_t cls = leaves.colour.empty() ? 0 : leaves.colour[i];
            const LinearRgb c =
                i < span.first + span.count ? look.leafFront(cls) : look.leafUnderside(cls);
            rgb[3 * i] = static_cast<float>(std::clamp(c.r * f, 0.0, 1.0));
            rgb[3 * i + 1] = static_cast<float>(std::clamp(c.g * f, 0.0, 1.0));
            rgb[3 * i + 2] = static_cast<float>(std::clamp(c.b * f, 0.0, 1.0));
        }
    }
    return rgb;
}

std::string barkPng(const MeshLook& look) { return encodeBark(look, false, "barkPng"); }

std::string objBarkPng(const MeshLook& look) { return encodeBark(look, true, "objBarkPng"); }

std::string meshPly(const TreeMesh& mesh) {
    const Mesh* parts[2] = {&mesh.wood, &mesh.leaves};
    const size_t nv = mesh.wood.vertexCount() + mesh.leaves.vertexCount();
    const size_t nf = mesh.wood.triangleCount() + mesh.leaves.triangleCount();
    std::string out;
    out += "ply\n";
    out += "format binary_little_endian 1.0\n";
    out += "comment generated by sylva\n";
    out += "comment units: metres; up axis: +y\n";
    out += "element vertex " + std::to_string(nv) + "\n";
    for (const char* name : {"x", "y", "z", "nx", "ny", "nz", "u", "v"}) {
        out += "property float ";
        out += name;
        out += '\n';
    }
    out += "property int order\n";
    out += "property uchar part\n";
    out += "property uchar colour\n";
    out += "element face " + std::to_string(nf) + "\n";
    out += "property list uchar uint vertex_indices\n";
    out += "end_header\n";
    constexpr size_t kVertexBytes = 8 * 4 + 4 + 1 + 1, kFaceBytes = 1 + 3 * 4;
    const size_t headerBytes = out.size();
    out.resize(headerBytes + nv * kVertexBytes + nf * kFaceBytes);
    char* p = out.data() + headerBytes;
    for (int part = 0; part < 2; ++part) {
        const Mesh& m = *parts[part];
        for (size_t i = 0; i < m.vertexCount(); ++i) {
            for (int c = 0; c < 3; ++c) p = storeFloat(p, m.positions[3 * i + c]);
            for (int c = 0; c < 3; ++c) p = storeFloat(p, attr(m.normals, i, 3, c));
            for (int c = 0; c < 2; ++c) p = storeFloat(p, attr(m.uvs, i, 2, c));
            p = storeU32(
                p, static_cast<uint32_t>(m.order.empty() ? (part == 0 ? 0 : -1) : m.order[i]));
            *p++ = static_cast<char>(part);
            *p++ = static_cast<char>(m.colour.empty() ? 0 : m.colour[i]);
        }
    }
    const uint32_t leafOffset = static_cast<uint32_t>(mesh.wood.vertexCount());
    for (int part = 0; part < 2; ++part) {
        const Mesh& m = *parts[part];
        const uint32_t offset = part == 0 ? 0 : leafOffset;
        for (size_t f = 0; f < m.triangleCount(); ++f) {
            *p++ = 3;
            for (int c = 0; c < 3; ++c) p = storeU32(p, m.indices[3 * f + c] + offset);
        }
    }
    return out;
}

std::string meshObj(const TreeMesh& mesh, const std::string& mtllib, const MeshLook* look) {
    std::string out;
    out.reserve(64 + (mesh.wood.vertexCount() + mesh.leaves.vertexCount()) * 100 +
                (mesh.wood.triangleCount() + mesh.leaves.triangleCount()) * 40);
    out += "# generated by sylva: metres; +y up\n";
    if (!mtllib.empty()) out += "mtllib " + mtllib + "\n";
    size_t base = 1;  // OBJ indices are 1-based and global over the file
    for (const Part& part : parts(mesh)) {
        const Mesh& m = *part.mesh;
        if (m.empty()) continue;
        out += "o ";
        out += part.object;
        out += "\nusemtl ";
        out += part.material->name;
        out += '\n';
        const size_t n = m.vertexCount();
        // The leaves' colours under a look, sRGB: appended to their "v" lines.
        std::vector<float> srgb;
        if (look && part.mesh == &mesh.leaves) {
            srgb = leafVertexColours(m, *look);
            for (float& c : srgb) c = static_cast<float>(linearToSrgb(c));
        }
        auto lines = [&](const char* tag, const std::vector<float>& a, int width,
                         const std::vector<float>* extra = nullptr) {
            for (size_t i = 0; i < n; ++i) {
                out += tag;
                for (int c = 0; c < width; ++c) {
                    out += ' ';
                    putNumber(out, attr(a, i, width, c));
                }
                for (int c = 0; extra && c < 3; ++c) {
                    out += ' ';
                    putNumber(out, (*extra)[3 * i + c]);
                }
                out += '\n';
            }
        };
        lines("v", m.positions, 3, srgb.empty() ? nullptr : &srgb);
        lines("vt", m.uvs, 2);
        lines("vn", m.normals, 3);
        char buf[24];
        for (size_t f = 0; f < m.triangleCount(); ++f) {
            out += 'f';
            for (int c = 0; c < 3; ++c) {
                auto res = std::to_chars(buf, buf + sizeof buf, base + m.indices[3 * f + c]);
                const std::string_view idx(buf, res.ptr - buf);
                out += ' ';
                out += idx;
                out += '/';
                out += idx;
                out += '/';
                out += idx;
            }
            out += '\n';
        }
        base += n;
    }
    return out;
}

std::string meshMtl(const TreeMesh& mesh, const MeshLook* look, const std::string& barkMap) {
    if (look) requireLook(*look, "meshMtl");
    if (look && !mesh.wood.empty() && barkMap.empty()) {
        throw std::invalid_argument("meshMtl: a textured bark needs its map's file name");
    }
    std::string out = "# generated by sylva: the materials of the OBJ beside it\n";
    for (const Part& part : parts(mesh)) {
        if (part.mesh->empty()) continue;
        const PartMaterial mat = partMaterial(part, look);
        auto line = [&](const char* tag, std::initializer_list<double> values) {
            out += tag;
            for (double v : values) {
                out += ' ';
                putNumber(out, v);
            }
            out += '\n';
        };
        out += "\nnewmtl ";
        out += mat.name;
        out += '\n';
        line("Ka", {0.0, 0.0, 0.0});
        line("Kd", {mat.rgb[0], mat.rgb[1], mat.rgb[2]});
        line("Ks", {0.04, 0.04, 0.04});
        // A conventional Phong exponent for roughness r, Ns = 1000 (1 − r)²; PBR readers take Pr.
        line("Ns", {std::round(1000.0 * (1.0 - mat.roughness) * (1.0 - mat.roughness))});
        line("d", {1.0});
        out += "illum 2\n";
        line("Pr", {mat.roughness});
        line("Pm", {0.0});
        if (look && part.material == &kBark) out += "map_Kd " + barkMap + "\n";
    }
    return out;
}

namespace {

// A stream buffer appending to a string reserved beforehand: tinygltf's GLB goes straight into
// the string returned (an ostringstream grew by copies and copied its whole contents out).
class AppendBuf : public std::streambuf {
  public:
    explicit AppendBuf(std::string& out) : out_(out) {}

  protected:
    std::streamsize xsputn(const char* s, std::streamsize n) override {
        out_.append(s, static_cast<size_t>(n));
        return n;
    }
    int_type overflow(int_type c) override {
        if (!traits_type::eq_int_type(c, traits_type::eof())) out_.push_back(static_cast<char>(c));
        return traits_type::not_eof(c);
    }

  private:
    std::string& out_;
};

// The model as GLB bytes (tinygltf; `who` names the writer in the error).
std::string serialiseGlb(tinygltf::Model& model, const char* who) {
    std::string out;
    size_t bytes = 4096;  // the JSON chunk, generously
    for (const tinygltf::Buffer& b : model.buffers) bytes += b.data.size() + 8;
    out.reserve(bytes);
    AppendBuf buf(out);
    std::ostream stream(&buf);
    tinygltf::TinyGLTF gltf;
    if (!gltf.WriteGltfSceneToStream(&model, stream, /*prettyPrint=*/false,
                                     /*writeBinary=*/true)) {
        throw std::runtime_error(std::string(who) + ": tinygltf could not serialise the model");
    }
    return out;
}

// Appends raw little-endian bytes of `values` to the buffer (4-byte aligned: every element
// written here is 4 bytes) and returns a new buffer view over them.
template <typename T>
int addView(tinygltf::Model& model, const std::vector<T>& values, int target) {
    static_assert(sizeof(T) == 4, "glTF attribute elements here are 4-byte aligned");
    std::vector<unsigned char>& data = model.buffers[0].data;
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = data.size();
    view.byteLength = values.size() * sizeof(T);
    view.target = target;
    data.resize(data.size() + values.size() * 4);
    unsigned char* out = data.data() + view.byteOffset;
    if (isLittleEndian()) {
        if (!values.empty()) std::memcpy(out, values.data(), values.size() * 4);
    } else {
        for (size_t k = 0; k < values.size(); ++k) {
            uint32_t bits;
            std::memcpy(&bits, &values[k], 4);
            for (int i = 0; i < 4; ++i)
                out[4 * k + i] = static_cast<unsigned char>(bits >> (8 * i));
        }
    }
    model.bufferViews.push_back(std::move(view));
    return static_cast<int>(model.bufferViews.size() - 1);
}

int addAccessor(tinygltf::Model& model, int view, int componentType, int type, size_t count) {
    tinygltf::Accessor accessor;
    accessor.bufferView = view;
    accessor.componentType = componentType;
    accessor.type = type;
    accessor.count = count;
    model.accessors.push_back(std::move(accessor));
    return static_cast<int>(model.accessors.size() - 1);
}

std::vector<float> orZeros(const std::vector<float>& a, size_t n) {
    return a.empty() ? std::vector<float>(n, 0.0f) : a;
}

// The bounds of a mesh's positions, which POSITION must carry (glTF 2.0 §5.1.1).
void positionBounds(const Mesh& m, double lo[3], double hi[3]) {
    for (int c = 0; c < 3; ++c) {
        lo[c] = std::numeric_limits<double>::infinity();
        hi[c] = -std::numeric_limits<double>::infinity();
    }
    for (size_t i = 0; i < m.vertexCount(); ++i) {
        for (int c = 0; c < 3; ++c) {
            lo[c] = std::min(lo[c], double(m.positions[3 * i + c]));
            hi[c] = std::max(hi[c], double(m.positions[3 * i + c]));
        }
    }
}

tinygltf::Primitive makePrimitive(tinygltf::Model& model, const Mesh& m, int material,
                                  bool withColour, const std::vector<float>* rgb = nullptr) {
    const size_t n = m.vertexCount();
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.material = material;

    const int pos = addAccessor(model, addView(model, m.positions, TINYGLTF_TARGET_ARRAY_BUFFER),
                                TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
    double lo[3], hi[3];
    positionBounds(m, lo, hi);
    model.accessors[pos].minValues = {lo[0], lo[1], lo[2]};
    model.accessors[pos].maxValues = {hi[0], hi[1], hi[2]};
    prim.attributes["POSITION"] = pos;
    prim.attributes["NORMAL"] =
        addAccessor(model, addView(model, orZeros(m.normals, 3 * n), TINYGLTF_TARGET_ARRAY_BUFFER),
                    TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
    prim.attributes["TEXCOORD_0"] =
        addAccessor(model, addView(model, orZeros(m.uvs, 2 * n), TINYGLTF_TARGET_ARRAY_BUFFER),
                    TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, n);
    // Application-specific attributes must start with '_' (glTF 2.0 §3.7.2.1). Floats: every
    // viewer/importer reads them, and vertex attributes stay 4-byte aligned without strides.
    std::vector<float> values(n);
    for (size_t i = 0; i < n; ++i) values[i] = m.order.empty() ? 0.0f : float(m.order[i]);
    prim.attributes["_ORDER"] =
        addAccessor(model, addView(model, values, TINYGLTF_TARGET_ARRAY_BUFFER),
                    TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR, n);
    if (withColour) {
        for (size_t i = 0; i < n; ++i) values[i] = m.colour.empty() ? 0.0f : float(m.colour[i]);
        prim.attributes["_COLOUR"] =
            addAccessor(model, addView(model, values, TINYGLTF_TARGET_ARRAY_BUFFER),
                        TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR, n);
    }
    if (rgb) {  // linear vertex colours (glTF 2.0 §3.7.2.1: COLOR_0 multiplies the base colour)
        prim.attributes["COLOR_0"] =
            addAccessor(model, addView(model, *rgb, TINYGLTF_TARGET_ARRAY_BUFFER),
                        TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
    }
    prim.indices =
        addAccessor(model, addView(model, m.indices, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
                    TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, m.indices.size());
    return prim;
}

void addPart(tinygltf::Model& model, const Mesh& m, const std::string& name, int material,
             bool withColour, const std::vector<float>* rgb) {
    tinygltf::Mesh gm;
    gm.name = name;
    gm.primitives.push_back(makePrimitive(model, m, material, withColour, rgb));
    model.meshes.push_back(std::move(gm));
    tinygltf::Node node;
    node.name = name;
    node.mesh = static_cast<int>(model.meshes.size() - 1);
    model.nodes.push_back(std::move(node));
    model.scenes[0].nodes.push_back(static_cast<int>(model.nodes.size() - 1));
}

tinygltf::Material material(const PartMaterial& m, const std::string& name) {
    tinygltf::Material mat;
    mat.name = name;
    mat.pbrMetallicRoughness.baseColorFactor = {m.rgb[0], m.rgb[1], m.rgb[2], 1.0};
    mat.pbrMetallicRoughness.metallicFactor = 0.0;
    mat.pbrMetallicRoughness.roughnessFactor = m.roughness;
    mat.doubleSided = m.doubleSided;
    return mat;
}

// `bytes` appended to the buffer (after every 4-byte element: nothing follows them) as a new
// buffer view with no target (an image's).
int addBytesView(tinygltf::Model& model, const std::string& bytes) {
    std::vector<unsigned char>& data = model.buffers[0].data;
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = data.size();
    view.byteLength = bytes.size();
    data.insert(data.end(), bytes.begin(), bytes.end());
    model.bufferViews.push_back(std::move(view));
    return static_cast<int>(model.bufferViews.size() - 1);
}

// A bark tile (`png`, barkPng's bytes) as material `material`'s base colour texture: image,
// sampler and texture, the image and texture named `name`.
void addBarkTexture(tinygltf::Model& model, int material, const std::string& name,
                    const std::string& png) {
    tinygltf::Image image;
    image.name = name;
    image.mimeType = "image/png";
    image.bufferView = addBytesView(model, png);
    model.images.push_back(std::move(image));
    // Magnified as the renderer samples it (BarkTile::sample: bilinear, wrapping); minified
    // through mipmaps, as a viewer drawing a twig a pixel wide must (the renderer averages
    // several samples per pixel instead).
    tinygltf::Sampler sampler;
    sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
    sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
    sampler.wrapS = TINYGLTF_TEXTURE_WRAP_REPEAT;
    sampler.wrapT = TINYGLTF_TEXTURE_WRAP_REPEAT;
    model.samplers.push_back(std::move(sampler));
    tinygltf::Texture texture;
    texture.name = name;
    texture.sampler = static_cast<int>(model.samplers.size() - 1);
    texture.source = static_cast<int>(model.images.size() - 1);
    model.textures.push_back(std::move(texture));
    model.materials[material].pbrMetallicRoughness.baseColorTexture.index =
        static_cast<int>(model.textures.size() - 1);
}

// A material as tinygltf writes it (material() above): the defaults — a white base colour, a
// roughness of 1, single-sided — left out.
nlohmann::json materialJson(const PartMaterial& m, const std::string& name) {
    nlohmann::json pbr = {{"metallicFactor", 0.0}};
    if (m.roughness != 1.0) pbr["roughnessFactor"] = m.roughness;
    if (!(m.rgb[0] == 1.0 && m.rgb[1] == 1.0 && m.rgb[2] == 1.0)) {
        pbr["baseColorFactor"] = {m.rgb[0], m.rgb[1], m.rgb[2], 1.0};
    }
    nlohmann::json mat = {{"name", name}, {"pbrMetallicRoughness", std::move(pbr)}};
    if (m.doubleSided) mat["doubleSided"] = true;
    return mat;
}

// The sampler and texture of a bark tile (addBarkTexture's) as JSON.
nlohmann::json barkSamplerJson() {
    return {{"magFilter", TINYGLTF_TEXTURE_FILTER_LINEAR},
            {"minFilter", TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR},
            {"wrapS", TINYGLTF_TEXTURE_WRAP_REPEAT},
            {"wrapT", TINYGLTF_TEXTURE_WRAP_REPEAT}};
}

// A glTF document as tinygltf writes one: its lists (empty ones left out), one buffer of
// `binBytes` (none when 0) and one scene named `sceneName` holding `sceneNodes`.
struct GltfLists {
    nlohmann::json accessors = nlohmann::json::array(), bufferViews = nlohmann::json::array(),
                   images = nlohmann::json::array(), samplers = nlohmann::json::array(),
                   textures = nlohmann::json::array(), materials = nlohmann::json::array(),
                   meshes = nlohmann::json::array(), nodes = nlohmann::json::array(),
                   sceneNodes = nlohmann::json::array();
};
nlohmann::json gltfDocument(GltfLists l, uint64_t binBytes, const char* sceneName) {
    nlohmann::json doc;
    doc["asset"] = {{"generator", "sylva"}, {"version", "2.0"}};
    if (binBytes > 0) doc["buffers"] = nlohmann::json::array({{{"byteLength", binBytes}}});
    for (auto [key, list] : {std::pair{"accessors", &l.accessors},
                             {"bufferViews", &l.bufferViews},
                             {"images", &l.images},
                             {"samplers", &l.samplers},
                             {"textures", &l.textures},
                             {"materials", &l.materials},
                             {"meshes", &l.meshes},
                             {"nodes", &l.nodes}}) {
        if (!list->empty()) doc[key] = std::move(*list);
    }
    doc["scene"] = 0;
    nlohmann::json scene = {{"name", sceneName}};
    if (!l.sceneNodes.empty()) scene["nodes"] = std::move(l.sceneNodes);
    doc["scenes"] = nlohmann::json::array({std::move(scene)});
    return doc;
}

}  // namespace

namespace {

// A leaf's frame (tangent, across, normal: the columns of a rotation) as a unit quaternion
// (x, y, z, w), w ≥ 0 (Shepperd's method: the largest of the four first, for accuracy).
std::array<double, 4> leafQuaternion(const LeafFrame& f) {
    const Vec3 &c0 = f.tangent, &c1 = f.across, &c2 = f.normal;
    const double trace = c0.x + c1.y + c2.z;
    std::array<double, 4> q;
    if (trace > 0) {
        const double s = 2.0 * std::sqrt(1.0 + trace);
        q = {(c1.z - c2.y) / s, (c2.x - c0.z) / s, (c0.y - c1.x) / s, 0.25 * s};
    } else if (c0.x > c1.y && c0.x > c2.z) {
        const double s = 2.0 * std::sqrt(1.0 + c0.x - c1.y - c2.z);
        q = {0.25 * s, (c1.x + c0.y) / s, (c2.x + c0.z) / s, (c1.z - c2.y) / s};
    } else if (c1.y > c2.z) {
        const double s = 2.0 * std::sqrt(1.0 + c1.y - c0.x - c2.z);
        q = {(c1.x + c0.y) / s, 0.25 * s, (c2.y + c1.z) / s, (c2.x - c0.z) / s};
    } else {
        const double s = 2.0 * std::sqrt(1.0 + c2.z - c0.x - c1.y);
        q = {(c2.x + c0.z) / s, (c2.y + c1.z) / s, 0.25 * s, (c0.y - c1.x) / s};
    }
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    const double sign = q[3] < 0 ? -1.0 : 1.0;
    for (double& v : q) v *= sign / norm;
    return q;
}

// The leaves given for instancing are those `leaves` (leafMesh's, or empty: not made) was made
// from: the same vertex and index counts; and few enough that each index is exact as a float
// (_LEAF).
void checkLeafInstances(const Mesh& leaves, const std::vector<Leaf>& instances) {
    const LeafMeshSize size = leafMeshSize(instances);
    if (!leaves.empty() &&
        (size.vertices != leaves.vertexCount() || size.triangles != leaves.triangleCount())) {
        throw std::invalid_argument("meshGlbParts: the leaves to instance are not the leaf mesh's");
    }
    if (instances.size() > (size_t(1) << 24)) {
        throw std::invalid_argument("meshGlbParts: more than 2^24 leaves to instance");
    }
}

}  // namespace

GlbParts meshGlbParts(const TreeMesh& mesh, const MeshLook* look,
                      const std::vector<Leaf>* instances) {
    using nlohmann::json;
    if (look) requireLook(*look, "meshGlbParts");
    if (instances) checkLeafInstances(mesh.leaves, *instances);
    GlbParts out;
    GltfLists lists;
    json &accessors = lists.accessors, &bufferViews = lists.bufferViews,
         &materials = lists.materials, &meshes = lists.meshes, &nodes = lists.nodes,
         &sceneNodes = lists.sceneNodes;
    size_t binBytes = 0;
    auto view = [&](std::string_view bytes, int target) {
        json v = {{"buffer", 0}, {"byteLength", bytes.size()}};
        if (binBytes > 0) v["byteOffset"] = binBytes;
        if (target != 0) v["target"] = target;
        bufferViews.push_back(std::move(v));
        out.views.push_back(bytes);
        binBytes += bytes.size();
        return bufferViews.size() - 1;
    };
    // 4-byte values as the file stores them: as they are on a little-endian host, else a
    // byte-swapped copy.
    auto asStored = [&](const void* data, size_t count) {
        std::string_view raw(static_cast<const char*>(data), 4 * count);
        if (isLittleEndian()) return raw;
        std::string& swapped = out.bytes.emplace_back(raw);
        for (size_t k = 0; k < swapped.size(); k += 4) std::reverse(&swapped[k], &swapped[k + 4]);
        return std::string_view(swapped);
    };
    auto floats = [&](const float* data, size_t count) { return asStored(data, count); };
    auto made = [&](std::vector<float> values) {
        out.floats.push_back(std::move(values));
        return floats(out.floats.back().data(), out.floats.back().size());
    };
    auto accessor = [&](size_t bufferView, int componentType, const char* type, size_t count) {
        accessors.push_back({{"bufferView", bufferView},
                             {"componentType", componentType},
                             {"count", count},
                             {"type", type}});
        return accessors.size() - 1;
    };
    constexpr int kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT;
    constexpr int kArray = TINYGLTF_TARGET_ARRAY_BUFFER;
    // One triangle primitive of `m` (the leaves' with _COLOUR and, coloured by `colours`,
    // COLOR_0).
    auto primitive = [&](const Mesh& m, bool leaves, size_t material, const MeshLook* colours) {
        const size_t n = m.vertexCount();
        json attributes;
        const size_t pos =
            accessor(view(floats(m.positions.data(), 3 * n), kArray), kFloat, "VEC3", n);
        double lo[3], hi[3];
        positionBounds(m, lo, hi);
        accessors[pos]["max"] = {hi[0], hi[1], hi[2]};
        accessors[pos]["min"] = {lo[0], lo[1], lo[2]};
        attributes["POSITION"] = pos;
        attributes["NORMAL"] = accessor(view(m.normals.empty() ? made(std::vector<float>(3 * n))
                                                               : floats(m.normals.data(), 3 * n),
                                             kArray),
                                        kFloat, "VEC3", n);
        attributes["TEXCOORD_0"] = accessor(
            view(m.uvs.empty() ? made(std::vector<float>(2 * n)) : floats(m.uvs.data(), 2 * n),
                 kArray),
            kFloat, "VEC2", n);
        std::vector<float> values(n);
        for (size_t i = 0; i < n; ++i) values[i] = m.order.empty() ? 0.0f : float(m.order[i]);
        attributes["_ORDER"] = accessor(view(made(std::move(values)), kArray), kFloat, "SCALAR", n);
        if (leaves) {
            std::vector<float> classes(n);
            for (size_t i = 0; i < n; ++i)
                classes[i] = m.colour.empty() ? 0.0f : float(m.colour[i]);
            attributes["_COLOUR"] =
                accessor(view(made(std::move(classes)), kArray), kFloat, "SCALAR", n);
            if (colours) {
                attributes["COLOR_0"] =
                    accessor(view(made(leafVertexColours(m, *colours)), kArray), kFloat, "VEC3", n);
            }
        }
        const size_t indices =
            accessor(view(asStored(m.indices.data(), m.indices.size()),
                          TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
                     TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, "SCALAR", m.indices.size());
        return json{{"attributes", std::move(attributes)},
                    {"indices", indices},
                    {"material", material},
                    {"mode", TINYGLTF_MODE_TRIANGLES}};
    };
    // The class colours without the per-leaf lightness (the instances carry it).
    Look flatLook;
    if (look) {
        flatLook = *look->look;
        flatLook.leafVariation = 0.0;
    }
    const MeshLook flat{&flatLook, look ? look->treeSeed : 0, look ? look->barkTextureSize : 256};
    // The leaves as instances of one mesh per (shape, colour class), in that order: the
    // shape's outline on the unit card, both faces as leafMesh lays out one leaf, drawn by
    // every leaf of the group at its translation, rotation and scale.
    auto addLeafInstances = [&](const std::vector<Leaf>& leaves, size_t material) {
        std::vector<uint32_t> order(leaves.size());
        for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
        auto key = [&](uint32_t i) {
            return static_cast<int>(leaves[i].shape) * 256 + leaves[i].colour;
        };
        std::stable_sort(order.begin(), order.end(),
                         [&](uint32_t a, uint32_t b) { return key(a) < key(b); });
        bool used = false;
        for (size_t g0 = 0; g0 < order.size();) {
            size_t g1 = g0;
            while (g1 < order.size() && key(order[g1]) == key(order[g0])) ++g1;
            // The group's mesh: leafMesh's of one leaf of its shape and class on the unit
            // card (size 1, aspect 1, at the origin, facing +z, its tip toward +x).
            Tree unit;
            Leaf& one = unit.leaves.emplace_back();
            one.position = {0, 0, 0};
            one.normal = {0, 0, 1};
            one.tangent = {1, 0, 0};
            one.size = one.aspect = 1.0;
            one.shape = leaves[order[g0]].shape;
            one.colour = leaves[order[g0]].colour;
            const Mesh& card = out.meshes.emplace_back(leafMesh(unit));
            const json cardPrimitive = primitive(card, true, material, look ? &flat : nullptr);
            meshes.push_back({{"name", "leaves"}, {"primitives", json::array({cardPrimitive})}});
            // Per instance: where, how turned, how large (x along the leaf, y across it, z
            // along its normal: size, size · aspect, size), its lightness and its index.
            const size_t count = g1 - g0;
            std::vector<float> tr, rot, sc, light, index;
            tr.reserve(3 * count), rot.reserve(4 * count), sc.reserve(3 * count);
            for (size_t k = g0; k < g1; ++k) {
                const Leaf& leaf = leaves[order[k]];
                const std::array<double, 4> q = leafQuaternion(leafFrame(leaf));
                tr.insert(tr.end(),
                          {float(leaf.position.x), float(leaf.position.y), float(leaf.position.z)});
                rot.insert(rot.end(), {float(q[0]), float(q[1]), float(q[2]), float(q[3])});
                sc.insert(sc.end(),
                          {float(leaf.size), float(leaf.size * leaf.aspect), float(leaf.size)});
                if (look) {
                    const float f = static_cast<float>(
                        leafLightness(look->treeSeed, order[k], look->look->leafVariation));
                    light.insert(light.end(), {f, f, f});
                }
                index.push_back(static_cast<float>(order[k]));
            }
            json inst;
            inst["TRANSLATION"] = accessor(view(made(std::move(tr)), 0), kFloat, "VEC3", count);
            inst["ROTATION"] = accessor(view(made(std::move(rot)), 0), kFloat, "VEC4", count);
            inst["SCALE"] = accessor(view(made(std::move(sc)), 0), kFloat, "VEC3", count);
            if (look) {
                inst["_COLOR_0"] = accessor(view(made(std::move(light)), 0), kFloat, "VEC3", count);
            }
            inst["_LEAF"] = accessor(view(made(std::move(index)), 0), kFloat, "SCALAR", count);
            nodes.push_back(
                {{"mesh", meshes.size() - 1},
                 {"name", "leaves"},
                 {"extensions", {{"EXT_mesh_gpu_instancing", {{"attributes", inst}}}}}});
            sceneNodes.push_back(nodes.size() - 1);
            used = true;
            g0 = g1;
        }
        return used;
    };
    int barkMaterial = -1;
    bool instanced = false;
    for (const Part& part : parts(mesh)) {
        const Mesh& m = *part.mesh;
        const bool leaves = part.mesh == &mesh.leaves;
        if (m.empty() && !(leaves && instances && !instances->empty())) continue;
        materials.push_back(materialJson(partMaterial(part, look), part.material->name));
        const size_t material = materials.size() - 1;
        if (!leaves) barkMaterial = static_cast<int>(material);
        if (leaves && instances) {
            instanced = addLeafInstances(*instances, material);
            continue;
        }
        meshes.push_back({{"name", part.object},
                          {"primitives", json::array({primitive(m, leaves, material, look)})}});
        nodes.push_back({{"mesh", meshes.size() - 1}, {"name", part.object}});
        sceneNodes.push_back(nodes.size() - 1);
    }
    if (look && barkMaterial >= 0) {  // the tile last, as meshGlb adds it
        out.bytes.push_back(barkPng(*look));
        lists.images.push_back({{"bufferView", view(out.bytes.back(), 0)},
                                {"mimeType", "image/png"},
                                {"name", "bark"}});
        lists.samplers.push_back(barkSamplerJson());
        lists.textures.push_back({{"name", "bark"}, {"sampler", 0}, {"source", 0}});
        materials[barkMaterial]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
    }
    json doc = gltfDocument(std::move(lists), binBytes, "tree");
    if (instanced) {
        doc["extensionsUsed"] = json::array({"EXT_mesh_gpu_instancing"});
        doc["extensionsRequired"] = json::array({"EXT_mesh_gpu_instancing"});
    }
    out.json = doc.dump();
    return out;
}

std::string glbFromParts(const GlbParts& parts) {
    std::string content = parts.json;
    content.append((4 - content.size() % 4) % 4, ' ');
    size_t bin = 0;
    for (std::string_view v : parts.views) bin += v.size();
    const size_t padding = (4 - bin % 4) % 4;
    std::string out;
    out.reserve(12 + 8 + content.size() + 8 + bin + padding);
    putU32(out, 0x46546C67u);  // "glTF"
    putU32(out, 2);
    putU32(out, static_cast<uint32_t>(12 + 8 + content.size() + (bin > 0 ? 8 + bin + padding : 0)));
    putU32(out, static_cast<uint32_t>(content.size()));
    putU32(out, 0x4E4F534Au);  // "JSON"
    out += content;
    if (bin > 0) {
        putU32(out, static_cast<uint32_t>(bin + padding));
        putU32(out, 0x004E4942u);  // "BIN\0"
        for (std::string_view v : parts.views) out.append(v.data(), v.size());
        out.append(padding, '\0');
    }
    return out;
}

std::string meshGlb(const TreeMesh& mesh, const MeshLook* look,
                    const std::vector<Leaf>* instances) {
    if (instances) return glbFromParts(meshGlbParts(mesh, look, instances));
    if (look) requireLook(*look, "meshGlb");
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "sylva";
    model.buffers.resize(1);
    model.scenes.resize(1);
    model.scenes[0].name = "tree";
    model.defaultScene = 0;
    int barkMaterial = -1;
    // The buffer's size before the image: position, normal, UV, order (and colour, RGB for
    // the leaves) per vertex and the indices, reserved so that appending copies nothing twice.
    size_t bufferBytes = 0;
    for (const Part& part : parts(mesh)) {
        const bool leaves = part.mesh == &mesh.leaves;
        bufferBytes += 4 * (part.mesh->vertexCount() * (9 + (leaves ? 1 + (look ? 3 : 0) : 0)) +
                            part.mesh->indices.size());
    }
    model.buffers[0].data.reserve(bufferBytes);
    for (const Part& part : parts(mesh)) {
        if (part.mesh->empty()) continue;  // neither an empty accessor nor an unused material
        model.materials.push_back(material(partMaterial(part, look), part.material->name));
        const int index = static_cast<int>(model.materials.size() - 1);
        const bool leaves = part.mesh == &mesh.leaves;
        std::vector<float> rgb;
        if (look && leaves) rgb = leafVertexColours(mesh.leaves, *look);
        addPart(model, *part.mesh, part.object, index, /*withColour=*/leaves,
                rgb.empty() ? nullptr : &rgb);
        if (!leaves) barkMaterial = index;
    }
    // The image last: every vertex attribute before it stays 4-byte aligned.
    if (look && barkMaterial >= 0) addBarkTexture(model, barkMaterial, "bark", barkPng(*look));
    if (model.buffers[0].data.empty()) model.buffers.clear();  // no zero-length buffer

    return serialiseGlb(model, "meshGlb");
}

namespace {

constexpr PartMaterial kGround = {"ground", {0.35, 0.28, 0.18}, 0.95, false};
constexpr PartMaterial kLowVegetation = {"low-vegetation", {0.25, 0.40, 0.12}, 0.7, true};

// A scene's materials in first-use order, each once by name: the plain ones, and with looks a
// bark and a leaf material per species ("bark-<species>", "leaf-<species>"), the bark's
// carrying its species' tile.
struct SceneMaterial {
    std::string name;
    PartMaterial part;
    const MeshLook* bark = nullptr;  // a textured bark's look
};
class SceneMaterials {
  public:
    explicit SceneMaterials(const SceneLooks* looks) : looks_(looks) {}
    // The index of a part's material: tree `tree`'s (−1: terrain, ground cover).
    int index(const PartMaterial& plain, int tree) {
        const MeshLook* look = looks_ && tree >= 0 && (&plain == &kBark || &plain == &kLeaf)
                                   ? &looks_->trees[tree]
                                   : nullptr;
        std::string name = plain.name;
        if (look) name += "-" + looks_->names[tree];
        for (size_t k = 0; k < list_.size(); ++k) {
            if (list_[k].name == name) return static_cast<int>(k);
        }
        const Part part{nullptr, "", &plain};
        list_.push_back({name, partMaterial(part, look), &plain == &kBark ? look : nullptr});
        return static_cast<int>(list_.size() - 1);
    }
    const std::vector<SceneMaterial>& list() const { return list_; }

  private:
    const SceneLooks* looks_;
    std::vector<SceneMaterial> list_;
};

// A scene GLB's nodes in file order, each as addNode(name, tree_id, tree index (−1: none),
// its parts with their materials): terrain, ground cover, then the trees.
template <typename AddNode>
void forEachSceneNode(const PlotScene& scene, AddNode& addNode) {
    addNode("terrain", 0, -1, {{&scene.terrain, &kGround}});
    addNode("ground-cover", 0, -1, {{&scene.groundCover, &kLowVegetation}});
    for (size_t k = 0; k < scene.trees.size(); ++k) {
        const PlotSceneTree& t = scene.trees[k];
        addNode(t.name, t.id, static_cast<int>(k),
                {{&t.mesh.wood, &kBark}, {&t.mesh.leaves, &kLeaf}});
    }
}

void checkSceneLooks(const PlotScene& scene, const SceneLooks* looks, const char* who) {
    if (!looks) return;
    if (looks->trees.size() != scene.trees.size() || looks->names.size() != scene.trees.size()) {
        throw std::invalid_argument(std::string(who) + ": one look and one name per scene tree");
    }
    for (const MeshLook& l : looks->trees) requireLook(l, who);
}

// The pieces of a scene's PLY in file order: terrain, ground cover, then per tree its wood
// and its leaves.
struct PlyPiece {
    const Mesh* mesh;
    int32_t treeId;
    uint8_t part;                       // for every vertex, unless …
    const std::vector<uint8_t>* parts;  // … per vertex
};

std::vector<PlyPiece> plyPieces(const PlotScene& scene) {
    std::vector<PlyPiece> pieces = {{&scene.terrain, 0, kPartTerrain, nullptr},
                                    {&scene.groundCover, 0, kPartLowVegetation, nullptr}};
    for (const PlotSceneTree& t : scene.trees) {
        pieces.push_back({&t.mesh.wood, t.id, kPartBranch, &t.woodParts});
        pieces.push_back({&t.mesh.leaves, t.id, kPartLeaf, nullptr});
    }
    return pieces;
}

std::string scenePlyHeader(size_t nv, size_t nf) {
    std::string out;
    out += "ply\n";
    out += "format binary_little_endian 1.0\n";
    out += "comment generated by sylva\n";
    out += "comment units: metres; up axis: +y\n";
    out += "comment part: 0 terrain, 1 stem, 2 branch, 3 leaf, 4 root, 5 low vegetation\n";
    out += "comment tree_id: the tree's id in the plot, 0 terrain and ground cover\n";
    out += "element vertex " + std::to_string(nv) + "\n";
    for (const char* name : {"x", "y", "z", "nx", "ny", "nz"}) {
        out += "property float ";
        out += name;
        out += '\n';
    }
    out += "property int tree_id\n";
    out += "property uchar part\n";
    out += "element face " + std::to_string(nf) + "\n";
    out += "property list uchar uint vertex_indices\n";
    out += "end_header\n";
    return out;
}

// Vertices [i0, i1) and faces [f0, f1) of a piece in the scene PLY's layout (faces' indices
// offset by the vertices of the pieces before it); return the end of what they stored.
char* storeSceneVertices(char* p, const PlyPiece& piece, size_t i0, size_t i1) {
    const Mesh& m = *piece.mesh;
    for (size_t i = i0; i < i1; ++i) {
        for (int c = 0; c < 3; ++c) p = storeFloat(p, m.positions[3 * i + c]);
        for (int c = 0; c < 3; ++c) p = storeFloat(p, attr(m.normals, i, 3, c));
        p = storeU32(p, static_cast<uint32_t>(piece.treeId));
        *p++ = static_cast<char>(piece.parts ? (*piece.parts)[i] : piece.part);
    }
    return p;
}
char* storeSceneFaces(char* p, const Mesh& m, size_t f0, size_t f1, uint32_t offset) {
    for (size_t f = f0; f < f1; ++f) {
        *p++ = 3;
        for (int c = 0; c < 3; ++c) p = storeU32(p, m.indices[3 * f + c] + offset);
    }
    return p;
}

constexpr size_t kSceneVertexBytes = 6 * 4 + 4 + 1, kSceneFaceBytes = 1 + 3 * 4;
constexpr size_t kStreamBlock = 4096;  // vertices, faces or values per buffer reservation

}  // namespace

std::string scenePly(const PlotScene& scene) {
    const std::vector<PlyPiece> pieces = plyPieces(scene);
    size_t nv = 0, nf = 0;
    for (const PlyPiece& p : pieces) {
        nv += p.mesh->vertexCount();
        nf += p.mesh->triangleCount();
    }
    std::string out = scenePlyHeader(nv, nf);
    const size_t headerBytes = out.size();
    out.resize(headerBytes + nv * kSceneVertexBytes + nf * kSceneFaceBytes);
    char* p = out.data() + headerBytes;
    for (const PlyPiece& piece : pieces)
        p = storeSceneVertices(p, piece, 0, piece.mesh->vertexCount());
    uint32_t offset = 0;
    for (const PlyPiece& piece : pieces) {
        p = storeSceneFaces(p, *piece.mesh, 0, piece.mesh->triangleCount(), offset);
        offset += static_cast<uint32_t>(piece.mesh->vertexCount());
    }
    return out;
}

std::string sceneGlb(const PlotScene& scene, const SceneLooks* looks) {
    checkSceneLooks(scene, looks, "sceneGlb");
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "sylva";
    model.buffers.resize(1);
    model.scenes.resize(1);
    model.scenes[0].name = "plot";
    model.defaultScene = 0;
    SceneMaterials materials(looks);
    auto materialIndex = [&](const PartMaterial& m, int tree) {
        const int index = materials.index(m, tree);
        if (static_cast<size_t>(index) == model.materials.size()) {
            const SceneMaterial& sm = materials.list().back();
            model.materials.push_back(material(sm.part, sm.name));
        }
        return index;
    };
    // A node with one mesh of the given parts (those with triangles); none when all are empty.
    // `tree`: the scene tree's index (−1: terrain, ground cover).
    auto addNode = [&](const std::string& name, int32_t treeId, int tree,
                       std::initializer_list<std::pair<const Mesh*, const PartMaterial*>> parts) {
        tinygltf::Mesh gm;
        gm.name = name;
        for (const auto& [mesh, mat] : parts) {
            if (mesh->empty()) continue;
            std::vector<float> rgb;
            if (looks && tree >= 0 && mat == &kLeaf)
                rgb = leafVertexColours(*mesh, looks->trees[tree]);
            gm.primitives.push_back(makePrimitive(model, *mesh, materialIndex(*mat, tree),
                                                  /*withColour=*/mat == &kLeaf,
                                                  rgb.empty() ? nullptr : &rgb));
        }
        if (gm.primitives.empty()) return;
        model.meshes.push_back(std::move(gm));
        tinygltf::Node node;
        node.name = name;
        node.mesh = static_cast<int>(model.meshes.size() - 1);
        tinygltf::Value::Object extras;
        extras["tree_id"] = tinygltf::Value(static_cast<int>(treeId));
        node.extras = tinygltf::Value(extras);
        model.nodes.push_back(std::move(node));
        model.scenes[0].nodes.push_back(static_cast<int>(model.nodes.size() - 1));
    };
    forEachSceneNode(scene, addNode);
    // The tiles last, in the materials' order: every vertex attribute before them stays
    // 4-byte aligned.
    for (size_t k = 0; k < materials.list().size(); ++k) {
        const SceneMaterial& sm = materials.list()[k];
        if (sm.bark) addBarkTexture(model, static_cast<int>(k), sm.name, barkPng(*sm.bark));
    }
    if (model.buffers[0].data.empty()) model.buffers.clear();

    return serialiseGlb(model, "sceneGlb");
}

// --- streamed scene writers ----------------------------------------------------------------

uint64_t writeScenePly(const PlotScene& scene, const std::filesystem::path& path) {
    const std::vector<PlyPiece> pieces = plyPieces(scene);
    size_t nv = 0, nf = 0;
    for (const PlyPiece& p : pieces) {
        nv += p.mesh->vertexCount();
        nf += p.mesh->triangleCount();
    }
    AtomicFileWriter file(path);
    file.write(scenePlyHeader(nv, nf));
    for (const PlyPiece& piece : pieces) {
        const size_t n = piece.mesh->vertexCount();
        for (size_t i0 = 0; i0 < n; i0 += kStreamBlock) {
            const size_t i1 = std::min(n, i0 + kStreamBlock);
            storeSceneVertices(file.reserve((i1 - i0) * kSceneVertexBytes), piece, i0, i1);
        }
    }
    uint32_t offset = 0;
    for (const PlyPiece& piece : pieces) {
        const size_t n = piece.mesh->triangleCount();
        for (size_t f0 = 0; f0 < n; f0 += kStreamBlock) {
            const size_t f1 = std::min(n, f0 + kStreamBlock);
            storeSceneFaces(file.reserve((f1 - f0) * kSceneFaceBytes), *piece.mesh, f0, f1, offset);
        }
        offset += static_cast<uint32_t>(piece.mesh->vertexCount());
    }
    const uint64_t bytes = file.bytesWritten();
    file.commit();
    return bytes;
}

// The GLB is written by hand rather than through tinygltf, which serialises only a whole
// tinygltf::Model — every buffer byte copied into the model, then into the output stream, then
// into its string: three copies of a scene that is gigabytes at a hectare. Measured with
// /usr/bin/time -v sylva build on 0.25 ha of bench/plot-1ha.toml's stand (100 trees, leaf
// cards) with mesh = ["ply"] and no views (scene.glb 956 MB, scene.ply 771 MB): peak RSS
// 4.41 GB through tinygltf and the in-memory PLY (main at 42d3b94), 1.50 GB streamed (the
// scene itself), every file byte-identical; the whole hectare passed 14 GB through tinygltf.
// The JSON is built as tinygltf builds it (nlohmann::json, keys sorted, defaults left out), so
// the bytes are the same (MeshWriters.StreamedSceneFilesEqualInMemoryOnes).
uint64_t writeSceneGlb(const PlotScene& scene, const std::filesystem::path& path,
                       const SceneLooks* looks) {
    using nlohmann::json;
    checkSceneLooks(scene, looks, "writeSceneGlb");
    struct View {
        enum Kind { kPositions, kNormals, kUvs, kOrder, kColour, kRgb, kIndices, kImage } kind;
        const Mesh* mesh;
        size_t item;  // kRgb: the scene tree; kImage: the tile in `tiles`
    };
    std::vector<View> views;  // buffer views in BIN order
    uint64_t binBytes = 0;
    GltfLists lists;
    json &accessors = lists.accessors, &bufferViews = lists.bufferViews, &meshes = lists.meshes,
         &nodes = lists.nodes, &sceneNodes = lists.sceneNodes;
    SceneMaterials materials(looks);
    // A buffer view and its accessor; returns the accessor's index.
    auto add = [&](View::Kind kind, const Mesh& m, int componentType, const char* type,
                   size_t count, size_t bytes, int target, size_t item = 0) {
        json view = {{"buffer", 0}, {"byteLength", bytes}, {"target", target}};
        if (binBytes > 0) view["byteOffset"] = binBytes;
        bufferViews.push_back(std::move(view));
        views.push_back({kind, &m, item});
        binBytes += bytes;
        json acc = {{"bufferView", bufferViews.size() - 1},
                    {"componentType", componentType},
                    {"count", count},
                    {"type", type}};
        accessors.push_back(std::move(acc));
        return static_cast<int>(accessors.size() - 1);
    };
    constexpr int kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT,
                  kUint = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    constexpr int kArray = TINYGLTF_TARGET_ARRAY_BUFFER;
    auto primitive = [&](const Mesh& m, int material, bool withColour, int tree) {
        const size_t n = m.vertexCount();
        json attributes;
        const int pos = add(View::kPositions, m, kFloat, "VEC3", n, 12 * n, kArray);
        double lo[3], hi[3];
        positionBounds(m, lo, hi);
        accessors[pos]["min"] = {lo[0], lo[1], lo[2]};
        accessors[pos]["max"] = {hi[0], hi[1], hi[2]};
        attributes["POSITION"] = pos;
        attributes["NORMAL"] = add(View::kNormals, m, kFloat, "VEC3", n, 12 * n, kArray);
        attributes["TEXCOORD_0"] = add(View::kUvs, m, kFloat, "VEC2", n, 8 * n, kArray);
        attributes["_ORDER"] = add(View::kOrder, m, kFloat, "SCALAR", n, 4 * n, kArray);
        if (withColour) {
            attributes["_COLOUR"] = add(View::kColour, m, kFloat, "SCALAR", n, 4 * n, kArray);
        }
        if (withColour && looks && tree >= 0) {
            attributes["COLOR_0"] =
                add(View::kRgb, m, kFloat, "VEC3", n, 12 * n, kArray, static_cast<size_t>(tree));
        }
        const int indices = add(View::kIndices, m, kUint, "SCALAR", m.indices.size(),
                                4 * m.indices.size(), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
        return json{{"attributes", std::move(attributes)},
                    {"indices", indices},
                    {"material", material},
                    {"mode", TINYGLTF_MODE_TRIANGLES}};
    };
    auto addNode = [&](const std::string& name, int32_t treeId, int tree,
                       std::initializer_list<std::pair<const Mesh*, const PartMaterial*>> parts) {
        json primitives = json::array();
        for (const auto& [mesh, mat] : parts) {
            if (mesh->empty()) continue;
            primitives.push_back(
                primitive(*mesh, materials.index(*mat, tree), mat == &kLeaf, tree));
        }
        if (primitives.empty()) return;
        meshes.push_back({{"name", name}, {"primitives", std::move(primitives)}});
        nodes.push_back(
            {{"extras", {{"tree_id", treeId}}}, {"mesh", meshes.size() - 1}, {"name", name}});
        sceneNodes.push_back(nodes.size() - 1);
    };
    forEachSceneNode(scene, addNode);
    // The materials as tinygltf writes them (a white base colour is its default, left out),
    // and after every vertex attribute the bark tiles, as sceneGlb adds them.
    json &materialList = lists.materials, &images = lists.images, &samplers = lists.samplers,
         &textures = lists.textures;
    std::vector<std::string> tiles;
    for (const SceneMaterial& sm : materials.list()) {
        json mat = materialJson(sm.part, sm.name);
        if (sm.bark) {
            tiles.push_back(barkPng(*sm.bark));
            json view = {{"buffer", 0}, {"byteLength", tiles.back().size()}};
            if (binBytes > 0) view["byteOffset"] = binBytes;
            bufferViews.push_back(std::move(view));
            views.push_back({View::kImage, nullptr, tiles.size() - 1});
            binBytes += tiles.back().size();
            images.push_back({{"bufferView", bufferViews.size() - 1},
                              {"mimeType", "image/png"},
                              {"name", sm.name}});
            samplers.push_back(barkSamplerJson());
            textures.push_back({{"name", sm.name},
                                {"sampler", samplers.size() - 1},
                                {"source", images.size() - 1}});
            mat["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", textures.size() - 1}};
        }
        materialList.push_back(std::move(mat));
    }
    // The BIN chunk padded to 4 bytes (a tile's length is any); the buffer keeps its own.
    const uint64_t binPadding = (4 - binBytes % 4) % 4;

    std::string content = gltfDocument(std::move(lists), binBytes, "plot").dump();
    content.append((4 - content.size() % 4) % 4, ' ');  // chunks start on 4-byte boundaries
    const uint64_t total = 12 + 8 + content.size() + (binBytes > 0 ? 8 + binBytes + binPadding : 0);
    if (total > std::numeric_limits<uint32_t>::max()) {
        throw std::runtime_error("cannot write '" + path.string() + "': the scene's " +
                                 std::to_string(total) + " bytes exceed GLB's 4 GiB limit");
    }

    AtomicFileWriter file(path);
    char head[20];
    std::memcpy(head, "glTF", 4);
    storeU32(head + 4, 2);
    storeU32(head + 8, static_cast<uint32_t>(total));
    storeU32(head + 12, static_cast<uint32_t>(content.size()));
    std::memcpy(head + 16, "JSON", 4);
    file.write({head, 20});
    file.write(content);
    content = std::string();
    if (binBytes > 0) {
        storeU32(head, static_cast<uint32_t>(binBytes + binPadding));
        std::memcpy(head + 4, "BIN\0", 4);
        file.write({head, 8});
    }
    // Per-vertex floats (absent arrays as zeros) or the indices, a block at a time.
    auto values = [&](size_t count, auto&& value) {
        for (size_t i0 = 0; i0 < count; i0 += kStreamBlock) {
            const size_t i1 = std::min(count, i0 + kStreamBlock);
            char* p = file.reserve(4 * (i1 - i0));
            for (size_t i = i0; i < i1; ++i) p = value(p, i);
        }
    };
    for (const View& v : views) {
        if (v.kind == View::kImage) {
            file.write(tiles[v.item]);
            continue;
        }
        const Mesh& m = *v.mesh;
        const size_t n = m.vertexCount();
        switch (v.kind) {
            case View::kPositions:
                values(3 * n, [&](char* p, size_t i) { return storeFloat(p, m.positions[i]); });
                break;
            case View::kNormals:
                values(3 * n, [&](char* p, size_t i) {
                    return storeFloat(p, m.normals.empty() ? 0.0f : m.normals[i]);
                });
                break;
            case View::kUvs:
                values(2 * n, [&](char* p, size_t i) {
                    return storeFloat(p, m.uvs.empty() ? 0.0f : m.uvs[i]);
                });
                break;
            case View::kOrder:
                values(n, [&](char* p, size_t i) {
                    return storeFloat(p, m.order.empty() ? 0.0f : float(m.order[i]));
                });
                break;
            case View::kColour:
                values(n, [&](char* p, size_t i) {
                    return storeFloat(p, m.colour.empty() ? 0.0f : float(m.colour[i]));
                });
                break;
            case View::kRgb: {
                const std::vector<float> rgb = leafVertexColours(m, looks->trees[v.item]);
                values(rgb.size(), [&](char* p, size_t i) { return storeFloat(p, rgb[i]); });
                break;
            }
            case View::kIndices:
                values(m.indices.size(),
                       [&](char* p, size_t i) { return storeU32(p, m.indices[i]); });
                break;
            case View::kImage:  // (above)
                break;
        }
    }
    if (binBytes > 0) file.write(std::string(binPadding, '\0'));
    const uint64_t bytes = file.bytesWritten();
    file.commit();
    return bytes;
}

}  // namespace sylva
