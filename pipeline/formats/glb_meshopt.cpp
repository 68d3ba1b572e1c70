#include "pipeline/formats/glb_meshopt.h"

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <vector>

#include "pipeline/formats/little_endian.h"

namespace sylva {

namespace {

using nlohmann::json;

constexpr int kByte = 5120, kUnsignedByte = 5121, kShort = 5122, kUnsignedShort = 5123,
              kUnsignedInt = 5125, kFloat = 5126;

// The codec a refusal names (compressGlbMeshopt or compressGlbDraco; set per call, per thread).
thread_local const char* tCaller = "compressGlbMeshopt";

[[noreturn]] void refuse(const std::string& why) {
    throw std::invalid_argument(std::string(tCaller) + ": " + why);
}

uint32_t loadU32(const std::string& s, size_t at) {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(uint8_t(s[at + i])) << (8 * i);
    return v;
}

int components(const std::string& type) {
    if (type == "SCALAR") return 1;
    if (type == "VEC2") return 2;
    if (type == "VEC3") return 3;
    if (type == "VEC4") return 4;
    refuse("an accessor of type " + type);
}

// A buffer view's new bytes (decoded, as the fallback buffer would hold them) and how to
// compress them.
struct View {
    std::vector<unsigned char> bytes;
    size_t count = 0;   // elements (vertices, indices)
    size_t stride = 0;  // bytes per element; 0: not compressed (an image)
    bool indices = false;
    const char* filter = nullptr;  // meshoptimizer's filter the bytes went through, if any
};

// Bits of the instances' filtered values (EXT_meshopt_compression's filters): translations a
// 16-bit mantissa under the largest coordinate of each (about the positions' grid: a
// coordinate off by ≤ its magnitude / 2^16), rotations 12 bits a component (≈ 0.03°), scales
// a 12-bit mantissa (≤ 1/4096 of the leaf's size).
constexpr int kTranslationBits = 16, kRotationBits = 12, kScaleBits = 12;
// Instance colours (the leaves' lightness, a factor about 1) a 10-bit mantissa: ≤ 0.1 %.
constexpr int kInstanceColourBits = 10;

// A node's EXT_mesh_gpu_instancing object, or null.
const json* instancingOf(const json& node) {
    const auto ext = node.find("extensions");
    if (ext == node.end()) return nullptr;
    const auto inst = ext->find("EXT_mesh_gpu_instancing");
    return inst == ext->end() ? nullptr : &*inst;
}

// The compression of a GLB's document and its buffer views' bytes (`source`, one per buffer
// view); `bytesBefore`: the plain file's size, for the report.
std::string compress(json doc, std::vector<std::string_view> source, size_t bytesBefore, bool draco,
                     GlbCompression* report);

// The container's JSON document and its buffer views' bytes.
json parseGlb(const std::string& glb, std::vector<std::string_view>& source) {
    // The container: a 12-byte header, a JSON chunk, a BIN chunk (glTF 2.0 §4.4).
    if (glb.size() < 20 || loadU32(glb, 0) != 0x46546C67u || loadU32(glb, 4) != 2) {
        refuse("not a GLB 2.0 file");
    }
    const size_t jsonLength = loadU32(glb, 12);
    if (loadU32(glb, 16) != 0x4E4F534Au || 20 + jsonLength > glb.size()) refuse("no JSON chunk");
    json doc = json::parse(glb.begin() + 20, glb.begin() + 20 + jsonLength);
    std::string_view bin;
    if (size_t at = 20 + jsonLength; at + 8 <= glb.size()) {
        const size_t binLength = loadU32(glb, at);
        if (loadU32(glb, at + 4) != 0x004E4942u || at + 8 + binLength > glb.size()) {
            refuse("a chunk after the JSON that is not BIN");
        }
        bin = std::string_view(glb).substr(at + 8, binLength);
    }
    const json& views = doc["bufferViews"];
    if (!views.is_array()) refuse("no buffer views or accessors");
    for (const json& view : views) {
        if (view.value("buffer", -1) != 0) refuse("a buffer view outside the BIN chunk");
        const size_t off = view.value("byteOffset", size_t(0)), len = view.at("byteLength");
        if (off + len > bin.size()) refuse("a buffer view past the BIN chunk");
        source.push_back(bin.substr(off, len));
    }
    return doc;
}

// The size of the plain GLB that meshGlb's parts make.
size_t plainSize(const GlbParts& parts) {
    size_t bin = 0;
    for (std::string_view v : parts.views) bin += v.size();
    return 12 + 8 + (parts.json.size() + 3) / 4 * 4 + (bin > 0 ? 8 + (bin + 3) / 4 * 4 : 0);
}

json partsDocument(const GlbParts& parts) {
    json doc = json::parse(parts.json);
    if (!doc["bufferViews"].is_array() || doc["bufferViews"].size() != parts.views.size()) {
        refuse("parts whose views are not the document's");
    }
    return doc;
}

std::string compressFile(const std::string& glb, bool draco, GlbCompression* report) {
    tCaller = draco ? "compressGlbDraco" : "compressGlbMeshopt";
    std::vector<std::string_view> source;
    json doc = parseGlb(glb, source);
    return compress(std::move(doc), std::move(source), glb.size(), draco, report);
}

std::string compressParts(const GlbParts& parts, bool draco, GlbCompression* report) {
    tCaller = draco ? "compressGlbDraco" : "compressGlbMeshopt";
    return compress(partsDocument(parts), parts.views, plainSize(parts), draco, report);
}

}  // namespace

std::string compressGlbMeshopt(const std::string& glb, GlbCompression* report) {
    return compressFile(glb, false, report);
}
std::string compressGlbMeshopt(const GlbParts& parts, GlbCompression* report) {
    return compressParts(parts, false, report);
}
std::string compressGlbDraco(const std::string& glb, GlbCompression* report) {
    return compressFile(glb, true, report);
}
std::string compressGlbDraco(const GlbParts& parts, GlbCompression* report) {
    return compressParts(parts, true, report);
}

namespace {

// Draco's settings (KHR_draco_mesh_compression): positions on one grid for the whole file,
// 16 bits over its largest extent (the meshopt grid's step); normals 8 bits (octahedral, as
// Draco's and glTF-Pipeline's defaults; 10 bits made four library trees' files 2–5 % larger);
// texture coordinates at least 512 steps a unit (a texture's repeat: off by at most 1/1024 of
// it; 4,096 steps made the files 1–15 % larger) and at least 12 bits over their range; vertex
// colours 8 bits. Speed 7 of Draco's 0 (smallest) … 10 (fastest): on one tree of each library
// species the same bytes as its default 5 (and as 6) in 0.85× the CPU; 8 made them 9 % larger.
constexpr int kDracoPositionBits = 16, kDracoNormalBits = 8, kDracoColourBits = 8;
constexpr double kDracoUvSteps = 512;  // per unit
constexpr int kDracoUvMinBits = 12;
constexpr int kDracoSpeed = 7;

// An attribute's Draco type, or refuses it.
draco::GeometryAttribute::Type dracoType(const std::string& name) {
    if (name == "POSITION") return draco::GeometryAttribute::POSITION;
    if (name == "NORMAL") return draco::GeometryAttribute::NORMAL;
    if (name == "TEXCOORD_0") return draco::GeometryAttribute::TEX_COORD;
    if (name == "COLOR_0") return draco::GeometryAttribute::COLOR;
    if (!name.empty() && name[0] == '_') return draco::GeometryAttribute::GENERIC;
    refuse("an attribute Draco cannot take: " + name);
}

// Every triangle primitive of a mesh not drawn as instances, its vertex and index views replaced
// by one KHR_draco_mesh_compression view (appended to `source`, its bytes kept in `store`);
// the views no longer read are removed and every index to the others renumbered. Application
// attributes (_ORDER, _COLOUR) whose values are all whole numbers go in as integers
// (UNSIGNED_BYTE, or SHORT), Draco's lossless integer coding; the accessors then say so.
// Returns the accessors Draco now holds (they have no buffer view) and, in `step`, the
// positions' grid step.
std::vector<bool> dracoPrimitives(json& doc, std::vector<std::string_view>& source,
                                  std::deque<std::string>& store,
                                  const std::vector<bool>& instancedMesh, const double lo[3],
                                  const double hi[3], double& step) {
    json& views = doc["bufferViews"];
    json& accessors = doc["accessors"];
    std::vector<bool> held(accessors.size(), false), dead(views.size(), false);
    float origin[3] = {0, 0, 0};
    double range = 0.0;
    if (std::isfinite(lo[0])) {
        for (int c = 0; c < 3; ++c) {
            origin[c] = static_cast<float>(lo[c]);
            range = std::max(range, hi[c] - lo[c]);
        }
    }
    // A hair over the extent, so the float origin's rounding cannot put a corner past it.
    const float drange = static_cast<float>(range > 0 ? range * (1 + 1e-6) + 1e-6 : 1.0);
    step = drange / ((1 << kDracoPositionBits) - 1);

    auto floatsOf = [&](size_t accessor, int n, size_t& count) -> const float* {
        const json& acc = accessors.at(accessor);
        count = acc.at("count");
        if (!acc.contains("bufferView")) refuse("an accessor shared by primitives");
        const size_t v = acc.at("bufferView");
        if (acc.at("componentType") != kFloat || components(acc.at("type")) != n ||
            v >= views.size() || views[v].contains("byteStride") ||
            source[v].size() != 4 * n * count) {
            refuse("an attribute that is not tightly packed floats");
        }
        return reinterpret_cast<const float*>(source[v].data());
    };

    for (size_t m = 0; m < instancedMesh.size(); ++m) {
        if (instancedMesh[m]) continue;
        for (json& prim : doc["meshes"][m].at("primitives")) {
            if (prim.value("mode", 4) != 4 || !prim.contains("indices")) {
                refuse("a primitive that is not an indexed triangle list");
            }
            const size_t ia = prim["indices"];
            const json& iacc = accessors.at(ia);
            if (!iacc.contains("bufferView")) refuse("an accessor shared by primitives");
            const size_t iv = iacc.at("bufferView");
            const size_t nIdx = iacc.at("count");
            if (iacc.at("componentType") != kUnsignedInt || nIdx % 3 != 0 ||
                source.at(iv).size() != 4 * nIdx) {
                refuse("indices that are not a UNSIGNED_INT triangle list");
            }
            const json& attrs = prim.at("attributes");
            if (!attrs.contains("POSITION")) refuse("a primitive without positions");
            size_t nv = 0;
            floatsOf(attrs["POSITION"], 3, nv);

            draco::Mesh mesh;
            mesh.set_num_points(static_cast<uint32_t>(nv));
            mesh.SetNumFaces(nIdx / 3);
            const auto* idx = reinterpret_cast<const uint32_t*>(source[iv].data());
            for (size_t f = 0; f < nIdx / 3; ++f) {
                draco::Mesh::Face face;
                for (int k = 0; k < 3; ++k) {
                    if (idx[3 * f + k] >= nv) refuse("an index past the vertices");
                    face[k] = draco::PointIndex(idx[3 * f + k]);
                }
                mesh.SetFace(draco::FaceIndex(static_cast<uint32_t>(f)), face);
            }
            draco::Encoder encoder;
            encoder.SetSpeedOptions(kDracoSpeed, kDracoSpeed);
            encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
            encoder.SetAttributeExplicitQuantization(draco::GeometryAttribute::POSITION,
                                                     kDracoPositionBits, 3, origin, drange);
            encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, kDracoNormalBits);
            encoder.SetAttributeQuantization(draco::GeometryAttribute::COLOR, kDracoColourBits);
            struct Added {
                std::string name;
                size_t accessor;
                int id;
                int componentType;  // as decoded
            };
            std::vector<Added> added;
            for (const auto& [name, index] : attrs.items()) {
                const size_t a = index.get<size_t>();
                const int n = components(accessors.at(a).at("type"));
                size_t count = 0;
                const float* f = floatsOf(a, n, count);
                if (count != nv) refuse("attributes of different lengths");
                const draco::GeometryAttribute::Type type = dracoType(name);
                draco::DataType dt = draco::DT_FLOAT32;
                int componentType = kFloat;
                const float* end = f + n * nv;
                const auto [least, most] = std::minmax_element(f, end);
                const float vmin = nv > 0 ? *least : 0.0f, vmax = nv > 0 ? *most : 0.0f;
                if (type == draco::GeometryAttribute::GENERIC) {
                    const bool whole = std::all_of(
                        f, end, [](float x) { return std::isfinite(x) && x == std::round(x); });
                    if (whole && vmin >= 0 && vmax <= 255) {
                        dt = draco::DT_UINT8;
                        componentType = kUnsignedByte;
                    } else if (whole && vmin >= -32768 && vmax <= 32767) {
                        dt = draco::DT_INT16;
                        componentType = kShort;
                    }
                } else if (type == draco::GeometryAttribute::TEX_COORD) {
                    const double span = std::max(1.0, double(vmax) - double(vmin));
                    const int bits =
                        std::clamp(static_cast<int>(std::ceil(std::log2(span * kDracoUvSteps))),
                                   kDracoUvMinBits, 30);
                    encoder.SetAttributeQuantization(type, bits);
                }
                draco::GeometryAttribute ga;
                ga.Init(type, nullptr, static_cast<uint8_t>(n), dt, false,
                        static_cast<int64_t>(draco::DataTypeLength(dt)) * n, 0);
                const int id = mesh.AddAttribute(ga, true, static_cast<uint32_t>(nv));
                draco::PointAttribute* pa = mesh.attribute(id);
                std::vector<unsigned char> value(draco::DataTypeLength(dt) * n);
                for (size_t i = 0; i < nv; ++i) {
                    for (int c = 0; c < n; ++c) {
                        const float x = f[n * i + c];
                        if (dt == draco::DT_UINT8) {
                            value[c] = static_cast<uint8_t>(x);
                        } else if (dt == draco::DT_INT16) {
                            const int16_t q = static_cast<int16_t>(x);
                            std::memcpy(&value[2 * c], &q, 2);
                        } else {
                            std::memcpy(&value[4 * c], &x, 4);
                        }
                    }
                    pa->SetAttributeValue(draco::AttributeValueIndex(static_cast<uint32_t>(i)),
                                          value.data());
                }
                added.push_back({name, a, static_cast<int>(pa->unique_id()), componentType});
                dead.at(accessors[a].at("bufferView").get<size_t>()) = true;
            }
            dead.at(iv) = true;
            draco::EncoderBuffer encoded;
            const draco::Status status = encoder.EncodeMeshToBuffer(mesh, &encoded);
            if (!status.ok())
                refuse("Draco could not encode a primitive: " + status.error_msg_string());

            // Decoded as a reader decodes it: Draco may split a vertex or drop a degenerate
            // triangle, so the accessors take the decoded counts and positions' bounds.
            draco::DecoderBuffer in;
            in.Init(encoded.data(), encoded.size());
            draco::Decoder decoder;
            auto decoded = decoder.DecodeMeshFromBuffer(&in);
            if (!decoded.ok()) throw std::runtime_error("compressGlbDraco: Draco cannot decode");
            const draco::Mesh& back = *decoded.value();

            store.emplace_back(encoded.data(), encoded.size());
            views.push_back({{"buffer", 0}, {"byteLength", encoded.size()}});
            source.push_back(store.back());
            dead.push_back(false);
            json ext = {{"bufferView", views.size() - 1}, {"attributes", json::object()}};
            for (const Added& at : added) {
                json& acc = accessors[at.accessor];
                acc.erase("bufferView");
                acc.erase("byteOffset");
                acc["count"] = back.num_points();
                acc["componentType"] = at.componentType;
                if (at.name == "POSITION") {
                    const draco::PointAttribute* pos = back.GetAttributeByUniqueId(at.id);
                    std::array<float, 3> p{}, pmin{}, pmax{};
                    for (uint32_t i = 0; i < back.num_points(); ++i) {
                        pos->GetMappedValue(draco::PointIndex(i), p.data());
                        for (int c = 0; c < 3; ++c) {
                            pmin[c] = i == 0 ? p[c] : std::min(pmin[c], p[c]);
                            pmax[c] = i == 0 ? p[c] : std::max(pmax[c], p[c]);
                        }
                    }
                    acc["min"] = pmin;
                    acc["max"] = pmax;
                }
                ext["attributes"][at.name] = at.id;
                held.at(at.accessor) = true;
            }
            json& ind = accessors[ia];
            ind.erase("bufferView");
            ind.erase("byteOffset");
            ind["count"] = 3 * back.num_faces();
            held.at(ia) = true;
            prim["extensions"]["KHR_draco_mesh_compression"] = ext;
        }
    }

    // The views left, renumbered.
    std::vector<long> renumber(views.size(), -1);
    json kept = json::array();
    std::vector<std::string_view> keptSource;
    for (size_t v = 0; v < views.size(); ++v) {
        if (dead[v]) continue;
        renumber[v] = static_cast<long>(kept.size());
        kept.push_back(views[v]);
        keptSource.push_back(source[v]);
    }
    views = std::move(kept);
    source = std::move(keptSource);
    for (json& acc : accessors) {
        if (acc.contains("bufferView"))
            acc["bufferView"] = renumber.at(acc["bufferView"].get<size_t>());
    }
    if (doc.contains("images")) {
        for (json& image : doc["images"]) {
            if (image.contains("bufferView")) {
                image["bufferView"] = renumber.at(image["bufferView"].get<size_t>());
            }
        }
    }
    for (json& mesh : doc["meshes"]) {
        for (json& prim : mesh["primitives"]) {
            if (!prim.contains("extensions") ||
                !prim["extensions"].contains("KHR_draco_mesh_compression")) {
                continue;
            }
            json& e = prim["extensions"]["KHR_draco_mesh_compression"];
            e["bufferView"] = renumber.at(e["bufferView"].get<size_t>());
        }
    }
    return held;
}

std::string compress(json doc, std::vector<std::string_view> source, size_t bytesBefore, bool draco,
                     GlbCompression* report) {
    json& views = doc["bufferViews"];
    json& accessors = doc["accessors"];
    if (!views.is_array() || !accessors.is_array()) refuse("no buffer views or accessors");

    // Which accessor reads each view, and what it is.
    std::vector<int> accessorOf(views.size(), -1);
    std::vector<std::string> semanticOf(accessors.size());
    // Meshes drawn as GPU instances (EXT_mesh_gpu_instancing): their positions are in the
    // instance's own frame, kept as floats off the grid; the instances' attributes are
    // "#instance:<name>".
    std::vector<bool> instancedMesh(doc.value("meshes", json::array()).size(), false);
    for (const json& node : doc.value("nodes", json::array())) {
        const json* inst = instancingOf(node);
        if (!inst) continue;
        if (!node.contains("mesh")) refuse("an instancing node without a mesh");
        instancedMesh.at(node["mesh"].get<size_t>()) = true;
        for (const auto& [name, index] : inst->at("attributes").items()) {
            semanticOf.at(index.get<size_t>()) = "#instance:" + name;
        }
    }
    for (size_t m = 0; m < instancedMesh.size(); ++m) {
        for (const json& prim : doc["meshes"][m].at("primitives")) {
            for (const auto& [name, index] : prim.at("attributes").items()) {
                semanticOf.at(index.get<size_t>()) =
                    instancedMesh[m] && name == "POSITION" ? "#card-position" : name;
            }
            if (prim.contains("indices")) semanticOf.at(prim["indices"].get<size_t>()) = "#indices";
        }
    }
    for (size_t a = 0; a < accessors.size(); ++a) {
        const json& acc = accessors[a];
        if (acc.contains("sparse") || !acc.contains("bufferView")) refuse("a sparse accessor");
        const size_t v = acc["bufferView"];
        if (v >= views.size() || accessorOf[v] >= 0) refuse("buffer views shared by accessors");
        accessorOf[v] = static_cast<int>(a);
    }

    // The positions' grid: one for the file, centred on the bounds of every POSITION.
    double lo[3], hi[3];
    std::fill(lo, lo + 3, std::numeric_limits<double>::infinity());
    std::fill(hi, hi + 3, -std::numeric_limits<double>::infinity());
    for (size_t a = 0; a < accessors.size(); ++a) {
        if (semanticOf[a] != "POSITION") continue;
        for (int c = 0; c < 3; ++c) {
            lo[c] = std::min(lo[c], accessors[a].at("min")[c].get<double>());
            hi[c] = std::max(hi[c], accessors[a].at("max")[c].get<double>());
        }
    }

    // Draco: the meshes' primitives become Draco's; what stays for meshoptimizer are the
    // instances and their leaf cards.
    std::deque<std::string> dracoBytes;
    double dracoStep = 0.0;
    if (draco) {
        const std::vector<bool> held =
            dracoPrimitives(doc, source, dracoBytes, instancedMesh, lo, hi, dracoStep);
        accessorOf.assign(views.size(), -1);
        for (size_t a = 0; a < accessors.size(); ++a) {
            if (held[a]) {
                semanticOf[a] = "#draco";
                continue;
            }
            accessorOf[accessors[a].at("bufferView").get<size_t>()] = static_cast<int>(a);
        }
    }
    double centre[3] = {0, 0, 0}, half = 0.0;
    if (std::isfinite(lo[0])) {
        for (int c = 0; c < 3; ++c) {
            centre[c] = 0.5 * (lo[c] + hi[c]);
            half = std::max(half, 0.5 * (hi[c] - lo[c]));
        }
    }
    const double scale = half > 0 ? half / 32767.0 : 1.0;
    double translationError = 0.0;

    std::vector<View> out(views.size());
    for (size_t v = 0; v < views.size(); ++v) {
        json& view = views[v];
        const std::string_view src = source[v];
        View& o = out[v];
        if (accessorOf[v] < 0) {  // an image: as it is
            o.bytes.assign(src.begin(), src.end());
            continue;
        }
        json& acc = accessors[accessorOf[v]];
        const std::string& semantic = semanticOf[accessorOf[v]];
        const size_t count = acc.at("count");
        const int n = components(acc.at("type"));
        const int type = acc.at("componentType");
        if (view.contains("byteStride")) refuse("an interleaved buffer view");
        o.count = count;
        if (semantic == "#indices") {
            if (type != kUnsignedInt || count % 3 != 0 || src.size() != 4 * count) {
                refuse("indices that are not a UNSIGNED_INT triangle list");
            }
            o.bytes.assign(src.begin(), src.end());
            o.stride = 4;
            o.indices = true;
            continue;
        }
        if (type != kFloat || src.size() != 4 * n * count)
            refuse("a vertex attribute not of floats");
        auto value = [&](size_t i, int c) {
            float f;
            std::memcpy(&f, src.data() + 4 * (n * i + c), 4);
            return f;
        };
        if (semantic == "#instance:TRANSLATION" || semantic == "#instance:SCALE" ||
            semantic == "#instance:_COLOR_0") {
            // Floats through the exponential filter (a shared exponent per vector), the
            // translations relative to the grid's centre (the node's translation).
            if (n != 3) refuse("an instance " + semantic.substr(10) + " not of VEC3");
            const bool translation = semantic == "#instance:TRANSLATION";
            const int bits = translation                     ? kTranslationBits
                             : semantic == "#instance:SCALE" ? kScaleBits
                                                             : kInstanceColourBits;
            std::vector<float> values(3 * count);
            for (size_t i = 0; i < count; ++i) {
                for (int c = 0; c < 3; ++c) {
                    values[3 * i + c] = translation ? float(value(i, c) - centre[c]) : value(i, c);
                }
            }
            o.stride = 12;
            o.bytes.assign(12 * count, 0);
            meshopt_encodeFilterExp(o.bytes.data(), count, 12, bits, values.data());
            o.filter = "EXPONENTIAL";
            if (translation && count > 0) {  // the largest error, decoded as a reader decodes
                std::vector<unsigned char> decoded = o.bytes;
                meshopt_decodeFilterExp(decoded.data(), count, 12);
                for (size_t k = 0; k < 3 * count; ++k) {
                    float f;
                    std::memcpy(&f, &decoded[4 * k], 4);
                    translationError =
                        std::max(translationError, std::abs(double(f) - double(values[k])));
                }
            }
            view["byteStride"] = o.stride;
            continue;
        }
        if (semantic == "#instance:ROTATION") {  // unit quaternions through the filter
            if (n != 4) refuse("an instance ROTATION not of VEC4");
            std::vector<float> values(4 * count);
            for (size_t i = 0; i < count; ++i) {
                for (int c = 0; c < 4; ++c) values[4 * i + c] = value(i, c);
            }
            o.stride = 8;
            o.bytes.assign(8 * count, 0);
            meshopt_encodeFilterQuat(o.bytes.data(), count, 8, kRotationBits, values.data());
            o.filter = "QUATERNION";
            acc["componentType"] = kShort;
            acc["normalized"] = true;
            view["byteStride"] = o.stride;
            continue;
        }
        if (semantic == "POSITION" || semantic == "NORMAL") {
            const bool position = semantic == "POSITION";
            o.stride = position ? 8 : 4;
            o.bytes.assign(o.stride * count, 0);
            std::vector<int> qmin(3, 0), qmax(3, 0);
            for (size_t i = 0; i < count; ++i) {
                for (int c = 0; c < 3; ++c) {
                    if (position) {
                        const double q = std::clamp(std::round((value(i, c) - centre[c]) / scale),
                                                    -32767.0, 32767.0);
                        const int16_t s = static_cast<int16_t>(q);
                        std::memcpy(&o.bytes[8 * i + 2 * c], &s, 2);
                        qmin[c] = i == 0 ? s : std::min<int>(qmin[c], s);
                        qmax[c] = i == 0 ? s : std::max<int>(qmax[c], s);
                    } else {
                        const double q =
                            std::clamp(std::round(double(value(i, c)) * 127.0), -127.0, 127.0);
                        o.bytes[4 * i + c] = static_cast<unsigned char>(static_cast<int8_t>(q));
                    }
                }
            }
            acc["componentType"] = position ? kShort : kByte;
            if (position) {
                acc["min"] = qmin;
                acc["max"] = qmax;
            } else {
                acc["normalized"] = true;
            }
            view["byteStride"] = o.stride;
            continue;
        }
        // Vertex colours (in [0, 1]) as UNSIGNED_BYTE normalised, texture coordinates that lie
        // in [0, 1] (the leaves' outline UVs) as UNSIGNED_SHORT normalised; each element padded
        // to 4 bytes.
        bool unit = semantic == "COLOR_0" || semantic == "TEXCOORD_0";
        for (size_t i = 0; unit && i < count; ++i) {
            for (int c = 0; c < n && unit; ++c) unit = value(i, c) >= 0.0f && value(i, c) <= 1.0f;
        }
        if (unit && semantic == "COLOR_0" && n <= 4) {
            o.stride = 4;
            o.bytes.assign(4 * count, 0);
            for (size_t i = 0; i < count; ++i) {
                for (int c = 0; c < n; ++c) {
                    o.bytes[4 * i + c] =
                        static_cast<unsigned char>(std::lround(value(i, c) * 255.0));
                }
            }
            acc["componentType"] = kUnsignedByte;
            acc["normalized"] = true;
        } else if (unit && semantic == "TEXCOORD_0" && n == 2) {
            o.stride = 4;
            o.bytes.assign(4 * count, 0);
            for (size_t i = 0; i < count; ++i) {
                for (int c = 0; c < 2; ++c) {
                    const auto u = static_cast<uint16_t>(std::lround(value(i, c) * 65535.0));
                    std::memcpy(&o.bytes[4 * i + 2 * c], &u, 2);
                }
            }
            acc["componentType"] = kUnsignedShort;
            acc["normalized"] = true;
        } else {
            o.bytes.assign(src.begin(), src.end());
            o.stride = 4 * n;
            if (o.stride > 256) refuse("a vertex attribute wider than 256 bytes");
        }
        view["byteStride"] = o.stride;
    }

    // The BIN chunk: each compressed view (or image) 4-byte aligned; the fallback buffer's
    // layout: each decoded view likewise.
    std::string newBin;
    size_t fallback = 0, meshoptViews = 0;
    for (size_t v = 0; v < views.size(); ++v) {
        json& view = views[v];
        View& o = out[v];
        while (newBin.size() % 4) newBin.push_back('\0');
        if (o.stride == 0) {
            view["byteOffset"] = newBin.size();
            view["byteLength"] = o.bytes.size();
            newBin.append(reinterpret_cast<const char*>(o.bytes.data()), o.bytes.size());
            continue;
        }
        std::vector<unsigned char> packed;
        size_t size = 0;
        if (o.indices) {
            std::vector<unsigned> idx(o.count);
            std::memcpy(idx.data(), o.bytes.data(), 4 * o.count);
            size_t vertices = 0;
            for (unsigned i : idx) vertices = std::max<size_t>(vertices, i + 1);
            packed.resize(meshopt_encodeIndexBufferBound(o.count, vertices));
            size = meshopt_encodeIndexBuffer(packed.data(), packed.size(), idx.data(), o.count);
        } else {
            packed.resize(meshopt_encodeVertexBufferBound(o.count, o.stride));
            size = meshopt_encodeVertexBuffer(packed.data(), packed.size(), o.bytes.data(), o.count,
                                              o.stride);
        }
        if (size == 0) throw std::runtime_error("compressGlbMeshopt: meshoptimizer failed");
        json ext = {{"buffer", 0},        {"byteOffset", newBin.size()},
                    {"byteLength", size}, {"byteStride", o.stride},
                    {"count", o.count},   {"mode", o.indices ? "TRIANGLES" : "ATTRIBUTES"}};
        if (o.filter) ext["filter"] = o.filter;
        newBin.append(reinterpret_cast<const char*>(packed.data()), size);
        ++meshoptViews;
        while (fallback % 4) ++fallback;
        view["buffer"] = 1;
        view["byteOffset"] = fallback;
        view["byteLength"] = o.bytes.size();
        view["extensions"]["EXT_meshopt_compression"] = ext;
        fallback += o.bytes.size();
    }
    while (newBin.size() % 4) newBin.push_back('\0');
    doc["buffers"] = json::array();
    doc["buffers"].push_back({{"byteLength", newBin.size()}});
    // (With Draco and no instances, meshoptimizer compressed nothing: no fallback buffer.)
    const bool meshopt = !draco || meshoptViews > 0;
    if (meshopt) {
        doc["buffers"].push_back(
            {{"byteLength", std::max<size_t>(fallback, 4)},
             {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}});
    }

    // Every node with a mesh: the grid's translation and scale; an instancing node the
    // translation alone (its instances' translations are relative to it, its mesh unscaled).
    for (json& node : doc["nodes"]) {
        if (!node.contains("mesh")) continue;
        if (node.contains("matrix") || node.contains("translation") || node.contains("scale") ||
            node.contains("rotation")) {
            refuse("a node with a transform of its own");
        }
        if ((instancingOf(node) != nullptr) != instancedMesh.at(node["mesh"].get<size_t>())) {
            refuse("a mesh drawn both as instances and alone");
        }
        const bool instanced = instancedMesh.at(node["mesh"].get<size_t>());
        if (draco && !instanced) continue;  // Draco decodes positions in the world's frame
        node["translation"] = {centre[0], centre[1], centre[2]};
        if (!instanced) node["scale"] = {scale, scale, scale};
    }
    std::vector<const char*> extensions;
    if (draco) extensions.push_back("KHR_draco_mesh_compression");
    if (meshopt) {
        extensions.push_back("EXT_meshopt_compression");
        extensions.push_back("KHR_mesh_quantization");
    }
    for (const char* list : {"extensionsUsed", "extensionsRequired"}) {
        json& names = doc[list];
        if (!names.is_array()) names = json::array();
        for (const char* e : extensions) {
            if (std::find(names.begin(), names.end(), e) == names.end()) names.push_back(e);
        }
    }

    std::string text = doc.dump();
    while (text.size() % 4) text.push_back(' ');
    std::string file;
    putU32(file, 0x46546C67u);
    putU32(file, 2);
    putU32(file, static_cast<uint32_t>(12 + 8 + text.size() + 8 + newBin.size()));
    putU32(file, static_cast<uint32_t>(text.size()));
    putU32(file, 0x4E4F534Au);
    file += text;
    putU32(file, static_cast<uint32_t>(newBin.size()));
    putU32(file, 0x004E4942u);
    file += newBin;
    if (report) {
        report->bytesBefore = bytesBefore;
        report->bytesAfter = file.size();
        report->positionError = std::max(0.5 * (draco ? dracoStep : scale), translationError);
    }
    return file;
}

}  // namespace

}  // namespace sylva
