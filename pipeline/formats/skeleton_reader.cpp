#include "pipeline/formats/skeleton_reader.h"

#include <cstdint>
#include <cstring>
#include <map>
#include <sstream>
#include <vector>

#include "core/errors.h"

namespace sylva {

namespace {

struct Property {
    std::string name;
    char kind = 'f';  // 'i' signed, 'u' unsigned, 'f' floating point
    int size = 4;     // bytes
};

struct Element {
    std::string name;
    size_t count = 0;
    std::vector<Property> properties;
    size_t stride() const {
        size_t s = 0;
        for (const Property& p : properties) s += static_cast<size_t>(p.size);
        return s;
    }
    // Byte offset of the named property within a row, or -1.
    long offset(const std::string& prop) const {
        long o = 0;
        for (const Property& p : properties) {
            if (p.name == prop) return o;
            o += p.size;
        }
        return -1;
    }
    const Property* find(const std::string& prop) const {
        for (const Property& p : properties) {
            if (p.name == prop) return &p;
        }
        return nullptr;
    }
};

bool scalarType(const std::string& t, Property& p) {
    static const std::map<std::string, std::pair<char, int>> kTypes = {
        {"char", {'i', 1}},  {"int8", {'i', 1}},    {"uchar", {'u', 1}},  {"uint8", {'u', 1}},
        {"short", {'i', 2}}, {"int16", {'i', 2}},   {"ushort", {'u', 2}}, {"uint16", {'u', 2}},
        {"int", {'i', 4}},   {"int32", {'i', 4}},   {"uint", {'u', 4}},   {"uint32", {'u', 4}},
        {"float", {'f', 4}}, {"float32", {'f', 4}}, {"double", {'f', 8}}, {"float64", {'f', 8}}};
    auto it = kTypes.find(t);
    if (it == kTypes.end()) return false;
    p.kind = it->second.first;
    p.size = it->second.second;
    return true;
}

// A little-endian scalar of the property's type at p, as a double.
double load(const unsigned char* p, const Property& prop) {
    uint64_t bits = 0;
    for (int i = 0; i < prop.size; ++i) bits |= static_cast<uint64_t>(p[i]) << (8 * i);
    if (prop.kind == 'f') {
        if (prop.size == 4) {
            uint32_t b32 = static_cast<uint32_t>(bits);
            float f;
            std::memcpy(&f, &b32, 4);
            return f;
        }
        double d;
        std::memcpy(&d, &bits, 8);
        return d;
    }
    if (prop.kind == 'u') return static_cast<double>(bits);
    const int shift = 64 - 8 * prop.size;  // sign-extend
    return static_cast<double>(static_cast<int64_t>(bits << shift) >> shift);
}

}  // namespace

Tree readSkeletonPly(const std::string& bytes, const std::string& name) {
    auto fail = [&](const std::string& what) { throw InputError(name + ": " + what); };
    // Header: lines up to "end_header\n".
    const size_t end = bytes.find("end_header\n");
    if (bytes.compare(0, 4, "ply\n") != 0 || end == std::string::npos) {
        fail("not a PLY file (no \"ply\" line or no \"end_header\")");
    }
    std::istringstream header(bytes.substr(0, end));
    std::vector<Element> elements;
    std::string line;
    bool format = false;
    while (std::getline(header, line)) {
        std::istringstream words(line);
        std::string word;
        words >> word;
        if (word == "format") {
            std::string f, version;
            words >> f >> version;
            if (f != "binary_little_endian") fail("expected format binary_little_endian, got " + f);
            format = true;
        } else if (word == "element") {
            Element e;
            long long count = -1;
            words >> e.name >> count;
            if (e.name.empty() || count < 0) fail("bad element line \"" + line + "\"");
            e.count = static_cast<size_t>(count);
            elements.push_back(e);
        } else if (word == "property") {
            if (elements.empty()) fail("a property before any element");
            std::string type;
            Property p;
            words >> type >> p.name;
            if (type == "list") fail("list property in \"" + line + "\": expected scalars only");
            if (!scalarType(type, p)) fail("unknown property type " + type);
            elements.back().properties.push_back(p);
        }
    }
    if (!format) fail("no format line");
    if (elements.size() < 2 || elements[0].name != "vertex" || elements[1].name != "edge") {
        fail("expected element vertex, then element edge");
    }
    const Element& ve = elements[0];
    const Element& ee = elements[1];
    for (const char* p : {"x", "y", "z", "radius"}) {
        if (!ve.find(p)) fail(std::string("vertex has no property ") + p);
    }
    for (const char* p : {"vertex1", "vertex2"}) {
        if (!ee.find(p)) fail(std::string("edge has no property ") + p);
    }
    size_t pos = end + std::strlen("end_header\n");
    const size_t need = ve.count * ve.stride() + ee.count * ee.stride();
    if (bytes.size() - pos < need) fail("truncated: the header announces more data than there is");
    if (ve.count == 0) fail("no vertices");
    if (ee.count != ve.count - 1) fail("expected one edge per vertex but the root");

    const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
    Tree tree;
    tree.nodes.resize(ve.count);
    auto get = [&](const Element& e, size_t row, size_t base, const char* prop) {
        return load(data + base + row * e.stride() + e.offset(prop), *e.find(prop));
    };
    const bool hasOrder = ve.find("order") != nullptr, hasPart = ve.find("part") != nullptr;
    for (size_t i = 0; i < ve.count; ++i) {
        SkeletonNode& n = tree.nodes[i];
        n.position = {get(ve, i, pos, "x"), get(ve, i, pos, "y"), get(ve, i, pos, "z")};
        n.radius = get(ve, i, pos, "radius");
        n.order = hasOrder ? static_cast<int32_t>(get(ve, i, pos, "order")) : 0;
        n.part = hasPart ? static_cast<uint8_t>(get(ve, i, pos, "part"))
                         : static_cast<uint8_t>(kShootPart);
        n.parent = -1;
    }
    pos += ve.count * ve.stride();
    for (size_t k = 0; k < ee.count; ++k) {
        const double p = get(ee, k, pos, "vertex1"), c = get(ee, k, pos, "vertex2");
        if (!(p >= 0 && c >= 1 && c < static_cast<double>(ve.count) && p < c)) {
            fail("edge " + std::to_string(k) +
                 ": expected a parent index below its child's, within the vertices");
        }
        SkeletonNode& child = tree.nodes[static_cast<size_t>(c)];
        if (child.parent >= 0)
            fail("vertex " + std::to_string(static_cast<size_t>(c)) + " has two parents");
        child.parent = static_cast<int32_t>(p);
    }
    return tree;
}

}  // namespace sylva
