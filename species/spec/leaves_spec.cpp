#include "species/spec/leaves_spec.h"

#include <tuple>

#include "species/model/leaf_shape.h"

namespace sylva {

void readLeafCards(Params& l, LeafCardOptions& o) {
    std::tie(o.sizeMin, o.sizeMax) = l.interval("size", {o.sizeMin, o.sizeMax}, Range::positive());
    o.aspect = l.number("aspect", o.aspect, Range::leftOpen(0, 10));
    o.shape = readLeafShape(l, o.shape);
    o.orientation = l.choice("orientation", o.orientation,
                             {{"random", LeafOrientation::kRandom},
                              {"sun", LeafOrientation::kSun},
                              {"planophile", LeafOrientation::kPlanophile},
                              {"erectophile", LeafOrientation::kErectophile},
                              {"plagiophile", LeafOrientation::kPlagiophile},
                              {"extremophile", LeafOrientation::kExtremophile},
                              {"uniform", LeafOrientation::kUniform},
                              {"spherical", LeafOrientation::kSpherical}});
    o.sun = l.vec3("sun_direction", o.sun);
    if (length(o.sun) < 1e-12) l.fail("sun_direction", "expected a non-zero direction");
    o.sunWeight = l.number("sun_weight", o.sunWeight, Range::closed(0, 1));
}

LeafShape readLeafShape(Params& l, LeafShape fallback) {
    return l.choice("shape", fallback, leafShapeWords());
}

LeafOptions readLeaves(Params& species) {
    LeafOptions o;
    auto l = species.optionalTable("leaves");
    if (!l) return o;
    o.enabled = true;
    o.perTip = static_cast<int>(l->integer("per_tip", o.perTip, Range::closed(0, 1000)));
    o.alongTwig = l->number("along_twig", o.alongTwig, Range::nonNegative());
    readLeafCards(*l, o);
    o.colourClasses =
        static_cast<int>(l->integer("colour_classes", o.colourClasses, Range::closed(1, 254)));
    o.colourJitter = l->number("colour_jitter", o.colourJitter, Range::closed(0, 1));
    l->finish();
    return o;
}

}  // namespace sylva
