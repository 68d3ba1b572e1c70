// type = "revolution": the surface of revolution of a sketched stroke (Xu & Mould 2012
// §3.3.1, Figure 8), about the volume's local +y (tilt it with `axis`, move it with
// `position`, as for any volume).
//
//   [crown]
//   type = "revolution"
//   stroke = [[0.1, 0], [1.2, 1.5], [0.9, 4], [0, 5.5]]   # [radius, height] metres, or
//   # svg = "../sketches/umbrella.svg"  axis_x = 20  height = 6    (first <path>, SVG units)
//   # image = "../sketches/twotier.png" axis_x = 12  height = 7    (pixel column)
//   samples = 96           # points after arc-length resampling (≥ 8)
//   smoothing = 2          # Laplacian passes, ends fixed (≥ 0)
//   close_tolerance = 0.25 # an end may lie this fraction of the widest radius from the axis
//   segments = 64          # steps around the axis (≥ 8)
//   level_set_voxel = 0.05 # metres; default: the profile's largest dimension / 100
//
// close_tolerance is in [0, 1]: an end is never farther from the axis than the widest
// radius, so 1 already accepts every stroke and larger values would mean nothing.
// Errors from the stroke (crossing itself, never reaching the axis, bad SVG path data, an
// image without stroke pixels, …) are reported at the source key (stroke, svg or image).
#include <algorithm>
#include <cmath>

#include "species/spec/volume_spec.h"
#include "volumes/revolution.h"

namespace sylva {

VolumePtr parseRevolutionVolume(Params& p) {
    static const char* kSources[] = {"stroke", "svg", "image"};
    std::string source;
    for (const char* k : kSources) {
        if (!p.has(k)) continue;
        if (!source.empty()) {
            p.fail(k, "give only one stroke source: \"" + source + "\" is already given");
        }
        source = k;
    }
    if (source.empty()) {
        p.failHere(
            "type \"revolution\" needs a stroke: one of stroke = [[r, h], ...], svg = "
            "\"file.svg\" or image = \"file.png\"");
    }

    std::vector<Vec2> raw;
    if (source == "stroke") {
        raw = p.pairArray("stroke", 1);
    } else {
        const std::string file = p.filePath(source);
        const double axisX = p.number("axis_x", 0.0, Range::any());
        const double height = p.number("height", Range::positive());
        try {
            raw = source == "svg" ? readSvgStroke(file, axisX, height)
                                  : traceStrokeImage(file, axisX, height);
        } catch (const StrokeError& e) {
            p.fail(source, e.what());
        }
    }

    StrokeCleaning cleaning;
    cleaning.samples =
        static_cast<int>(p.integer("samples", cleaning.samples, Range::closed(8, 100000)));
    cleaning.smoothing =
        static_cast<int>(p.integer("smoothing", cleaning.smoothing, Range::closed(0, 10000)));
    cleaning.closeTolerance =
        p.number("close_tolerance", cleaning.closeTolerance, Range::closed(0, 1));
    const int segments =
        static_cast<int>(p.integer("segments", kRevolutionSegments, Range::closed(8, 4096)));

    std::vector<Vec2> profile;
    try {
        profile = cleanStroke(raw, cleaning);
    } catch (const StrokeError& e) {
        p.fail(source, e.what());
    }
    double maxR = 0, lo = profile.front().y, hi = profile.front().y;
    for (const Vec2& q : profile) {
        maxR = std::max(maxR, q.x);
        lo = std::min(lo, q.y);
        hi = std::max(hi, q.y);
    }
    const double largest = std::max(2.0 * maxR, hi - lo);
    double voxel = largest / 100.0;
    if (p.has("level_set_voxel")) {
        voxel = p.number("level_set_voxel", Range::positive());
        const double cells = std::pow(2.0 * maxR / voxel, 2) * ((hi - lo) / voxel);
        if (cells > kMaxLevelSetVoxels) {
            p.fail("level_set_voxel", "too fine for a crown of this size (over 2·10⁹ voxels)");
        }
    }
    for (double c : {maxR, lo, hi}) {
        if (!withinVoxelReach(c, voxel)) {
            p.fail(p.has("level_set_voxel") ? "level_set_voxel" : source, kVoxelReachMessage);
        }
    }
    try {
        return makeRevolution(profile, voxel, segments);
    } catch (const StrokeError& e) {
        p.fail(source, e.what());
    }
}

}  // namespace sylva
