#include "species/spec/volume_spec.h"

#include <cmath>

namespace sylva {

namespace {

constexpr double kDeg = kPi / 180.0;

VolumePtr parsePrimitive(Params& p, const std::string& type) {
    if (type == "sphere") return makeSphere(p.number("radius", Range::positive()));
    if (type == "hemisphere") return makeHemisphere(p.number("radius", Range::positive()));
    if (type == "ellipsoid") return makeEllipsoid(p.vec3("radii", {1, 1, 1}, Range::positive()));
    if (type == "cylinder") {
        return makeCylinder(p.number("radius", Range::positive()),
                            p.number("height", Range::positive()));
    }
    if (type == "cone") {
        double r = p.number("radius", Range::positive());
        double h = p.number("height", Range::positive());
        double top = p.number("top_radius", 0.0, Range::nonNegative());
        return makeCone(r, h, top);
    }
    if (type == "box") return makeBox(p.vec3("size", {1, 1, 1}, Range::positive()));
    if (type == "sphere-sector") {
        return makeSphereSector(p.number("radius", Range::positive()),
                                p.number("alpha_deg", Range::leftOpen(0, 180)) * kDeg);
    }
    return nullptr;
}

}  // namespace

VolumePtr parseVolume(Params& p, bool topLevel) {
    static const std::vector<std::string> kTypes = {"sphere",
                                                    "hemisphere",
                                                    "ellipsoid",
                                                    "cylinder",
                                                    "cone",
                                                    "box",
                                                    "sphere-sector",
                                                    "revolution",
                                                    "mask-revolution",
                                                    "visual-hull",
                                                    "canopy-envelope",
                                                    "crown-refinement",
                                                    "union",
                                                    "intersection",
                                                    "difference"};
    DocumentAs volumeKeys(p, "volume");
    std::string type = p.choice("type", "", kTypes);
    VolumePtr v;
    DocumentAs typeKeys(p, "volume." + type);
    if (type == "union" || type == "intersection" || type == "difference") {
        std::vector<Params> parts = p.tableArray("parts");
        if (parts.size() < (type == "difference" ? 2u : 1u)) {
            p.fail("parts", type == "difference"
                                ? "expected at least two parts (the base, then what to cut)"
                                : "expected at least one part");
        }
        std::vector<VolumePtr> vs;
        for (auto& part : parts) vs.push_back(parseVolume(part, false));
        if (type == "union") {
            v = makeUnion(vs);
        } else if (type == "intersection") {
            v = makeIntersection(vs);
        } else {
            VolumePtr base = vs.front();
            vs.erase(vs.begin());
            v = makeDifference(base, vs);
        }
    } else if (type == "revolution") {
        v = parseRevolutionVolume(p);
    } else if (type == "mask-revolution") {
        v = parseMaskRevolutionVolume(p);
    } else if (type == "visual-hull") {
        v = parseVisualHullVolume(p);
    } else if (type == "canopy-envelope") {
        v = parseCanopyEnvelopeVolume(p);
    } else if (type == "crown-refinement") {
        v = parseCrownRefinementVolume(p);
    } else {
        v = parsePrimitive(p, type);
    }
    // Placement: local +y onto `axis`, scale in the local frame, then move to `position`.
    p.documentAs("volume");
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
        if (cells > 2e9) {
            p.fail("voxel_size", "too fine for a crown of this size (over 2·10⁹ voxels)");
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
