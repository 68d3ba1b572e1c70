#include "species/spec/form_spec.h"

namespace sylva {

FormOptions readForm(Params& species) {
    FormOptions o;
    auto f = species.optionalTable("form");
    if (!f) return o;
    o.clearBole = f->number("clear_bole", o.clearBole, Range::nonNegative());
    o.shadeShed = f->number("shade_shed", o.shadeShed, Range::closed(0, 1));
    o.shadeVoxel = f->number("shade_voxel", o.shadeVoxel, Range::closed(0.01, 10));
    o.shadeStrength = f->number("shade_strength", o.shadeStrength, Range::leftOpen(0, 1));
    o.shadeDecay = f->number("shade_decay", o.shadeDecay, Range::leftOpen(1, 100));
    o.shadeDepth = static_cast<int>(f->integer("shade_depth", o.shadeDepth, Range::closed(0, 16)));
    o.shadeMinOrder =
        static_cast<int>(f->integer("shade_min_order", o.shadeMinOrder, Range::closed(1, 64)));
    if (!(o.shadeShed > 0)) {
        for (const char* key :
             {"shade_voxel", "shade_strength", "shade_decay", "shade_depth", "shade_min_order"}) {
            if (f->has(key)) f->fail(key, "needs shade_shed (the light under which branches go)");
        }
    }
    o.pipeExponent = f->number("pipe_exponent", o.pipeExponent, Range::closed(0, 4));
    if (o.pipeExponent > 0 && o.pipeExponent < 1) {
        f->fail("pipe_exponent", "expected 0 (off) or a value in [1, 4]");
    }
    o.tipRadius = f->number("tip_radius", o.tipRadius, Range::positive());
    o.pipeTaper = f->number("pipe_taper", o.pipeTaper, Range::closed(0, 10));
    o.baseRadius = f->number("base_radius", o.baseRadius, Range::nonNegative());
    o.pipeExponentSd = f->number("pipe_exponent_sd", o.pipeExponentSd, Range::closed(0, 2));
    if (o.pipeExponentSd > 0 && !(o.pipeExponent > 0)) {
        f->fail("pipe_exponent_sd", "needs pipe_exponent (the mean it spreads about)");
    }
    o.pipeExponentLogSd =
        f->number("pipe_exponent_log_sd", o.pipeExponentLogSd, Range::closed(0, 1.5));
    if (o.pipeExponentLogSd > 0 && !(o.pipeExponent > 0)) {
        f->fail("pipe_exponent_log_sd", "needs pipe_exponent (the median it spreads about)");
    }
    o.pipeExponentLogMedian =
        f->number("pipe_exponent_log_median", o.pipeExponentLogMedian, Range::closed(0, 4));
    if (o.pipeExponentLogMedian > 0 && !(o.pipeExponentLogSd > 0)) {
        f->fail("pipe_exponent_log_median", "needs pipe_exponent_log_sd (the spread about it)");
    }
    if (o.pipeExponentLogMedian > 0 && o.pipeExponentLogMedian < 1) {
        f->fail("pipe_exponent_log_median", "expected 0 (pipe_exponent) or a value in [1, 4]");
    }
    o.pipeMinChildRatio =
        f->number("pipe_min_child_ratio", o.pipeMinChildRatio, Range::closed(0, 0.9));
    if (o.pipeMinChildRatio > 0 && !(o.pipeExponentLogSd > 0)) {
        f->fail("pipe_min_child_ratio", "needs pipe_exponent_log_sd (the forks it bounds)");
    }
    if (o.pipeExponentLogSd > 0 && o.pipeExponentSd > 0) {
        f->fail("pipe_exponent_log_sd", "set either pipe_exponent_sd or pipe_exponent_log_sd");
    }
    o.angleSdRad = f->degrees("angle_sd_deg", o.angleSdRad, Range::closed(0, 45));
    o.angleShiftRad = f->degrees("angle_shift_deg", o.angleShiftRad, Range::closed(-45, 45));
    o.bendRadPerM = f->degrees("bend_deg_per_m", o.bendRadPerM, Range::closed(-90, 90));
    o.bendSdRadPerM = f->degrees("bend_sd_deg_per_m", o.bendSdRadPerM, Range::closed(0, 90));
    o.lengthSd = f->number("length_sd", o.lengthSd, Range::closed(0, 1.5));
    o.spreadReach = f->number("spread_reach", o.spreadReach, Range::leftOpen(0, 10));
    o.scale = f->number("scale", o.scale, Range::leftOpen(0, 100));
    o.width = f->number("width", o.width, Range::closed(0.25, 4));
    o.asymmetry = f->number("asymmetry", o.asymmetry, Range::closed(0, 0.9));
    o.leanRad = f->degrees("lean_deg", o.leanRad, Range::closed(0, 60));
    o.ground =
        f->choice("ground", o.ground, {{"none", GroundRule::kNone}, {"prune", GroundRule::kPrune}});
    f->finish();
    return o;
}

}  // namespace sylva
