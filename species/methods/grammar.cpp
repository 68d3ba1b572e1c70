// The `grammar` growth method (Jain et al. 2021 §3): derivation of the stochastic grammar,
// stems as noisy Catmull–Rom splines sampled into skeleton nodes, particle leaves and fruit.
// Frame: +y up, metres, radians. Format and conventions: grammar.h.
#include "species/methods/grammar.h"

#include <algorithm>
#include <cmath>

namespace sylva {

namespace {

// Sub-keys of a stem's derivation-path key, one stream each.
constexpr uint64_t kRootKey = 0x6772616d6d6172ull;  // "grammar"
constexpr uint64_t kRuleTag = 1, kEvenTag = 2, kLeafTag = 3, kFruitTag = 4, kShyTag = 5;

double lerp(double a, double b, double t) { return a + (b - a) * t; }

// A stem's sampled points: index 0 is the attachment (its base node), then its own nodes.
struct StemCurve {
    std::vector<Vec3> point, tangent, normal;
    std::vector<double> width;  // metres (diameter)
    std::vector<int32_t> node;  // skeleton node of each point
    int drawnSegments = 0;      // segments as drawn, before a shyness bound stopped the stem
};

struct Pending {
    int state;
    int parentStem;  // −1: the start rule
    int level;
    int order;
    uint64_t key;
    bool even;
    double evenAngle;    // slot angle when even, radians
    int distichousSide;  // 0 or 1 for a distichous sibling, −1 otherwise
};

// Uniform Catmull–Rom through c[0..m-1] at global parameter t ∈ [0, m−1]; phantom ends by
// reflection, so equally spaced collinear points give a straight, uniformly sampled line.
void catmullRom(const std::vector<Vec3>& c, double t, Vec3& pos, Vec3& der) {
    const int m = static_cast<int>(c.size());
    int i = std::min(static_cast<int>(std::floor(t)), m - 2);
    const double u = t - i;
    auto at = [&](int k) {
        if (k < 0) return c[0] * 2.0 - c[1];
        if (k >= m) return c[m - 1] * 2.0 - c[m - 2];
        return c[k];
    };
    const Vec3 p0 = at(i - 1), p1 = at(i), p2 = at(i + 1), p3 = at(i + 2);
    const double u2 = u * u, u3 = u2 * u;
    pos = (p1 * 2.0 + (p2 - p0) * u + (p0 * 2.0 - p1 * 5.0 + p2 * 4.0 - p3) * u2 +
           (p1 * 3.0 - p0 - p2 * 3.0 + p3) * u3) *
          0.5;
    der = ((p2 - p0) + (p0 * 2.0 - p1 * 5.0 + p2 * 4.0 - p3) * (2.0 * u) +
           (p1 * 3.0 - p0 - p2 * 3.0 + p3) * (3.0 * u2)) *
          0.5;
}

double latticeValue(int64_t x, int64_t y, int64_t z, uint64_t seed) {
    uint64_t h = hashCombine(
        hashCombine(hashCombine(seed, static_cast<uint64_t>(x)), static_cast<uint64_t>(y)),
        static_cast<uint64_t>(z));
    return static_cast<double>(h >> 11) * 0x1.0p-53 * 2.0 - 1.0;
}

}  // namespace

int GrammarOptions::state(const std::string& name) {
    for (size_t i = 0; i < states.size(); ++i) {
        if (states[i] == name) return static_cast<int>(i);
    }
    states.push_back(name);
    stop.push_back(false);
    rules.emplace_back();
    particles.emplace_back();
    fruit.emplace_back();
    roots.emplace_back();
    return static_cast<int>(states.size()) - 1;
}

const GrammarGeometry& GrammarOptions::geometry(int from, int to) const {
    auto it = transition.find({from, to});
    return it == transition.end() ? fallback : it->second;
}

double valueNoise3(const Vec3& p, uint64_t seed) {
    const double fx = std::floor(p.x), fy = std::floor(p.y), fz = std::floor(p.z);
    const auto x0 = static_cast<int64_t>(fx), y0 = static_cast<int64_t>(fy),
               z0 = static_cast<int64_t>(fz);
    auto smooth = [](double t) { return t * t * (3.0 - 2.0 * t); };
    const double u = smooth(p.x - fx), v = smooth(p.y - fy), w = smooth(p.z - fz);
    double c[2][2];
    for (int i = 0; i < 2; ++i) {
        for (int j = 0; j < 2; ++j) {
            c[i][j] = lerp(latticeValue(x0, y0 + i, z0 + j, seed),
                           latticeValue(x0 + 1, y0 + i, z0 + j, seed), u);
        }
    }
    return lerp(lerp(c[0][0], c[1][0], v), lerp(c[0][1], c[1][1], v), w);
}

namespace {

// One tree's derivation in progress: the queue of outputs still to draw, the stems drawn so
// far with their sampled curves, and the skeleton they make.
struct Derivation {
    const GrammarOptions& o;
    const GrowthGuard& guard;
    uint64_t work = 0;  // for guard.work
    Rng& rng;
    int maxDepth;       // D, or the internal cap when unbounded
    double trunkWidth;  // W, drawn once per tree
    uint64_t noiseSeed;
    Tree tree;
    GrammarStats stats;
    std::vector<Pending> queue;
    std::vector<GrammarStem> stems;
    std::vector<StemCurve> curves;
};

// Jain §3.1.1: applies `state`'s rule for the stem `parentStem` (−1: the start rule) and
// queues its outputs; the alternative is drawn from the parent's own keyed stream, and the
// "even" siblings of one application share a random offset (our extension), the "distichous"
// ones alternate sides.
void expand(Derivation& d, int state, int parentStem, int level, int order, uint64_t key) {
    const GrammarOptions& o = d.o;
    const std::vector<GrammarAlternative>& alts = o.rules[state];
    if (alts.empty()) return;
    if (level >= d.maxDepth) {
        ++d.stats.truncated;
        return;
    }
    Rng pick = d.rng.derive(hashCombine(key, kRuleTag));
    const double u = pick.uniform();
    size_t a = 0;
    for (double acc = alts[0].p; a + 1 < alts.size() && u >= acc; acc += alts[++a].p) {
    }
    const std::vector<int>& out = alts[a].out;
    int evenCount = 0;
    for (int s : out) {
        if (!o.stop[s] && o.geometry(state, s).evenSpread) ++evenCount;
    }
    const double evenOffset = d.rng.derive(hashCombine(key, kEvenTag)).uniform(0.0, 2 * kPi);
    int evenSlot = 0, distichousSlot = 0;
    bool continued = false;
    for (size_t i = 0; i < out.size(); ++i) {
        const int s = out[i];
        if (o.stop[s]) {
            ++d.stats.stopStates;
            continue;
        }
        // Every queued output is drawn in turn until max_stems stems are: those queued after
        // the first max_stems never are, so they are counted here rather than kept (a queue of
        // max_stems × branching entries could not be held).
        if (static_cast<int64_t>(d.queue.size()) >= o.maxStems) {
            ++d.stats.truncated;
            continue;
        }
        Pending p;
        p.state = s;
        p.parentStem = parentStem;
        p.level = level;
        const bool continues = parentStem >= 0 && s == state && !continued;
        if (continues) continued = true;
        p.order = parentStem < 0 ? 0 : (continues ? order : order + 1);
        p.key = hashCombine(key, i + 1);
        const GrammarGeometry& g = o.geometry(state, s);
        p.even = g.evenSpread;
        p.evenAngle = p.even ? evenOffset + 2 * kPi * evenSlot++ / evenCount : 0.0;
        // Our extension: distichous siblings alternate between the two sides of the parent
        // (drawStem), the first side alternating by level.
        p.distichousSide = g.distichous ? (distichousSlot++ + level) % 2 : -1;
        d.queue.push_back(p);
    }
}

// Where a stem grows from: the parent's sampled point nearest the drawn fraction of its
// length (never the parent's base, which is the grandparent's node), or the ground point.
// A parent stopped short by a shyness bound keeps its drawn length's fractions: a point
// beyond its end was never grown (`grown` false).
struct Attachment {
    Vec3 base, tangent, normal;
    double width;  // the parent's width there, metres
    int32_t node;
    bool grown = true;
};
Attachment attachment(const Derivation& d, int parentStem, double position) {
    if (parentStem < 0) return {{0, 0, 0}, {0, 1, 0}, {1, 0, 0}, d.trunkWidth, 0};
    const StemCurve& pc = d.curves[parentStem];
    const int kept = static_cast<int>(pc.point.size()) - 1;
    const int n = std::max(kept, pc.drawnSegments);
    const int j = std::clamp(static_cast<int>(std::lround(position * n)), 1, n);
    if (j > kept)
        return {pc.point[kept], pc.tangent[kept], pc.normal[kept],
                pc.width[kept], pc.node[kept],    false};
    return {pc.point[j], pc.tangent[j], pc.normal[j], pc.width[j], pc.node[j]};
}

// The stem's control points: a circular arc from `base` along `dir` turning toward −y
// (tropism > 0) or +y, never past the vertical; then displaced by smooth value noise
// ∝ curve · length (Jain §3.1.2's noisy spline). `tau` returns the turn actually used.
std::vector<Vec3> controlPoints(const Derivation& d, const GrammarGeometry& g, double tropism,
                                const Vec3& base, const Vec3& dir, double len, double curve,
                                const Vec3& noiseOrigin, double& tau) {
    tau = tropism;
    Vec3 bendAxis{0, 0, 0};
    if (tau != 0.0) {
        const Vec3 toward = tau > 0 ? Vec3{0, -1, 0} : Vec3{0, 1, 0};
        const Vec3 k = cross(dir, toward);
        if (length(k) < 1e-9) {
            tau = 0.0;
        } else {
            bendAxis = normalize(k);
            tau = std::min(std::abs(tau), angleBetween(dir, toward));
        }
    }
    const int m = std::max(2, g.controlPoints);
    std::vector<Vec3> ctrl(m);
    const Vec3 bendTo = cross(bendAxis, dir);
    for (int k = 0; k < m; ++k) {
        const double s = len * k / (m - 1);
        Vec3 p;
        if (tau < 1e-9) {
            p = base + dir * s;
        } else {
            const double phi = tau * s / len;
            p = base + dir * (std::sin(phi) * len / tau) +
                bendTo * ((1.0 - std::cos(phi)) * len / tau);
        }
        if (curve > 0 && k > 0) {
            const Vec3 q = noiseOrigin + Vec3{0.6 * k, 0.0, 0.0};
            const Vec3 n{valueNoise3(q, d.noiseSeed),
                         valueNoise3(q + Vec3{31.7, 0, 0}, d.noiseSeed),
                         valueNoise3(q + Vec3{0, 57.3, 0}, d.noiseSeed)};
            p += n * (curve * len * k / (m - 1));
        }
        ctrl[k] = p;
    }
    return ctrl;
}

// Our extension (issue 13): a shoot stem stepping down below the clearance h has each
// downward step dy damped by the height left, dy' = dy·y/h — integrated over the step,
// y ← y·exp(dy/h) — so the stem bends toward the horizontal as it nears the ground and never
// reaches y = 0 (a stem already at or below it goes no lower). Steps up are kept. Returns the
// new height.
double descend(double y, double dy, double h) {
    if (dy >= 0 || y + dy >= h) return y + dy;
    if (y > h) {
        dy += y - h;  // the part of the step above h is kept
        y = h;
    }
    return y <= 0 ? y : y * std::exp(dy / h);
}

// The stem's points before they become nodes: the spline sampled at `segments` + 1 even
// parameter values (index 0 the attachment), with its derivative.
struct StemSamples {
    std::vector<Vec3> point, der;
};

StemSamples sampleSpline(const std::vector<Vec3>& ctrl, int segments, const Vec3& base) {
    const int m = static_cast<int>(ctrl.size());
    StemSamples ss;
    for (int i = 0; i <= segments; ++i) {
        Vec3 pos, der;
        catmullRom(ctrl, static_cast<double>(i) * (m - 1) / segments, pos, der);
        if (i == 0) pos = base;
        ss.point.push_back(pos);
        ss.der.push_back(der);
    }
    return ss;
}

// Ground clearance on a shoot stem's samples (see descend): the heights re-integrated step by
// step from the attachment, the derivative's y scaled as its step was.
void clearGround(StemSamples& ss, double h) {
    Vec3 prevOld = ss.point[0];
    for (size_t i = 1; i < ss.point.size(); ++i) {
        const Vec3 old = ss.point[i];
        const double dy = old.y - prevOld.y;
        const double y = descend(ss.point[i - 1].y, dy, h);
        if (dy < 0 && y - ss.point[i - 1].y != dy) ss.der[i].y *= (y - ss.point[i - 1].y) / dy;
        ss.point[i].y = y;
        prevOld = old;
    }
}

// A root reaching the ground: the samples cut where they first meet y = 0, the last point on
// it. Returns whether they reach it (from an attachment above the ground).
bool cutAtGround(StemSamples& ss) {
    if (ss.point[0].y <= 0) return false;
    for (size_t i = 1; i < ss.point.size(); ++i) {
        if (ss.point[i].y > 0) continue;
        const Vec3 a = ss.point[i - 1], b = ss.point[i];
        const double f = a.y / (a.y - b.y);
        ss.point[i] = a + (b - a) * f;
        ss.point[i].y = 0.0;
        ss.point.resize(i + 1);
        ss.der.resize(i + 1);
        return true;
    }
    return false;
}

// A sample beyond a bound moved onto its plane (the bounds in order), its derivative turned
// along it.
void slideOnto(Vec3& p, Vec3& der, const std::vector<ShyBound>& bounds) {
    for (const ShyBound& b : bounds) {
        if (b.holds(p)) continue;
        p -= b.plane.normal * (b.plane.distance(p) + 1e-9);
        der -= b.plane.normal * std::max(0.0, dot(der, b.plane.normal));
    }
}

// Crown shyness for a trunk (GrammarOptions::shyBounds): never stopped, every sample beyond a
// plane moved onto it — a leaning trunk grows on up along a neighbour's plane.
void slideInsideBounds(StemSamples& ss, const std::vector<ShyBound>& bounds) {
    for (size_t i = 1; i < ss.point.size(); ++i) slideOnto(ss.point[i], ss.der[i], bounds);
}

// Crown shyness (GrammarOptions::shyBounds), each plane moved back by u × its slack: a sample
// beyond a bound is moved onto its plane when the stem rises there (its last segment more than
// kShySlideRise above the horizontal: it grows on up along the neighbour's crown, as a shaded
// shoot turns to the light above), and the stem stops at the sample before it otherwise.
// Returns the number of segments kept (0: not even the first).
constexpr double kShySlideRise = 0.5;  // sin 30°

int keepInsideBounds(StemSamples& ss, const std::vector<ShyBound>& bounds, double u) {
    std::vector<ShyBound> moved = bounds;
    for (ShyBound& b : moved) b.plane.offset -= u * b.slack;
    for (size_t i = 1; i < ss.point.size(); ++i) {
        if (keepsAll(moved, ss.point[i])) continue;
        const Vec3 step = ss.point[i] - ss.point[i - 1];
        const double len = length(step);
        if (len > 0 && step.y > kShySlideRise * len) {
            slideOnto(ss.point[i], ss.der[i], moved);
            if (keepsAll(moved, ss.point[i])) continue;  // (a corner may still hold it out)
        }
        ss.point.resize(i);
        ss.der.resize(i);
        return static_cast<int>(i) - 1;
    }
    return static_cast<int>(ss.point.size()) - 1;
}

// Turns the samples into the stem's skeleton nodes (widths linear from begin to end, the
// reference normal carried by parallel transport).
StemCurve addNodes(Derivation& d, const StemSamples& ss, const Attachment& at, const Vec3& dir,
                   const Vec3& refN, int order, int level, uint8_t part, GrammarStem& st) {
    const int segments = static_cast<int>(ss.point.size()) - 1;
    StemCurve sc;
    Vec3 prevN = refN;
    for (int i = 0; i <= segments; ++i) {
        const Vec3 pos = ss.point[i], der = ss.der[i];
        const Vec3 t = length(der) > 1e-12 ? normalize(der) : dir;
        Vec3 nn = prevN - t * dot(prevN, t);  // parallel transport of the reference
        nn = length(nn) > 1e-9 ? normalize(nn) : anyPerpendicular(t);
        prevN = nn;
        const double width = lerp(st.widthBegin, st.widthEnd, static_cast<double>(i) / segments);
        int32_t node = at.node;
        if (i > 0) {
            SkeletonNode sn;
            sn.position = pos;
            sn.radius = 0.5 * width;
            sn.parent = i == 1 ? at.node : static_cast<int32_t>(d.tree.nodes.size()) - 1;
            sn.order = order;
            sn.level = level;
            sn.part = part;
            node = static_cast<int32_t>(d.tree.nodes.size());
            d.tree.nodes.push_back(sn);
            st.nodes.push_back(node);
        }
        sc.point.push_back(pos);
        sc.tangent.push_back(t);
        sc.normal.push_back(nn);
        sc.width.push_back(width);
        sc.node.push_back(node);
    }
    return sc;
}

// Our extension (phyllotaxis = "distichous"): the azimuth that puts a sibling on side 0 or 1
// of its parent in the plane through the parent's axis closest to the horizontal — the two
// ranks of a flat spray (a vertical parent: 90° and 270° from its reference normal).
double distichousAngle(const Attachment& at, int side) {
    const Vec3 across = cross(at.tangent, Vec3{0, 1, 0});
    double base = 0.5 * kPi;
    if (length(across) > 1e-6) {
        const Vec3 h = normalize(across);
        base = std::atan2(dot(cross(at.normal, h), at.tangent), dot(at.normal, h));
    }
    return base + kPi * side;
}

// Jain §3.1.2: draws the stem of one queued output with its transition's geometry — length
// t_l = b_l·r_l^c, Euler angles t_a = b_a·r_a^c, attachment, noisy spline — adds its nodes to
// the skeleton, then expands its own state's rule.
void drawStem(Derivation& d, const Pending& pd) {
    const GrammarOptions& o = d.o;
    const int parentState = pd.parentStem >= 0 ? d.stems[pd.parentStem].state : o.start;
    const GrammarGeometry& g = o.geometry(parentState, pd.state);
    Rng r = d.rng.derive(pd.key);
    const int c = pd.level;

    // Draws, always in this order from the stem's own stream.
    const double baseLength = r.uniform(g.lengthLo, g.lengthHi);
    const double azimuthDraw = r.uniform(g.azimuthLo, g.azimuthHi);
    const double tiltDraw = r.uniform(g.tiltLo, g.tiltHi);
    const double rollDraw = r.uniform(g.rollLo, g.rollHi);
    const double position = r.uniform(g.positionLo, g.positionHi);
    const double curve = r.uniform(g.curveLo, g.curveHi);
    const Vec3 noiseOrigin{r.uniform(0, 1000), r.uniform(0, 1000), r.uniform(0, 1000)};

    const double len = baseLength * std::pow(g.reduceLength, c) * o.lengthScale;
    double azimuth = (pd.even ? pd.evenAngle : 0.0) + azimuthDraw * std::pow(g.reduceAngle.x, c);
    double tilt = tiltDraw * std::pow(g.reduceAngle.y, c);
    const double roll = rollDraw * std::pow(g.reduceAngle.z, c);

    // Our extensions: aerial roots (a root state's stems and all drawn from them) and the
    // straight leader (every order-0 shoot stem straight up).
    const GrammarRoots& rt = o.roots[pd.state];
    const bool root = rt.enabled || (pd.parentStem >= 0 && d.stems[pd.parentStem].root);
    const double pillarWidth = rt.enabled ? r.uniform(rt.pillarWidthLo, rt.pillarWidthHi) : 0.0;
    const bool vertical = rt.enabled && rt.form == RootForm::kVertical;
    const bool straight = o.straightLeader && pd.order == 0 && !root;
    double tropism = g.tropism, bend = curve;
    if (straight || vertical) tilt = tropism = bend = 0.0;

    const Attachment at = attachment(d, pd.parentStem, position);
    if (!at.grown) {  // on the part of a stopped parent that never grew
        ++d.stats.shyStopped;
        return;
    }
    if (pd.distichousSide >= 0) azimuth += distichousAngle(at, pd.distichousSide);
    // Intrinsic Euler angles: azimuth about the parent's tangent, tilt away from it, roll
    // about the new axis.
    const Vec3 side = rotate(at.normal, at.tangent, azimuth);
    Vec3 dir = normalize(at.tangent * std::cos(tilt) + side * std::sin(tilt));
    Vec3 refN = rotate(normalize(at.tangent * -std::sin(tilt) + side * std::cos(tilt)), dir, roll);
    if (straight || vertical) {
        dir = straight ? Vec3{0, 1, 0} : Vec3{0, -1, 0};
        refN = rotate(normalize(side - dir * dot(side, dir)), dir, roll);
        if (!(length(refN) > 1e-9)) refN = anyPerpendicular(dir);
    }
    if (!root && !straight && length2(o.lightTropism) > 0) {
        // A trunk (order 0) leans by half the tropism; a branch turns toward the light about
        // the vertical, its rise kept (so a tree among neighbours grows no taller than alone:
        // its crown-shyness planes hold up to the height it has alone).
        const Vec3 h{dir.x, 0, dir.z};
        const double lh = length(h);
        if (pd.order == 0) {
            dir = normalize(dir + o.lightTropism * 0.5);
        } else if (lh > 1e-9) {
            const Vec3 turned = normalize(h / lh + o.lightTropism) * lh;
            dir = normalize(Vec3{turned.x, dir.y, turned.z});
        }
        refN = refN - dir * dot(refN, dir);
        refN = length(refN) > 1e-9 ? normalize(refN) : anyPerpendicular(dir);
    }

    double tau = 0.0;
    const std::vector<Vec3> ctrl =
        controlPoints(d, g, tropism, at.base, dir, len, bend, noiseOrigin, tau);
    const int m = static_cast<int>(ctrl.size());
    const double wanted = std::max(1.0, std::ceil(len / o.segmentLength - 1e-9));
    const int64_t nodes =
        static_cast<int64_t>(d.tree.nodes.size()) + static_cast<int64_t>(std::min(wanted, 1e18));
    if (nodes > d.guard.budget().maxSkeletonNodes) {  // (the message only when it is needed)
        d.guard.skeletonNodes(nodes, " (stem " + std::to_string(d.stems.size()) + ", " +
                                         formatSize(wanted) + " segments)");
    }
    d.guard.work(d.work, static_cast<uint64_t>(wanted) + 64);
    int segments = static_cast<int>(wanted);
    if (bend > 0 || tau > 0) segments = std::max(segments, 2 * (m - 1));

    GrammarStem st;
    st.state = pd.state;
    st.parent = pd.parentStem;
    st.level = c;
    st.order = pd.order;
    st.key = pd.key;
    st.baseNode = at.node;
    st.length = len;
    st.direction = dir;
    st.parentTangent = at.tangent;
    st.widthBegin = at.width * g.reduceWidthBegin;
    st.widthEnd = at.width * g.reduceWidthEnd;
    st.root = root;
    StemSamples ss = sampleSpline(ctrl, segments, at.base);
    if (rt.enabled) {
        st.rooted = cutAtGround(ss);
        if (st.rooted && pillarWidth > 0) st.widthBegin = st.widthEnd = pillarWidth;
        ++d.stats.roots;
        d.stats.rooted += st.rooted;
    } else if (!root && o.groundClearance > 0) {
        clearGround(ss, o.groundClearance);
    }
    const int drawn = static_cast<int>(ss.point.size()) - 1;
    if (!root && pd.order == 0 && !o.shyBounds.empty()) {
        slideInsideBounds(ss, o.shyBounds);  // a trunk is never stopped
    } else if (!root && !o.shyBounds.empty()) {
        const double u = d.rng.derive(hashCombine(pd.key, kShyTag)).uniform();
        const int kept = keepInsideBounds(ss, o.shyBounds, u);
        if (kept < drawn) {
            ++d.stats.shyStopped;
            if (kept == 0) return;
            // The width tapers as along the drawn stem: its end is the width where it stopped.
            st.widthEnd = lerp(st.widthBegin, st.widthEnd, static_cast<double>(kept) / drawn);
        }
    }
    StemCurve sc = addNodes(d, ss, at, dir, refN, pd.order, c, root ? kRootPart : kShootPart, st);
    sc.drawnSegments = drawn;

    d.tree.endpoints.push_back(st.nodes.back());
    d.stats.depthReached = std::max(d.stats.depthReached, c + 1);
    const int stemIndex = static_cast<int>(d.stems.size());
    d.stems.push_back(std::move(st));
    d.curves.push_back(std::move(sc));
    expand(d, pd.state, stemIndex, c + 1, pd.order, pd.key);
}

// A point at fraction a of a stem's sampled curve: position, tangent, normal, width, node.
void pointAt(const StemCurve& sc, double a, Vec3& p, Vec3& t, Vec3& n, double& w, int32_t& node) {
    const int segs = static_cast<int>(sc.point.size()) - 1;
    const double x = std::clamp(a, 0.0, 1.0) * segs;
    const int i = std::min(static_cast<int>(std::floor(x)), segs - 1);
    const double f = x - i;
    p = sc.point[i] + (sc.point[i + 1] - sc.point[i]) * f;
    t = normalize(sc.tangent[i] * (1 - f) + sc.tangent[i + 1] * f);
    n = sc.normal[i] * (1 - f) + sc.normal[i + 1] * f;
    n = n - t * dot(n, t);
    n = length(n) > 1e-9 ? normalize(n) : anyPerpendicular(t);
    w = lerp(sc.width[i], sc.width[i + 1], f);
    node = sc.node[f < 0.5 ? i : i + 1];
}

// The tree's height range, for the leaves' size and colour by relative height.
struct HeightRange {
    double lo, span;
};
HeightRange heightRange(const Tree& tree) {
    double yLo = 1e300, yHi = -1e300;
    for (const SkeletonNode& n : tree.nodes) {
        yLo = std::min(yLo, n.position.y);
        yHi = std::max(yHi, n.position.y);
    }
    return {yLo, std::max(1e-9, yHi - yLo)};
}

// Jain §3.2: the particle leaves of one stem, lighter and smaller higher up; the season's
// density keeps a subset (the first draw of each leaf decides its presence).
void emitParticles(Derivation& d, size_t si, const HeightRange& y) {
    const GrammarStem& st = d.stems[si];
    const StemCurve& sc = d.curves[si];
    const GrammarParticles& pp = d.o.particles[st.state];
    const SeasonPalette& season = d.o.seasons[static_cast<int>(d.o.season)];
    const int classes = static_cast<int>(season.classes.size());
    if (!(pp.enabled && st.level >= pp.minLevel && classes > 0 && season.density > 0)) return;
    const Rng stream = d.rng.derive(hashCombine(st.key, kLeafTag));
    // Our extension: `per_metre` more leaves per metre of the leafy stretch of the stem's
    // sampled curve, all of them then spread evenly along it (stratified: one in each of n
    // equal sub-intervals) so they cover the stem without gaps or clumps.
    double wanted = pp.count;
    if (pp.perMetre > 0) {
        double arc = 0.0;
        for (size_t i = 1; i < sc.point.size(); ++i) arc += distance(sc.point[i - 1], sc.point[i]);
        wanted += std::round(pp.perMetre * arc * (pp.alongHi - pp.alongLo));
    }
    const int64_t leaves =
        static_cast<int64_t>(d.tree.leaves.size()) + static_cast<int64_t>(std::min(wanted, 1e18));
    if (leaves > d.guard.budget().maxLeaves) {
        d.guard.leaves(leaves, " (particles of stem " + std::to_string(si) + ")");
    }
    d.guard.work(d.work, static_cast<uint64_t>(wanted) * 16);
    const int n = static_cast<int>(wanted);
    for (int k = 0; k < n; ++k) {
        Rng lr = stream.derive(static_cast<uint64_t>(k));
        if (lr.uniform() >= season.density) continue;
        const double a = pp.perMetre > 0
                             ? pp.alongLo + (pp.alongHi - pp.alongLo) * (k + lr.uniform()) / n
                             : lr.uniform(pp.alongLo, pp.alongHi);
        // Around the stem: anywhere ("spiral"), or alternately on the two sides of the stem's
        // plane (leaflets of a pinnate frond, distichous leaves).
        const double uPsi = lr.uniform();
        const double psi = pp.twoRows
                               ? (k % 2 ? 0.5 : -0.5) * kPi + (uPsi - 0.5) * 0.5 * pp.randomness
                               : uPsi * 2 * kPi;
        const double uRot = lr.uniform(), uSize = lr.uniform(), uColour = lr.uniform();
        Vec3 p, t, n;
        double w;
        int32_t node;
        pointAt(sc, a, p, t, n, w, node);
        const double h = std::clamp((p.y - y.lo) / y.span, 0.0, 1.0);
        const double rho = lerp(pp.rotationLo, pp.rotationHi, lerp(0.5, uRot, pp.randomness));
        const Vec3 side = rotate(n, t, psi);
        Leaf leaf;
        // Larger, older leaves low; smaller, newer leaves high (Jain §3.2).
        leaf.size = lerp(pp.sizeHi, pp.sizeLo, lerp(h, uSize, pp.randomness));
        leaf.aspect = pp.aspect;
        leaf.shape = pp.shape;
        leaf.tangent = normalize(t * std::cos(rho) + side * std::sin(rho));
        leaf.normal = normalize(t * -std::sin(rho) + side * std::cos(rho));
        leaf.position = p + side * (0.5 * w) + leaf.tangent * (0.5 * leaf.size);
        const int ci =
            std::clamp(static_cast<int>(std::floor(h * classes - 0.5 + uColour)), 0, classes - 1);
        leaf.colour = season.classes[ci];
        leaf.node = node;
        d.tree.leaves.push_back(leaf);
        ++d.stats.leaves;
    }
}

// The fruit or flower cards of one stem, hanging from it, in the seasons they appear.
void emitFruit(Derivation& d, size_t si) {
    const GrammarStem& st = d.stems[si];
    const StemCurve& sc = d.curves[si];
    const GrammarFruit& fr = d.o.fruit[st.state];
    if (!(fr.enabled && st.level >= fr.minLevel && fr.seasons[static_cast<int>(d.o.season)])) {
        return;
    }
    const Rng stream = d.rng.derive(hashCombine(st.key, kFruitTag));
    const int64_t leaves = static_cast<int64_t>(d.tree.leaves.size()) + fr.count;
    if (leaves > d.guard.budget().maxLeaves) {
        d.guard.leaves(leaves, " (fruit of stem " + std::to_string(si) + ")");
    }
    for (int k = 0; k < fr.count; ++k) {
        Rng fr2 = stream.derive(static_cast<uint64_t>(k));
        const double a = fr2.uniform(fr.alongLo, fr.alongHi);
        const double size = fr2.uniform(fr.sizeLo, fr.sizeHi);
        const double turn = fr2.uniform(0.0, 2 * kPi);
        Vec3 p, t, n;
        double w;
        int32_t node;
        pointAt(sc, a, p, t, n, w, node);
        Leaf card;
        card.size = size;
        card.aspect = fr.aspect;
        card.tangent = {0, -1, 0};  // hanging
        card.normal = {std::cos(turn), 0.0, std::sin(turn)};
        card.position = p + Vec3{0, -(0.5 * size + 0.5 * w), 0};
        card.colour = fr.colour;
        card.node = node;
        d.tree.leaves.push_back(card);
        ++d.stats.fruit;
    }
}

}  // namespace

Tree growGrammar(const GrammarOptions& o, Rng& rng, GrammarStats* statsOut,
                 std::vector<GrammarStem>* stemsOut, const GrowthGuard& guard) {
    const int maxDepth = o.maxDepth > 0 ? o.maxDepth : GrammarOptions::kMaxLevels;
    const double trunkWidth = rng.derive("trunk_width").uniform(o.trunkWidthLo, o.trunkWidthHi);
    const uint64_t noiseSeed = hashCombine(rng.seed(), hashString("curve-noise"));
    Derivation d{o, guard, 0, rng, maxDepth, trunkWidth, noiseSeed, {}, {}, {}, {}, {}};
    SkeletonNode root;
    root.radius = 0.5 * trunkWidth;
    d.tree.nodes.push_back(root);

    // The derivation, breadth first from the start rule (§3.1.1), one stem per output.
    expand(d, o.start, -1, 0, 0, kRootKey);
    for (size_t head = 0; head < d.queue.size(); ++head) {
        const Pending pd = d.queue[head];
        if (static_cast<int64_t>(d.stems.size()) >= o.maxStems) {
            ++d.stats.truncated;
            continue;
        }
        drawStem(d, pd);
    }
    d.stats.stems = static_cast<int64_t>(d.stems.size());

    // Particles along the stems (§3.2).
    const HeightRange y = heightRange(d.tree);
    for (size_t si = 0; si < d.stems.size(); ++si) {
        emitParticles(d, si, y);
        emitFruit(d, si);
    }
    // Crown shyness: a leaf or fruit card whose centre lies beyond a bound (on a stopped
    // branch's last stretch, or a stem moved onto a plane) is not kept.
    if (!o.shyBounds.empty()) {
        std::vector<Leaf>& leaves = d.tree.leaves;
        const auto kept = std::remove_if(leaves.begin(), leaves.end(), [&](const Leaf& l) {
            return !keepsAll(o.shyBounds, l.position);
        });
        d.stats.shyLeaves = leaves.end() - kept;
        leaves.erase(kept, leaves.end());
    }

    if (statsOut) *statsOut = d.stats;
    if (stemsOut) *stemsOut = std::move(d.stems);
    return std::move(d.tree);
}

}  // namespace sylva
