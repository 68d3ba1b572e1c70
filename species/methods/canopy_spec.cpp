// Species-file parameters of the `canopy` method (Shesh et al. §3) → CanopyOptions.
//
// Keys, units, defaults and ranges: docs/methods/canopy.md (tests/project/spec_keys_test.cpp checks
// them against this reader); every default is CanopyOptions' and its members'.
#include <cmath>
#include <memory>
#include <string>
#include <utility>

#include "species/methods/canopy.h"
#include "species/model/leaf_shape.h"
#include "species/spec/growth_method.h"
#include "species/spec/leaves_spec.h"
#include "species/spec/volume_spec_canopy_envelope.h"

namespace sylva {

namespace {

constexpr double kMaxSegments = 200000;  // template budget (F symbols after expansion)
constexpr double kMaxWord = 4.0e6;       // template word length budget

std::string num(double v) { return formatNumber(v, 4); }

class CanopyMethod : public GrowthMethod {
  public:
    explicit CanopyMethod(CanopyOptions o)
        : o_(std::move(o)), sampler_(std::make_shared<CanopySurfaceSampler>(*o_.envelope)) {}

    Tree grow(Rng& rng, bool, std::map<std::string, double>& stats,
              const GrowthGuard& guard) const override {
        return growWith(o_, rng, stats, guard);
    }

    // Crown shyness: branches and leaves kept inside the half-spaces between this tree and
    // its neighbours (CanopyOptions::clip).
    Tree growAmong(Rng& rng, bool, std::map<std::string, double>& stats, const GrowthGuard& guard,
                   const Neighbourhood& neighbours) const override {
        if (neighbours.clip.empty()) return growWith(o_, rng, stats, guard);
        CanopyOptions o = o_;
        o.clip = neighbours.clip;
        return growWith(o, rng, stats, guard);
    }

    bool placesOwnLeaves() const override { return true; }

    std::vector<std::pair<std::string, VolumePtr>> volumes() const override {
        return {{"canopy", makePlaced(o_.envelope, Placement{o_.position, {0, 1, 0}, {1, 1, 1}})}};
    }

  private:
    Tree growWith(const CanopyOptions& o, Rng& rng, std::map<std::string, double>& stats,
                  const GrowthGuard& guard) const {
        CanopyStats s;
        Tree t = growCanopy(o, rng, &s, sampler_.get(), guard);
        stats["template"] = s.templateIndex;
        stats["template_segments"] = static_cast<double>(s.templateSegments);
        stats["kept_segments"] = static_cast<double>(s.keptSegments);
        stats["template_scale_y"] = s.scaleY;
        stats["template_scale_xz"] = s.scaleXZ;
        stats["trunk_height"] = s.trunkHeight;
        stats["unsupported_leaves"] = static_cast<double>(s.unsupportedLeaves);
        stats["unsupported_leaf_fraction"] = s.unsupportedLeafFraction;
        if (o.support.mode != LeafSupport::kNone) {
            stats["twig_nodes"] = static_cast<double>(s.twigNodes);
            stats["dropped_leaves"] = static_cast<double>(s.droppedLeaves);
        }
        return t;
    }

    CanopyOptions o_;
    std::shared_ptr<const CanopySurfaceSampler> sampler_;
};

void checkWord(Params& p, std::string_view key, const std::string& word) {
    const std::string problem = checkLSystemWord(word);
    if (!problem.empty()) p.fail(key, problem);
}

LSystem parseLSystem(Params& t) {
    LSystem ls;
    ls.axiom = t.string("axiom");
    checkWord(t, "axiom", ls.axiom);
    if (ls.axiom.find_first_not_of(" \t\r\n") == std::string::npos) {
        t.fail("axiom", "expected a non-empty word");
    }
    const toml::node* node = t.raw("rules");
    if (!node) return ls;
    const toml::table* table = node->as_table();
    if (!table) t.fail("rules", "expected a table of rules, e.g. { F = \"F[+F]F[-F]F\" }");
    Params r = t.table("rules");
    r.keysAreUserNames();  // the letters A-Z
    for (const auto& [k, v] : *table) {
        const std::string key(k.str());
        if (key.size() != 1 || key[0] < 'A' || key[0] > 'Z') {
            r.raw(key);
            r.fail(key, "a rule rewrites one letter A-Z, got \"" + key + "\"");
        }
        std::vector<LSystemSuccessor>& successors = ls.rules[key[0]];
        if (v.is_string()) {
            successors.push_back({r.string(key), 1.0});
            checkWord(r, key, successors.back().text);
        } else if (v.is_array()) {
            std::vector<Params> options = r.tableArray(key);
            if (options.empty()) r.fail(key, "expected at least one { to = \"…\", p = … }");
            double sum = 0.0;
            for (Params& o : options) {
                LSystemSuccessor s;
                s.text = o.string("to");
                checkWord(o, "to", s.text);
                s.probability = o.number("p", Range::closed(0, 1));
                sum += s.probability;
                o.finish();
                successors.push_back(s);
            }
            if (std::abs(sum - 1.0) > 1e-6) {
                r.fail(key, "the probabilities p sum to " + num(sum) + ", expected 1");
            }
        } else {
            r.raw(key);
            r.fail(key, "expected a word, or an array of { to = \"word\", p = probability }");
        }
    }
    r.finish();
    return ls;
}

BranchTemplate parseTemplate(Params& t) {
    BranchTemplate b;
    b.lsystem = parseLSystem(t);
    b.iterations = static_cast<int>(t.integer("iterations", Range::closed(0, 12)));
    const LSystemSize size = lsystemSizeBound(b.lsystem, b.iterations);
    if (size.segments > kMaxSegments || size.length > kMaxWord) {
        t.fail("iterations",
               "after " + std::to_string(b.iterations) + " iterations the template has up to " +
                   num(size.segments) + " segments and " + num(size.length) + " symbols (at most " +
                   num(kMaxSegments) + " and " + num(kMaxWord) + "): lower iterations");
    }
    if (size.segments < 1) {
        t.fail("iterations", "the template draws nothing: no F after " +
                                 std::to_string(b.iterations) + " iterations");
    }
    b.angle = t.degrees("angle_deg", b.angle, Range::closed(0, 180));
    b.roll = t.degrees("roll_deg", b.angle, Range::closed(0, 360));  // default: the same δ
    b.step = t.number("step", b.step, Range::positive());
    b.lengthRatio = t.number("length_ratio", b.lengthRatio, Range::leftOpen(0, 2));
    b.angleJitter = t.degrees("angle_jitter_deg", b.angleJitter, Range::closed(0, 90));
    b.weight = t.number("weight", b.weight, Range::positive());
    t.finish();
    return b;
}

// leaves.colours: an array of fractions summing to 1.
std::vector<double> parseFractions(Params& l, std::string_view key) {
    const toml::node* n = l.raw(key);
    if (!n) return {1.0};
    const toml::array* a = n->as_array();
    const std::string expected =
        "expected an array of fractions in [0, 1] summing to 1, e.g. "
        "[0.6, 0.4]";
    if (!a || a->empty() || a->size() > 254) l.fail(key, expected);
    std::vector<double> out;
    double sum = 0.0;
    for (size_t i = 0; i < a->size(); ++i) {
        const auto v = a->get(i)->value<double>();
        if (!a->get(i)->is_number() || !v || !(*v >= 0.0 && *v <= 1.0)) l.fail(key, expected);
        out.push_back(*v);
        sum += *v;
    }
    if (std::abs(sum - 1.0) > 1e-6)
        l.fail(key, "the fractions sum to " + num(sum) + ", expected 1");
    return out;
}

}  // namespace

std::unique_ptr<GrowthMethod> makeCanopyMethod(Params& sp) {
    CanopyOptions o;
    {
        Params c = sp.table("canopy");
        o.envelope = parseCanopyEnvelope(c);
        if (!c.has("position")) {
            c.raw("position");
            c.fail("position",
                   "required key missing (expected [x, y, z], metres: the canopy's "
                   "centre, or its base centre for a cone)");
        }
        o.position = c.vec3("position", o.position);
        c.finish();
    }

    if (auto br = sp.optionalTable("branches")) {
        CanopyBranchOptions& bo = o.branches;
        bo.trunkHeight =
            br->has("trunk_height") ? br->number("trunk_height", Range::positive()) : -1.0;
        bo.outgrow = br->number("outgrow", bo.outgrow, Range::closed(1, 10));
        bo.fit = br->choice("fit", bo.fit,
                            {{"stretch", TemplateFit::kStretch},
                             {"uniform", TemplateFit::kUniform},
                             {"none", TemplateFit::kNone}});
        bo.clipThreshold = br->number("clip_threshold", bo.clipThreshold, Range::closed(0, 10));
        bo.tipRadius = br->number("tip_radius", bo.tipRadius, Range::positive());
        bo.murrayExponent = br->number("murray_exponent", bo.murrayExponent, Range::closed(1.5, 4));
        bo.murrayOn =
            br->choice("radii", bo.murrayOn,
                       {{"clipped", MurrayOn::kClipped}, {"template", MurrayOn::kTemplate}});
        bo.randomYaw = br->boolean("random_yaw", bo.randomYaw);
        bo.leafMargin = br->number("leaf_margin", bo.leafMargin, Range::nonNegative());
        bo.cutAtSurface = br->boolean("cut_at_surface", bo.cutAtSurface);
        // The trunk top must be inside the canopy, or every crown segment would be cut.
        const double top = canopyTrunkHeight(o);
        const Vec3 local = Vec3{o.position.x, top, o.position.z} - o.position;
        if (bo.trunkHeight >= 0.0 && envelopeRatio(*o.envelope, local) > 1.0 + bo.clipThreshold) {
            br->fail("trunk_height", "the trunk top (" + num(o.position.x) + ", " + num(top) +
                                         ", " + num(o.position.z) +
                                         ") lies outside the canopy, so every branch would be "
                                         "clipped; put it inside the envelope");
        }
        br->finish();
    }
    if (canopyTrunkHeight(o) <= 0.0) {
        sp.fail("canopy", "the trunk top (the canopy's lowest point on its axis) is at " +
                              num(canopyTrunkHeight(o)) +
                              " m: raise canopy.position above the ground");
    }

    if (auto su = sp.optionalTable("support")) {
        CanopySupportOptions& so = o.support;
        so.mode = su->choice("mode", so.mode,
                             {{"none", LeafSupport::kNone}, {"twigs", LeafSupport::kTwigs}});
        so.reach = su->number("reach", so.reach, Range::positive());
        so.length = su->number("length", so.length, Range::positive());
        so.step = su->number("step", so.step, Range::positive());
        so.attach = su->number("attach", so.attach, Range::positive());
        so.sproutSpacing = su->number("sprout_spacing", so.sproutSpacing, Range::positive());
        so.droop = su->number("droop", so.droop, Range::closed(0, 2));
        so.pruneBare = su->boolean("prune_bare", so.pruneBare);
        // Runions et al. 2007: a twig must not step past the marker it grows to (d_k ≥ D), and
        // a marker must attract the node that will reach it (d_k ≤ d_i).
        if (so.attach < so.step) {
            su->fail(su->has("attach") ? "attach" : "step",
                     "attach (" + num(so.attach) + " m) must be at least step (" + num(so.step) +
                         " m): a twig would step past its leaf");
        }
        if (so.attach > so.reach) {
            su->fail("attach", "attach (" + num(so.attach) + " m) must not exceed reach (" +
                                   num(so.reach) + " m)");
        }
        su->finish();
    }

    std::vector<Params> ts = sp.tableArray("templates");
    if (ts.empty()) sp.fail("templates", "expected at least one [[templates]] table");
    for (Params& t : ts) o.templates.push_back(parseTemplate(t));

    SizeEstimate sizes;
    if (auto l = sp.optionalTable("leaves")) {
        CanopyLeafOptions& lo = o.leaves;
        lo.count = static_cast<int>(l->integer("count", lo.count, Range::closed(0, 1e6)));
        lo.depth = l->number("depth", lo.depth, Range::closed(0, 1));
        lo.openBase = l->number("open_base", lo.openBase, Range::closed(0, 0.9));
        readLeafCards(*l, lo);
        lo.cluster = static_cast<int>(l->integer("cluster", lo.cluster, Range::closed(1, 20)));
        lo.twig = l->number("twig", lo.twig, Range::nonNegative());
        lo.colourFractions = parseFractions(*l, "colours");
        if (const toml::node* n = l->raw("colour_classes")) {
            const toml::array* a = n->as_array();
            const std::string expected =
                "expected one class (an integer 0–254) per entry of "
                "colours (" +
                std::to_string(lo.colourFractions.size()) + ")";
            if (!a || a->size() != lo.colourFractions.size()) l->fail("colour_classes", expected);
            for (size_t i = 0; i < a->size(); ++i) {
                const auto v = a->get(i)->value<int64_t>();
                if (!a->get(i)->is_integer() || !v || *v < 0 || *v > 254) {
                    l->fail("colour_classes", expected);
                }
                lo.colourClasses.push_back(static_cast<uint8_t>(*v));
            }
        }
        lo.colourPatchiness =
            l->number("colour_patchiness", lo.colourPatchiness, Range::closed(0, 1));
        lo.supportDistance = l->number("support_distance", lo.supportDistance, Range::positive());
        l->finish();
        // Every position gets its cluster (core/budget.h): count × cluster leaves are placed,
        // and without leaf support every one is meshed and drawn (both faces in the mesh).
        const double leaves = double(lo.count) * lo.cluster;
        if (leaves > 0) {
            sizes.add(BudgetKind::kLeaves, leaves, l->where("count"), l->path("count"),
                      "count × cluster = " + formatSize(leaves) + " leaves");
        }
        if (leaves > 0 && o.support.mode == LeafSupport::kNone) {
            const double triangles = 2.0 * leaves * leafOutline(lo.shape).triangleCount();
            sizes.add(BudgetKind::kTriangles, triangles, l->where("count"), l->path("count"),
                      "count × cluster = " + formatSize(leaves) + " leaves of " +
                          formatSize(2.0 * leafOutline(lo.shape).triangleCount()) +
                          " triangles each (both faces) make " + formatSize(triangles) +
                          " mesh triangles");
        }
    }
    auto method = std::make_unique<CanopyMethod>(std::move(o));
    method->sizes = std::move(sizes);
    return method;
}

}  // namespace sylva
