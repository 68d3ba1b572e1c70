// type = "crown-refinement" (Wolff 2013 §3.1.1, Abb. 11; volumes/crown_refinement.h):
// keys, units, defaults and ranges in docs/specs.md, "crown-refinement"
// (tests/project/spec_keys_test.cpp checks them against this reader).
#include "species/spec/volume_spec.h"
#include "volumes/crown_refinement.h"
#include "volumes/poisson.h"

namespace sylva {

VolumePtr parseCrownRefinementVolume(Params& p) {
    VolumePtr crown;
    {
        Params sub = p.table("crown");
        crown = parseVolume(sub, false);
    }
    CrownRefinementOptions o;
    if (!p.has("trunk_top")) {
        p.raw("trunk_top");
        p.fail("trunk_top", "required key missing (expected [x, y, z], metres)");
    }
    o.trunkTop = p.vec3("trunk_top", {0, 0, 0});
    o.count = static_cast<int>(p.integer("count", Range::closed(1, 100000)));
    o.sphereRadius = p.number("sphere_radius", Range::positive());
    o.coneRadius = p.number("cone_radius", 0.5 * o.sphereRadius, Range::positive());
    o.gap = p.number("gap", o.gap, Range::nonNegative());
    Rng rng = p.has("seed")
                  ? Rng(static_cast<uint64_t>(p.integer("seed", Range::closed(0, 9.0e15))))
                  : p.randomStream("seed");
    try {
        return refineCrown(*crown, o, rng).volume;
    } catch (const PoissonSaturated& e) {
        p.fail("count",
               std::string("the spheres do not fit (centres 2·sphere_radius + gap apart): ") +
                   e.what());
    }
}

}  // namespace sylva
