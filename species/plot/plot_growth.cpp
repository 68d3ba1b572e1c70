// Growing a plot's trees together (plot_growth.h).
//
// Order of work, each step a pure function of the layout and the stems' seeds:
//  1. every stem's method and budget drawn (prepareSpecies, as growSpecies draws them);
//  2. each tree's crown predicted at its target scale: height and radius from the bounds of
//     its method's volumes (a method without volumes — the grammar — is grown alone first and
//     measured); the scale s = targetHeight / predicted height;
//  3. the trees grown: space-colonization trees together (one shared marker set, each at scale
//     s, then brought back to the species' scale), the others each with its neighbourhood
//     (clip planes or tropism, in its own frame);
//  4. form and leaves (finishSpecies), then each tree placed: node 0 at the stem base, scaled
//     about it so its highest shoot node is targetHeight above it;
//  5. leaves thinned (keyed draws) and scaled to the LAI targets.
// Trees are independent in 2–4 except within the shared marker set, whose driver is itself
// deterministic: the trees come out the same on any number of threads.
#include "species/plot/plot_growth.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/errors.h"
#include "core/rng.h"
#include "species/methods/space_colonization.h"
#include "species/model/form.h"
#include "species/model/leaf_shape.h"
#include "species/plot/inventory.h"

namespace sylva {

namespace {

template <class F>
void forEach(size_t n, bool threaded, const F& f) {
    if (threaded && n > 1) {
        tbb::parallel_for(size_t(0), n, [&](size_t i) { f(i); });
    } else {
        for (size_t i = 0; i < n; ++i) f(i);
    }
}

// The crown a tree is expected to have at the species' own scale (tree frame).
struct Predicted {
    double height = 0;  // metres above the root
    double radius = 0;  // horizontal, from the stem axis
};

// The highest shoot node above node 0, and the farthest horizontal reach of shoot nodes and
// leaves from it.
Predicted measure(const Tree& tree) {
    Predicted p;
    if (tree.nodes.empty()) return p;
    const Vec3 root = tree.nodes[0].position;
    for (const SkeletonNode& n : tree.nodes) {
        if (n.part != kShootPart) continue;
        p.height = std::max(p.height, n.position.y - root.y);
        p.radius = std::max(p.radius, std::hypot(n.position.x - root.x, n.position.z - root.z));
    }
    for (const Leaf& l : tree.leaves) {
        p.radius = std::max(p.radius, std::hypot(l.position.x - root.x, l.position.z - root.z));
    }
    return p;
}

// From the method's crown volumes (all but the roots'), when it has any.
bool predictFromVolumes(const GrowthMethod& method, Predicted& p) {
    Aabb box;
    bool any = false;
    for (const auto& [name, volume] : method.volumes()) {
        if (name == "roots" || !volume) continue;
        box.extend(volume->bounds());
        any = true;
    }
    if (!any || !(box.hi.y > 0)) return false;
    p.height = box.hi.y;
    p.radius = std::max({box.hi.x, -box.lo.x, box.hi.z, -box.lo.z, 1e-3});
    return true;
}

SpaceColonizationOptions scaledOptions(const SpaceColonizationOptions& o, double s) {
    SpaceColonizationOptions c = o;
    if (s == 1.0) return c;
    c.internode *= s;
    c.trunkLength *= s;
    c.tipRadius *= s;
    if (c.crown) c.crown = makePlaced(c.crown, Placement{{0, 0, 0}, {0, 1, 0}, {s, s, s}});
    for (GuideMarker& g : c.guides) g.position = g.position * s;
    return c;
}

// Places a grown tree: node 0 at `base`, everything scaled by `s` about it (leaf sizes too).
void place(Tree& tree, const Vec3& base, double s) {
    if (tree.nodes.empty()) return;
    const Vec3 root = tree.nodes[0].position;
    for (SkeletonNode& n : tree.nodes) {
        n.position = base + (n.position - root) * s;
        n.radius *= s;
    }
    tree.nodes[0].position = base;
    for (Leaf& l : tree.leaves) {
        l.position = base + (l.position - root) * s;
        l.size *= s;
    }
}

// Every leaf's size times k about its attachment (the card's base edge): its area times k².
void scaleLeaves(Tree& tree, double k) {
    for (Leaf& l : tree.leaves) {
        const Vec3 attach = l.position - l.tangent * (0.5 * l.size);
        l.size *= k;
        l.position = attach + l.tangent * (0.5 * l.size);
    }
}

std::string fmt(double v) { return formatNumber(v, 4); }

// A stand-grown stem (`slenderness` = height / DBH, e.g. 60–100 for trees of a closed stand
// against 30–50 open-grown; Wonn & O'Hara 2001): every node's radius times one factor, so the
// DBH at 1.3 m (measureTree) is height / slenderness and the pipe model's proportions stay. A
// tree shorter than 1.3 m has no DBH and keeps its radii.
void standSlenderness(Tree& tree, const Vec3& base, double slenderness) {
    const TreeRecord m = measureTree(tree, base);
    if (!(m.dbh > 0) || !(m.height > 0)) return;
    const double k = m.height / slenderness / m.dbh;
    for (SkeletonNode& n : tree.nodes) n.radius *= k;
}

// Thinning a species' leaves to `ratio` (< 1) of their area (plot_growth.h, reachLai): leaf i
// of a tree is kept when its draw u_i (a stream keyed by the tree's seed — itself hashed from
// the plot seed and the tree id — and i) is below p_i = min(1, c·w_i), its weight
// w_i = kThinFloor + t_i³ growing with its height t_i in the tree's own leaf layer (0 at the
// lowest leaf, 1 at the highest): the shaded lower leaves go first, as a closed stand's crowns
// recede from below (the top leaf is 21× as likely kept as the lowest, 6× as one halfway up).
// c is solved (bisection) so the expected kept area Σ a_i·p_i is ratio × the grown area.
// Returns the kept area.
constexpr double kThinFloor = 0.05;

double thinLeaves(std::vector<PlotTree*>& trees, double ratio) {
    struct Weighted {
        double area, weight;
    };
    std::vector<std::vector<Weighted>> w(trees.size());
    double total = 0;
    for (size_t k = 0; k < trees.size(); ++k) {
        const std::vector<Leaf>& leaves = trees[k]->grown.tree.leaves;
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (const Leaf& l : leaves) {
            lo = std::min(lo, l.position.y);
            hi = std::max(hi, l.position.y);
        }
        w[k].reserve(leaves.size());
        for (const Leaf& l : leaves) {
            const double t = hi > lo ? (l.position.y - lo) / (hi - lo) : 1.0;
            w[k].push_back({leafArea(l), kThinFloor + t * t * t});
            total += w[k].back().area;
        }
    }
    auto expected = [&](double c) {
        double a = 0;
        for (const auto& tree : w) {
            for (const Weighted& x : tree) a += x.area * std::min(1.0, c * x.weight);
        }
        return a;
    };
    double lo = 0, hi = 1.0 / kThinFloor;  // every p_i = 1 at c = hi
    for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        (expected(mid) < ratio * total ? lo : hi) = mid;
    }
    const double c = 0.5 * (lo + hi);
    double kept = 0;
    for (size_t k = 0; k < trees.size(); ++k) {
        std::vector<Leaf>& leaves = trees[k]->grown.tree.leaves;
        const Rng stream = Rng(trees[k]->stem.seed).derive("lai thinning");
        size_t out = 0;
        for (size_t i = 0; i < leaves.size(); ++i) {
            if (stream.derive(static_cast<uint64_t>(i)).uniform() >= c * w[k][i].weight) continue;
            kept += w[k][i].area;
            leaves[out++] = leaves[i];
        }
        leaves.resize(out);
    }
    return kept;
}

// Reaching the LAI targets (plot_growth.h).
void reachLai(const PlotSpec& spec, GrownPlot& plot) {
    const double area = spec.area.area();
    const size_t nSpecies = spec.species.size();
    std::vector<double> leafArea(nSpecies, 0.0);
    for (PlotTree& t : plot.trees) {
        t.leavesGrown = static_cast<int64_t>(t.grown.tree.leaves.size());
        const auto s = static_cast<size_t>(t.stem.species);
        if (s < nSpecies) leafArea[s] += treeLeafArea(t.grown.tree);
    }
    // Per species, the grown leaf area times `ratio` is its target; 1: no target.
    std::vector<double> ratio(nSpecies, 1.0);
    auto check = [&](double r, const SourcePos& where, const std::string& key, double target,
                     double grown) {
        if (!(grown > 0)) {
            throw SpecError(where, key,
                            "expected species with leaves to scale to it, got " + fmt(target) +
                                " for trees without leaves");
        }
        if (!(r >= kMinLeavesKept && r <= kMaxLeafScale * kMaxLeafScale)) {
            throw SpecError(where, key,
                            "expected a leaf area index the grown leaves reach with at least " +
                                fmt(100 * kMinLeavesKept) +
                                " % of their area kept or their sizes scaled up to " +
                                fmt(kMaxLeafScale) + "× (they give " + fmt(grown / area) + ", so " +
                                fmt(target) + " needs ×" + fmt(r) + " of their area), got " +
                                fmt(target));
        }
    };
    double fixed = 0;  // m² of leaves of the species with their own lai
    for (size_t s = 0; s < nSpecies; ++s) {
        const PlotSpecies& ps = spec.species[s];
        if (ps.lai < 0) continue;
        const double r = ps.lai * area / leafArea[s];
        check(r, ps.where, ps.keyPath + ".lai", ps.lai, leafArea[s]);
        ratio[s] = r;
        fixed += ps.lai * area;
    }
    if (spec.lai > 0) {
        double rest = 0;
        for (size_t s = 0; s < nSpecies; ++s) {
            if (spec.species[s].lai < 0) rest += leafArea[s];
        }
        const double want = spec.lai * area - fixed;
        const std::string key = spec.keyPath + ".lai";
        bool restExists = false;
        for (const PlotSpecies& ps : spec.species) restExists |= ps.lai < 0;
        if (!restExists) {
            if (std::abs(fixed - spec.lai * area) > 0.05 * spec.lai * area) {
                throw SpecError(spec.where, key,
                                "expected the species' lai to sum to it, got " + fmt(spec.lai) +
                                    " (the species' sum to " + fmt(fixed / area) + ")");
            }
        } else {
            if (!(want > 0)) {
                throw SpecError(spec.where, key,
                                "expected more than the species' own lai (" + fmt(fixed / area) +
                                    "), got " + fmt(spec.lai));
            }
            const double r = rest > 0 ? want / rest : 0.0;
            check(r, spec.where, key, want / area, rest);
            for (size_t s = 0; s < nSpecies; ++s) {
                if (spec.species[s].lai < 0) ratio[s] = r;
            }
        }
    }
    // Per species: thinned when its leaves are to lose area, then every (kept) leaf scaled by
    // one factor to the target exactly.
    for (size_t s = 0; s < nSpecies; ++s) {
        if (ratio[s] == 1.0 || !(leafArea[s] > 0)) continue;  // (leafless: in no target)
        std::vector<PlotTree*> trees;
        for (PlotTree& t : plot.trees) {
            if (static_cast<size_t>(t.stem.species) == s) trees.push_back(&t);
        }
        const double kept = ratio[s] < 1.0 ? thinLeaves(trees, ratio[s]) : leafArea[s];
        const double k = kept > 0 ? std::sqrt(ratio[s] * leafArea[s] / kept) : 0.0;
        if (!(k >= kMinLeafScale && k <= kMaxLeafScale)) {
            const PlotSpecies& ps = spec.species[s];
            const bool own = ps.lai >= 0;
            throw SpecError(own ? ps.where : spec.where,
                            own ? ps.keyPath + ".lai" : spec.keyPath + ".lai",
                            "expected a leaf area index the thinned leaves reach with their "
                            "sizes scaled " +
                                fmt(kMinLeafScale) + "–" + fmt(kMaxLeafScale) + "× (the " +
                                std::to_string(trees.size()) + " trees of " + ps.keyPath +
                                " kept too few leaves), got " + fmt(own ? ps.lai : spec.lai));
        }
        for (PlotTree* t : trees) {
            t->leafScale = k;
            if (k != 1.0) scaleLeaves(t->grown.tree, k);
        }
    }
    plot.lai = plotLai(plot);
}

double cross2(const Vec2& o, const Vec2& a, const Vec2& b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// Andrew's monotone chain: the convex hull, counter-clockwise, no collinear points.
std::vector<Vec2> convexHull(std::vector<Vec2> p) {
    std::sort(p.begin(), p.end(),
              [](const Vec2& a, const Vec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
    p.erase(std::unique(p.begin(), p.end(),
                        [](const Vec2& a, const Vec2& b) { return a.x == b.x && a.y == b.y; }),
            p.end());
    if (p.size() < 3) return p;
    std::vector<Vec2> h(2 * p.size());
    size_t k = 0;
    for (size_t i = 0; i < p.size(); ++i) {
        while (k >= 2 && cross2(h[k - 2], h[k - 1], p[i]) <= 0) --k;
        h[k++] = p[i];
    }
    for (size_t i = p.size() - 1, t = k + 1; i-- > 0;) {
        while (k >= t && cross2(h[k - 2], h[k - 1], p[i]) <= 0) --k;
        h[k++] = p[i];
    }
    h.resize(k - 1);
    return h;
}

bool inHull(const std::vector<Vec2>& h, const Vec2& q) {
    if (h.size() < 3) return false;
    for (size_t i = 0; i < h.size(); ++i) {
        if (cross2(h[i], h[(i + 1) % h.size()], q) < 0) return false;
    }
    return true;
}

struct Box2 {
    double x0 = std::numeric_limits<double>::infinity(), z0 = x0;
    double x1 = -x0, z1 = -x0;
};
Box2 boxOf(const std::vector<Vec2>& h) {
    Box2 b;
    for (const Vec2& p : h) {
        b.x0 = std::min(b.x0, p.x);
        b.x1 = std::max(b.x1, p.x);
        b.z0 = std::min(b.z0, p.y);
        b.z1 = std::max(b.z1, p.y);
    }
    return b;
}

// Cells (centres on the global lattice of edge `cell`) of `box` that pass `in`.
template <class F>
int64_t countCells(const Box2& box, double cell, const F& in) {
    int64_t n = 0;
    const auto i0 = static_cast<int64_t>(std::floor(box.x0 / cell));
    const auto i1 = static_cast<int64_t>(std::ceil(box.x1 / cell));
    const auto j0 = static_cast<int64_t>(std::floor(box.z0 / cell));
    const auto j1 = static_cast<int64_t>(std::ceil(box.z1 / cell));
    for (int64_t i = i0; i <= i1; ++i) {
        for (int64_t j = j0; j <= j1; ++j) {
            if (in(Vec2{(i + 0.5) * cell, (j + 0.5) * cell})) ++n;
        }
    }
    return n;
}

}  // namespace

double treeLeafArea(const Tree& tree) {
    double a = 0;
    for (const Leaf& l : tree.leaves) a += leafArea(l);
    return a;
}

double plotLai(const GrownPlot& plot) {
    if (!plot.spec) return 0.0;
    double a = 0;
    for (const PlotTree& t : plot.trees) a += treeLeafArea(t.grown.tree);
    const double area = plot.spec->area.area();
    return area > 0 ? a / area : 0.0;
}

GrownPlot growPlot(const PlotSpec& spec, PlotLayout layout, const BudgetTable* datasetBudget,
                   bool threaded, const PlotProgress& progress) {
    // The plot's own budget, checked before each tree's steps (each tree has its own too).
    Budget plotBudget;
    if (datasetBudget) datasetBudget->applyTo(plotBudget);
    const auto start = std::chrono::steady_clock::now();
    auto checkTime = [&] {
        checkSeconds(
            "max_plot_seconds", plotBudget.maxPlotSeconds,
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
            "the plot still growing", "grow fewer trees");
    };
    GrownPlot plot;
    plot.spec = &spec;
    plot.layout = std::move(layout);
    plot.groundCover = plot.layout.groundCover;
    const std::vector<PlotStem>& stems = plot.layout.stems;
    const size_t n = stems.size();
    std::atomic<int64_t> grownCount{0}, finishedCount{0};
    auto grewOne = [&] {
        const int64_t k = ++grownCount;
        if (progress) progress("growing", k, static_cast<int64_t>(n));
    };
    auto finishedOne = [&] {
        const int64_t k = ++finishedCount;
        if (progress) progress("finishing", k, static_cast<int64_t>(n));
    };
    for (const PlotStem& st : stems) {
        if (st.species < 0 || static_cast<size_t>(st.species) >= spec.species.size()) {
            throw std::invalid_argument("growPlot: stem " + std::to_string(st.id) +
                                        " has no species " + std::to_string(st.species));
        }
    }

    // 1. Methods and budgets.
    std::vector<PreparedTree> prepared(n);
    forEach(n, threaded, [&](size_t i) {
        checkTime();
        prepared[i] = prepareSpecies(spec.species[stems[i].species].species, stems[i].seed, nullptr,
                                     datasetBudget);
        // In a stand the crown is the one the tree grew among its neighbours (their shyness
        // planes): the form stage's per-branch turns, lengths and bends and its per-tree width,
        // applied after growth, would carry it across them. Forks keep their drawn exponents.
        if (prepared[i].form &&
            (prepared[i].form->turnsBranches() || prepared[i].form->width != 1)) {
            FormOptions f = *prepared[i].form;
            f.angleSdRad = f.angleShiftRad = f.lengthSd = f.bendRadPerM = f.bendSdRadPerM = 0;
            f.width = 1;
            prepared[i].form = std::make_shared<const FormOptions>(f);
        }
    });
    std::vector<Tree> grown(n);
    std::vector<uint8_t> done(n, 0);
    std::vector<double> preScale(n, 1.0);  // target height / predicted height
    // The clip planes of crown-shy trees in the plot's frame: the placed tree is cut at them
    // (its leaves and the parts its method grew beyond its clipped volume).
    std::vector<std::vector<HalfSpace>> plotClip(n);
    // The crown-shyness bounds of space-colonization trees (plot frame), held again once the
    // tree is placed: its scale to its drawn height may have moved its crown over them.
    std::vector<std::vector<ShyBound>> pbounds(n);
    // A grammar tree's bounds in the plot's frame: its form stage (scale, asymmetry, lean; the
    // turns and width are off in a stand) moves branches after it grew, so the placed tree is
    // cut at them again (as a colonizer is at pbounds).
    std::vector<std::vector<ShyBound>> gbounds(n);
    std::vector<uint8_t> shy(n, 0);  // a grammar tree grown within shyness bounds

    if (!spec.neighbours) {
        forEach(n, threaded, [&](size_t i) {
            checkTime();
            const GrowthGuard guard(prepared[i].out.budget);
            Rng rng(prepared[i].seed);
            grown[i] = prepared[i].method->grow(rng, threaded, prepared[i].out.methodStats, guard);
            grewOne();
        });
    } else {
        // 2. Each crown predicted at its target scale.
        std::vector<Predicted> own(n);
        forEach(n, threaded, [&](size_t i) {
            if (predictFromVolumes(*prepared[i].method, own[i])) return;
            checkTime();
            // No volumes: grown alone and measured (kept as it is when no neighbour is close).
            const GrowthGuard guard(prepared[i].out.budget);
            Rng rng(prepared[i].seed);
            grown[i] = prepared[i].method->grow(rng, threaded, prepared[i].out.methodStats, guard);
            own[i] = measure(grown[i]);
            done[i] = 1;
            grewOne();
        });
        std::vector<double> radius(n);  // predicted crown radius in the plot, metres
        std::vector<double> top(n);     // predicted crown top (plot y)
        for (size_t i = 0; i < n; ++i) {
            const double h = std::max(own[i].height, 1e-3);
            if (stems[i].targetHeight > 0) preScale[i] = stems[i].targetHeight / h;
            radius[i] = std::max(own[i].radius, 1e-3) * preScale[i];
            top[i] = stems[i].base.y + h * preScale[i];
        }
        // Close neighbours (every pair: a plot has at most a few thousand stems).
        std::vector<std::vector<size_t>> close(n);
        for (size_t i = 0; i < n; ++i) {
            for (size_t j = 0; j < n; ++j) {
                if (j == i) continue;
                const double d = std::hypot(stems[j].base.x - stems[i].base.x,
                                            stems[j].base.z - stems[i].base.z);
                if (d < kNeighbourReach * (radius[i] + radius[j])) close[i].push_back(j);
            }
        }

        // The crown-shyness plane between tree i and its close neighbour j (docs/plots.md,
        // "Crown shyness"): normal u (unit, horizontal, toward j), offset from i's base in plot
        // metres, and the gap; false when it does not cut i's crown. The distance d between
        // the stems is shared in proportion to the predicted crown radii; each crown's radius
        // toward the other is its share, at most its own radius; the gap is crown_shyness
        // (the larger of the two species') × the larger of those two radii, half of it taken
        // from each side, a side keeping at least half its share (so the planes of a pair
        // never cross).
        auto shyPlane = [&](size_t i, size_t j, Vec3& u, double& offset, double& gap) {
            u = {stems[j].base.x - stems[i].base.x, 0, stems[j].base.z - stems[i].base.z};
            const double d = length(u);
            if (!(d > 1e-9)) return false;
            u = u / d;
            const double share = d * radius[i] / (radius[i] + radius[j]);
            const double shyness = std::max(spec.species[stems[i].species].crownShyness,
                                            spec.species[stems[j].species].crownShyness);
            gap = shyness * std::max(std::min(radius[i], share), std::min(radius[j], d - share));
            offset = std::max(share - 0.5 * gap, 0.5 * share);
            return offset < radius[i];
        };
        // The same plane held up to the lower of the two crowns' predicted tops (and kShyAbove
        // of the shorter tree's height over it, for its leaves above its top node), in the
        // plot's frame: above it the taller crown may spread over the shorter (overtopping it),
        // below it neither grows into the other's side — not even under the other's crown base,
        // where its branches would stand in that crown's shade. False when the plane does not
        // cut i's crown.
        auto shyBound = [&](size_t i, size_t j, ShyBound& b) {
            Vec3 u;
            double offset = 0, gap = 0;
            b.low = -std::numeric_limits<double>::infinity();
            b.high = std::min(top[i], top[j]) +
                     kShyAbove * std::min(top[i] - stems[i].base.y, top[j] - stems[j].base.y);
            if (!shyPlane(i, j, u, offset, gap)) return false;
            b.plane = {u, dot(u, stems[i].base) + offset};
            b.slack = 0.5 * gap;
            return true;
        };
        // A bound of tree i (plot frame) in the tree's own frame at scale 1/s: its root at the
        // origin, metres divided by s.
        auto treeFrame = [&](ShyBound b, size_t i, double s) {
            b.plane.offset = (b.plane.offset - dot(b.plane.normal, stems[i].base)) / s;
            b.low = (b.low - stems[i].base.y) / s;
            b.high = (b.high - stems[i].base.y) / s;
            b.slack /= s;
            return b;
        };

        // 3a. Space colonization: one shared marker set per group of trees that reach each
        // other (connected through close neighbours), every tree at its target scale; the
        // groups are independent and grow in parallel.
        std::vector<size_t> group(n);
        for (size_t i = 0; i < n; ++i) group[i] = i;
        std::function<size_t(size_t)> find = [&](size_t i) {
            return group[i] == i ? i : group[i] = find(group[i]);
        };
        for (size_t i = 0; i < n; ++i) {
            if (!prepared[i].method->spaceColonization()) continue;
            for (size_t j : close[i]) {
                if (!prepared[j].method->spaceColonization()) continue;
                const size_t a = find(i), b = find(j);
                if (a != b) group[std::max(a, b)] = std::min(a, b);
            }
        }
        std::map<size_t, std::vector<size_t>> groups;  // by their first tree: a fixed order
        for (size_t i = 0; i < n; ++i) {
            if (prepared[i].method->spaceColonization()) groups[find(i)].push_back(i);
        }
        std::vector<std::vector<size_t>> members;
        for (auto& [first, m] : groups) members.push_back(std::move(m));
        forEach(members.size(), threaded, [&](size_t g) {
            checkTime();
            const std::vector<size_t>& m = members[g];
            std::vector<ColonizingTree> together(m.size());
            std::vector<std::unique_ptr<GrowthGuard>> guards;
            for (size_t k = 0; k < m.size(); ++k) {
                const size_t i = m[k];
                ColonizingTree& c = together[k];
                c.options = scaledOptions(*prepared[i].method->spaceColonization(), preScale[i]);
                // Crown shyness toward every close neighbour, up to the lower crown's top: the
                // crown's markers drawn on its side of the planes only, as many as the
                // species' density there gives (the crown volume's share kept), and its buds
                // perceive no marker beyond them (another tree's) — a marker in the gap is
                // nobody's. The crown is at plot scale, about the tree's root, here.
                for (size_t j : close[i]) {
                    ShyBound b;
                    if (shyBound(i, j, b)) pbounds[i].push_back(b);
                }
                if (c.options.crown && !pbounds[i].empty()) {
                    std::vector<ShyBound> local;
                    for (const ShyBound& b : pbounds[i]) local.push_back(treeFrame(b, i, 1.0));
                    const VolumePtr whole = c.options.crown;
                    c.options.crown = makeShyClipped(whole, std::move(local));
                    const double all = whole->measure();
                    const double kept = all > 0 ? c.options.crown->measure() / all : 1.0;
                    c.options.markers = static_cast<int>(
                        std::lround(c.options.markers * std::clamp(kept, 0.0, 1.0)));
                    c.territory = pbounds[i];
                }
                c.options.threaded = threaded;
                c.origin = stems[i].base;
                c.rng = Rng(prepared[i].seed);
                guards.push_back(std::make_unique<GrowthGuard>(prepared[i].out.budget));
                c.guard = guards.back().get();
            }
            growSpaceColonizationTogether(together, threaded);
            for (size_t k = 0; k < m.size(); ++k) {
                const size_t i = m[k];
                grown[i] = std::move(together[k].tree);
                // Back to the species' own scale, where its form and leaves (in metres) apply
                // as to any tree of it; step 4 scales it to its height with them.
                if (preScale[i] != 1.0) {
                    for (SkeletonNode& node : grown[i].nodes) {
                        node.position = node.position / preScale[i];
                        node.radius /= preScale[i];
                    }
                }
                for (auto& [key, v] : together[k].stats) prepared[i].out.methodStats[key] = v;
                done[i] = 1;
                grewOne();
            }
        });

        // 3b. The others, each with its neighbourhood in its own frame (plot metres / s):
        // iterated graph and canopy clip their crown volumes at the planes (at every height),
        // the grammar stops its branches at them up to the lower crown's top and turns them
        // away from the neighbours.
        auto growAmong = [&](size_t i) {
            const double s = preScale[i];
            const bool hasVolumes = !prepared[i].method->volumes().empty();
            Neighbourhood nb;
            Vec3 away{0, 0, 0};
            plotClip[i].clear();
            gbounds[i].clear();
            for (size_t j : close[i]) {
                Vec3 u;
                double offset = 0, gap = 0;
                if (hasVolumes && shyPlane(i, j, u, offset, gap)) {
                    nb.clip.push_back({u, offset / s});
                    plotClip[i].push_back({u, dot(u, stems[i].base) + offset});
                }
                ShyBound b;
                if (!hasVolumes && shyBound(i, j, b)) {
                    nb.bounds.push_back(treeFrame(b, i, s));
                    gbounds[i].push_back(b);
                }
                const double d = std::hypot(stems[j].base.x - stems[i].base.x,
                                            stems[j].base.z - stems[i].base.z);
                const Vec3 toJ{stems[j].base.x - stems[i].base.x, 0,
                               stems[j].base.z - stems[i].base.z};
                if (d > 1e-9) away -= toJ / d * (radius[j] / d);
            }
            const double a = length(away);
            if (a > 1e-12) nb.away = away * (kShadeTropism * std::min(1.0, a) / a);
            if (done[i] && nb.clip.empty() && nb.bounds.empty() && !(length2(nb.away) > 0)) {
                return;
            }
            checkTime();
            prepared[i].out.methodStats.clear();
            const GrowthGuard guard(prepared[i].out.budget);
            Rng rng(prepared[i].seed);
            grown[i] = prepared[i].method->growAmong(rng, threaded, prepared[i].out.methodStats,
                                                     guard, nb);
            done[i] = 1;
            shy[i] = !nb.bounds.empty();
            grewOne();
        };
        std::vector<size_t> pending;
        for (size_t i = 0; i < n; ++i) {
            if (!(done[i] && prepared[i].method->spaceColonization())) pending.push_back(i);
        }
        // A grammar tree among neighbours may grow a little taller than alone (a turned stem
        // bends differently): its planes' neighbours are grown again with its top as grown, so
        // the planes hold up to the lower crown's real top (at most kShyRegrowths times).
        for (int pass = 0; !pending.empty(); ++pass) {
            forEach(pending.size(), threaded, [&](size_t k) { growAmong(pending[k]); });
            if (pass == kShyRegrowths) break;
            std::vector<uint8_t> raised(n, 0);
            for (size_t i : pending) {
                if (!shy[i]) continue;
                const double grownTop = stems[i].base.y + measure(grown[i]).height * preScale[i];
                if (grownTop > top[i] + 1e-6) {
                    top[i] = grownTop;
                    raised[i] = 1;
                }
            }
            std::vector<size_t> again;
            for (size_t i = 0; i < n; ++i) {
                if (!shy[i]) continue;
                bool affected = raised[i] != 0;
                for (size_t j : close[i]) affected = affected || raised[j] != 0;
                if (affected) again.push_back(i);
            }
            pending = std::move(again);
        }
    }

    // 4. Form, leaves, placement.
    plot.trees.resize(n);
    forEach(n, threaded, [&](size_t i) {
        checkTime();
        const GrowthGuard guard(prepared[i].out.budget);
        PlotTree& t = plot.trees[i];
        t.stem = stems[i];
        t.grown = finishSpecies(prepared[i], std::move(grown[i]), guard);
        const double h = measure(t.grown.tree).height;
        // A grammar tree whose branches the shyness bounds stopped keeps the scale they were set
        // at: scaled to its drawn height instead, its crown would cross them again (its top may
        // have come from branches that were stopped; its height is then below the drawn). A
        // space-colonization tree is scaled to its height and cut at its bounds again (below).
        const double s = shy[i]                             ? preScale[i]
                         : t.stem.targetHeight > 0 && h > 0 ? t.stem.targetHeight / h
                                                            : 1.0;
        place(t.grown.tree, t.stem.base, s);
        if (t.stem.slenderness > 0) standSlenderness(t.grown.tree, t.stem.base, t.stem.slenderness);
        if (!plotClip[i].empty()) {
            pruneTree(t.grown.tree, [&](const Vec3& p) { return insideAll(plotClip[i], p); });
        }
        if (!pbounds[i].empty()) {
            pruneTree(t.grown.tree, [&](const Vec3& p) { return keepsAll(pbounds[i], p); });
        }
        if (!gbounds[i].empty()) {  // a trunk slid onto a plane lies on it: 1 µm of slack
            pruneTree(t.grown.tree, [&](const Vec3& p) { return keepsAll(gbounds[i], p, 1e-6); });
        }
        finishedOne();
    });

    // 5. Leaf area index.
    checkTime();
    reachLai(spec, plot);
    return plot;
}

namespace {

// A crown's points (CrownShape): leaf centres and shoot tips, else shoot nodes.
std::vector<Vec3> crownPoints(const Tree& t) {
    std::vector<Vec3> pts;
    pts.reserve(t.leaves.size() + t.endpoints.size());
    for (const Leaf& l : t.leaves) pts.push_back(l.position);
    for (int32_t e : t.endpoints) {
        if (e >= 0 && static_cast<size_t>(e) < t.nodes.size() && t.nodes[e].part == kShootPart) {
            pts.push_back(t.nodes[e].position);
        }
    }
    if (pts.empty()) {
        for (const SkeletonNode& nd : t.nodes) {
            if (nd.part == kShootPart) pts.push_back(nd.position);
        }
    }
    return pts;
}

// The convex hull (x, z) of the crown points with lo ≤ y ≤ hi.
std::vector<Vec2> layerHull(const Tree& t, double lo, double hi) {
    std::vector<Vec2> p;
    for (const Vec3& q : crownPoints(t)) {
        if (q.y >= lo && q.y <= hi) p.push_back({q.x, q.z});
    }
    return convexHull(std::move(p));
}

}  // namespace

CrownShape crownShape(const PlotTree& tree) {
    CrownShape c;
    c.base = {tree.stem.base.x, tree.stem.base.z};
    const std::vector<Vec3> pts3 = crownPoints(tree.grown.tree);
    if (pts3.empty()) {
        c.centroid = c.base;
        c.low = c.top = tree.stem.base.y;
        return c;
    }
    std::vector<Vec2> pts;
    pts.reserve(pts3.size());
    Vec2 sum{0, 0};
    c.low = std::numeric_limits<double>::infinity();
    c.top = -c.low;
    for (const Vec3& q : pts3) {
        const Vec2 p{q.x, q.z};
        pts.push_back(p);
        sum.x += p.x;
        sum.y += p.y;
        c.radius = std::max(c.radius, std::hypot(p.x - c.base.x, p.y - c.base.y));
        c.low = std::min(c.low, q.y);
        c.top = std::max(c.top, q.y);
    }
    c.centroid = {sum.x / pts.size(), sum.y / pts.size()};
    c.hull = convexHull(std::move(pts));
    return c;
}

std::vector<CrownAsymmetry> crownAsymmetry(const GrownPlot& plot) {
    const size_t n = plot.trees.size();
    std::vector<CrownShape> shapes(n);
    for (size_t i = 0; i < n; ++i) shapes[i] = crownShape(plot.trees[i]);
    std::vector<CrownAsymmetry> out(n);
    for (size_t i = 0; i < n; ++i) {
        CrownAsymmetry& a = out[i];
        a.id = plot.trees[i].stem.id;
        a.radius = shapes[i].radius;
        a.offset = {shapes[i].centroid.x - shapes[i].base.x,
                    shapes[i].centroid.y - shapes[i].base.y};
        for (size_t j = 0; j < n; ++j) {
            if (j == i) continue;
            const double dx = shapes[i].base.x - shapes[j].base.x;
            const double dz = shapes[i].base.y - shapes[j].base.y;
            const double d = std::hypot(dx, dz);
            if (d > 1e-9 && d < 2 * shapes[i].radius) {
                a.neighbours.x += dx / d;
                a.neighbours.y += dz / d;
            }
        }
    }
    return out;
}

double crownNeighbourCosine(const std::vector<CrownAsymmetry>& trees) {
    double sum = 0;
    int count = 0;
    for (const CrownAsymmetry& a : trees) {
        const double lo = std::hypot(a.offset.x, a.offset.y);
        const double ln = std::hypot(a.neighbours.x, a.neighbours.y);
        if (lo < 1e-3 || ln < 1e-9) continue;
        sum += (a.offset.x * a.neighbours.x + a.offset.y * a.neighbours.y) / (lo * ln);
        ++count;
    }
    return count ? sum / count : 0.0;
}

std::vector<CrownOverlap> crownOverlaps(const GrownPlot& plot, double cell) {
    const size_t n = plot.trees.size();
    std::vector<CrownShape> shapes(n);
    std::vector<Box2> boxes(n);
    double smallest = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < n; ++i) {
        shapes[i] = crownShape(plot.trees[i]);
        boxes[i] = boxOf(shapes[i].hull);
        if (shapes[i].hull.size() >= 3) smallest = std::min(smallest, shapes[i].radius);
    }
    if (!(cell > 0)) cell = std::isfinite(smallest) ? std::max(0.02, smallest / 50) : 0.1;
    std::vector<int64_t> cells(n, -1);  // each hull's raster area, counted when first needed
    auto areaOf = [&](size_t i) {
        if (cells[i] < 0) {
            cells[i] = countCells(boxes[i], cell,
                                  [&](const Vec2& q) { return inHull(shapes[i].hull, q); });
        }
        return cells[i];
    };
    std::vector<CrownOverlap> out;
    for (size_t i = 0; i < n; ++i) {
        if (shapes[i].hull.size() < 3) continue;
        for (size_t j = i + 1; j < n; ++j) {
            if (shapes[j].hull.size() < 3) continue;
            Box2 b;
            b.x0 = std::max(boxes[i].x0, boxes[j].x0);
            b.x1 = std::min(boxes[i].x1, boxes[j].x1);
            b.z0 = std::max(boxes[i].z0, boxes[j].z0);
            b.z1 = std::min(boxes[i].z1, boxes[j].z1);
            if (b.x0 > b.x1 || b.z0 > b.z1) continue;
            const int64_t both = countCells(b, cell, [&](const Vec2& q) {
                return inHull(shapes[i].hull, q) && inHull(shapes[j].hull, q);
            });
            const int64_t smaller = std::min(areaOf(i), areaOf(j));
            CrownOverlap o;
            o.a = std::min(plot.trees[i].stem.id, plot.trees[j].stem.id);
            o.b = std::max(plot.trees[i].stem.id, plot.trees[j].stem.id);
            o.projected =
                smaller > 0 ? static_cast<double>(both) / static_cast<double>(smaller) : 0;
            const double lo = std::max(shapes[i].low, shapes[j].low);
            const double hi = std::min(shapes[i].top, shapes[j].top);
            if (hi < lo) {
                o.overtopped = both > 0;
            } else if (both > 0) {
                const std::vector<Vec2> hullI = layerHull(plot.trees[i].grown.tree, lo, hi);
                const std::vector<Vec2> hullJ = layerHull(plot.trees[j].grown.tree, lo, hi);
                if (hullI.size() >= 3 && hullJ.size() >= 3) {
                    const Box2 bi = boxOf(hullI), bj = boxOf(hullJ);
                    Box2 bb;
                    bb.x0 = std::max(bi.x0, bj.x0);
                    bb.x1 = std::min(bi.x1, bj.x1);
                    bb.z0 = std::max(bi.z0, bj.z0);
                    bb.z1 = std::min(bi.z1, bj.z1);
                    const int64_t shared = bb.x0 > bb.x1 || bb.z0 > bb.z1
                                               ? 0
                                               : countCells(bb, cell, [&](const Vec2& q) {
                                                     return inHull(hullI, q) && inHull(hullJ, q);
                                                 });
                    const int64_t small = std::min(
                        countCells(bi, cell, [&](const Vec2& q) { return inHull(hullI, q); }),
                        countCells(bj, cell, [&](const Vec2& q) { return inHull(hullJ, q); }));
                    o.fraction =
                        small > 0 ? static_cast<double>(shared) / static_cast<double>(small) : 0;
                }
            }
            out.push_back(o);
        }
    }
    return out;
}

double maxCrownOverlap(const std::vector<CrownOverlap>& overlaps) {
    double m = 0;
    for (const CrownOverlap& o : overlaps) m = std::max(m, o.fraction);
    return m;
}

}  // namespace sylva
