// Species-file reader for type = "visual-hull" (Liu et al. 2020 §4.3): the intersection of
// the extrusions of two or more silhouette masks seen horizontally from known azimuths
// (volumes/mask.h). A view at azimuth_deg = 0 looks along −z (image right = +x); 90 looks
// along −x (image right = −z).
//
//   [crown]
//   type = "visual-hull"
//   views = [ { mask = "../sketches/acacia-front.png", azimuth_deg = 0 },
//             { mask = "../sketches/acacia-side.png", azimuth_deg = 90 } ]
//   height = 9
//
// Keys, units, defaults and ranges: docs/specs.md, "visual-hull" (tests/project/spec_keys_test.cpp
// checks them against this reader).
#include "species/spec/volume_spec.h"
#include "volumes/mask.h"

namespace sylva {

VolumePtr parseVisualHullVolume(Params& p) {
    std::vector<Params> viewTables = p.tableArray("views");
    if (viewTables.size() < 2) {
        p.fail("views",
               "expected at least two views ({ mask = \"front.png\", azimuth_deg = 0 }, "
               "{ mask = \"side.png\", azimuth_deg = 90 }), got " +
                   std::to_string(viewTables.size()));
    }
    const PixelScale scale = readPixelScale(p, "each mask's");

    std::vector<MaskView> views;
    for (Params& v : viewTables) {
        MaskView view;
        view.mask = readMaskKeys(v);
        view.azimuthDeg = v.number("azimuth_deg", Range::closed(-360, 360));
        view.axisColumn =
            v.number("axis_column", view.mask.width / 2.0, Range::closed(0, view.mask.width));
        view.metresPerPixel = scale.metresPerPixel(view.mask.height);
        v.finish();
        views.push_back(std::move(view));
    }

    const MaskFalloff falloff = readMaskFalloff(p);

    VolumePtr hull;
    try {
        hull = makeVisualHull(std::move(views), falloff);
    } catch (const MaskError& e) {
        p.fail("views", e.what());
    }
    if (!(hull->measure() > 0.0)) {
        p.fail("views",
               "the masks' extrusions do not intersect: the volume is empty (check the "
               "axis columns and the heights)");
    }
    return hull;
}

}  // namespace sylva
