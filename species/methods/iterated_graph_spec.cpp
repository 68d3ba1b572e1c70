// Species-file parameters of the `iterated-graph` method → IteratedGraphOptions.
//
// | key                          | type      | default       | meaning |
// |------------------------------|-----------|---------------|------------------------------------------|
// | crown                        | volume    | required      | level-0 graph volume (§3.3.1) | |
// endpoints                    | volume    | crown         | level-0 endpoint region | |
// graph.linking                | string    | "distance"    | "distance" (d) or "yao" (Yao graph) |
// | graph.link_factor            | number    | 1.8           | link distance / node spacing | |
// graph.yao_sectors            | 6 or 8    | 8             | Yao sectors (cube faces or octants) |
// | graph.spacing_factor         | number    | 0.7           | spacing = f·(V/K)^(1/3) if none
// given    | | graph.edge_weight            | [a, b]    | [0.5, 1.5]    | per-edge weight: uniform
// [a,b] / [μ,σ]   | | graph.edge_weight_kind       | string    | "uniform"     | "uniform" or
// "normal"                    | | graph.length_exponent        | number    | 1.0           | cost =
// weight · length^e                 | | graph.subgraph_radius        | metres    | 1.0           |
// r: sub-graph sphere radius at level 1    | | graph.shrink                 | number    | 0.7 | a:
// radius ratio between levels (§3.3.2)  | | lifespan.rule                | string    | "fixed" |
// "fixed" (L−1) or "stochastic" (§3.3.3)   | | lifespan.terminate_probability | [0,1]   | 0.3 |
// stochastic: chance a branch ends         | | lifespan.initial             | number    | levels −
// 1    | lifespan of level-0 endpoints            | | thickness.zeta               | number    |
// 0.3           | ζ in w = (d')^ζ/(i+1)                    | | thickness.scale              |
// metres    | 0.05          | w multiplier                             | | light.direction |
// [x,y,z]   | (absent=off)  | towards the light (journal version)      | | light.spread / endpoints
// / lifespan | …  | 0.5/true/true | range half-width, what light steers      | | levels[i].nodes |
// integer   | required      | K (level 0) / k (sub-graphs)             | | levels[i].spacing |
// metres    | derived       | Poisson-disc minimum distance            | | levels[i].endpoints |
// integer   | required      | b, endpoints per graph                   | | levels[i].endpoint_shell
// | metres    | 0 (anywhere)  | d_e, endpoint shell thickness            | | levels[i].shape |
// string    | "sector"      | "sector" or "cone" (apex at endpoint)    | | levels[i].alpha_deg |
// degrees   | 54 (0.3π)     | α, sub-graph sector half-angle           | | levels[i].radius |
// metres    | r·a^(i−1)     | sub-graph sphere radius override         | | levels[i].gamma_deg |
// degrees   | 0             | γ, rotation of v_g (+ down, − up)        | | levels[i].orientation |
// string    | "parent"      | "parent","up","down","random","fixed"    | | levels[i].direction |
// [x,y,z]   | [0,1,0]       | v_g for orientation = "fixed"            | |
// levels[i].from_all_levels    | bool      | false         | sub-graphs at endpoints of all levels
// | | roots.volume                 | volume    | hemisphere ↓  | below-ground graph volume (Figure
// 15)    | | roots.taproot_depth          | metres    | 2.0           | depth of the taproot
// endpoint            | | roots.lateral_distance       | metres    | 0.5           | lateral
// endpoints near the taproot       | | roots.subgraph_radius/shrink | …         | 0.5 / 0.7     |
// as graph.*, for root sub-graphs          | | roots.levels[i]              | as levels | required
// | level 0: nodes, lateral endpoints        |
#include <cmath>
#include <cstdio>

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

std::vector<IteratedGraphLevel> parseLevels(Params& owner, const char* key,
                                            std::vector<Params>* tables = nullptr) {
    std::vector<Params> ls = owner.tableArray(key);
    if (ls.empty()) owner.fail(key, "expected at least one [[" + std::string(key) + "]] table");
    std::vector<IteratedGraphLevel> levels;
    for (size_t i = 0; i < ls.size(); ++i) {
        Params& p = ls[i];
        IteratedGraphLevel l;
        l.nodes = static_cast<int>(p.integer("nodes", Range::closed(1, 5e6)));
        l.spacing = p.number("spacing", 0.0, Range::nonNegative());
        l.endpoints = static_cast<int>(p.integer("endpoints", Range::closed(0, 1e6)));
        l.endpointShell = p.number("endpoint_shell", 0.0, Range::nonNegative());
        if (i == 0) {
            for (const char* k : {"alpha_deg", "radius", "gamma_deg", "orientation", "direction",
                                  "from_all_levels", "shape"}) {
                if (p.has(k)) {
                    p.raw(k);
                    p.fail(k, "applies to sub-graph levels only (levels[1] and later)");
                }
            }
        } else {
            std::string shape = p.choice("shape", "sector", {"sector", "cone"});
            l.shape = shape == "cone" ? SubgraphShape::kCone : SubgraphShape::kSector;
            l.alpha = p.number("alpha_deg", 54.0, Range::leftOpen(0, 180)) * kDeg;
            if (l.shape == SubgraphShape::kCone && l.alpha >= 85 * kDeg) {
                p.fail("alpha_deg", "a cone sub-graph needs alpha_deg < 85");
            }
            l.radius = p.number("radius", 0.0, Range::nonNegative());
            l.gamma = p.number("gamma_deg", 0.0, Range::closed(-180, 180)) * kDeg;
            std::string o =
                p.choice("orientation", "parent", {"parent", "up", "down", "random", "fixed"});
            l.orientation = o == "up"       ? Orientation::kUp
                            : o == "down"   ? Orientation::kDown
                            : o == "random" ? Orientation::kRandom
                            : o == "fixed"  ? Orientation::kFixed
                                            : Orientation::kParent;
            l.direction = p.vec3("direction", {0, 1, 0});
            if (l.orientation == Orientation::kFixed && length(l.direction) < 1e-12) {
                p.fail("direction", "expected a non-zero direction");
            }
            l.fromAllLevels = p.boolean("from_all_levels", false);
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
    Tree grow(Rng& rng, bool threaded, std::map<std::string, double>& stats) const override {
        IteratedGraphStats s;
        Tree t = growIteratedGraph(o_, rng, threaded, &s);
        stats["graph_nodes"] = static_cast<double>(s.graphNodes);
        stats["graph_endpoints"] = static_cast<double>(s.graphEndpoints);
        stats["graphs"] = static_cast<double>(s.graphs);
        stats["bridging_edges"] = static_cast<double>(s.bridgingEdges);
        return t;
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
        std::string linking = g->choice("linking", "distance", {"distance", "yao"});
        o.linking = linking == "yao" ? Linking::kYao : Linking::kDistance;
        o.linkFactor = g->number("link_factor", 1.8, Range::closed(1.0, 10.0));
        o.yaoSectors = static_cast<int>(g->integer("yao_sectors", 8, Range::closed(6, 8)));
        if (o.yaoSectors != 6 && o.yaoSectors != 8) {
            g->fail("yao_sectors",
                    "expected 6 (cube faces) or 8 (octants), got " + std::to_string(o.yaoSectors));
        }
        o.spacingFactor = g->number("spacing_factor", 0.7, Range::leftOpen(0, 0.88));
        std::string kind = g->choice("edge_weight_kind", "uniform", {"uniform", "normal"});
        o.edgeWeightKind = kind == "normal" ? EdgeWeightKind::kNormal : EdgeWeightKind::kUniform;
        auto [a, b] = g->interval("edge_weight", {0.5, 1.5},
                                  kind == "normal" ? Range::nonNegative() : Range::positive());
        o.edgeWeightA = a;
        o.edgeWeightB = b;
        o.lengthExponent = g->number("length_exponent", 1.0, Range::closed(0, 4));
        o.crown.subgraphRadius = g->number("subgraph_radius", 1.0, Range::positive());
        o.crown.shrink = g->number("shrink", 0.7, Range::leftOpen(0, 2));
        g->finish();
    }
    if (auto l = sp.optionalTable("lifespan")) {
        std::string rule = l->choice("rule", "fixed", {"fixed", "stochastic"});
        o.lifespan = rule == "stochastic" ? LifespanRule::kStochastic : LifespanRule::kFixed;
        o.terminateProbability = l->number("terminate_probability", 0.3, Range::closed(0, 1));
        o.initialLifespan = l->number("initial", -1.0, Range::atLeast(0));
        l->finish();
    }
    if (auto t = sp.optionalTable("thickness")) {
        o.zeta = t->number("zeta", 0.3, Range::closed(0, 3));
        o.thicknessScale = t->number("scale", 0.05, Range::positive());
        t->finish();
    }
    if (auto l = sp.optionalTable("light")) {
        o.light.enabled = true;
        o.light.direction = l->vec3("direction", {0, 1, 0});
        if (length(o.light.direction) < 1e-12) l->fail("direction", "expected a non-zero vector");
        o.light.direction = normalize(o.light.direction);
        o.light.spread = l->number("spread", 0.5, Range::closed(0, 1));
        o.light.endpoints = l->boolean("endpoints", true);
        o.light.lifespan = l->boolean("lifespan", true);
        l->finish();
    }
    std::vector<Params> levelTables;
    o.crown.levels = parseLevels(sp, "levels", &levelTables);
    checkCapacity(levelTables, o.crown);

    if (auto r = sp.optionalTable("roots")) {
        o.roots.enabled = true;
        o.roots.taprootDepth = r->number("taproot_depth", 2.0, Range::positive());
        o.roots.lateralDistance = r->number("lateral_distance", 0.5, Range::positive());
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
        o.roots.system.subgraphRadius = r->number("subgraph_radius", 0.5, Range::positive());
        o.roots.system.shrink = r->number("shrink", 0.7, Range::leftOpen(0, 2));
        std::vector<Params> rootTables;
        o.roots.system.levels = parseLevels(*r, "levels", &rootTables);
        checkCapacity(rootTables, o.roots.system);
        r->finish();
    }
    return std::make_unique<IteratedGraphMethod>(std::move(o));
}

}  // namespace sylva
