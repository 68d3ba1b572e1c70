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
constexpr uint64_t kRuleTag = 1, kEvenTag = 2, kLeafTag = 3, kFruitTag = 4;

double lerp(double a, double b, double t) { return a + (b - a) * t; }

// A stem's sampled points: index 0 is the attachment (its base node), then its own nodes.
struct StemCurve {
    std::vector<Vec3> point, tangent, normal;
    std::vector<double> width;  // metres (diameter)
    std::vector<int32_t> node;  // skeleton node of each point
};

struct Pending {
    int state;
    int parentStem;  // −1: the start rule
    int level;
    int order;
    uint64_t key;
    bool even;
    double evenAngle;  // slot angle when even, radians
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

std::array<GrammarSeason, 4> defaultSeasons() {
    std::array<GrammarSeason, 4> s;
    s[static_cast<int>(Season::kSpring)] = {{1, 2, 3}, 0.6};
    s[static_cast<int>(Season::kSummer)] = {{0, 1, 2, 3}, 1.0};
    s[static_cast<int>(Season::kAutumn)] = {{4, 5, 6, 7}, 0.8};
    s[static_cast<int>(Season::kWinter)] = {{}, 0.0};
    return s;
}

int GrammarOptions::state(const std::string& name) {
    for (size_t i = 0; i < states.size(); ++i) {
        if (states[i] == name) return static_cast<int>(i);
    }
    states.push_back(name);
    stop.push_back(false);
    rules.emplace_back();
    particles.emplace_back();
    fruit.emplace_back();
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

Tree growGrammar(const GrammarOptions& o, Rng& rng, GrammarStats* statsOut,
                 std::vector<GrammarStem>* stemsOut) {
    GrammarStats stats;
    std::vector<GrammarStem> stems;
    std::vector<StemCurve> curves;
    Tree tree;

    const int maxDepth = o.maxDepth > 0 ? o.maxDepth : GrammarOptions::kMaxLevels;
    const double trunkWidth = rng.derive("trunk_width").uniform(o.trunkWidthLo, o.trunkWidthHi);
    const uint64_t noiseSeed = hashCombine(rng.seed(), hashString("curve-noise"));

    SkeletonNode root;
    root.radius = 0.5 * trunkWidth;
    tree.nodes.push_back(root);

    std::vector<Pending> queue;
    // Applies `state`'s rule for the stem `parent` (−1: the start rule) and queues the
    // outputs; the alternative is drawn from the parent's own keyed stream.
    auto expand = [&](int state, int parentStem, int level, int order, uint64_t key) {
        const std::vector<GrammarAlternative>& alts = o.rules[state];
        if (alts.empty()) return;
        if (level >= maxDepth) {
            ++stats.truncated;
            return;
        }
        Rng pick = rng.derive(hashCombine(key, kRuleTag));
        const double u = pick.uniform();
        size_t a = 0;
        for (double acc = alts[0].p; a + 1 < alts.size() && u >= acc; acc += alts[++a].p) {
        }
        const std::vector<int>& out = alts[a].out;
        // Jain §3.1.2 Euler angles; "even" siblings share one random offset (our extension).
        int evenCount = 0;
        for (int s : out) {
            if (!o.stop[s] && o.geometry(state, s).evenSpread) ++evenCount;
        }
        const double evenOffset = rng.derive(hashCombine(key, kEvenTag)).uniform(0.0, 2 * kPi);
        int evenSlot = 0;
        bool continued = false;
        for (size_t i = 0; i < out.size(); ++i) {
            const int s = out[i];
            if (o.stop[s]) {
                ++stats.stopStates;
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
            p.even = o.geometry(state, s).evenSpread;
            p.evenAngle = p.even ? evenOffset + 2 * kPi * evenSlot++ / evenCount : 0.0;
            queue.push_back(p);
        }
    };

    expand(o.start, -1, 0, 0, kRootKey);
    for (size_t head = 0; head < queue.size(); ++head) {
        const Pending pd = queue[head];
        if (static_cast<int64_t>(stems.size()) >= o.maxStems) {
            ++stats.truncated;
            continue;
        }
        const int parentState = pd.parentStem >= 0 ? stems[pd.parentStem].state : o.start;
        const GrammarGeometry& g = o.geometry(parentState, pd.state);
        Rng r = rng.derive(pd.key);
        const int c = pd.level;

        // Draws, always in this order from the stem's own stream.
        const double baseLength = r.uniform(g.lengthLo, g.lengthHi);
        const double azimuthDraw = r.uniform(g.azimuthLo, g.azimuthHi);
        const double tiltDraw = r.uniform(g.tiltLo, g.tiltHi);
        const double rollDraw = r.uniform(g.rollLo, g.rollHi);
        const double position = r.uniform(g.positionLo, g.positionHi);
        const double curve = r.uniform(g.curveLo, g.curveHi);
        const Vec3 noiseOrigin{r.uniform(0, 1000), r.uniform(0, 1000), r.uniform(0, 1000)};

        // Jain §3.1.2: t_l = b_l · r_l^c and t_a = b_a · r_a^c.
        const double len = baseLength * std::pow(g.reduceLength, c);
        const double azimuth =
            (pd.even ? pd.evenAngle : 0.0) + azimuthDraw * std::pow(g.reduceAngle.x, c);
        const double tilt = tiltDraw * std::pow(g.reduceAngle.y, c);
        const double roll = rollDraw * std::pow(g.reduceAngle.z, c);

        // Attachment: the parent's sampled point nearest the drawn fraction of its length.
        Vec3 base, parentT, parentN;
        double w;
        int32_t baseNode;
        if (pd.parentStem < 0) {
            base = {0, 0, 0};
            parentT = {0, 1, 0};
            parentN = {1, 0, 0};
            w = trunkWidth;
            baseNode = 0;
        } else {
            const StemCurve& pc = curves[pd.parentStem];
            const int n = static_cast<int>(pc.point.size()) - 1;
            // Index 0 is the grandparent's node: a child grows from one of its parent's own.
            const int j = std::clamp(static_cast<int>(std::lround(position * n)), 1, n);
            base = pc.point[j];
            parentT = pc.tangent[j];
            parentN = pc.normal[j];
            w = pc.width[j];
            baseNode = pc.node[j];
        }
        // Intrinsic Euler angles: azimuth about the parent's tangent, tilt away from it,
        // roll about the new axis.
        const Vec3 side = rotate(parentN, parentT, azimuth);
        const Vec3 dir = normalize(parentT * std::cos(tilt) + side * std::sin(tilt));
        const Vec3 refN =
            rotate(normalize(parentT * -std::sin(tilt) + side * std::cos(tilt)), dir, roll);

        // Centre line: a circular arc turning toward −y (tropism > 0) or +y, never past the
        // vertical; then control points displaced by value noise ∝ curve · length.
        double tau = g.tropism;
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
                const Vec3 n{valueNoise3(q, noiseSeed),
                             valueNoise3(q + Vec3{31.7, 0, 0}, noiseSeed),
                             valueNoise3(q + Vec3{0, 57.3, 0}, noiseSeed)};
                p += n * (curve * len * k / (m - 1));
            }
            ctrl[k] = p;
        }

        int segments = std::max(1, static_cast<int>(std::ceil(len / o.segmentLength - 1e-9)));
        if (curve > 0 || tau > 0) segments = std::max(segments, 2 * (m - 1));

        StemCurve sc;
        GrammarStem st;
        st.state = pd.state;
        st.parent = pd.parentStem;
        st.level = c;
        st.order = pd.order;
        st.key = pd.key;
        st.baseNode = baseNode;
        st.length = len;
        st.direction = dir;
        st.parentTangent = parentT;
        st.widthBegin = w * g.reduceWidthBegin;
        st.widthEnd = w * g.reduceWidthEnd;

        Vec3 prevN = refN;
        for (int i = 0; i <= segments; ++i) {
            Vec3 pos, der;
            catmullRom(ctrl, static_cast<double>(i) * (m - 1) / segments, pos, der);
            if (i == 0) pos = base;
            const Vec3 t = length(der) > 1e-12 ? normalize(der) : dir;
            Vec3 nn = prevN - t * dot(prevN, t);  // parallel transport of the reference
            nn = length(nn) > 1e-9 ? normalize(nn) : anyPerpendicular(t);
            prevN = nn;
            const double width =
                lerp(st.widthBegin, st.widthEnd, static_cast<double>(i) / segments);
            int32_t node = baseNode;
            if (i > 0) {
                SkeletonNode sn;
                sn.position = pos;
                sn.radius = 0.5 * width;
                sn.parent = i == 1 ? baseNode : static_cast<int32_t>(tree.nodes.size()) - 1;
                sn.order = pd.order;
                sn.level = c;
                node = static_cast<int32_t>(tree.nodes.size());
                tree.nodes.push_back(sn);
                st.nodes.push_back(node);
            }
            sc.point.push_back(pos);
            sc.tangent.push_back(t);
            sc.normal.push_back(nn);
            sc.width.push_back(width);
            sc.node.push_back(node);
        }
        tree.endpoints.push_back(st.nodes.back());
        stats.depthReached = std::max(stats.depthReached, c + 1);
        const int stemIndex = static_cast<int>(stems.size());
        stems.push_back(std::move(st));
        curves.push_back(std::move(sc));
        expand(pd.state, stemIndex, c + 1, pd.order, pd.key);
    }
    stats.stems = static_cast<int64_t>(stems.size());

    // Jain §3.2: particle leaves along each stem's spline, lighter and smaller higher up.
    double yLo = 1e300, yHi = -1e300;
    for (const SkeletonNode& n : tree.nodes) {
        yLo = std::min(yLo, n.position.y);
        yHi = std::max(yHi, n.position.y);
    }
    const double ySpan = std::max(1e-9, yHi - yLo);
    const GrammarSeason& season = o.seasons[static_cast<int>(o.season)];
    const int classes = static_cast<int>(season.classes.size());

    // A point at fraction a of a stem's sampled curve: position, tangent, normal, width, node.
    auto pointAt = [](const StemCurve& sc, double a, Vec3& p, Vec3& t, Vec3& n, double& w,
                      int32_t& node) {
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
    };

    for (size_t si = 0; si < stems.size(); ++si) {
        const GrammarStem& st = stems[si];
        const StemCurve& sc = curves[si];
        const GrammarParticles& pp = o.particles[st.state];
        if (pp.enabled && st.level >= pp.minLevel && classes > 0 && season.density > 0) {
            const Rng stream = rng.derive(hashCombine(st.key, kLeafTag));
            for (int k = 0; k < pp.count; ++k) {
                Rng lr = stream.derive(static_cast<uint64_t>(k));
                // First draw decides presence: a sparser season keeps a subset of the leaves.
                if (lr.uniform() >= season.density) continue;
                const double a = lr.uniform(pp.alongLo, pp.alongHi);
                // Around the stem: anywhere ("spiral"), or alternately on the two sides of the
                // stem's plane (leaflets of a pinnate frond, distichous leaves).
                const double uPsi = lr.uniform();
                const double psi =
                    pp.twoRows ? (k % 2 ? 0.5 : -0.5) * kPi + (uPsi - 0.5) * 0.5 * pp.randomness
                               : uPsi * 2 * kPi;
                const double uRot = lr.uniform(), uSize = lr.uniform(), uColour = lr.uniform();
                Vec3 p, t, n;
                double w;
                int32_t node;
                pointAt(sc, a, p, t, n, w, node);
                const double h = std::clamp((p.y - yLo) / ySpan, 0.0, 1.0);
                const double rho =
                    lerp(pp.rotationLo, pp.rotationHi, lerp(0.5, uRot, pp.randomness));
                const Vec3 side = rotate(n, t, psi);
                Leaf leaf;
                // Larger, older leaves low; smaller, newer leaves high (Jain §3.2).
                leaf.size = lerp(pp.sizeHi, pp.sizeLo, lerp(h, uSize, pp.randomness));
                leaf.aspect = pp.aspect;
                leaf.tangent = normalize(t * std::cos(rho) + side * std::sin(rho));
                leaf.normal = normalize(t * -std::sin(rho) + side * std::cos(rho));
                leaf.position = p + side * (0.5 * w) + leaf.tangent * (0.5 * leaf.size);
                const int ci = std::clamp(static_cast<int>(std::floor(h * classes - 0.5 + uColour)),
                                          0, classes - 1);
                leaf.colour = season.classes[ci];
                leaf.node = node;
                tree.leaves.push_back(leaf);
                ++stats.leaves;
            }
        }
        const GrammarFruit& fr = o.fruit[st.state];
        if (fr.enabled && st.level >= fr.minLevel && fr.seasons[static_cast<int>(o.season)]) {
            const Rng stream = rng.derive(hashCombine(st.key, kFruitTag));
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
                tree.leaves.push_back(card);
                ++stats.fruit;
            }
        }
    }

    if (statsOut) *statsOut = stats;
    if (stemsOut) *stemsOut = std::move(stems);
    return tree;
}

}  // namespace sylva
