// Species-file reader for type = "mask-revolution" (Liu et al. 2020 §4.3): a silhouette mask
// whose half-profile is revolved about its vertical axis (volumes/mask.h).
//
// Keys, units, defaults and ranges: docs/specs.md, "mask-revolution"
// (tests/project/spec_keys_test.cpp checks them against this reader); defaults are
// MaskRevolutionOptions' and MaskFalloff's.
#include <algorithm>
#include <cmath>

#include "species/spec/volume_spec.h"
#include "volumes/mask.h"

namespace sylva {

MaskFalloff readMaskFalloff(Params& p) {
    MaskFalloff f;
    f.enabled = p.boolean("soft_edge", f.enabled);
    f.radius = p.number("falloff_radius", f.radius, Range::nonNegative());
    f.k = p.number("falloff_k", f.k, Range::positive());
    return f;
}

PixelScale readPixelScale(Params& p, const std::string& images) {
    const bool byHeight = p.has("height"), bySize = p.has("metres_per_pixel");
    if (byHeight && bySize) {
        p.fail("metres_per_pixel", "give either height or metres_per_pixel, not both");
    }
    if (!byHeight && !bySize) {
        p.failHere("expected height (metres " + images +
                   " full image height represents) or metres_per_pixel");
    }
    return byHeight ? PixelScale{true, p.number("height", Range::positive())}
                    : PixelScale{false, p.number("metres_per_pixel", Range::positive())};
}

Mask readMaskKeys(Params& p) {
    const std::string file = p.filePath("mask");
    const bool invert = p.boolean("invert", false);
    try {
        return readMask(file, invert);
    } catch (const MaskError& e) {
        p.fail("mask", e.what());
    }
}

VolumePtr parseMaskRevolutionVolume(Params& p) {
    const Mask mask = readMaskKeys(p);
    MaskRevolutionOptions o;
    o.side = p.choice(
        "side", o.side,
        {{"right", ProfileSide::kRight}, {"left", ProfileSide::kLeft}, {"max", ProfileSide::kMax}});
    o.axisColumn = p.number("axis_column", mask.width / 2.0, Range::closed(0, mask.width));
    o.metresPerPixel = readPixelScale(p, "the mask's").metresPerPixel(mask.height);
    // Same ranges as type "revolution".
    o.cleaning.samples =
        static_cast<int>(p.integer("samples", o.cleaning.samples, Range::closed(8, 100000)));
    o.cleaning.smoothing =
        static_cast<int>(p.integer("smoothing", o.cleaning.smoothing, Range::closed(0, 10000)));
    o.segments = static_cast<int>(p.integer("segments", o.segments, Range::closed(8, 4096)));
    o.falloff = readMaskFalloff(p);
    if (p.has("level_set_voxel")) {
        o.voxelSize = p.number("level_set_voxel", Range::positive());
        std::vector<Vec2> stroke;
        try {
            stroke = maskHalfProfile(mask, o.axisColumn, o.side, o.metresPerPixel);
        } catch (const MaskError& e) {
            p.fail("mask", e.what());
        }
        double widest = 0.0;
        for (const Vec2& q : stroke) widest = std::max(widest, q.x);
        const double tall = stroke.back().y - stroke.front().y;
        if (std::pow(2.0 * widest / o.voxelSize, 2) * (tall / o.voxelSize) > kMaxLevelSetVoxels) {
            p.fail("level_set_voxel", "too fine for a crown of this size (over 2·10⁹ voxels)");
        }
        for (double c : {widest, stroke.front().y, stroke.back().y}) {
            if (!withinVoxelReach(c, o.voxelSize)) p.fail("level_set_voxel", kVoxelReachMessage);
        }
    }
    try {
        return makeMaskRevolution(mask, o);
    } catch (const MaskError& e) {
        p.fail("mask", e.what());
    } catch (const StrokeError& e) {
        p.fail("mask", std::string("the mask's half-profile cannot be revolved: ") + e.what());
    }
}

}  // namespace sylva
