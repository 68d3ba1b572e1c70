#include "species/spec/form_spec.h"

namespace sylva {

FormOptions readForm(Params& species) {
    FormOptions o;
    auto f = species.optionalTable("form");
    if (!f) return o;
    o.clearBole = f->number("clear_bole", o.clearBole, Range::nonNegative());
    o.pipeExponent = f->number("pipe_exponent", o.pipeExponent, Range::closed(0, 4));
    if (o.pipeExponent > 0 && o.pipeExponent < 1) {
        f->fail("pipe_exponent", "expected 0 (off) or a value in [1, 4]");
    }
    o.tipRadius = f->number("tip_radius", o.tipRadius, Range::positive());
    o.pipeTaper = f->number("pipe_taper", o.pipeTaper, Range::closed(0, 10));
    o.baseRadius = f->number("base_radius", o.baseRadius, Range::nonNegative());
    o.scale = f->number("scale", o.scale, Range::leftOpen(0, 100));
    o.asymmetry = f->number("asymmetry", o.asymmetry, Range::closed(0, 0.9));
    o.leanRad = f->degrees("lean_deg", o.leanRad, Range::closed(0, 60));
    o.ground =
        f->choice("ground", o.ground, {{"none", GroundRule::kNone}, {"prune", GroundRule::kPrune}});
    f->finish();
    return o;
}

}  // namespace sylva
