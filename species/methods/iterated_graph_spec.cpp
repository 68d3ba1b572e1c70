// Species-file keys of the `iterated-graph` method → IteratedGraphOptions. Every default is
// the options struct's (iterated_graph.h); keys, units and ranges are documented in
// docs/methods/iterated-graph.md, which tests/project/spec_keys_test.cpp checks against this
// reader. Levels are numbered by their index in [[levels]]: levels[0] is the initial graph.
#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>

#include "species/methods/iterated_graph.h"
#include "species/spec/growth_method.h"
#include "species/spec/volume_spec.h"
#include "volumes/poisson.h"

namespace sylva {

namespace {

constexpr double kDeg = kPi / 180.0;

// Explicit spacings must leave room for the level's nodes: report it here, with the key's
// place, rather than as a failed tree in the middle of a build.
void checkCapacity(std::vector<Params>& ls, const GraphSystem& sys) {
    const std::vector<double> radius = subgraphRadii(sys);
    for (size_t i = 0; i < sys.levels.size(); ++i) {
        const IteratedGraphLevel& l = sys.levels[i];
        if (l.spacing <= 0) continue;
        const double v = i == 0 ? sys.volume->measure() : subgraphVolume(l, radius[i])->measure();
        const double capacity = poissonCapacity(v, l.spacing);
        if (l.nodes > capacity) {
            char buf[200];
            std::snprintf(buf, sizeof buf,
                          "%d nodes do not fit at spacing %g m in this level's volume (≈ %.3g m³, "
                          "capacity ≈ %.0f): lower nodes or spacing",
                          l.nodes, l.spacing, v, capacity);
            ls[i].fail("nodes", buf);
        }
    }
}

// Lower bounds of a system's sizes (core/budget.h), level by level, as growSystem builds it:
// level 0 is one graph; the graphs of level k + 1 hang from the endpoints (of level k, or of
// every level before with from_all_levels) whose lifespan is surely still ≥ 1. Counts are the
// least the rules allow: the light's smallest branching factor, its largest decrement, and no
// sub-graph beyond level 1 under the stochastic rule (any endpoint may terminate). A graph asks
// for K nodes and b endpoints (graph nodes), and every endpoint is a skeleton node of its own.
// Each level adds the bounds reached with it, so the first one over a budget names the level
// where the tree certainly outgrows it.
void estimateSystem(const IteratedGraphOptions& o, const GraphSystem& sys,
                    std::vector<Params>& tables, bool roots, double skeletonBefore,
                    SizeEstimate& sizes, double& skeletonAfter) {
    const int levels = static_cast<int>(sys.levels.size());
    const double initial =
        o.initialLifespan >= 0 ? o.initialLifespan : static_cast<double>(levels - 1);
    const double s = o.light.enabled ? o.light.spread : 0.0;
    const double maxDecrement = o.light.enabled && o.light.lifespan ? 1.0 + s : 1.0;
    const bool stochastic = o.lifespan == LifespanRule::kStochastic;
    auto leastEndpoints = [&](const IteratedGraphLevel& l, int k) {
        if (k > 0 && o.light.enabled && o.light.endpoints) {
            return static_cast<double>(std::max(0L, std::lround(l.endpoints * (1 - s))));
        }
        return static_cast<double>(l.endpoints);
    };
    std::map<double, double> all, last;  // endpoints by their least lifespan
    double graphNodes = 0.0, skeleton = skeletonBefore;
    for (int k = 0; k < levels; ++k) {
        const IteratedGraphLevel& l = sys.levels[k];
        double jobs = 0.0;
        std::map<double, double> made;
        if (k == 0) {
            jobs = 1.0;
            made[initial] = leastEndpoints(l, 0) + (roots ? 1.0 : 0.0);  // + the taproot
        } else {
            for (const auto& [life, count] : l.fromAllLevels ? all : last) {
                if (!(life >= 1.0 - 1e-9) || count <= 0) continue;
                jobs += count;
                const double left = stochastic ? 0.0 : life - maxDecrement;
                made[left] += count * leastEndpoints(l, k);
            }
        }
        if (jobs <= 0) break;
        double endpoints = 0.0;
        for (const auto& [life, count] : made) {
            endpoints += count;
            all[life] += count;
        }
        last = std::move(made);
        graphNodes = std::min(1e300, graphNodes + jobs * (l.nodes + leastEndpoints(l, k)));
        skeleton = std::min(1e300, skeleton + endpoints);
        Params& t = tables[k];
        const std::string many =
            k == 0 ? ""
                   : " (" + formatSize(jobs) +
                         " graphs at this level, from the endpoints of the levels before)";
        sizes.add(
            BudgetKind::kGraphNodes, graphNodes, t.where("nodes"), t.path("nodes"),
            (k == 0 ? "this level alone makes ≈ " : "the levels up to this one make at least ≈ ") +
                formatSize(graphNodes) + " graph nodes and endpoints" + many);
        sizes.add(
            BudgetKind::kSkeletonNodes, skeleton, t.where("endpoints"), t.path("endpoints"),
            (k == 0 ? "this level alone makes ≈ " : "the levels up to this one make at least ≈ ") +
                formatSize(skeleton) + " endpoints, each a skeleton node" + many);
    }
    skeletonAfter = skeleton;
}

std::vector<IteratedGraphLevel> parseLevels(Params& owner, const char* key,
                                            std::vector<Params>* tables = nullptr) {
    std::vector<Params> ls = owner.tableArray(key);
    if (ls.empty()) owner.fail(key, "expected at least one [[" + std::string(key) + "]] table");
    std::vector<IteratedGraphLevel> levels;
    for (size_t i = 0; i < ls.size(); ++i) {
        Params& p = ls[i];
        IteratedGraphLevel l;
        l.nodes = static_cast<int>(p.integer("nodes", Range::closed(1, 5e6)));
        l.spacing = p.number("spacing", l.spacing, Range::nonNegative());
        l.endpoints = static_cast<int>(p.integer("endpoints", Range::closed(0, 1e6)));
        l.endpointShell = p.number("endpoint_shell", l.endpointShell, Range::nonNegative());
        if (i == 0) {
            for (const char* k : {"alpha_deg", "radius", "gamma_deg", "orientation", "direction",
                                  "from_all_levels", "shape"}) {
                if (p.has(k)) {
                    p.raw(k);
                    p.fail(k, "applies to sub-graph levels only (levels[1] and later)");
                }
            }
        } else {
            l.shape =
                p.choice("shape", l.shape,
                         {{"sector", SubgraphShape::kSector}, {"cone", SubgraphShape::kCone}});
            l.alpha = p.degrees("alpha_deg", l.alpha, Range::leftOpen(0, 180));
            if (l.shape == SubgraphShape::kCone && l.alpha >= 85 * kDeg) {
                p.fail("alpha_deg", "a cone sub-graph needs alpha_deg < 85");
            }
            l.radius = p.number("radius", l.radius, Range::nonNegative());
            l.gamma = p.degrees("gamma_deg", l.gamma, Range::closed(-180, 180));
            l.orientation = p.choice("orientation", l.orientation,
                                     {{"parent", Orientation::kParent},
                                      {"up", Orientation::kUp},
                                      {"down", Orientation::kDown},
                                      {"random", Orientation::kRandom},
                                      {"fixed", Orientation::kFixed}});
            l.direction = p.vec3("direction", l.direction);
            if (l.orientation == Orientation::kFixed && length(l.direction) < 1e-12) {
                p.fail("direction", "expected a non-zero direction");
            }
            l.fromAllLevels = p.boolean("from_all_levels", l.fromAllLevels);
        }
        if (l.endpoints == 0 && i == 0) p.fail("endpoints", "level 0 needs at least one endpoint");
        p.finish();
        levels.push_back(l);
    }
    if (tables) *tables = ls;
    return levels;
}

class IteratedGraphMethod : public GrowthMethod {
  public:
    explicit IteratedGraphMethod(IteratedGraphOptions o) : o_(std::move(o)) {}
    Tree grow(Rng& rng, bool threaded, std::map<std::string, double>& stats,
              const GrowthGuard& guard) const override {
        IteratedGraphStats s;
        Tree t = growIteratedGraph(o_, rng, threaded, &s, guard);
        stats["graph_nodes"] = static_cast<double>(s.graphNodes);
        stats["graph_endpoints"] = static_cast<double>(s.graphEndpoints);
        stats["graphs"] = static_cast<double>(s.graphs);
        stats["bridging_edges"] = static_cast<double>(s.bridgingEdges);
        if (o_.merge.distance > 0) stats["merged_nodes"] = static_cast<double>(s.mergedNodes);
        return t;
    }

    // Crown shyness: the crown's volumes (the graph's and the endpoints') clipped by the
    // half-spaces between this tree and its neighbours, and the grown tree cut at them.
    Tree growAmong(Rng& rng, bool threaded, std::map<std::string, double>& stats,
                   const GrowthGuard& guard, const Neighbourhood& neighbours) const override {
        if (neighbours.clip.empty()) return grow(rng, threaded, stats, guard);
        IteratedGraphOptions o = o_;
        o.crown.volume = makeClipped(o.crown.volume, neighbours.clip);
        if (o.crown.endpointVolume) {
            o.crown.endpointVolume = makeClipped(o.crown.endpointVolume, neighbours.clip);
        }
        // The sub-graphs grow from the level-0 endpoints beyond the crown volume: cut at the
        // planes too.
        Tree tree = IteratedGraphMethod(std::move(o)).grow(rng, threaded, stats, guard);
        pruneTree(tree, [&](const Vec3& p) { return insideAll(neighbours.clip, p); });
        return tree;
    }

    // "crown", then "endpoints" when [endpoints] is given, then "roots" when [roots] is.
    std::vector<std::pair<std::string, VolumePtr>> volumes() const override {
        std::vector<std::pair<std::string, VolumePtr>> v = {{"crown", o_.crown.volume}};
        if (o_.crown.endpointVolume) v.emplace_back("endpoints", o_.crown.endpointVolume);
        if (o_.roots.enabled) v.emplace_back("roots", o_.roots.system.volume);
        return v;
    }

  private:
    IteratedGraphOptions o_;
};

}  // namespace

std::unique_ptr<GrowthMethod> makeIteratedGraphMethod(Params& sp) {
    IteratedGraphOptions o;
    {
        Params crown = sp.table("crown");
        o.crown.volume = parseVolume(crown);
    }
    if (auto e = sp.optionalTable("endpoints")) o.crown.endpointVolume = parseVolume(*e);

    if (auto g = sp.optionalTable("graph")) {
        o.linking = g->choice("linking", o.linking,
                              {{"distance", Linking::kDistance}, {"yao", Linking::kYao}});
        o.linkFactor = g->number("link_factor", o.linkFactor, Range::closed(1.0, 10.0));
        o.yaoSectors =
            static_cast<int>(g->integer("yao_sectors", o.yaoSectors, Range::closed(6, 8)));
        if (o.yaoSectors != 6 && o.yaoSectors != 8) {
            g->fail("yao_sectors",
                    "expected 6 (cube faces) or 8 (octants), got " + std::to_string(o.yaoSectors));
        }
        o.spacingFactor = g->number("spacing_factor", o.spacingFactor, Range::leftOpen(0, 0.88));
        o.edgeWeightKind =
            g->choice("edge_weight_kind", o.edgeWeightKind,
                      {{"uniform", EdgeWeightKind::kUniform}, {"normal", EdgeWeightKind::kNormal}});
        std::tie(o.edgeWeightA, o.edgeWeightB) = g->interval(
            "edge_weight", {o.edgeWeightA, o.edgeWeightB},
            o.edgeWeightKind == EdgeWeightKind::kNormal ? Range::nonNegative() : Range::positive());
        o.lengthExponent = g->number("length_exponent", o.lengthExponent, Range::closed(0, 4));
        o.radialWeight = g->number("radial_weight", o.radialWeight, Range::closed(0, 100));
        o.crown.subgraphRadius =
            g->number("subgraph_radius", o.crown.subgraphRadius, Range::positive());
        o.crown.shrink = g->number("shrink", o.crown.shrink, Range::leftOpen(0, 2));
        g->finish();
    }
    if (auto l = sp.optionalTable("lifespan")) {
        o.lifespan =
            l->choice("rule", o.lifespan,
                      {{"fixed", LifespanRule::kFixed}, {"stochastic", LifespanRule::kStochastic}});
        o.terminateProbability =
            l->number("terminate_probability", o.terminateProbability, Range::closed(0, 1));
        o.initialLifespan = l->number("initial", o.initialLifespan, Range::atLeast(0));
        l->finish();
    }
    if (auto t = sp.optionalTable("thickness")) {
        o.zeta = t->number("zeta", o.zeta, Range::closed(0, 3));
        o.thicknessScale = t->number("scale", o.thicknessScale, Range::positive());
        t->finish();
    }
    if (auto l = sp.optionalTable("light")) {
        o.light.enabled = true;
        o.light.direction = l->vec3("direction", o.light.direction);
        if (length(o.light.direction) < 1e-12) l->fail("direction", "expected a non-zero vector");
        o.light.direction = normalize(o.light.direction);
        o.light.spread = l->number("spread", o.light.spread, Range::closed(0, 1));
        o.light.endpoints = l->boolean("endpoints", o.light.endpoints);
        o.light.lifespan = l->boolean("lifespan", o.light.lifespan);
        l->finish();
    }
    SizeEstimate sizes;
    std::optional<Params> trunkTable = sp.optionalTable("trunk");
    if (trunkTable) {
        o.trunk.height = trunkTable->number("height", o.trunk.height, Range::nonNegative());
        trunkTable->finish();
    }
    if (auto m = sp.optionalTable("merge")) {
        o.merge.distance = m->number("distance", o.merge.distance, Range::nonNegative());
        o.merge.shrink = m->number("shrink", o.merge.shrink, Range::leftOpen(0, 1));
        o.merge.maxAngle = m->degrees("max_angle_deg", o.merge.maxAngle, Range::closed(0, 90));
        m->finish();
    }
    if (auto m = sp.optionalTable("smoothing")) {
        o.smoothing.iterations = static_cast<int>(
            m->integer("iterations", o.smoothing.iterations, Range::closed(0, 10000)));
        m->finish();
    }
    std::vector<Params> levelTables;
    o.crown.levels = parseLevels(sp, "levels", &levelTables);
    checkCapacity(levelTables, o.crown);
    double skeleton = 1.0;  // the root
    if (o.trunk.height > 0) {
        // The bole: a node about every level-0 spacing (growSystem).
        const IteratedGraphLevel& l0 = o.crown.levels[0];
        const double spacing =
            l0.spacing > 0
                ? l0.spacing
                : o.spacingFactor * std::cbrt(o.crown.volume->measure() / std::max(1, l0.nodes));
        skeleton += std::max(1.0, std::ceil(o.trunk.height / spacing - 1e-9));
        sizes.add(BudgetKind::kSkeletonNodes, skeleton, trunkTable->where("height"),
                  trunkTable->path("height"),
                  "the bole alone is ≈ " + formatSize(skeleton) + " skeleton nodes (one every " +
                      formatNumber(spacing, 3) + " m, the level-0 spacing)");
    }
    estimateSystem(o, o.crown, levelTables, false, skeleton, sizes, skeleton);

    if (auto r = sp.optionalTable("roots")) {
        o.roots.enabled = true;
        o.roots.taprootDepth = r->number("taproot_depth", o.roots.taprootDepth, Range::positive());
        o.roots.lateralDistance =
            r->number("lateral_distance", o.roots.lateralDistance, Range::positive());
        if (auto v = r->optionalTable("volume")) {
            o.roots.system.volume = parseVolume(*v);
        } else {
            // Default: a hemisphere hanging below the ground (Figure 15).
            o.roots.system.volume = makePlaced(makeHemisphere(o.roots.taprootDepth * 1.1),
                                               Placement{{0, 0, 0}, {0, -1, 0}, {1, 1, 1}});
        }
        if (!o.roots.system.volume->inside({0, -o.roots.taprootDepth, 0})) {
            r->fail("taproot_depth", "the taproot endpoint (0, -" +
                                         std::to_string(o.roots.taprootDepth) +
                                         ", 0) lies outside roots.volume");
        }
        o.roots.system.subgraphRadius =
            r->number("subgraph_radius", o.roots.system.subgraphRadius, Range::positive());
        o.roots.system.shrink = r->number("shrink", o.roots.system.shrink, Range::leftOpen(0, 2));
        std::vector<Params> rootTables;
        o.roots.system.levels = parseLevels(*r, "levels", &rootTables);
        checkCapacity(rootTables, o.roots.system);
        r->finish();
        estimateSystem(o, o.roots.system, rootTables, true, skeleton, sizes, skeleton);
    }
    auto method = std::make_unique<IteratedGraphMethod>(std::move(o));
    method->sizes = std::move(sizes);
    return method;
}

}  // namespace sylva
