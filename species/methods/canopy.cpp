// The `canopy` method (Shesh et al. §3): leaves on a canopy envelope, and an L-system branch
// template scaled to outgrow the envelope and clipped against it.
#include "species/methods/canopy.h"

#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/Search_traits_adapter.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/property_map.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <utility>

#include "volumes/point_grid.h"

namespace sylva {

namespace {

constexpr int kCellsPhi = 256, kCellsTheta = 128;  // surface sampler grid
constexpr double kBoleSegment = 0.5;  // a straight bole is cut into segments this long, metres
constexpr double kClusterSpread = 60.0 * kPi / 180.0;  // cluster leaves from their twig's axis

bool isSpace(char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; }

// Rotates two vectors of the turtle frame by `angle` about the third, `axis` (right-handed).
void turn(Vec3& a, Vec3& b, const Vec3& axis, double angle) {
    a = rotate(a, axis, angle);
    b = rotate(b, axis, angle);
}

}  // namespace

// --- L-system ------------------------------------------------------------------------------

bool isLSystemSymbol(char c) {
    if (c >= 'A' && c <= 'Z') return true;
    switch (c) {
        case '+':
        case '-':
        case '&':
        case '^':
        case '\\':
        case '/':
        case '|':
        case '[':
        case ']':
            return true;
        default:
            return false;
    }
}

std::string checkLSystemWord(const std::string& word) {
    int depth = 0;
    for (size_t i = 0; i < word.size(); ++i) {
        const char c = word[i];
        if (isSpace(c)) continue;
        if (!isLSystemSymbol(c)) {
            std::string what = c == 'f'   ? " (moving without drawing would disconnect the "
                                            "skeleton; use F)"
                               : c == '!' ? " (widths come from Murray's rule)"
                                          : "";
            // A non-ASCII symbol is named whole (all its UTF-8 bytes), not as a stray byte.
            std::string symbol(1, c);
            for (size_t j = i + 1;
                 (static_cast<unsigned char>(c) & 0xC0) == 0xC0 && j < word.size() &&
                 (static_cast<unsigned char>(word[j]) & 0xC0) == 0x80;
                 ++j) {
                symbol += word[j];
            }
            return "unknown L-system symbol '" + symbol + "' at position " + std::to_string(i + 1) +
                   " of \"" + word + "\"" + what +
                   "; known: F (draw), A-Z (variables), + - & ^ \\ / | [ ]";
        }
        if (c == '[') ++depth;
        if (c == ']' && --depth < 0) {
            return "']' without a matching '[' at position " + std::to_string(i + 1) + " of \"" +
                   word + "\"";
        }
    }
    if (depth > 0) return "unclosed '[' in \"" + word + "\"";
    return "";
}

std::string expandLSystem(const LSystem& system, int iterations, Rng& rng) {
    std::string word;
    for (char c : system.axiom)
        if (!isSpace(c)) word.push_back(c);
    // Rules by symbol in a flat table (the word can be millions of symbols long).
    const std::vector<LSystemSuccessor>* rule[256] = {};
    for (const auto& [symbol, successors] : system.rules) {
        if (!successors.empty()) rule[static_cast<unsigned char>(symbol)] = &successors;
    }
    std::string next;
    for (int it = 0; it < iterations; ++it) {
        next.clear();
        for (char c : word) {
            const auto* r = rule[static_cast<unsigned char>(c)];
            if (!r) {
                next.push_back(c);
                continue;
            }
            const LSystemSuccessor* chosen = &r->front();
            if (r->size() > 1) {  // stochastic: one draw per occurrence
                double u = rng.uniform();
                for (const LSystemSuccessor& s : *r) {
                    chosen = &s;
                    if (u < s.probability) break;
                    u -= s.probability;
                }
            }
            for (char s : chosen->text)
                if (!isSpace(s)) next.push_back(s);
        }
        word.swap(next);
    }
    return word;
}

LSystemSize lsystemSizeBound(const LSystem& system, int iterations) {
    std::vector<double> count(256, 0.0);
    for (char c : system.axiom)
        if (!isSpace(c)) count[static_cast<unsigned char>(c)] += 1.0;
    // produce[s][t]: the most t's any successor of s holds.
    std::vector<std::vector<double>> produce(256);
    for (const auto& [symbol, successors] : system.rules) {
        std::vector<double> most(256, 0.0);
        for (const LSystemSuccessor& s : successors) {
            std::vector<double> n(256, 0.0);
            for (char c : s.text)
                if (!isSpace(c)) n[static_cast<unsigned char>(c)] += 1.0;
            for (int t = 0; t < 256; ++t) most[t] = std::max(most[t], n[t]);
        }
        if (!successors.empty()) produce[static_cast<unsigned char>(symbol)] = std::move(most);
    }
    for (int it = 0; it < iterations; ++it) {
        std::vector<double> next(256, 0.0);
        for (int s = 0; s < 256; ++s) {
            if (count[s] == 0.0) continue;
            if (produce[s].empty()) {
                next[s] += count[s];
                continue;
            }
            for (int t = 0; t < 256; ++t) next[t] += count[s] * produce[s][t];
        }
        count.swap(next);
    }
    LSystemSize size;
    for (double c : count) size.length += c;
    size.segments = count['F'];
    return size;
}

// --- turtle and radii --------------------------------------------------------------------------

Tree interpretTurtle(const std::string& word, const BranchTemplate& t, Rng& rng) {
    struct State {
        Vec3 pos{0, 0, 0}, h{0, 1, 0}, l{-1, 0, 0}, u{0, 0, 1};  // heading, left, up
        int32_t node = 0;
        int32_t depth = 0;
        double step = 1.0;
    };
    Tree tree;
    tree.nodes.push_back(SkeletonNode{});
    State s;
    s.step = t.step;
    std::vector<State> stack;
    auto angle = [&](double a) {
        return t.angleJitter > 0.0 ? a + rng.uniform(-t.angleJitter, t.angleJitter) : a;
    };
    for (char c : word) {
        switch (c) {
            case 'F': {
                s.pos = s.pos + s.h * s.step;
                SkeletonNode n;
                n.position = s.pos;
                n.parent = s.node;
                n.order = n.level = s.depth;
                tree.nodes.push_back(n);
                s.node = static_cast<int32_t>(tree.nodes.size() - 1);
                break;
            }
            // Right-handed rotations: about up, h turns toward left (u × h = l); about left,
            // h turns toward −up (l × h = −u: pitch down); about the heading, l toward up.
            case '+':
                turn(s.h, s.l, s.u, angle(t.angle));
                break;
            case '-':
                turn(s.h, s.l, s.u, -angle(t.angle));
                break;
            case '&':
                turn(s.h, s.u, s.l, angle(t.angle));
                break;
            case '^':
                turn(s.h, s.u, s.l, -angle(t.angle));
                break;
            case '\\':
                turn(s.l, s.u, s.h, angle(t.roll));
                break;
            case '/':
                turn(s.l, s.u, s.h, -angle(t.roll));
                break;
            case '|':
                turn(s.h, s.l, s.u, kPi);
                break;
            case '[':
                stack.push_back(s);
                ++s.depth;
                s.step *= t.lengthRatio;
                break;
            case ']':
                if (!stack.empty()) {
                    s = stack.back();
                    stack.pop_back();
                }
                break;
            default:
                break;  // variables and whitespace
        }
        if (c != 'F' && c != '[' && c != ']') {
            // Keep the frame orthonormal over long words.
            s.h = normalize(s.h);
            s.l = normalize(s.l - s.h * dot(s.l, s.h));
            s.u = cross(s.h, s.l);
        }
    }
    return tree;
}

void murrayRadii(Tree& tree, double tipRadius, double exponent) {
    const size_t n = tree.nodes.size();
    if (n == 0) return;
    std::vector<double> sum(n, 0.0);  // Σ r_childⁿ per node
    std::vector<char> hasChild(n, 0);
    for (size_t i = n; i-- > 0;) {
        SkeletonNode& node = tree.nodes[i];
        node.radius = hasChild[i] ? std::pow(sum[i], 1.0 / exponent) : tipRadius;
        if (node.parent >= 0) {
            sum[node.parent] += std::pow(node.radius, exponent);
            hasChild[node.parent] = 1;
        }
    }
}

// --- envelope test and surface sampling ----------------------------------------------------------

double envelopeRatio(const CanopyEnvelope& e, const Vec3& p) {
    constexpr double kInf = 1e300;
    const Vec2 a = e.angles(p);
    const Vec3 s = e.surfacePoint(a.x, a.y);
    if (e.domain() == CanopyDomain::kEllipsoid) {
        const double r = length(p), rs = length(s);
        if (rs > 0.0) return r / rs;
        return r > 0.0 ? kInf : 0.0;
    }
    const double ky = e.radii().y;
    const double rho = std::hypot(p.x, p.z), rhoS = std::hypot(s.x, s.z);
    double ratio = rhoS > 0.0 ? rho / rhoS : (rho > 0.0 ? kInf : 0.0);
    if (p.y > ky) ratio = std::max(ratio, p.y / ky);
    if (p.y < 0.0) ratio = std::max(ratio, 1.0 - p.y / ky);
    return ratio;
}

double envelopeDepth(const CanopyEnvelope& e, const Vec3& p) {
    const Vec2 a = e.angles(p);
    const Vec3 s = e.surfacePoint(a.x, a.y);
    if (e.domain() == CanopyDomain::kEllipsoid) return length(s) - length(p);
    // Cone: angles() clamps θ to the apex above it, where the surface radius is 0.
    return std::hypot(s.x, s.z) - std::hypot(p.x, p.z);
}

CanopySurfaceSampler::CanopySurfaceSampler(const CanopyEnvelope& e) {
    // Surface points at the cell corners: φ_i = 2πi/U (wrapping), θ_j = πj/V.
    std::vector<Vec3> p(size_t(kCellsPhi) * (kCellsTheta + 1));
    for (int j = 0; j <= kCellsTheta; ++j) {
        for (int i = 0; i < kCellsPhi; ++i) {
            p[size_t(j) * kCellsPhi + i] =
                e.surfacePoint(2 * kPi * i / kCellsPhi, kPi * j / kCellsTheta);
        }
    }
    const size_t cells = size_t(kCellsPhi) * kCellsTheta;
    cdf_.resize(cells);
    widthTop_.resize(cells);
    widthBottom_.resize(cells);
    double running = 0.0;
    for (int j = 0; j < kCellsTheta; ++j) {
        for (int i = 0; i < kCellsPhi; ++i) {
            const int i1 = (i + 1) % kCellsPhi;
            const Vec3& a = p[size_t(j) * kCellsPhi + i];
            const Vec3& b = p[size_t(j) * kCellsPhi + i1];
            const Vec3& c = p[size_t(j + 1) * kCellsPhi + i1];
            const Vec3& d = p[size_t(j + 1) * kCellsPhi + i];
            const double area = 0.5 * (length(cross(b - a, c - a)) + length(cross(c - a, d - a)));
            const size_t k = size_t(j) * kCellsPhi + i;
            running += area;
            cdf_[k] = running;
            widthTop_[k] = distance(a, b);
            widthBottom_[k] = distance(d, c);
        }
    }
    total_ = running;
}

Vec2 CanopySurfaceSampler::sample(Rng& rng) const {
    const double x = rng.uniform() * total_;
    size_t k = static_cast<size_t>(std::upper_bound(cdf_.begin(), cdf_.end(), x) - cdf_.begin());
    k = std::min(k, cdf_.size() - 1);
    const int i = static_cast<int>(k % kCellsPhi), j = static_cast<int>(k / kCellsPhi);
    const double a = rng.uniform();
    // Within the cell the width changes linearly from w0 (θ_j) to w1 (θ_{j+1}): draw b with
    // density ∝ (1 − b)·w0 + b·w1 by inverting its CDF.
    const double w0 = widthTop_[k], w1 = widthBottom_[k], xi = rng.uniform();
    double b = xi;
    if (std::abs(w1 - w0) > 1e-12 * (w0 + w1)) {
        b = (-w0 + std::sqrt(std::max(0.0, w0 * w0 + (w1 - w0) * (w0 + w1) * xi))) / (w1 - w0);
        b = std::clamp(b, 0.0, 1.0);
    }
    return {2 * kPi * (i + a) / kCellsPhi, kPi * (j + b) / kCellsTheta};
}

// --- growth -----------------------------------------------------------------------------------

double canopyTrunkHeight(const CanopyOptions& o) {
    if (o.branches.trunkHeight >= 0.0) return o.branches.trunkHeight;
    if (o.envelope->domain() == CanopyDomain::kCone) return o.position.y;
    // 10 % of the way from the lowest point on the axis (θ = π) to the centre.
    const double bottom = o.envelope->surfacePoint(0.0, kPi).y;  // ≤ 0
    return o.position.y + 0.9 * bottom;
}

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using KPoint = Kernel::Point_3;
using IndexedPoint = std::pair<KPoint, int32_t>;
using SearchTraits =
    CGAL::Search_traits_adapter<IndexedPoint, CGAL::First_of_pair_property_map<IndexedPoint>,
                                CGAL::Search_traits_3<Kernel>>;
using NeighbourSearch = CGAL::Orthogonal_k_neighbor_search<SearchTraits>;

// The template as a tree in the world frame: the bole (the chain below the template's first
// fork) stretched to reach the trunk top, the crown above it scaled to outgrow the envelope.
struct FittedTemplate {
    Tree tree;
    std::vector<char> bole;  // per node: part of the bole (never clipped)
    double scaleY = 1.0, scaleXZ = 1.0;
};

// The envelope's girth: the largest over θ rows of the mean horizontal radius over φ (not the
// bounds, which a lopsided base layer stretches on one side only).
double envelopeGirth(const CanopyEnvelope& env) {
    constexpr int kRows = 32, kCols = 64;
    double girth = 0.0;
    for (int j = 0; j <= kRows; ++j) {
        double sum = 0.0;
        for (int i = 0; i < kCols; ++i) {
            const Vec3 p = env.surfacePoint(2 * kPi * (i + 0.5) / kCols, kPi * j / kRows);
            sum += std::hypot(p.x, p.z);
        }
        girth = std::max(girth, sum / kCols);
    }
    return girth;
}

// How far the template reaches out of the envelope at crown scale (sxz, sy, sxz): per
// direction bin (8 in φ × 4 in θ, the envelope's angles from its centre) the largest
// envelopeRatio of the given crown points (relative to the trunk top), then the median over
// the bins the template reaches at all.
double medianReach(const CanopyEnvelope& env, const Vec3& centre, const Vec3& top,
                   const std::vector<Vec3>& rel, double sxz, double sy) {
    constexpr int kBinsPhi = 8, kBinsTheta = 4;
    std::vector<double> best(kBinsPhi * kBinsTheta, -1.0);
    for (const Vec3& d : rel) {
        const Vec3 local = top + Vec3{d.x * sxz, d.y * sy, d.z * sxz} - centre;
        const Vec2 a = env.angles(local);
        const int bp = std::min(kBinsPhi - 1, static_cast<int>(a.x / (2 * kPi) * kBinsPhi));
        const int bt = std::min(kBinsTheta - 1, static_cast<int>(a.y / kPi * kBinsTheta));
        double& b = best[size_t(bt) * kBinsPhi + bp];
        b = std::max(b, envelopeRatio(env, local));
    }
    std::vector<double> reached;
    for (double b : best)
        if (b >= 0.0) reached.push_back(b);
    if (reached.empty()) return 0.0;
    const size_t mid = reached.size() / 2;
    std::nth_element(reached.begin(), reached.begin() + mid, reached.end());
    return reached[mid];
}

FittedTemplate fitTemplate(const Tree& t, const CanopyOptions& o, double trunkTop, double yaw) {
    const CanopyEnvelope& env = *o.envelope;
    const Vec3 top{o.position.x, trunkTop, o.position.z};
    const ChildIndex children(t);
    // The first fork: follow single children from the root. No fork at all: no bole.
    int32_t fork = 0;
    while (children.count(fork) == 1) fork = children.child[children.offset[fork]];
    if (children.count(fork) == 0) fork = 0;
    const Vec3 forkPos = t.nodes[fork].position;

    FittedTemplate out;
    Tree& tree = out.tree;
    tree.nodes.push_back(SkeletonNode{});
    out.bole.push_back(1);
    // Bole: nodes 1..fork are a chain (see the header) — or a straight one when the template
    // has none that rises.
    std::vector<int32_t> map(t.nodes.size(), 0);
    if (fork > 0 && forkPos.y > 1e-9 * std::max(1.0, length(forkPos))) {
        // Scale so the fork reaches the trunk top's height, then shear it over the top.
        const double s = trunkTop / forkPos.y;
        const Vec3 shift{top.x - forkPos.x * s, 0.0, top.z - forkPos.z * s};
        for (int32_t i = 1; i <= fork; ++i) {
            SkeletonNode n = t.nodes[i];
            n.position = n.position * s;
            n.position = n.position + shift * (n.position.y / trunkTop);
            n.order = n.level = 0;
            map[i] = static_cast<int32_t>(tree.nodes.size());
            n.parent = map[t.nodes[i].parent];
            tree.nodes.push_back(n);
            out.bole.push_back(1);
        }
    } else {
        const int m = std::max(1, static_cast<int>(std::ceil(length(top) / kBoleSegment)));
        for (int k = 1; k <= m; ++k) {
            SkeletonNode n;
            n.position = top * (double(k) / m);
            n.parent = static_cast<int32_t>(tree.nodes.size() - 1);
            tree.nodes.push_back(n);
            out.bole.push_back(1);
        }
        map[fork] = static_cast<int32_t>(tree.nodes.size() - 1);
    }

    // Crown: every node after the fork, relative to it, turned by `yaw` about +y.
    const double cy = std::cos(yaw), sy = std::sin(yaw);
    auto rel = [&](const Vec3& p) {
        const Vec3 d = p - forkPos;
        return Vec3{cy * d.x + sy * d.z, d.y, -sy * d.x + cy * d.z};
    };
    // Shape of the scale: "uniform" keeps the template's proportions; "stretch" matches its
    // height above the trunk top and its horizontal reach to the envelope's (top of its bounds,
    // girth). Its size: bisection (in log scale) for the median reach = outgrow (§3.4: the
    // template "outgrows" the canopy, in most directions rather than only its widest).
    if (o.branches.fit != TemplateFit::kNone) {
        double heightT = 0.0, reachT = 0.0;
        std::vector<Vec3> probe;  // crown tips, at most ~2000 (strided): where the reach is
        std::vector<int32_t> tips;
        for (int32_t i = fork + 1; i < static_cast<int32_t>(t.nodes.size()); ++i) {
            const Vec3 d = rel(t.nodes[i].position);
            heightT = std::max(heightT, d.y);
            reachT = std::max(reachT, std::hypot(d.x, d.z));
            if (children.count(i) == 0) tips.push_back(i);
        }
        const size_t stride = std::max<size_t>(1, tips.size() / 2000);
        for (size_t k = 0; k < tips.size(); k += stride)
            probe.push_back(rel(t.nodes[tips[k]].position));
        double ay = 1.0, axz = 1.0;
        if (o.branches.fit == TemplateFit::kStretch && heightT > 0.0 && reachT > 0.0) {
            const double heightC = o.position.y + env.bounds().hi.y - trunkTop;
            const double reachC = envelopeGirth(env);
            ay = heightC / heightT;
            axz = reachC / reachT;
        }
        const double target = o.branches.outgrow;
        auto reach = [&](double m) {
            return medianReach(env, o.position, top, probe, m * axz, m * ay);
        };
        if (!probe.empty()) {
            double lo = 1.0, hi = 1.0;
            for (int k = 0; k < 60 && reach(lo) >= target; ++k) lo *= 0.5;
            for (int k = 0; k < 60 && reach(hi) < target; ++k) hi *= 2.0;
            for (int k = 0; k < 24; ++k) {
                const double mid = std::sqrt(lo * hi);
                (reach(mid) < target ? lo : hi) = mid;
            }
            out.scaleY = hi * ay;
            out.scaleXZ = hi * axz;
        }
    }
    for (size_t i = fork + 1; i < t.nodes.size(); ++i) {
        SkeletonNode n = t.nodes[i];
        const Vec3 d = rel(n.position);
        n.position = top + Vec3{d.x * out.scaleXZ, d.y * out.scaleY, d.z * out.scaleXZ};
        n.parent = map[n.parent];
        map[i] = static_cast<int32_t>(tree.nodes.size());
        tree.nodes.push_back(n);
        out.bole.push_back(0);
    }
    return out;
}

// Shesh §3.5: a segment whose end lies beyond the envelope (ratio > 1 + threshold) is cut,
// and so is everything above it. Parents precede children, so one pass suffices. With a leaf
// margin, a crown node less than the margin inside the surface is cut too. With cutAtSurface,
// the segment is shortened to where it leaves (bisection) instead of dropped — "ideally one
// must determine where the branch would intersect the canopy surface to clip it" (§3.5).
// `bole` (if given) gets the kept nodes' bole flags.
Tree clipTemplate(const FittedTemplate& f, const CanopyOptions& o,
                  std::vector<char>* bole = nullptr) {
    const std::vector<SkeletonNode>& nodes = f.tree.nodes;
    const double limit = 1.0 + o.branches.clipThreshold;
    const double margin = o.branches.leafMargin;
    auto keeps = [&](const Vec3& p) {
        if (!o.clip.empty() && !insideAll(o.clip, p)) return false;
        const Vec3 local = p - o.position;
        if (envelopeRatio(*o.envelope, local) > limit) return false;
        return !(margin > 0.0 && envelopeDepth(*o.envelope, local) < margin);
    };
    std::vector<int32_t> map(nodes.size(), -1);
    Tree out;
    for (size_t i = 0; i < nodes.size(); ++i) {
        const SkeletonNode& n = nodes[i];
        SkeletonNode kept = n;
        bool cut = false;
        if (i > 0) {
            if (map[n.parent] < 0) continue;
            if (!f.bole[i] && !keeps(n.position)) {
                if (!o.branches.cutAtSurface) continue;
                // The last point of the segment still kept (the parent is).
                const Vec3 a = out.nodes[map[n.parent]].position;
                double lo = 0.0, hi = 1.0;
                for (int k = 0; k < 30; ++k) {
                    const double mid = 0.5 * (lo + hi);
                    (keeps(a + (n.position - a) * mid) ? lo : hi) = mid;
                }
                if (lo * distance(a, n.position) < 1e-3) continue;
                kept.position = a + (n.position - a) * lo;
                cut = true;
            }
        }
        kept.parent = i > 0 ? map[n.parent] : -1;
        out.nodes.push_back(kept);
        if (bole) bole->push_back(f.bole[i]);
        // A cut node ends its branch: nothing above it is kept.
        map[i] = cut ? -1 : static_cast<int32_t>(out.nodes.size() - 1);
    }
    return out;
}

// A random unit vector perpendicular to the unit vector n.
Vec3 randomPerpendicular(const Vec3& n, Rng& rng) {
    Vec3 v = rng.unitVector();
    v = v - n * dot(v, n);
    return length(v) > 1e-6 ? normalize(v) : anyPerpendicular(n);
}

Vec3 leafNormal(const CanopyLeafOptions& o, const Vec3& sun, Rng& rng) {
    if (isInclinationDistribution(o.orientation)) return inclinedLeafNormal(o.orientation, rng);
    Vec3 n = rng.unitVector();
    // §3.2: "specify the position of the sun to modulate this random assignment".
    if (o.orientation == LeafOrientation::kSun) n = sun * o.sunWeight + n * (1.0 - o.sunWeight);
    return length(n) > 1e-9 ? normalize(n) : sun;
}

void placeCanopyLeaves(Tree& tree, const CanopyOptions& o, const CanopySurfaceSampler& sampler,
                       Rng& rng) {
    const CanopyLeafOptions& lo = o.leaves;
    const CanopyEnvelope& env = *o.envelope;
    const Vec3 sun = normalize(lo.sun);
    Rng positions = rng.derive("positions");
    std::vector<Vec2> angles(lo.count);
    tree.leaves.reserve(size_t(lo.count) * lo.cluster);
    for (int k = 0; k < lo.count; ++k) {
        Vec2 a = sampler.sample(positions);
        // An open base: positions below the leafy part are drawn again (the rest of the
        // surface stays uniform by area).
        for (int tries = 0; lo.openBase > 0.0 && a.y > kPi * (1.0 - lo.openBase) && tries < 1000;
             ++tries) {
            a = sampler.sample(positions);
        }
        angles[k] = a;
        const Vec3 s = env.surfacePoint(a.x, a.y);
        // Inward toward the centre (ellipsoid) or the axis at the same height (cone).
        const Vec3 centre =
            env.domain() == CanopyDomain::kEllipsoid ? Vec3{0, 0, 0} : Vec3{0, s.y, 0};
        const double depth = lo.depth > 0.0 ? positions.uniform(0.0, lo.depth) : 0.0;
        Vec3 at = o.position + centre + (s - centre) * (1.0 - depth);
        if (!o.clip.empty()) at = projectInside(o.clip, at);
        const Vec3 outward = length(s - centre) > 0.0 ? normalize(s - centre) : Vec3{0, 1, 0};
        const Vec3 n0 = leafNormal(lo, sun, positions);
        if (lo.cluster == 1) {
            Leaf leaf;
            leaf.position = at;
            leaf.normal = n0;
            leaf.tangent = randomPerpendicular(n0, positions);
            // Supported leaves point out of the crown from their base (the attachment, where
            // a twig will reach them): the same card, its near edge on the inner side.
            if (o.support.mode != LeafSupport::kNone && dot(leaf.tangent, outward) < 0.0) {
                leaf.tangent = -leaf.tangent;
            }
            leaf.size = positions.uniform(lo.sizeMin, lo.sizeMax);
            leaf.aspect = lo.aspect;
            leaf.shape = lo.shape;
            tree.leaves.push_back(leaf);
            continue;
        }
        // Figure 4(a): a short twig pointing out of the canopy with the leaves fanned around
        // its end, evenly in angle from a random start.
        const Vec3 twig = normalize(outward + positions.unitVector() * 0.5);
        const Vec3 e1 = randomPerpendicular(twig, positions), e2 = cross(twig, e1);
        // Supported: the twig ends at the position (its leaves' attachment, where the grown
        // twigs reach them, stays inside the canopy) instead of starting there.
        const Vec3 end = o.support.mode != LeafSupport::kNone ? at : at + twig * lo.twig;
        for (int j = 0; j < lo.cluster; ++j) {
            const double psi = 2 * kPi * j / lo.cluster;
            const Vec3 side = e1 * std::cos(psi) + e2 * std::sin(psi);
            Leaf leaf;
            leaf.size = positions.uniform(lo.sizeMin, lo.sizeMax);
            leaf.aspect = lo.aspect;
            leaf.shape = lo.shape;
            leaf.tangent =
                normalize(twig * std::cos(kClusterSpread) + side * std::sin(kClusterSpread));
            leaf.position = end + leaf.tangent * (0.5 * leaf.size);
            Vec3 n = n0 - leaf.tangent * dot(n0, leaf.tangent);
            leaf.normal = length(n) > 1e-6 ? normalize(n) : anyPerpendicular(leaf.tangent);
            tree.leaves.push_back(leaf);
        }
    }

    // Colour classes (Figure 4(c): two leaf colours for fall, chosen "based on its coordinate
    // (ϕ, θ) … and a random noise function"): positions ranked by a mix of a smooth noise over
    // (φ, θ) and white noise, then cut at the cumulative fractions — exact shares, in patches.
    const size_t classes = lo.colourFractions.size();
    if (classes == 1 && !lo.colourClasses.empty()) {
        for (Leaf& leaf : tree.leaves) leaf.colour = lo.colourClasses[0];
    } else if (classes > 1 && lo.count > 0) {
        Rng cr = rng.derive("colours");
        CanopyGrid patches;
        patches.width = 8;
        patches.height = 4;
        patches.values.resize(32);
        for (float& v : patches.values) v = static_cast<float>(cr.uniform());
        std::vector<double> key(lo.count);
        for (int k = 0; k < lo.count; ++k) {
            const double u = angles[k].x / (2 * kPi), v = std::clamp(angles[k].y / kPi, 0.0, 1.0);
            key[k] = lo.colourPatchiness * patches.at(u - std::floor(u), v) +
                     (1.0 - lo.colourPatchiness) * cr.uniform();
        }
        std::vector<int32_t> rank(lo.count);
        std::iota(rank.begin(), rank.end(), 0);
        std::stable_sort(rank.begin(), rank.end(),
                         [&](int32_t a, int32_t b) { return key[a] < key[b]; });
        double cumulative = 0.0;
        size_t r = 0;
        for (size_t c = 0; c < classes; ++c) {
            cumulative += lo.colourFractions[c];
            const size_t end =
                c + 1 == classes
                    ? size_t(lo.count)
                    : std::min(size_t(lo.count), size_t(std::llround(cumulative * lo.count)));
            for (; r < end; ++r) {
                const size_t first = size_t(rank[r]) * lo.cluster;
                for (int j = 0; j < lo.cluster; ++j) {
                    tree.leaves[first + j].colour =
                        lo.colourClasses.empty() ? static_cast<uint8_t>(c) : lo.colourClasses[c];
                }
            }
        }
    }
}

// Leaf.node: the nearest branch node within the support distance (CGAL kd-tree), else −1.
int64_t attachLeaves(Tree& tree, double supportDistance) {
    std::vector<IndexedPoint> points;
    points.reserve(tree.nodes.size());
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
        const Vec3& p = tree.nodes[i].position;
        points.emplace_back(KPoint(p.x, p.y, p.z), static_cast<int32_t>(i));
    }
    NeighbourSearch::Tree kd(points.begin(), points.end());
    const double limit2 = supportDistance * supportDistance;
    int64_t unsupported = 0;
    for (Leaf& leaf : tree.leaves) {
        const KPoint q(leaf.position.x, leaf.position.y, leaf.position.z);
        NeighbourSearch search(kd, q, 1);
        leaf.node = -1;
        if (search.begin() != search.end() && search.begin()->second <= limit2) {
            leaf.node = search.begin()->first.second;
        } else {
            ++unsupported;
        }
    }
    return unsupported;
}

// Support: crown segments longer than `maxLength` are cut into equal pieces, so twigs can
// sprout along them and a leaf beside a segment has a node near it. The pieces take the
// child's order, level and radius (Murray's rule gives a chain one radius); the bole is left
// whole. `sprouts` and `own` (per node) follow the nodes; inserted nodes get 0 own flow.
Tree subdivideCrown(const Tree& t, double maxLength, std::vector<char>& sprouts,
                    std::vector<double>& own, const GrowthGuard& guard) {
    double total = static_cast<double>(t.nodes.size());
    for (size_t i = 1; i < t.nodes.size(); ++i) {
        if (!sprouts[i]) continue;
        const double len = distance(t.nodes[t.nodes[i].parent].position, t.nodes[i].position);
        total += std::max(1.0, std::ceil(len / maxLength)) - 1.0;
    }
    guard.skeletonNodes(static_cast<int64_t>(std::min(total, 1e18)),
                        " (the crown cut into pieces of [support] sprout_spacing)");
    Tree out;
    std::vector<char> outSprouts;
    std::vector<double> outOwn;
    std::vector<int32_t> map(t.nodes.size(), -1);
    for (size_t i = 0; i < t.nodes.size(); ++i) {
        SkeletonNode n = t.nodes[i];
        if (i > 0) {
            const int32_t parent = map[n.parent];
            const Vec3 from = t.nodes[n.parent].position;
            const double len = distance(from, n.position);
            const int pieces =
                sprouts[i] ? std::max(1, static_cast<int>(std::ceil(len / maxLength))) : 1;
            int32_t at = parent;
            for (int k = 1; k < pieces; ++k) {
                SkeletonNode mid = n;
                mid.position = from + (n.position - from) * (double(k) / pieces);
                mid.parent = at;
                at = static_cast<int32_t>(out.nodes.size());
                out.nodes.push_back(mid);
                outSprouts.push_back(sprouts[i]);
                outOwn.push_back(0.0);
            }
            n.parent = at;
        }
        map[i] = static_cast<int32_t>(out.nodes.size());
        out.nodes.push_back(n);
        outSprouts.push_back(sprouts[i]);
        outOwn.push_back(own[i]);
    }
    out.leaves = t.leaves;
    sprouts.swap(outSprouts);
    own.swap(outOwn);
    return out;
}

// Murray's rule with a flow of the node's own (Murray 1927; Shesh §3.4): r_iⁿ = own_i +
// Σ r_childⁿ, and a tip max(own_i, r_tipⁿ). own ≡ 0 is murrayRadii; own = what a template
// node lost to clipping keeps the template's radii where nothing was added.
void flowRadii(Tree& tree, const std::vector<double>& own, double tipRadius, double exponent) {
    const size_t n = tree.nodes.size();
    std::vector<double> sum(n, 0.0);
    std::vector<char> hasChild(n, 0);
    const double tipFlow = std::pow(tipRadius, exponent);
    for (size_t i = n; i-- > 0;) {
        SkeletonNode& node = tree.nodes[i];
        const double o = i < own.size() ? own[i] : 0.0;
        if (!hasChild[i]) {
            node.radius = o > tipFlow ? std::pow(o, 1.0 / exponent) : tipRadius;
        } else {
            node.radius = std::pow(sum[i] + o, 1.0 / exponent);
        }
        if (node.parent >= 0) {
            sum[node.parent] += std::pow(node.radius, exponent);
            hasChild[node.parent] = 1;
        }
    }
}

void setEndpoints(Tree& tree) {
    const ChildIndex children(tree);
    tree.endpoints.clear();
    for (int32_t i = 1; i < static_cast<int32_t>(tree.nodes.size()); ++i) {
        if (children.count(i) == 0) tree.endpoints.push_back(i);
    }
}

Tree finish(Tree tree, CanopyStats& st, CanopyStats* stats) {
    st.leaves = static_cast<int64_t>(tree.leaves.size());
    st.unsupportedLeafFraction =
        st.leaves > 0 ? static_cast<double>(st.unsupportedLeaves) / st.leaves : 0.0;
    if (stats) *stats = st;
    return tree;
}

// Removes the nodes i ≥ `from` (but not those with keep[i]) that carry no leaf, neither
// themselves nor any node above them; parents precede children, so one backward pass marks
// and one forward pass compacts. Leaf nodes are renumbered; `survivors` (if given) gets the
// old index of every node left. Returns the node count.
size_t shedBare(Tree& tree, size_t from, const std::vector<char>* keep,
                std::vector<int32_t>* survivors = nullptr) {
    std::vector<char> bears(tree.nodes.size(), 0);
    for (size_t i = 0; i < std::min(from, tree.nodes.size()); ++i) bears[i] = 1;
    if (keep) {
        for (size_t i = 0; i < keep->size(); ++i) bears[i] |= (*keep)[i];
    }
    for (const Leaf& l : tree.leaves) bears[l.node] = 1;
    for (size_t i = tree.nodes.size(); i-- > 1;) {
        if (bears[i]) bears[tree.nodes[i].parent] = 1;
    }
    std::vector<int32_t> remap(tree.nodes.size(), -1);
    if (survivors) survivors->clear();
    size_t next = 0;
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
        if (!bears[i]) continue;
        SkeletonNode n = tree.nodes[i];
        if (n.parent >= 0) n.parent = remap[n.parent];
        remap[i] = static_cast<int32_t>(next);
        tree.nodes[next++] = n;
        if (survivors) survivors->push_back(static_cast<int32_t>(i));
    }
    tree.nodes.resize(next);
    for (Leaf& l : tree.leaves) l.node = remap[l.node];
    return next;
}

}  // namespace

// --- leaf support ------------------------------------------------------------------------------

int64_t growSupportTwigs(Tree& tree, const std::vector<char>& sprouts,
                         const CanopySupportOptions& o,
                         const std::function<bool(const Vec3&)>& inside, int64_t* grown,
                         const GrowthGuard& guard) {
    if (grown) *grown = 0;
    const size_t leafCount = tree.leaves.size();
    if (leafCount == 0) return 0;
    if (tree.nodes.empty()) {
        tree.leaves.clear();
        return static_cast<int64_t>(leafCount);
    }
    const size_t firstGrown = tree.nodes.size();  // grown nodes follow
    const double reach = o.reach, step = o.step, kill2 = o.attach * o.attach;
    constexpr double kInf = std::numeric_limits<double>::infinity();
    constexpr int kRetargets = 3;  // times a marker turns to another node before giving up

    // Markers: the leaves' attachment points (the middle of the card's near edge); the leaves
    // of a cluster share one (consecutive leaves at the same point).
    std::vector<Vec3> marker;
    std::vector<int32_t> markerOf(leafCount);
    Aabb box;
    for (size_t k = 0; k < leafCount; ++k) {
        const Leaf& l = tree.leaves[k];
        const Vec3 a = l.position - l.tangent * (0.5 * l.size);
        if (marker.empty() ||
            !(a.x == marker.back().x && a.y == marker.back().y && a.z == marker.back().z)) {
            marker.push_back(a);
            box.extend(a);
        }
        markerOf[k] = static_cast<int32_t>(marker.size() - 1);
    }
    const size_t markerCount = marker.size();
    for (const SkeletonNode& n : tree.nodes) box.extend(n.position);
    box.extend(box.lo - Vec3{reach, reach, reach});
    box.extend(box.hi + Vec3{reach, reach, reach});
    // Markers are fixed: packed by cell, and the grid is rebuilt with the markers still
    // waiting whenever a tenth of them have been carried (a carried marker only costs its
    // distance test; a rebuild costs one pass over those waiting). Cells a quarter of the
    // reach: a query reads about 11 reach³ of cells for its 4.2 reach³ ball, against 16 at
    // half the reach. Which markers the grid holds, and in what order it lists them, change
    // nothing: each marker keeps the lowest (distance, node) of those that reach it.
    // Nodes are added as twigs grow.
    const double markerCell = reach / 4;
    PackedPointGrid markerGrid;
    std::vector<int32_t> gridMarker(markerCount);  // grid id → marker
    std::iota(gridMarker.begin(), gridMarker.end(), 0);
    markerGrid.assign(marker, markerCell);
    PointGrid nodeGrid(box, 0.5 * reach);
    nodeGrid.reserve(tree.nodes.size() * 2);
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
        nodeGrid.insert(static_cast<int32_t>(i), tree.nodes[i].position);
    }

    // Per marker: the nearest node that may grow (within reach) and, once one is within the
    // kill distance, the node that carries it. Ties go to the lower index (determinism).
    struct Marker {
        int32_t nearest = -1;
        double d2 = kInf;
        int32_t carrier = -1;
        double carrierD2 = kInf;
        int retargets = 0;
        int carriedAt = -1;  // iteration
    };
    std::vector<Marker> m(markerCount);
    // A marker outside the region attracts nothing (no twig may reach it); a node may still
    // come within the kill distance of it.
    std::vector<char> pulling(markerCount);
    for (size_t k = 0; k < markerCount; ++k) pulling[k] = inside(marker[k]) ? 1 : 0;
    std::vector<char> canGrow(sprouts.begin(), sprouts.end());
    canGrow.resize(tree.nodes.size(), 0);
    auto better = [](double d2, int32_t id, double bestD2, int32_t bestId) {
        return d2 < bestD2 || (d2 == bestD2 && id < bestId);
    };
    {
        // The nearest node, and the nearest that may grow, by kd-tree (CGAL).
        std::vector<IndexedPoint> all, growing;
        for (size_t i = 0; i < tree.nodes.size(); ++i) {
            const Vec3& p = tree.nodes[i].position;
            all.emplace_back(KPoint(p.x, p.y, p.z), static_cast<int32_t>(i));
            if (canGrow[i]) growing.push_back(all.back());
        }
        const NeighbourSearch::Tree allKd(all.begin(), all.end());
        const NeighbourSearch::Tree growKd(growing.begin(), growing.end());
        for (size_t k = 0; k < markerCount; ++k) {
            Marker& mk = m[k];
            const KPoint q(marker[k].x, marker[k].y, marker[k].z);
            NeighbourSearch nearest(allKd, q, 1);
            if (nearest.begin() != nearest.end() && nearest.begin()->second <= kill2) {
                mk.carrier = nearest.begin()->first.second;
                mk.carrierD2 = nearest.begin()->second;
                continue;
            }
            if (growing.empty()) continue;
            NeighbourSearch grower(growKd, q, 1);
            if (grower.begin() != grower.end() && grower.begin()->second <= reach * reach) {
                mk.nearest = grower.begin()->first.second;
                mk.d2 = grower.begin()->second;
            }
        }
    }

    std::vector<int32_t> childCount(tree.nodes.size(), 0);
    std::vector<double> path(tree.nodes.size(), 0.0);  // twig length from the sprouting node
    for (size_t i = 1; i < tree.nodes.size(); ++i) ++childCount[tree.nodes[i].parent];
    std::vector<int32_t> firstTwig(tree.nodes.size(), -1), nextTwig(tree.nodes.size(), -1);
    std::vector<Vec3> pull(tree.nodes.size());         // Σ unit directions to the markers
    std::vector<int32_t> pulls(tree.nodes.size(), 0);  // markers attracted
    std::vector<int32_t> closest(tree.nodes.size(), -1);
    std::vector<int32_t> touched, added;
    const double duplicate2 = 0.25 * step * step;  // a twig child this close is the same twig
    const Vec3 size = box.size();
    const int maxIterations =  // a safety bound
        16 + static_cast<int>(std::min(1e9, std::ceil(4.0 * length(size) / step)));
    std::vector<int32_t> active;  // markers not yet carried
    for (size_t k = 0; k < markerCount; ++k) {
        if (m[k].carrier < 0) active.push_back(static_cast<int32_t>(k));
    }
    for (int iteration = 0; iteration < maxIterations; ++iteration) {
        guard.time();
        if (static_cast<int64_t>(tree.nodes.size()) > guard.budget().maxSkeletonNodes) {
            guard.skeletonNodes(static_cast<int64_t>(tree.nodes.size()),
                                " (leaf-support twigs, round " + std::to_string(iteration) + ")");
        }
        // Runions et al. 2007, §3: every marker pulls its nearest node.
        touched.clear();
        size_t alive = 0;
        for (int32_t k : active) {
            Marker& mk = m[k];
            if (mk.carrier >= 0) continue;
            active[alive++] = k;
            if (mk.nearest < 0 || !pulling[k]) continue;
            // Its node stopped growing (at its longest, blocked by the envelope, or caught
            // between markers): the marker turns to the nearest node that still grows, a few
            // times, then gives up rather than pull twig after twig from the nodes around.
            if (!canGrow[mk.nearest]) {
                mk.nearest = -1;
                mk.d2 = kInf;
                if (mk.retargets++ < kRetargets) {
                    nodeGrid.forEachWithin(marker[k], reach, [&](int32_t id, const Vec3& p) {
                        const double d2 = distance2(p, marker[k]);
                        if (canGrow[id] && better(d2, id, mk.d2, mk.nearest)) {
                            mk.nearest = id;
                            mk.d2 = d2;
                        }
                    });
                }
                if (mk.nearest < 0) {
                    pulling[k] = 0;
                    continue;
                }
            }
            const int32_t i = mk.nearest;
            const Vec3 d = marker[k] - tree.nodes[i].position;
            const double len = length(d);
            if (pulls[i]++ == 0) touched.push_back(i);
            if (len > 0.0) pull[i] += d * (1.0 / len);
            if (closest[i] < 0 || better(mk.d2, k, m[closest[i]].d2, closest[i])) closest[i] = k;
        }
        active.resize(alive);
        if (10 * active.size() < 9 * gridMarker.size()) {  // pack the markers still waiting
            gridMarker = active;
            std::vector<Vec3> waiting;
            for (int32_t k : active) waiting.push_back(marker[k]);
            markerGrid.assign(waiting, markerCell);
        }
        if (touched.empty()) break;
        std::sort(touched.begin(), touched.end());
        added.clear();
        for (int32_t i : touched) {
            const Vec3 p = tree.nodes[i].position;
            auto fits = [&](const Vec3& q) {
                if (!inside(q)) return false;
                for (int32_t c = firstTwig[i]; c >= 0; c = nextTwig[c]) {
                    if (distance2(tree.nodes[c].position, q) < duplicate2) return false;
                }
                return true;
            };
            const Vec3 toClosest = marker[closest[i]] - p;
            Vec3 q{0, 0, 0};
            bool ok = false;
            if (length(pull[i]) > 1e-6 * pulls[i]) {
                // Liu et al. 2020, §3: v = norm(v_markers + λ v_g), gravity v_g = (0, −1, 0):
                // drooping twigs.
                Vec3 v = normalize(pull[i]);
                if (o.droop > 0.0) {
                    v = v + Vec3{0, -o.droop, 0};
                    v = length(v) > 1e-9 ? normalize(v) : normalize(pull[i]);
                }
                q = p + v * step;
                ok = fits(q);
            }
            if (!ok && length(toClosest) > 0.0) {  // opposite pulls cancel: the nearest marker
                q = p + normalize(toClosest) * step;
                ok = fits(q);
            }
            pull[i] = Vec3{0, 0, 0};
            pulls[i] = 0;
            closest[i] = -1;
            if (!ok) {
                canGrow[i] = 0;  // it cannot grow toward its markers: another node may
                continue;
            }
            SkeletonNode n;
            n.position = q;
            n.parent = i;
            n.order = tree.nodes[i].order + (childCount[i] > 0 ? 1 : 0);
            n.level = n.order;
            n.part = tree.nodes[i].part;
            const int32_t id = static_cast<int32_t>(tree.nodes.size());
            tree.nodes.push_back(n);
            ++childCount[i];
            childCount.push_back(0);
            path.push_back(path[i] + step);
            // A twig is at most `reach` long: beyond, it would crawl along the leaf layer.
            canGrow.push_back(path.back() + step <= o.length * (1 + 1e-9) ? 1 : 0);
            nextTwig.push_back(firstTwig[i]);
            firstTwig[i] = id;
            firstTwig.push_back(-1);
            pull.push_back(Vec3{0, 0, 0});
            pulls.push_back(0);
            closest.push_back(-1);
            nodeGrid.insert(id, q);
            added.push_back(id);
        }
        if (added.empty()) continue;  // only frozen nodes: their markers give up

        // The new nodes take over the markers they are nearer to, and carry those in reach (a
        // marker is carried by the nearest of the nodes that first reach it).
        for (int32_t id : added) {
            const Vec3 q = tree.nodes[id].position;
            markerGrid.forEachWithin(q, reach, [&](int32_t g, const Vec3& p) {
                Marker& mk = m[gridMarker[g]];
                if (mk.carrier >= 0 && mk.carriedAt < iteration) return;
                const double d2 = distance2(p, q);
                if (d2 <= kill2 && better(d2, id, mk.carrierD2, mk.carrier)) {
                    mk.carrier = id;
                    mk.carrierD2 = d2;
                    mk.carriedAt = iteration;
                }
                if (canGrow[id] && better(d2, id, mk.d2, mk.nearest)) {
                    mk.nearest = id;
                    mk.d2 = d2;
                }
            });
        }
    }

    // Carried leaves keep their node; the rest are dropped.
    size_t kept = 0;
    for (size_t k = 0; k < leafCount; ++k) {
        const Marker& mk = m[markerOf[k]];
        if (mk.carrier < 0) continue;
        Leaf leaf = tree.leaves[k];
        leaf.node = mk.carrier;
        tree.leaves[kept++] = leaf;
    }
    tree.leaves.resize(kept);

    // Twigs that carry no leaf are shed (a shoot without leaves dies back).
    const size_t nodes = shedBare(tree, firstGrown, nullptr);
    if (grown) *grown = static_cast<int64_t>(nodes - firstGrown);
    return static_cast<int64_t>(leafCount - kept);
}

Tree growCanopy(const CanopyOptions& o, Rng& rng, CanopyStats* stats,
                const CanopySurfaceSampler* sampler, const GrowthGuard& guard) {
    guard.leaves(static_cast<int64_t>(o.leaves.count) * o.leaves.cluster,
                 " ([leaves] count × cluster)");
    if (!o.envelope) throw std::invalid_argument("growCanopy: no envelope");
    if (o.templates.empty()) throw std::invalid_argument("growCanopy: no branch template");
    CanopyStats st;

    // One template per instance, by weight.
    Rng pick = rng.derive("template");
    double total = 0.0;
    for (const BranchTemplate& t : o.templates) total += t.weight;
    double u = pick.uniform() * total;
    size_t chosen = 0;
    for (; chosen + 1 < o.templates.size(); ++chosen) {
        if (u < o.templates[chosen].weight) break;
        u -= o.templates[chosen].weight;
    }
    const BranchTemplate& bt = o.templates[chosen];
    st.templateIndex = static_cast<int>(chosen);

    Rng lr = rng.derive("lsystem"), tr = rng.derive("turtle");
    const Tree raw = interpretTurtle(expandLSystem(bt.lsystem, bt.iterations, lr), bt, tr);
    const double yaw = o.branches.randomYaw ? rng.derive("yaw").uniform(0.0, 2 * kPi) : 0.0;
    st.trunkHeight = canopyTrunkHeight(o);
    FittedTemplate fitted = fitTemplate(raw, o, st.trunkHeight, yaw);
    st.templateSegments = static_cast<int64_t>(fitted.tree.nodes.size()) - 1;
    st.scaleY = fitted.scaleY;
    st.scaleXZ = fitted.scaleXZ;
    if (o.branches.murrayOn == MurrayOn::kTemplate) {
        murrayRadii(fitted.tree, o.branches.tipRadius, o.branches.murrayExponent);
    }
    if (o.support.mode == LeafSupport::kNone) {
        Tree tree = clipTemplate(fitted, o);
        if (o.branches.murrayOn == MurrayOn::kClipped) {
            murrayRadii(tree, o.branches.tipRadius, o.branches.murrayExponent);
        }
        st.keptSegments = static_cast<int64_t>(tree.nodes.size()) - 1;
        setEndpoints(tree);
        // Leaves: their own stream, so changing them never moves a branch.
        if (o.leaves.count > 0) {
            Rng leafRng = rng.derive("leaves");
            if (sampler) {
                placeCanopyLeaves(tree, o, *sampler, leafRng);
            } else {
                const CanopySurfaceSampler own(*o.envelope);
                placeCanopyLeaves(tree, o, own, leafRng);
            }
            st.unsupportedLeaves = attachLeaves(tree, o.leaves.supportDistance);
        }
        return finish(std::move(tree), st, stats);
    }

    // Leaf support: the template clipped (with its leaf margin), its crown segments cut to the
    // kill distance, the leaves placed, twigs grown to them, then Murray's rule over it all.
    std::vector<char> bole;
    Tree tree = clipTemplate(fitted, o, &bole);
    st.keptSegments = static_cast<int64_t>(tree.nodes.size()) - 1;
    const double n = o.branches.murrayExponent;
    std::vector<double> own(tree.nodes.size(), 0.0);
    if (o.branches.murrayOn == MurrayOn::kTemplate) {
        // What each kept node carried in the template beyond its kept children: the flow of
        // the branches clipped off it (a kept tip: all of its own).
        for (size_t i = 0; i < tree.nodes.size(); ++i) own[i] = std::pow(tree.nodes[i].radius, n);
        for (size_t i = 1; i < tree.nodes.size(); ++i) {
            own[tree.nodes[i].parent] -= std::pow(tree.nodes[i].radius, n);
        }
        for (double& f : own) f = std::max(0.0, f);
    }
    std::vector<char> sprouts(bole.size());
    for (size_t i = 0; i < bole.size(); ++i) sprouts[i] = !bole[i];
    tree = subdivideCrown(tree, o.support.sproutSpacing, sprouts, own, guard);
    if (o.leaves.count > 0) {
        Rng leafRng = rng.derive("leaves");
        if (sampler) {
            placeCanopyLeaves(tree, o, *sampler, leafRng);
        } else {
            const CanopySurfaceSampler samplerOwn(*o.envelope);
            placeCanopyLeaves(tree, o, samplerOwn, leafRng);
        }
    }
    const CanopyEnvelope& env = *o.envelope;
    const Vec3 centre = o.position;
    st.droppedLeaves = growSupportTwigs(
        tree, sprouts, o.support,
        [&](const Vec3& p) {
            return envelopeRatio(env, p - centre) <= 1.0 + 1e-9 &&
                   (o.clip.empty() || insideAll(o.clip, p));
        },
        &st.twigNodes, guard);
    if (o.support.pruneBare) {
        // Self-pruning: crown branches that carry no leaf die (the bole stays); `own` follows.
        std::vector<char> keep(sprouts.size());
        for (size_t i = 0; i < sprouts.size(); ++i) keep[i] = !sprouts[i];  // the bole
        const size_t crown = own.size();  // nodes before the twigs (which all carry leaves)
        std::vector<int32_t> survivors;
        shedBare(tree, 1, &keep, &survivors);
        std::vector<double> ownKept;
        for (int32_t i : survivors) ownKept.push_back(size_t(i) < crown ? own[i] : 0.0);
        own.swap(ownKept);
    }
    flowRadii(tree, own, o.branches.tipRadius, n);
    setEndpoints(tree);
    return finish(std::move(tree), st, stats);
}

}  // namespace sylva
