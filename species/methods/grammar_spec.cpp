// Species-file parameters of the `grammar` method → GrammarOptions. Every key, with its unit,
// default and range, is documented in docs/methods/grammar.md; the defaults are GrammarOptions'.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <set>
#include <tuple>

#include "species/methods/grammar.h"
#include "species/spec/growth_method.h"
#include "species/spec/leaves_spec.h"

namespace sylva {

namespace {

constexpr double kDeg = kPi / 180.0;

std::string fmt(double v) { return formatNumber(v, 9); }

// The key names of a table, in file order (toml++ keeps them sorted; good enough: we only
// need them for iteration, every check reports its own key's position).
std::vector<std::string> keysOf(Params& owner, std::string_view key) {
    std::vector<std::string> out;
    const toml::node* n = owner.raw(key);
    if (!n) return out;
    const toml::table* t = n->as_table();
    if (!t) owner.fail(key, "expected a table");
    for (const auto& [k, v] : *t) out.emplace_back(k.str());
    return out;
}

// A geometry table's keys, each optional: merged from the most specific table that sets it.
struct GeometryTable {
    std::optional<std::pair<double, double>> length, azimuth, tilt, roll, position, curve;
    std::optional<double> reduceLength, reduceWidthBegin, reduceWidthEnd, tropism;
    std::optional<Vec3> reduceAngle;
    std::optional<std::string> phyllotaxis;
    std::optional<int> controlPoints;
};

GeometryTable readGeometry(Params& p) {
    GeometryTable g;
    auto range = [&](const char* key, const Range& r, double scale) {
        std::optional<std::pair<double, double>> v;
        if (p.has(key)) {
            auto [lo, hi] = p.interval(key, {0, 0}, r);
            v = std::make_pair(lo * scale, hi * scale);
        }
        return v;
    };
    auto number = [&](const char* key, const Range& r) {
        std::optional<double> v;
        if (p.has(key)) v = p.number(key, r);
        return v;
    };
    g.length = range("length", Range::positive(), 1.0);
    g.azimuth = range("azimuth_deg", Range::closed(-720, 720), kDeg);
    g.tilt = range("tilt_deg", Range::closed(-180, 180), kDeg);
    g.roll = range("roll_deg", Range::closed(-360, 360), kDeg);
    g.position = range("position", Range::closed(0, 1), 1.0);
    g.curve = range("curve", Range::closed(0, 2), 1.0);
    g.reduceLength = number("reduce_length", Range::leftOpen(0, 2));
    g.reduceWidthBegin = number("reduce_width_begin", Range::leftOpen(0, 1));
    g.reduceWidthEnd = number("reduce_width_end", Range::leftOpen(0, 1));
    if (auto t = number("tropism_deg", Range::closed(-180, 180))) g.tropism = *t * kDeg;
    if (p.has("reduce_angle")) g.reduceAngle = p.vec3("reduce_angle", {1, 1, 1}, Range::positive());
    if (p.has("phyllotaxis"))
        g.phyllotaxis = p.choice("phyllotaxis", "random", {"random", "even", "distichous"});
    if (p.has("control_points")) {
        g.controlPoints = static_cast<int>(p.integer("control_points", Range::closed(2, 32)));
    }
    // Absent keys count as asked, so a misspelt one gets a "did you mean" suggestion.
    for (const char* key : {"length", "azimuth_deg", "tilt_deg", "roll_deg", "position", "curve",
                            "reduce_length", "reduce_width_begin", "reduce_width_end",
                            "tropism_deg", "reduce_angle", "phyllotaxis", "control_points"}) {
        p.raw(key);
    }
    p.finish();
    return g;
}

// Applies the keys a table sets on top of `g`.
void apply(const GeometryTable& t, GrammarGeometry& g) {
    if (t.length) std::tie(g.lengthLo, g.lengthHi) = *t.length;
    if (t.azimuth) std::tie(g.azimuthLo, g.azimuthHi) = *t.azimuth;
    if (t.tilt) std::tie(g.tiltLo, g.tiltHi) = *t.tilt;
    if (t.roll) std::tie(g.rollLo, g.rollHi) = *t.roll;
    if (t.position) std::tie(g.positionLo, g.positionHi) = *t.position;
    if (t.curve) std::tie(g.curveLo, g.curveHi) = *t.curve;
    if (t.reduceLength) g.reduceLength = *t.reduceLength;
    if (t.reduceWidthBegin) g.reduceWidthBegin = *t.reduceWidthBegin;
    if (t.reduceWidthEnd) g.reduceWidthEnd = *t.reduceWidthEnd;
    if (t.tropism) g.tropism = *t.tropism;
    if (t.reduceAngle) g.reduceAngle = *t.reduceAngle;
    if (t.phyllotaxis) {
        g.evenSpread = *t.phyllotaxis == "even";
        g.distichous = *t.phyllotaxis == "distichous";
    }
    if (t.controlPoints) g.controlPoints = *t.controlPoints;
}

// "name" or "name*N" → (name, N).
std::pair<std::string, int> parseOutput(Params& alt, const std::string& item) {
    const size_t star = item.find('*');
    if (star == std::string::npos) return {item, 1};
    const std::string name = item.substr(0, star);
    const std::string count = item.substr(star + 1);
    char* end = nullptr;
    const long n = std::strtol(count.c_str(), &end, 10);
    if (name.empty() || count.empty() || *end != '\0' || n < 1 || n > 1000) {
        alt.fail("out",
                 "expected \"state\" or \"state*N\" with 1 ≤ N ≤ 1000, got \"" + item + "\"");
    }
    return {name, static_cast<int>(n)};
}

class GrammarMethod : public GrowthMethod {
  public:
    explicit GrammarMethod(GrammarOptions o) : o_(std::move(o)) {}
    bool hasOwnSeasons() const override { return true; }
    Tree grow(Rng& rng, bool, std::map<std::string, double>& stats,
              const GrowthGuard& guard) const override {
        GrammarStats s;
        Tree t = growGrammar(o_, rng, &s, nullptr, guard);
        stats["stems"] = static_cast<double>(s.stems);
        stats["depth_reached"] = s.depthReached;
        stats["stop_states"] = static_cast<double>(s.stopStates);
        stats["truncated"] = static_cast<double>(s.truncated);
        stats["leaves"] = static_cast<double>(s.leaves);
        stats["fruit"] = static_cast<double>(s.fruit);
        stats["roots"] = static_cast<double>(s.roots);
        stats["rooted_roots"] = static_cast<double>(s.rooted);
        if (!o_.shyBounds.empty()) {
            stats["shy_stopped"] = static_cast<double>(s.shyStopped);
            stats["shy_leaves_dropped"] = static_cast<double>(s.shyLeaves);
        }
        return t;
    }

    // A light/shade tropism away from the neighbours' crowns (GrammarOptions::lightTropism)
    // and crown shyness where their crowns share a layer (GrammarOptions::shyBounds).
    Tree growAmong(Rng& rng, bool threaded, std::map<std::string, double>& stats,
                   const GrowthGuard& guard, const Neighbourhood& neighbours) const override {
        if (!(length2(neighbours.away) > 0) && neighbours.bounds.empty()) {
            return grow(rng, threaded, stats, guard);
        }
        GrammarOptions o = o_;
        o.lightTropism = neighbours.away;
        o.shyBounds = neighbours.bounds;
        return GrammarMethod(std::move(o)).grow(rng, threaded, stats, guard);
    }

  private:
    GrammarOptions o_;
};

// The start state and stop states of a grammar without a [grammar] table, or that omits them.
const char* const kDefaultStart = "s";
const char* const kDefaultStop = "t";

// A state name that exists: one with a rule, or a stop state (its error names the closest).
int knownState(GrammarOptions& o, Params& owner, const std::set<std::string>& known,
               const std::string& name, const std::string& key) {
    if (!known.count(name)) {
        std::string hint;
        if (auto w = closestWord(name, known)) hint = "; did you mean \"" + *w + "\"?";
        owner.fail(key, "unknown state \"" + name + "\"" + hint);
    }
    return o.state(name);
}

// A state that draws stems: known, and not a stop state.
int stemState(GrammarOptions& o, Params& owner, const std::set<std::string>& known,
              const std::string& name, const std::string& key) {
    const int s = knownState(o, owner, known, name, key);
    if (o.stop[s]) owner.fail(key, "\"" + name + "\" is a stop state: it draws no stem");
    return s;
}

// [grammar]: the global parameters, the start state S and the stop states 𝒯 (§3.1).
void readGrammarTable(Params& sp, GrammarOptions& o) {
    std::string startName = kDefaultStart;
    std::vector<std::string> stopNames = {kDefaultStop};
    std::optional<Params> g = sp.optionalTable("grammar");
    if (g) {
        startName = g->string("start", kDefaultStart);
        if (g->has("stop")) stopNames = g->stringArray("stop");
        o.maxDepth = g->has("max_depth")
                         ? static_cast<int>(g->integer(
                               "max_depth", Range::closed(1, GrammarOptions::kMaxLevels)))
                         : 0;
        std::tie(o.trunkWidthLo, o.trunkWidthHi) =
            g->interval("trunk_width", {o.trunkWidthLo, o.trunkWidthHi}, Range::positive());
        o.segmentLength = g->number("segment_length", o.segmentLength, Range::positive());
        o.lengthScale = g->number("length_scale", o.lengthScale, Range::leftOpen(0, 10));
        o.groundClearance = g->number("ground_clearance", o.groundClearance, Range::nonNegative());
        o.straightLeader = g->boolean("straight_leader", o.straightLeader);
        o.maxStems = static_cast<int>(g->integer("max_stems", o.maxStems, Range::closed(1, 1e7)));
        o.season = readSeason(*g, "season", o.season);
    }
    auto failGrammar = [&](const char* key, const std::string& msg) {
        if (g && g->has(key)) g->fail(key, msg);
        if (g) g->failHere(msg);
        sp.failHere(msg);
    };
    if (startName.find('*') != std::string::npos || startName.find("->") != std::string::npos) {
        failGrammar("start", "expected a state name without '*' or '->'");
    }
    o.start = o.state(startName);
    for (const std::string& s : stopNames) {
        if (s == startName) failGrammar("stop", "the start state cannot be a stop state");
        if (o.stop[o.state(s)]) failGrammar("stop", "\"" + s + "\" is listed twice");
        o.stop[o.state(s)] = true;
    }
    if (g) g->finish();
}

// Every stop state a `stop` list names is the output of some rule: a misspelt name would
// otherwise be accepted and never used.
void checkStopStatesProduced(Params& sp, const GrammarOptions& o) {
    std::optional<Params> g = sp.optionalTable("grammar");
    if (!g || !g->has("stop")) return;  // the default ["t"] may go unused (max_depth grammars)
    std::vector<bool> produced(o.states.size(), false);
    for (const auto& alts : o.rules) {
        for (const GrammarAlternative& a : alts) {
            for (int t : a.out) produced[t] = true;
        }
    }
    for (size_t s = 0; s < o.states.size(); ++s) {
        if (o.stop[s] && !produced[s]) {
            g->fail("stop", "stop state \"" + o.states[s] + "\" is not the output of any rule");
        }
    }
}

// One rule's alternatives { out, p } (§3.1.1), their probabilities summing to 1.
void readAlternatives(Params& rules, const std::string& name, const std::set<std::string>& known,
                      GrammarOptions& o) {
    const int from = o.state(name);
    std::vector<Params> alts = rules.tableArray(name);
    if (alts.empty()) rules.fail(name, "expected at least one alternative { out = [...] }");
    double sum = 0;
    for (Params& alt : alts) {
        GrammarAlternative a;
        const std::vector<std::string> out = alt.stringArray("out");
        if (!alt.has("out")) alt.failHere("missing \"out\": the alternative's output states");
        if (out.empty()) alt.fail("out", "expected at least one output state");
        for (const std::string& item : out) {
            auto [outName, count] = parseOutput(alt, item);
            if (!known.count(outName)) {
                std::string hint;
                if (auto w = closestWord(outName, known)) hint = "; did you mean \"" + *w + "\"?";
                alt.fail("out", "unknown state \"" + outName +
                                    "\": it has no rule and is not a stop state" + hint);
            }
            const int to = o.state(outName);
            for (int k = 0; k < count; ++k) a.out.push_back(to);
        }
        if (alts.size() == 1) {
            a.p = alt.number("p", a.p, Range::closed(0, 1));
        } else {
            if (!alt.has("p")) {
                alt.failHere(
                    "missing \"p\": a rule with several alternatives needs each one's "
                    "probability");
            }
            a.p = alt.number("p", Range::closed(0, 1));
        }
        sum += a.p;
        alt.finish();
        o.rules[from].push_back(std::move(a));
    }
    if (std::abs(sum - 1.0) > 1e-6) {
        rules.fail(name,
                   "the alternatives' probabilities sum to " + fmt(sum) + ", expected 1 (±1e-6)");
    }
}

// With D unbounded, every state reachable from the start must have a path to a stop state.
void checkTermination(const GrammarOptions& o, Params& rules,
                      const std::vector<std::string>& ruleNames) {
    const int nStates = static_cast<int>(o.states.size());
    std::vector<bool> reachable(nStates, false);
    std::vector<int> todo = {o.start};
    reachable[o.start] = true;
    while (!todo.empty()) {
        const int s = todo.back();
        todo.pop_back();
        for (const GrammarAlternative& a : o.rules[s]) {
            for (int t : a.out) {
                if (!reachable[t]) {
                    reachable[t] = true;
                    todo.push_back(t);
                }
            }
        }
    }
    // Least fixed point: a state can terminate if some alternative's outputs all can.
    std::vector<bool> ends(o.stop.begin(), o.stop.end());
    for (bool changed = true; changed;) {
        changed = false;
        for (int s = 0; s < nStates; ++s) {
            if (ends[s]) continue;
            for (const GrammarAlternative& a : o.rules[s]) {
                bool all = a.p > 0;
                for (int t : a.out) all = all && ends[t];
                if (all) {
                    ends[s] = changed = true;
                    break;
                }
            }
        }
    }
    for (const std::string& name : ruleNames) {
        const int s = std::find(o.states.begin(), o.states.end(), name) - o.states.begin();
        if (reachable[s] && !ends[s]) {
            rules.fail(name, "no path from \"" + name +
                                 "\" to a stop state while grammar.max_depth is unbounded: "
                                 "add a stop state to the rule or set grammar.max_depth");
        }
    }
}

// [rules]: the grammar 𝒢 (§3.1.1), one key per input state; returns the known states (those
// with a rule, and the stop states).
std::set<std::string> readRules(Params& sp, GrammarOptions& o) {
    if (!sp.has("rules")) sp.fail("rules", "required table missing: the grammar's rules");
    const std::vector<std::string> ruleNames = keysOf(sp, "rules");
    Params rules = sp.table("rules");
    rules.keysAreUserNames();  // state names
    std::set<std::string> known;
    for (int s = 0; s < static_cast<int>(o.states.size()); ++s) {
        if (o.stop[s]) known.insert(o.states[s]);
    }
    // First every input state, so outputs can be checked against them.
    for (const std::string& name : ruleNames) {
        if (name.find('*') != std::string::npos || name.find("->") != std::string::npos) {
            rules.fail(name, "a state name may not contain '*' or '->'");
        }
        if (o.stop[o.state(name)]) {
            rules.fail(name, "\"" + name + "\" is a stop state: stop states have no rule");
        }
        known.insert(name);
    }
    if (!known.count(o.states[o.start]) || o.stop[o.start]) {
        const std::string msg = "no rule for the start state \"" + o.states[o.start] + "\"";
        std::optional<Params> g = sp.optionalTable("grammar");
        if (g && g->has("start")) g->fail("start", msg);
        rules.failHere(msg);
    }
    for (const std::string& name : ruleNames) readAlternatives(rules, name, known, o);
    rules.finish();
    if (o.maxDepth == 0) checkTermination(o, rules, ruleNames);
    return known;
}

// [geometry.default], [geometry.<state>], [geometry."<from>-><to>"]: the geometry ℋ of every
// transition (§3.1.2), each key from the most specific table that sets it.
void readGeometryTables(Params& sp, const std::set<std::string>& known, GrammarOptions& o) {
    std::set<std::pair<int, int>> transitions;
    for (int s = 0; s < static_cast<int>(o.states.size()); ++s) {
        for (const GrammarAlternative& a : o.rules[s]) {
            for (int t : a.out) {
                if (!o.stop[t]) transitions.insert({s, t});
            }
        }
    }
    GeometryTable fallbackTable;
    std::map<int, GeometryTable> stateTables;
    std::map<std::pair<int, int>, GeometryTable> transitionTables;
    if (sp.has("geometry")) {
        const std::vector<std::string> names = keysOf(sp, "geometry");
        Params geo = sp.table("geometry");
        geo.keysAreUserNames();  // "default", state names, transitions
        for (const std::string& name : names) {
            Params t = geo.table(name);
            const size_t arrow = name.find("->");
            if (name == "default") {
                fallbackTable = readGeometry(t);
            } else if (arrow == std::string::npos) {
                stateTables[stemState(o, geo, known, name, name)] = readGeometry(t);
            } else {
                const int from = stemState(o, geo, known, name.substr(0, arrow), name);
                const int to = stemState(o, geo, known, name.substr(arrow + 2), name);
                if (!transitions.count({from, to})) {
                    geo.fail(name, "no rule turns \"" + o.states[from] + "\" into \"" +
                                       o.states[to] + "\"");
                }
                transitionTables[{from, to}] = readGeometry(t);
            }
        }
        geo.finish();
    }
    apply(fallbackTable, o.fallback);
    for (const auto& [from, to] : transitions) {
        GrammarGeometry gg = o.fallback;
        if (auto it = stateTables.find(to); it != stateTables.end()) apply(it->second, gg);
        if (auto it = transitionTables.find({from, to}); it != transitionTables.end()) {
            apply(it->second, gg);
        }
        o.transition[{from, to}] = gg;
    }
}

// [particles.<state>]: leaves along every stem of that state (§3.2).
void readParticles(Params& sp, const std::set<std::string>& known, GrammarOptions& o) {
    if (!sp.has("particles")) return;
    const std::vector<std::string> names = keysOf(sp, "particles");
    Params parts = sp.table("particles");
    parts.keysAreUserNames();  // state names
    for (const std::string& name : names) {
        const int s = stemState(o, parts, known, name, name);
        Params p = parts.table(name);
        GrammarParticles& pp = o.particles[s];
        pp.enabled = true;
        pp.perMetre = p.number("per_metre", pp.perMetre, Range::closed(0, 100000));
        if (!p.has("count") && !p.has("per_metre")) {
            p.failHere("missing \"count\" (leaves per stem) or \"per_metre\" (leaves per metre)");
        }
        pp.count = static_cast<int>(p.integer("count", 0, Range::closed(0, 100000)));
        std::tie(pp.sizeLo, pp.sizeHi) =
            p.interval("size", {pp.sizeLo, pp.sizeHi}, Range::positive());
        pp.aspect = p.number("aspect", pp.aspect, Range::leftOpen(0, 10));
        pp.shape = readLeafShape(p, pp.shape);
        std::tie(pp.rotationLo, pp.rotationHi) =
            p.degreeInterval("rotation_deg", {pp.rotationLo, pp.rotationHi}, Range::closed(0, 180));
        pp.randomness = p.number("randomness", pp.randomness, Range::closed(0, 1));
        std::tie(pp.alongLo, pp.alongHi) =
            p.interval("along", {pp.alongLo, pp.alongHi}, Range::closed(0, 1));
        pp.minLevel = static_cast<int>(p.integer("min_level", pp.minLevel, Range::closed(0, 1000)));
        pp.twoRows = p.choice("arrangement", pp.twoRows ? "two-rows" : "spiral",
                              {"spiral", "two-rows"}) == "two-rows";
        p.finish();
    }
    parts.finish();
}

// [fruit.<state>]: fruit or flower cards hanging from the stems of that state.
void readFruit(Params& sp, const std::set<std::string>& known, GrammarOptions& o) {
    if (!sp.has("fruit")) return;
    const std::vector<std::string> names = keysOf(sp, "fruit");
    Params fruits = sp.table("fruit");
    fruits.keysAreUserNames();  // state names
    for (const std::string& name : names) {
        const int s = stemState(o, fruits, known, name, name);
        Params p = fruits.table(name);
        GrammarFruit& f = o.fruit[s];
        f.enabled = true;
        f.count = static_cast<int>(p.integer("count", Range::closed(0, 100000)));
        std::tie(f.sizeLo, f.sizeHi) = p.interval("size", {f.sizeLo, f.sizeHi}, Range::positive());
        f.aspect = p.number("aspect", f.aspect, Range::leftOpen(0, 10));
        f.colour = static_cast<uint8_t>(p.integer("colour", f.colour, Range::closed(0, 255)));
        std::tie(f.alongLo, f.alongHi) =
            p.interval("along", {f.alongLo, f.alongHi}, Range::closed(0, 1));
        f.minLevel = static_cast<int>(p.integer("min_level", f.minLevel, Range::closed(0, 1000)));
        if (p.has("seasons")) {
            f.seasons = {false, false, false, false};
            for (const std::string& sn : p.stringArray("seasons")) {
                const int index = seasonIndex(sn);
                if (index < 0) {
                    p.fail("seasons", "unknown season \"" + sn +
                                          "\" (expected spring, summer, autumn, winter)");
                }
                f.seasons[index] = true;
            }
        }
        p.finish();
    }
    fruits.finish();
}

// [roots.<state>]: the stems of that state (and all drawn from them) are roots: aerial or
// prop roots reaching down to the ground, pillars once rooted (our extension).
void readRoots(Params& sp, const std::set<std::string>& known, GrammarOptions& o) {
    if (!sp.has("roots")) return;
    const std::vector<std::string> names = keysOf(sp, "roots");
    Params roots = sp.table("roots");
    roots.keysAreUserNames();  // state names
    for (const std::string& name : names) {
        const int s = stemState(o, roots, known, name, name);
        if (s == o.start) roots.fail(name, "the start state draws no stem");
        Params p = roots.table(name);
        GrammarRoots& r = o.roots[s];
        r.enabled = true;
        r.form = p.choice("form", r.form,
                          {{"vertical", RootForm::kVertical}, {"arching", RootForm::kArching}});
        std::tie(r.pillarWidthLo, r.pillarWidthHi) =
            p.interval("pillar_width", {r.pillarWidthLo, r.pillarWidthHi}, Range::nonNegative());
        p.finish();
    }
    roots.finish();
}

// Lower bounds of every tree's sizes (core/budget.h) from the smallest derivation: every rule
// takes its alternative (of p > 0) that makes the least, to depth D. Every stem drawn has at
// least ⌈t_l / segment_length⌉ skeleton nodes (t_l from its transition's shortest base length;
// one node where roots may be cut at the ground), and a stem certainly carries its state's
// particle count (when the season keeps every leaf) and fruit count. max_stems cuts the
// derivation breadth first: a tree that reaches it has max_stems stems, of unknown states.
SizeEstimate estimateGrammar(const GrammarOptions& o, Params& sp) {
    const int states = static_cast<int>(o.states.size());
    const int depth = o.maxDepth > 0 ? o.maxDepth : GrammarOptions::kMaxLevels;
    bool anyRoots = false;
    for (const GrammarRoots& r : o.roots) anyRoots = anyRoots || r.enabled;
    const SeasonPalette& season = o.seasons[static_cast<int>(o.season)];
    auto capped = [](double v) { return std::min(v, 1e300); };
    auto stemNodes = [&](int from, int to, int c) {
        if (anyRoots) return 1.0;
        const GrammarGeometry& g = o.geometry(from, to);
        const double len = g.lengthLo * std::pow(g.reduceLength, c) * o.lengthScale;
        return std::max(1.0, std::ceil(len / o.segmentLength - 1e-9));
    };
    auto stemLeaves = [&](int to, int c) {
        double n = 0;
        const GrammarParticles& pp = o.particles[to];
        if (pp.enabled && c >= pp.minLevel && season.density >= 1 && !season.classes.empty()) {
            n += pp.count;
        }
        const GrammarFruit& f = o.fruit[to];
        if (f.enabled && c >= f.minLevel && f.seasons[static_cast<int>(o.season)]) n += f.count;
        return n;
    };
    // least[k][s]: the least of quantity k made below a stem of state s whose rule applies at
    // level c (k: 0 stems, 1 skeleton nodes, 2 leaves), for c = D … 0.
    std::vector<std::vector<double>> below(3, std::vector<double>(states, 0.0)), next = below;
    for (int c = depth - 1; c >= 0; --c) {
        for (int k = 0; k < 3; ++k) {
            for (int st = 0; st < states; ++st) {
                double best = o.rules[st].empty() ? 0.0 : 1e300;
                for (const GrammarAlternative& a : o.rules[st]) {
                    if (!(a.p > 0)) continue;
                    double sum = 0;
                    for (int out : a.out) {
                        if (o.stop[out]) continue;
                        const double own = k == 0   ? 1.0
                                           : k == 1 ? stemNodes(st, out, c)
                                                    : stemLeaves(out, c);
                        sum = capped(sum + own + below[k][out]);
                    }
                    best = std::min(best, sum);
                }
                next[k][st] = best >= 1e300 ? 0.0 : best;
            }
        }
        std::swap(below, next);
    }
    const double stems = below[0][o.start];
    SizeEstimate sizes;
    std::optional<Params> g = sp.optionalTable("grammar");
    const std::string d = std::to_string(depth);
    if (stems >= o.maxStems) {
        // Every tree draws max_stems stems, each at least one node.
        sizes.add(BudgetKind::kSkeletonNodes, 1.0 + o.maxStems,
                  g ? g->where("max_stems") : sp.whereTable(), g ? g->path("max_stems") : "grammar",
                  "every tree reaches max_stems = " + std::to_string(o.maxStems) +
                      " stems (its smallest derivation to depth " + d + " has ≈ " +
                      formatSize(stems) + "), each a skeleton node at least");
        return sizes;
    }
    const double nodes = 1.0 + below[1][o.start];
    const bool refined = nodes > 2.0 * (1.0 + stems) && g && g->has("segment_length");
    const bool deep = g && g->has("max_depth");
    const std::string key = refined ? "segment_length" : "max_depth";
    sizes.add(
        BudgetKind::kSkeletonNodes, nodes, refined || deep ? g->where(key) : sp.where("rules"),
        refined || deep ? g->path(key) : sp.path("rules"),
        "the smallest derivation to depth " + d + " draws ≈ " + formatSize(stems) + " stems of ≈ " +
            formatSize(nodes) + " skeleton nodes" + (refined ? " at this segment length" : ""));
    const double leaves = below[2][o.start];
    if (leaves > 0) {
        sizes.add(BudgetKind::kLeaves, leaves,
                  sp.where(sp.has("particles") ? "particles" : "fruit"),
                  sp.path(sp.has("particles") ? "particles" : "fruit"),
                  "the smallest derivation to depth " + d + " carries ≈ " + formatSize(leaves) +
                      " leaves and fruit");
    }
    return sizes;
}

}  // namespace

std::unique_ptr<GrowthMethod> makeGrammarMethod(Params& sp) {
    if (sp.has("leaves")) {
        sp.raw("leaves");
        sp.fail("leaves",
                "grammar species place particle leaves per state: use [particles.<state>] "
                "(and [fruit.<state>]) instead of [leaves]");
    }
    GrammarOptions o;
    readGrammarTable(sp, o);
    const std::set<std::string> known = readRules(sp, o);
    checkStopStatesProduced(sp, o);
    readGeometryTables(sp, known, o);
    readParticles(sp, known, o);
    readFruit(sp, known, o);
    readRoots(sp, known, o);
    readSeasonPalettes(sp, o.seasons, false);
    SizeEstimate sizes = estimateGrammar(o, sp);
    auto method = std::make_unique<GrammarMethod>(std::move(o));
    method->sizes = std::move(sizes);
    return method;
}

}  // namespace sylva
