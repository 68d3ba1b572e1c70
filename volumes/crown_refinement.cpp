// Crown refinement (Wolff 2013 §3.1.1, Abb. 11): "Punkte mit großem Abstand im Volumen
// verteilt und um diese Sphären mit festem Radius gebildet. Diese werden mittels Kegel mit dem
// Stamm ... verbunden" — spheres at well-separated points, each joined to the trunk by a cone.
#include "volumes/crown_refinement.h"

#include <cmath>
#include <stdexcept>

#include "volumes/poisson.h"

namespace sylva {

RefinedCrown refineCrown(const Volume& crown, const CrownRefinementOptions& o, Rng& rng) {
    if (o.count < 1) throw std::invalid_argument("refineCrown: count must be >= 1");
    if (!(o.sphereRadius > 0.0) || !std::isfinite(o.sphereRadius))
        throw std::invalid_argument("refineCrown: sphereRadius must be finite and > 0");
    if (!(o.gap >= 0.0) || !std::isfinite(o.gap))
        throw std::invalid_argument("refineCrown: gap must be finite and >= 0");
    const double coneRadius = o.coneRadius < 0.0 ? 0.5 * o.sphereRadius : o.coneRadius;
    if (!(coneRadius > 0.0) || !std::isfinite(coneRadius))
        throw std::invalid_argument("refineCrown: coneRadius must be finite and > 0");

    // Spheres of radius R are disjoint when their centres are at least 2R apart.
    PoissonOptions po;
    po.count = o.count;
    po.minDistance = 2.0 * o.sphereRadius + o.gap;
    po.maxConsecutiveRejections = o.maxConsecutiveRejections;
    RefinedCrown out;
    out.centres = poissonSample(crown, po, rng);

    std::vector<VolumePtr> parts;
    const VolumePtr sphere = makeSphere(o.sphereRadius);
    for (const Vec3& c : out.centres) {
        Placement at;
        at.position = c;
        parts.push_back(makePlaced(sphere, at));
        // The cone's base disc sits at the sphere's centre and its apex at the trunk top:
        // local +y (the cone's axis) turned onto centre → trunk top.
        const Vec3 axis = o.trunkTop - c;
        const double h = length(axis);
        if (h <= 1e-9 * std::max(1.0, o.sphereRadius)) continue;
        Placement cone;
        cone.position = c;
        cone.axis = axis / h;
        parts.push_back(makePlaced(makeCone(coneRadius, h), cone));
    }
    // A hub sphere of the cone radius at the trunk top: the cones meet there in thin apexes
    // that hold almost no graph nodes, and rounding could leave the apex point itself outside.
    Placement hub;
    hub.position = o.trunkTop;
    parts.push_back(makePlaced(makeSphere(coneRadius), hub));
    out.volume = makeUnion(std::move(parts));
    return out;
}

}  // namespace sylva
