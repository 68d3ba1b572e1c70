#include "species/spec/volume_spec.h"

#include <cmath>

namespace sylva {

namespace {

constexpr double kDeg = kPi / 180.0;

VolumePtr parseSphere(Params& p) { return makeSphere(p.number("radius", Range::positive())); }
VolumePtr parseHemisphere(Params& p) {
    return makeHemisphere(p.number("radius", Range::positive()));
}
VolumePtr parseEllipsoid(Params& p) {
    return makeEllipsoid(p.vec3("radii", {1, 1, 1}, Range::positive()));
}
VolumePtr parseCylinder(Params& p) {
    return makeCylinder(p.number("radius", Range::positive()),
                        p.number("height", Range::positive()));
}
VolumePtr parseCone(Params& p) {
    double r = p.number("radius", Range::positive());
    double h = p.number("height", Range::positive());
    double top = p.number("top_radius", 0.0, Range::nonNegative());
    return makeCone(r, h, top);
}
VolumePtr parseBox(Params& p) { return makeBox(p.vec3("size", {1, 1, 1}, Range::positive())); }
VolumePtr parseSphereSector(Params& p) {
    return makeSphereSector(p.number("radius", Range::positive()),
                            p.number("alpha_deg", Range::leftOpen(0, 180)) * kDeg);
}

// The parts of a union, intersection or difference, each a volume table of its own.
std::vector<VolumePtr> parseParts(Params& p, size_t atLeast, const char* expected) {
    std::vector<Params> parts = p.tableArray("parts");
    if (parts.size() < atLeast) p.fail("parts", expected);
    std::vector<VolumePtr> vs;
    for (auto& part : parts) vs.push_back(parseVolume(part, false));
    return vs;
}
VolumePtr parseUnion(Params& p) {
    return makeUnion(parseParts(p, 1, "expected at least one part"));
}
VolumePtr parseIntersection(Params& p) {
    return makeIntersection(parseParts(p, 1, "expected at least one part"));
}
VolumePtr parseDifference(Params& p) {
    std::vector<VolumePtr> vs =
        parseParts(p, 2, "expected at least two parts (the base, then what to cut)");
    VolumePtr base = vs.front();
    vs.erase(vs.begin());
    return makeDifference(base, vs);
}

// Every volume kind, by the name a volume table gives in `type`. Adding a kind is its files
// in volumes/, its reader and one line here.
struct VolumeKind {
    const char* type;
    VolumePtr (*parse)(Params& p);  // reads the kind's own keys
};
constexpr VolumeKind kVolumeKinds[] = {
    {"sphere", parseSphere},
    {"hemisphere", parseHemisphere},
    {"ellipsoid", parseEllipsoid},
    {"cylinder", parseCylinder},
    {"cone", parseCone},
    {"box", parseBox},
    {"sphere-sector", parseSphereSector},
    {"revolution", parseRevolutionVolume},
    {"mask-revolution", parseMaskRevolutionVolume},
    {"visual-hull", parseVisualHullVolume},
    {"canopy-envelope", parseCanopyEnvelopeVolume},
    {"crown-refinement", parseCrownRefinementVolume},
    {"union", parseUnion},
    {"intersection", parseIntersection},
    {"difference", parseDifference},
};

}  // namespace

std::vector<std::string> volumeTypeNames() {
    std::vector<std::string> names;
    for (const VolumeKind& k : kVolumeKinds) names.emplace_back(k.type);
    return names;
}

VolumePtr parseVolume(Params& p, bool topLevel) {
    DocumentAs volumeKeys(p, "volume");
    const std::string type = p.choice("type", "", volumeTypeNames());
    VolumePtr v;
    {
        DocumentAs typeKeys(p, "volume." + type);
        for (const VolumeKind& k : kVolumeKinds) {
            if (type == k.type) v = k.parse(p);
        }
    }
    // Placement: local +y onto `axis`, scale in the local frame, then move to `position`.
    Placement pl;
    pl.position = p.vec3("position", {0, 0, 0});
    pl.axis = p.vec3("axis", {0, 1, 0});
    if (length(pl.axis) < 1e-12) p.fail("axis", "expected a non-zero direction");
    if (const toml::node* s = p.raw("scale"); s && s->is_number()) {
        double k = p.number("scale", Range::positive());
        pl.scale = {k, k, k};
    } else {
        pl.scale = p.vec3("scale", {1, 1, 1}, Range::positive());
    }
    if (!(pl.position == Vec3{0, 0, 0}) || !(pl.axis == Vec3{0, 1, 0}) ||
        !(pl.scale == Vec3{1, 1, 1})) {
        v = makePlaced(v, pl);
    }
    if (topLevel && p.has("voxel_size")) {
        double voxel = p.number("voxel_size", Range::positive());
        Vec3 size = v->bounds().size();
        double cells = (size.x / voxel) * (size.y / voxel) * (size.z / voxel);
        if (cells > kMaxLevelSetVoxels) {
            p.fail("voxel_size", "too fine for a crown of this size (over 2·10⁹ voxels)");
        }
        const Aabb b = v->bounds();
        for (double c : {b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z}) {
            if (!withinVoxelReach(c, voxel)) p.fail("voxel_size", kVoxelReachMessage);
        }
        v = makeLevelSet(*v, voxel);
    } else if (!topLevel) {
        p.raw("voxel_size");  // only meaningful at the top; reject it in parts
        if (p.has("voxel_size")) p.fail("voxel_size", "only allowed on the top-level volume");
    }
    if (v->bounds().empty() || !(v->measure() > 0)) {
        p.failHere("the volume is empty");
    }
    p.finish();
    return v;
}

}  // namespace sylva
