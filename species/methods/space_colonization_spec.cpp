// Species-file parameters of the `space-colonization` method → SpaceColonizationOptions.
// The keys sit at the top level of the species file (before its first [table]); lengths
// marked "internodes" are multiples of `internode`.
//
// Keys, units, defaults and ranges: docs/methods/space-colonization.md
// (tests/project/spec_keys_test.cpp checks them against this reader); every default is
// SpaceColonizationOptions'.
//
// κ: the paper gives 2–4; values down to 1 are accepted too (κ = 1 draws a bud's markers
// exactly within its perception radius), below 1 a bud's markers could not fill its
// perception volume. The bole top (where growth starts) must lie within r of the crown or
// of a guide marker, else the tree could never start: an error at trunk_length (or [crown]).
// Guide markers are drawn per tree (a stream keyed by the instance seed),
// so a species with [guides] is parsed once per tree rather than cached.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "species/methods/space_colonization.h"
#include "species/methods/space_colonization_guides.h"
#include "species/spec/growth_method.h"
#include "species/spec/volume_spec.h"

namespace sylva {

namespace {

constexpr double kDeg = kPi / 180.0;

Range open(double a, double b) { return {a, b, true, true}; }

std::string num(double v) { return formatNumber(v, 6); }

class SpaceColonizationMethod : public GrowthMethod {
  public:
    explicit SpaceColonizationMethod(SpaceColonizationOptions o) : o_(std::move(o)) {}

    Tree grow(Rng& rng, bool threaded, std::map<std::string, double>& stats,
              const GrowthGuard& guard) const override {
        if (threaded == o_.threaded) return growSpaceColonization(o_, rng, &stats, guard);
        SpaceColonizationOptions o = o_;
        o.threaded = threaded;
        return growSpaceColonization(o, rng, &stats, guard);
    }

    const SpaceColonizationOptions* spaceColonization() const override { return &o_; }

    std::vector<std::pair<std::string, VolumePtr>> volumes() const override {
        if (!o_.crown) return {};
        return {{"crown", o_.crown}};
    }

  private:
    SpaceColonizationOptions o_;
};

}  // namespace

std::unique_ptr<GrowthMethod> makeSpaceColonizationMethod(Params& sp) {
    SpaceColonizationOptions o;
    o.variant = sp.choice("variant", o.variant,
                          {{"baseline", ColonizationVariant::kBaseline},
                           {"improved", ColonizationVariant::kImproved}});
    const bool improved = o.variant == ColonizationVariant::kImproved;

    std::optional<Params> crownTable = sp.optionalTable("crown");
    if (crownTable) {
        o.crown = parseVolume(*crownTable);
    } else if (!improved) {
        sp.failHere("[crown] is required for variant = \"baseline\" (its markers fill the crown)");
    }

    // Keys of one variant only are errors in the other, rather than silently ignored.
    const std::vector<std::string> baselineOnly = {"markers"};
    const std::vector<std::string> improvedOnly = {"markers_per_bud", "kappa", "sigma", "gravity"};
    for (const std::string& k : improved ? baselineOnly : improvedOnly) {
        if (sp.has(k)) {
            sp.raw(k);
            sp.fail(k, std::string("applies to variant = \"") +
                           (improved ? "baseline" : "improved") + "\" only");
        }
    }

    o.internode = sp.number("internode", o.internode, Range::positive());
    o.occupancy = sp.number("occupancy", o.occupancy, Range::positive());
    o.perception = sp.number("perception", o.perception, Range::positive());
    if (!(o.perception > o.occupancy)) {
        const std::string msg =
            "the perception radius r must exceed the occupancy radius ρ (got r = " +
            num(o.perception) + ", ρ = " + num(o.occupancy) + " internodes)";
        sp.fail(sp.has("perception") ? "perception" : "occupancy", msg);
    }
    o.perceptionAngle =
        sp.number("perception_angle_deg", o.perceptionAngle / kDeg, open(0, 180)) * kDeg;
    if (improved) {
        o.markersPerBud = static_cast<int>(
            sp.integer("markers_per_bud", o.markersPerBud, Range::closed(1, 100000)));
        o.kappa = sp.number("kappa", o.kappa, Range::closed(1, 4));
        o.sigma = sp.number("sigma", o.sigma, Range::positive());
        o.gravityWeight = sp.number("gravity", o.gravityWeight, Range::nonNegative());
    } else {
        o.markers = static_cast<int>(sp.integer("markers", o.markers, Range::closed(1, 5e7)));
    }

    // Borchert–Honda allocation and shedding (Palubicki 2009 §4): baseline only.
    if (improved && sp.has("allocation")) {
        sp.raw("allocation");
        sp.fail("allocation", "applies to variant = \"baseline\" only");
    }
    o.allocation =
        sp.choice("allocation", o.allocation,
                  {{"none", Allocation::kNone}, {"borchert-honda", Allocation::kBorchertHonda}});
    if (o.allocation == Allocation::kBorchertHonda) {
        o.apicalControl = sp.number("apical_control", o.apicalControl, open(0, 1));
        o.resourceCoefficient =
            sp.number("resource_coefficient", o.resourceCoefficient, Range::positive());
        o.light =
            sp.choice("light", o.light, {{"space", Light::kSpace}, {"shadow", Light::kShadow}});
        if (o.light == Light::kShadow) {
            o.shadowStrength = sp.number("shadow_strength", o.shadowStrength, open(0, 1e300));
            o.shadowDecay = sp.number("shadow_decay", o.shadowDecay, open(1, 1e300));
            o.shadowDepth =
                static_cast<int>(sp.integer("shadow_depth", o.shadowDepth, Range::closed(0, 64)));
            o.shedThreshold = sp.number("shed_threshold", o.shedThreshold, Range::closed(0, 1));
            o.shedDelay =
                static_cast<int>(sp.integer("shed_delay", o.shedDelay, Range::closed(1, 1000)));
        }
        o.spaceMarkers = sp.number("space_markers", o.spaceMarkers, Range::closed(0, 1e6));
        for (const char* k :
             {"shadow_strength", "shadow_decay", "shadow_depth", "shed_threshold", "shed_delay"}) {
            if (o.light == Light::kShadow || !sp.has(k)) continue;
            sp.raw(k);
            sp.fail(k, "applies to light = \"shadow\" only");
        }
    } else {
        for (const char* k :
             {"apical_control", "resource_coefficient", "light", "shadow_strength", "shadow_decay",
              "shadow_depth", "shed_threshold", "shed_delay", "space_markers"}) {
            if (!sp.has(k)) continue;
            sp.raw(k);
            sp.fail(k, "applies to allocation = \"borchert-honda\" only");
        }
    }

    // The per-instance crown deforms [crown]: without one there is nothing to deform.
    for (const char* k : {"envelope_scale_sd", "envelope_noise"}) {
        if (o.crown || !sp.has(k)) continue;
        sp.raw(k);
        sp.fail(k, "needs a [crown] to deform");
    }
    o.envelopeScaleSd = sp.number("envelope_scale_sd", o.envelopeScaleSd, Range::closed(0, 0.5));
    o.envelopeNoise = sp.number("envelope_noise", o.envelopeNoise, Range::closed(0, 0.9));

    o.turnSd = sp.number("shoot_turn_sd_deg", o.turnSd / kDeg, Range::closed(0, 90)) * kDeg;
    o.axisTurnMax =
        sp.number("axis_turn_max_deg", o.axisTurnMax / kDeg, Range::closed(0, 180)) * kDeg;
    o.limbTurnMax =
        sp.number("limb_turn_max_deg", o.limbTurnMax / kDeg, Range::closed(0, 180)) * kDeg;
    o.flatSprays = sp.boolean("flat_sprays", o.flatSprays);

    // Excurrent form: the leader, whorls on it, a bound on branch order.
    o.leaderWeight = sp.number("leader_weight", o.leaderWeight, Range::nonNegative());
    o.whorlLaterals =
        static_cast<int>(sp.integer("whorl_laterals", o.whorlLaterals, Range::closed(0, 12)));
    o.maxOrder = static_cast<int>(sp.integer("max_order", o.maxOrder, Range::closed(0, 1000)));

    o.branchAngle = sp.number("branch_angle_deg", o.branchAngle / kDeg, open(0, 180)) * kDeg;
    // Asked even when absent (it defaults to `branch_angle_deg`), as branchlet_tropism below.
    const bool ownBranchletAngle = sp.has("branchlet_angle_deg");
    const double branchletAngle =
        sp.number("branchlet_angle_deg", o.branchAngle / kDeg, open(0, 180)) * kDeg;
    if (ownBranchletAngle) o.branchletAngle = branchletAngle;
    o.phyllotaxis =
        sp.number("phyllotaxis_deg", o.phyllotaxis / kDeg, Range::closed(-360, 360)) * kDeg;
    o.tropism = sp.vec3("tropism", o.tropism);
    // Asked even when absent (it defaults to `tropism`), so a misspelling gets its suggestion.
    const bool ownBranchletTropism = sp.has("branchlet_tropism");
    const Vec3 branchletTropism = sp.vec3("branchlet_tropism", o.tropism);
    if (ownBranchletTropism) o.branchletTropism = branchletTropism;
    o.budDirectionWeight =
        sp.number("bud_direction_weight", o.budDirectionWeight, Range::nonNegative());
    o.trunkLength = sp.number("trunk_length", o.trunkLength, Range::nonNegative());
    o.pipeExponent = sp.number("pipe_exponent", o.pipeExponent, Range::closed(1.5, 3.5));
    o.tipRadius = sp.number("tip_radius", o.tipRadius, Range::positive());
    o.maxIterations =
        static_cast<int>(sp.integer("max_iterations", o.maxIterations, Range::closed(1, 1e6)));
    o.maxInternodes =
        static_cast<int>(sp.integer("max_internodes", o.maxInternodes, Range::closed(1, 5e7)));

    if (auto g = sp.optionalTable("guides")) {
        Rng rng = g->randomStream("markers");
        o.guides = parseGuides(*g, rng);
    }

    // Growth starts at the bole top: with nothing to perceive there (no crown and no guide
    // within r), the tree would stay a bare pole — a spec error, reported here. The crown's
    // signed distance never overstates, so this never rejects a crown that is in reach.
    const double reach = o.perception * o.internode;
    const int bole = static_cast<int>(
        std::min<double>(o.maxInternodes, std::floor(o.trunkLength / o.internode + 1e-9)));
    const Vec3 top{0, bole * o.internode, 0};
    const bool guideNear = std::any_of(o.guides.begin(), o.guides.end(), [&](const GuideMarker& g) {
        return distance(g.position, top) < reach;
    });
    if (o.crown && !guideNear) {
        const double d = o.crown->signedDistance(top);
        if (d >= reach) {
            const std::string msg = "growth starts at the bole top (0, " + num(top.y) + ", 0), " +
                                    num(d) + " m from the crown, beyond the " + num(reach) +
                                    " m buds perceive (perception × internode): "
                                    "lengthen the bole or lower the crown";
            if (sp.has("trunk_length")) sp.fail("trunk_length", msg);
            crownTable->failHere(msg);
        }
    }
    // Sizes every tree certainly reaches (core/budget.h): the baseline's markers are all
    // drawn before growth starts, the bole grows before any bud competes.
    SizeEstimate sizes;
    const double guides = static_cast<double>(o.guides.size());
    if (!improved) {
        sizes.add(BudgetKind::kGraphNodes, o.markers + guides, sp.where("markers"),
                  sp.path("markers"),
                  "the crown's markers" + std::string(guides > 0 ? " and the guides'" : "") +
                      " alone are " + formatSize(o.markers + guides));
    } else if (guides > 0) {
        sizes.add(BudgetKind::kGraphNodes, guides, sp.where("guides"), sp.path("guides"),
                  "the guides alone are " + formatSize(guides) + " markers");
    }
    sizes.add(BudgetKind::kSkeletonNodes, 1.0 + bole, sp.where("trunk_length"),
              sp.path("trunk_length"),
              "the bole alone is " + formatSize(1.0 + bole) +
                  " skeleton nodes (trunk_length ÷ "
                  "internode, at most max_internodes)");
    auto method = std::make_unique<SpaceColonizationMethod>(std::move(o));
    method->sizes = std::move(sizes);
    return method;
}

}  // namespace sylva
