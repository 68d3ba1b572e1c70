// The `iterated-graph` growth method (Xu & Mould 2012; Wolff 2013 for the journal version).
// Implemented iteratively, level by level, as the paper's implementation was (§3.2): each
// level's graphs are independent, so they are built in parallel, each from its own keyed
// random stream, and merged in a fixed order — the result does not depend on thread count.
#include "species/methods/iterated_graph.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <utility>

#include "volumes/point_grid.h"
#include "volumes/poisson.h"

namespace sylva {

namespace {

// CSR of the edges into g, reusing its storage; `fill` is scratch.
void fillGraph(int n, const std::vector<std::pair<int32_t, int32_t>>& edges,
               const std::vector<double>& costs, WeightedGraph& g, std::vector<int32_t>& fill) {
    g.offset.assign(n + 1, 0);
    for (const auto& [a, b] : edges) {
        ++g.offset[a + 1];
        ++g.offset[b + 1];
    }
    for (int i = 0; i < n; ++i) g.offset[i + 1] += g.offset[i];
    g.target.resize(g.offset[n]);
    g.cost.resize(g.offset[n]);
    fill.assign(g.offset.begin(), g.offset.end() - 1);
    for (size_t e = 0; e < edges.size(); ++e) {
        auto [a, b] = edges[e];
        g.target[fill[a]] = b;
        g.cost[fill[a]++] = costs[e];
        g.target[fill[b]] = a;
        g.cost[fill[b]++] = costs[e];
    }
}

}  // namespace

WeightedGraph makeGraph(int n, const std::vector<std::pair<int32_t, int32_t>>& edges,
                        const std::vector<double>& costs) {
    WeightedGraph g;
    std::vector<int32_t> fill;
    fillGraph(n, edges, costs, g, fill);
    return g;
}

namespace {

// Min-heap of (cost, node) entries, ordered by cost and then node index, with four children
// per entry (shallower than binary, so fewer cache lines per pop).
class CostHeap {
  public:
    struct Entry {
        double cost;
        int32_t node;
    };
    bool empty() const { return items_.empty(); }
    void clear() { items_.clear(); }
    void push(double cost, int32_t node) {
        size_t k = items_.size();
        items_.push_back({cost, node});
        const Entry e{cost, node};
        while (k > 0) {
            const size_t parent = (k - 1) / kArity;
            if (!before(e, items_[parent])) break;
            items_[k] = items_[parent];
            k = parent;
        }
        items_[k] = e;
    }
    Entry pop() {
        const Entry top = items_[0];
        const Entry last = items_.back();
        items_.pop_back();
        const size_t n = items_.size();
        if (n == 0) return top;
        size_t k = 0;
        for (;;) {
            const size_t first = k * kArity + 1;
            if (first >= n) break;
            size_t best = first;
            const size_t end = std::min(first + kArity, n);
            for (size_t c = first + 1; c < end; ++c)
                if (before(items_[c], items_[best])) best = c;
            if (!before(items_[best], last)) break;
            items_[k] = items_[best];
            k = best;
        }
        items_[k] = last;
        return top;
    }

  private:
    static constexpr size_t kArity = 4;
    static bool before(const Entry& a, const Entry& b) {
        return a.cost < b.cost || (a.cost == b.cost && a.node < b.node);
    }
    std::vector<Entry> items_;
};

}  // namespace

void leastCostTree(const WeightedGraph& g, int source, std::vector<double>& dist,
                   std::vector<int32_t>& pred) {
    const int n = g.size();
    dist.assign(n, std::numeric_limits<double>::infinity());
    pred.assign(n, -1);
    // Stale entries are skipped rather than decreased. Nodes settle in (cost, node) order
    // whatever the heap's layout, so the result is that order's. The heap is kept per
    // thread: a tree searches hundreds of small graphs.
    thread_local CostHeap heap;
    heap.clear();
    dist[source] = 0.0;
    heap.push(0.0, source);
    while (!heap.empty()) {
        const auto [d, u] = heap.pop();
        if (d > dist[u]) continue;  // stale entry
        for (int32_t k = g.offset[u]; k < g.offset[u + 1]; ++k) {
            int32_t v = g.target[k];
            double nd = d + g.cost[k];
            if (nd < dist[v]) {
                dist[v] = nd;
                pred[v] = u;
                heap.push(nd, v);
            }
        }
    }
}

std::vector<double> subgraphRadii(const GraphSystem& sys) {
    const size_t levels = sys.levels.size();
    std::vector<double> radius(levels, 0.0);
    for (size_t i = 1; i < levels; ++i) {
        radius[i] = sys.levels[i].radius > 0 ? sys.levels[i].radius
                    : i == 1                 ? sys.subgraphRadius
                                             : radius[i - 1] * sys.shrink;
    }
    return radius;
}

VolumePtr subgraphVolume(const IteratedGraphLevel& level, double radius) {
    if (level.shape == SubgraphShape::kCone) {
        // Apex at the origin, base disc of radius r·tan α at height r.
        return makePlaced(makeCone(radius * std::tan(level.alpha), radius),
                          Placement{{0, radius, 0}, {0, -1, 0}, {1, 1, 1}});
    }
    return makeSphereSector(radius, level.alpha);  // §3.3.2
}

namespace {

constexpr Vec3 kUp{0, 1, 0};

// One graph to build: a sub-graph volume hanging from an existing skeleton node.
struct GraphJob {
    int level = 0;         // index into the system's levels
    int32_t rootNode = 0;  // skeleton node the graph's root R is
    Vec3 rootPos;
    VolumePtr volume;
    VolumePtr endpointVolume;
    int endpoints = 0;        // b
    double lifespan = 0.0;    // lifespan of R (as an endpoint of the level before)
    double decrement = -1.0;  // light mode: decrement handed to this graph; < 0: use the rule
    uint64_t key = 0;         // stream key
    bool taproot = false;     // root-system level 0: taproot + lateral endpoints
    double minY = -std::numeric_limits<double>::infinity();  // graph nodes below are dropped
};

// A graph's contribution: the nodes on least-cost paths, parents first.
struct GraphResult {
    std::vector<Vec3> pos;
    std::vector<int32_t> parent;  // index into pos, or −1 for the job's root node
    std::vector<int32_t> endpoints;
    std::vector<double> endpointLifespan;
    int64_t graphNodes = 0;
    int64_t graphEndpoints = 0;
    int64_t bridged = 0;  // edges added to join components
};

struct EndpointRecord {
    int32_t node;
    Vec3 pos;
    Vec3 graphRoot;
    double lifespan;
};

double levelSpacing(const IteratedGraphOptions& o, const IteratedGraphLevel& level,
                    const Volume& volume) {
    if (level.spacing > 0) return level.spacing;
    double v = volume.measure();
    return o.spacingFactor * std::cbrt(v / std::max(1, level.nodes));
}

// Nearest point index among pos[first, last) satisfying keep(i), by expanding grid search.
template <class Keep>
int32_t nearestIn(const PackedPointGrid& grid, const Vec3& q, double start, Keep&& keep) {
    for (double r = start; r < 1e6; r *= 2) {
        int32_t best = -1;
        double bestD = std::numeric_limits<double>::infinity();
        grid.forEachWithin(q, r, [&](int32_t id, const Vec3& p) {
            if (!keep(id)) return;
            double d = distance2(p, q);
            if (d < bestD || (d == bestD && id < best)) {
                bestD = d;
                best = id;
            }
        });
        if (best >= 0) return best;
        if (grid.size() == 0) break;
    }
    return -1;
}

// solveGraph's buffers, kept per thread: a tree builds hundreds of small graphs, and
// allocating them afresh each time cost more than filling them.
struct SolveScratch {
    PackedPointGrid grid;
    std::vector<std::pair<int32_t, int32_t>> edges;
    std::vector<int32_t> comp, compSize;
    std::vector<double> costs;
    WeightedGraph graph;
    std::vector<int32_t> fill;
};

SolveScratch& threadScratch() {
    thread_local SolveScratch scratch;
    return scratch;
}

// Builds the graph over pos (node 0 = root R; [1, firstEndpoint) Poisson nodes; the rest
// endpoints, which link only to nodes, as in maketree step 2B), draws edge costs, and runs one
// least-cost search from R.
void solveGraph(const IteratedGraphOptions& o, const std::vector<Vec3>& pos, int firstEndpoint,
                double spacing, Rng& rng, std::vector<double>& dist, std::vector<int32_t>& pred,
                GraphResult& out, const GrowthGuard& guard) {
    uint64_t work = 0;
    const int n = static_cast<int>(pos.size());
    const double link = o.linkFactor * spacing;
    SolveScratch& scratch = threadScratch();
    PackedPointGrid& grid = scratch.grid;
    grid.assign(pos, link);
    auto isEndpoint = [&](int i) { return i >= firstEndpoint; };

    std::vector<std::pair<int32_t, int32_t>>& edges = scratch.edges;
    edges.clear();
    if (o.linking == Linking::kDistance) {
        // maketree 1G/2B: an edge between every pair closer than the linking distance, listed
        // from the lower index. Endpoints link only to nodes, so an endpoint i (all higher
        // indices being endpoints too) lists none.
        grid.pairsWithin(link, firstEndpoint, edges);
    } else {
        // Yao graph (Xu & Mould, journal version; Wolff §3): the space around each node is
        // cut by planes into sectors and the node links to its nearest neighbour in each.
        const double search = 2.0 * link;
        const int sectors = o.yaoSectors;
        std::vector<int32_t> best(sectors);
        std::vector<double> bestD(sectors);
        for (int i = 0; i < n; ++i) {
            std::fill(best.begin(), best.end(), -1);
            std::fill(bestD.begin(), bestD.end(), std::numeric_limits<double>::infinity());
            grid.forEachWithin(pos[i], search, [&](int32_t j, const Vec3& p) {
                if (j == i || isEndpoint(j)) return;
                Vec3 v = p - pos[i];
                int s;
                if (sectors == 8) {
                    s = (v.x > 0) | ((v.y > 0) << 1) | ((v.z > 0) << 2);
                } else {
                    Vec3 a = vabs(v);
                    int axis = (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
                    s = axis * 2 + (v[axis] > 0);
                }
                double d = length2(v);
                if (d < bestD[s] || (d == bestD[s] && j < best[s])) {
                    bestD[s] = d;
                    best[s] = j;
                }
            });
            for (int s = 0; s < sectors; ++s) {
                if (best[s] >= 0) edges.push_back({std::min(i, best[s]), std::max(i, best[s])});
            }
        }
    }
    // The root and every endpoint must reach each other. A sparse part of the volume (a thin
    // trunk cylinder, a sector's apex) can split the graph; join each component holding an
    // endpoint to the rest by its closest node pair — a short edge across the gap, rather
    // than a long straight one from the endpoint.
    std::vector<int32_t>& comp = scratch.comp;
    std::vector<int32_t>& compSize = scratch.compSize;
    comp.resize(n);
    compSize.assign(n, 1);
    for (int i = 0; i < n; ++i) comp[i] = i;
    auto find = [&](int32_t x) {
        while (comp[x] != x) x = comp[x] = comp[comp[x]];
        return x;
    };
    auto unite = [&](int32_t a, int32_t b) {
        a = find(a);
        b = find(b);
        if (a == b) return;
        if (compSize[a] < compSize[b]) std::swap(a, b);
        comp[b] = a;
        compSize[a] += compSize[b];
    };
    for (auto [a, b] : edges) unite(a, b);
    for (int e = firstEndpoint; e < n; ++e) {
        while (find(e) != find(0)) {
            // Search outwards from the smaller of the two components.
            const int32_t c = compSize[find(e)] <= compSize[find(0)] ? find(e) : find(0);
            int32_t bu = -1, bv = -1;
            double bd = std::numeric_limits<double>::infinity();
            for (int u = 0; u < n; ++u) {
                guard.work(work);
                if (find(u) != c) continue;
                int32_t v = nearestIn(grid, pos[u], link, [&](int32_t id) {
                    return find(id) != c && (id == 0 || !isEndpoint(id));
                });
                if (v >= 0 && distance2(pos[u], pos[v]) < bd) {
                    bd = distance2(pos[u], pos[v]);
                    bu = u;
                    bv = v;
                }
            }
            if (bu < 0) break;
            edges.push_back({std::min(bu, bv), std::max(bu, bv)});
            unite(bu, bv);
            ++out.bridged;
        }
    }
    // maketree 1H: random weights, drawn in edge order so the draw is reproducible.
    std::vector<double>& costs = scratch.costs;
    costs.resize(edges.size());
    for (size_t e = 0; e < edges.size(); ++e) {
        double w;
        if (o.edgeWeightKind == EdgeWeightKind::kUniform) {
            w = rng.uniform(o.edgeWeightA, o.edgeWeightB);
        } else {
            w = std::max(0.01, rng.normal(o.edgeWeightA, o.edgeWeightB));
        }
        double len = distance(pos[edges[e].first], pos[edges[e].second]);
        costs[e] = w * (o.lengthExponent == 1.0 ? len : std::pow(len, o.lengthExponent));
    }
    guard.time();
    fillGraph(n, edges, costs, scratch.graph, scratch.fill);
    if (o.radialWeight > 0) {
        // Straighter growth: the step u → v (outward, as the search runs from R) costs more
        // the further it turns from the ray from R through its midpoint.
        WeightedGraph& g = scratch.graph;
        for (int u = 0; u < n; ++u) {
            for (int32_t k = g.offset[u]; k < g.offset[u + 1]; ++k) {
                const Vec3& a = pos[u];
                const Vec3& b = pos[g.target[k]];
                const Vec3 step = b - a;
                const Vec3 ray = (a + b) * 0.5 - pos[0];
                const double len = std::sqrt(length2(step) * length2(ray));
                const double c = len > 0 ? dot(step, ray) / len : 1.0;
                g.cost[k] *= 1.0 + o.radialWeight * (1.0 - c);
            }
        }
    }
    leastCostTree(scratch.graph, 0, dist, pred);
}

// Endpoint positions: uniform in the volume, optionally only in the shell of depth d_e on its
// far side as seen from the graph root (a point is in the shell when stepping d_e further
// away from R leaves the volume — between the outer and inner surfaces of Wolff Abb. 9).
Vec3 drawEndpoint(const Volume& volume, const Vec3& root, double shell, Rng& rng,
                  const GrowthGuard& guard, uint64_t& work) {
    for (int attempt = 0; attempt < 100000; ++attempt) {
        guard.work(work);
        std::optional<Vec3> p = volume.sample(rng);
        if (!p) break;
        if (shell <= 0) return *p;
        Vec3 out = *p + normalize(*p - root) * shell;
        if (!volume.inside(out)) return *p;
    }
    throw std::runtime_error("could not place an endpoint in " + volume.describe() +
                             (shell > 0 ? " within the endpoint shell" : ""));
}

double segmentDistance(const Vec3& p, const Vec3& a, const Vec3& b) {
    Vec3 ab = b - a;
    double t = std::clamp(dot(p - a, ab) / std::max(1e-300, length2(ab)), 0.0, 1.0);
    return distance(p, a + ab * t);
}

// Collects the least-cost paths of all endpoints (maketree step 3) into out, parents first.
void collectPaths(const std::vector<Vec3>& pos, int firstEndpoint, const std::vector<int32_t>& pred,
                  GraphResult& out) {
    const int n = static_cast<int>(pos.size());
    std::vector<int32_t> local(n, -1);
    std::vector<int32_t> chain;
    for (int e = firstEndpoint; e < n; ++e) {
        chain.clear();
        int32_t v = e;
        while (v > 0 && local[v] < 0) {  // walk towards R until the path joins T
            chain.push_back(v);
            v = pred[v];
        }
        int32_t parentLocal = v > 0 ? local[v] : -1;
        for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
            local[*it] = static_cast<int32_t>(out.pos.size());
            out.pos.push_back(pos[*it]);
            out.parent.push_back(parentLocal);
            parentLocal = local[*it];
        }
        out.endpoints.push_back(local[e]);
    }
}

double nextLifespan(const IteratedGraphOptions& o, double lifespan, double decrement, Rng& rng) {
    if (o.lifespan == LifespanRule::kStochastic) {
        // §3.3.3: 30% terminate, otherwise decrement uniformly in (0, L).
        if (rng.uniform() < o.terminateProbability) return 0.0;
        double amount =
            decrement >= 0 ? decrement * rng.uniform() * lifespan : rng.uniform() * lifespan;
        return lifespan - amount;
    }
    return lifespan - (decrement >= 0 ? decrement : 1.0);
}

GraphResult buildGraph(const IteratedGraphOptions& o, const GraphSystem& sys,
                       const RootOptions* roots, const GraphJob& job, Rng rng,
                       const GrowthGuard& guard) {
    GraphResult out;
    uint64_t work = 0;
    const IteratedGraphLevel& level = sys.levels[job.level];
    const double spacing = levelSpacing(o, level, *job.volume);

    // maketree step 1: Poisson-disc nodes inside V.
    PoissonOptions po;
    po.count = level.nodes;
    po.minDistance = spacing;
    Rng nodeRng = rng.derive("nodes");
    std::vector<Vec3> pos;
    pos.reserve(level.nodes + job.endpoints + 2);
    pos.push_back(job.rootPos);
    poissonSample(*job.volume, po, nodeRng, pos);
    guard.time();
    out.graphNodes = level.nodes;
    if (job.minY > -std::numeric_limits<double>::infinity()) {
        // A trunk (TrunkOptions): no graph node beside the bole, below the trunk top.
        pos.erase(std::remove_if(pos.begin() + 1, pos.end(),
                                 [&](const Vec3& p) { return p.y < job.minY; }),
                  pos.end());
        out.graphNodes = static_cast<int64_t>(pos.size()) - 1;
    }
    const int firstEndpoint = static_cast<int>(pos.size());

    Rng endRng = rng.derive("endpoints");
    Rng weightRng = rng.derive("weights");
    std::vector<double> dist;
    std::vector<int32_t> pred;
    if (job.taproot) {
        // Figure 15: the taproot is the path to a single deep endpoint; lateral roots come
        // from endpoints placed around it.
        pos.push_back(Vec3{0, -roots->taprootDepth, 0} + job.rootPos);
        solveGraph(o, pos, firstEndpoint, spacing, weightRng, dist, pred, out, guard);
        std::vector<Vec3> tap;
        std::vector<std::pair<int32_t, int32_t>> tapPred;  // (node, pred) along the taproot
        for (int32_t v = firstEndpoint; v >= 0; v = pred[v]) {
            tap.push_back(pos[v]);
            tapPred.push_back({v, pred[v]});
        }
        const VolumePtr& ev = job.endpointVolume;
        for (int k = 0; k < job.endpoints; ++k) {
            for (int attempt = 0;; ++attempt) {
                if (attempt > 100000) {
                    throw std::runtime_error("could not place lateral root endpoints within " +
                                             std::to_string(roots->lateralDistance) +
                                             " m of the taproot");
                }
                Vec3 p = drawEndpoint(*ev, job.rootPos, level.endpointShell, endRng, guard, work);
                double d = std::numeric_limits<double>::infinity();
                for (size_t s = 0; s + 1 < tap.size(); ++s) {
                    d = std::min(d, segmentDistance(p, tap[s], tap[s + 1]));
                }
                if (d <= roots->lateralDistance) {
                    pos.push_back(p);
                    break;
                }
            }
        }
        out.bridged = 0;
        Rng weightRng2 = rng.derive("weights");
        solveGraph(o, pos, firstEndpoint, spacing, weightRng2, dist, pred, out, guard);
        // Keep the taproot the laterals were placed around: the second search draws the
        // weights in another edge order (the laterals' edges are interleaved) and may find
        // another path. Lateral paths follow the second search until they meet it.
        for (auto [v, p] : tapPred) pred[v] = p;
    } else {
        // maketree step 2: b endpoints at random positions in V.
        for (int k = 0; k < job.endpoints; ++k) {
            pos.push_back(drawEndpoint(*job.endpointVolume, job.rootPos, level.endpointShell,
                                       endRng, guard, work));
        }
        solveGraph(o, pos, firstEndpoint, spacing, weightRng, dist, pred, out, guard);
    }
    out.graphEndpoints = static_cast<int64_t>(pos.size()) - firstEndpoint;
    collectPaths(pos, firstEndpoint, pred, out);

    Rng lifeRng = rng.derive("lifespan");
    for (size_t k = 0; k < out.endpoints.size(); ++k) {
        // Level-0 endpoints start with the initial lifespan; later ones inherit R's, decremented.
        out.endpointLifespan.push_back(
            job.level == 0 ? job.lifespan : nextLifespan(o, job.lifespan, job.decrement, lifeRng));
    }
    return out;
}

// §3.3.2: turn v_g about the horizontal by γ (positive = downwards), never past vertical.
Vec3 applyGamma(const Vec3& vg, double gamma) {
    if (gamma == 0.0) return vg;
    Vec3 axis = cross(kUp, vg);  // rotating about up × v by +γ moves v downwards
    if (length(axis) < 1e-9) axis = Vec3{1, 0, 0};
    axis = normalize(axis);
    double room = gamma > 0 ? angleBetween(vg, -kUp) : angleBetween(vg, kUp);
    double a = gamma > 0 ? std::min(gamma, room) : -std::min(-gamma, room);
    return normalize(rotate(vg, axis, a));
}

Vec3 orientationFor(const IteratedGraphLevel& level, const EndpointRecord& e, Rng& rng) {
    Vec3 vg;
    switch (level.orientation) {
        case Orientation::kUp:
            vg = kUp;
            break;
        case Orientation::kDown:
            vg = -kUp;
            break;
        case Orientation::kRandom:
            vg = rng.unitVector();
            break;
        case Orientation::kFixed:
            vg = normalize(level.direction);
            break;
        case Orientation::kParent:
        default:
            // maketree 4B: v_g = (e − R)/|e − R|.
            vg = distance2(e.pos, e.graphRoot) > 0 ? normalize(e.pos - e.graphRoot) : kUp;
    }
    return applyGamma(vg, level.gamma);
}

// Grows one system (crown or roots) into `tree`, hanging from node 0.
void growSystem(const IteratedGraphOptions& o, const GraphSystem& sys, const RootOptions* roots,
                uint8_t part, const Rng& rng, bool threaded, Tree& tree, IteratedGraphStats& stats,
                const GrowthGuard& guard) {
    const int levels = static_cast<int>(sys.levels.size());
    if (levels == 0) return;
    const std::vector<double> radius = subgraphRadii(sys);
    const double initialLifespan =
        o.initialLifespan >= 0 ? o.initialLifespan : static_cast<double>(levels - 1);

    GraphJob first;
    first.level = 0;
    first.rootNode = 0;
    first.rootPos = tree.nodes[0].position;
    first.volume = sys.volume;
    first.endpointVolume = sys.endpointVolume ? sys.endpointVolume : sys.volume;
    first.endpoints = sys.levels[0].endpoints;
    first.lifespan = initialLifespan;
    first.key = 0;
    first.taproot = roots != nullptr;
    if (roots == nullptr && o.trunk.height > 0) {
        // TrunkOptions: a straight bole of nodes about the level-0 spacing apart from the
        // root up to the trunk top T, where the level-0 graph is rooted instead.
        const double h = o.trunk.height;
        const double spacing = levelSpacing(o, sys.levels[0], *sys.volume);
        const double count = std::max(1.0, std::ceil(h / spacing - 1e-9));
        guard.skeletonNodes(
            static_cast<int64_t>(tree.nodes.size()) + static_cast<int64_t>(std::min(count, 1e18)),
            " (the bole of [trunk] height)");
        const int segments = static_cast<int>(count);
        for (int k = 1; k <= segments; ++k) {
            SkeletonNode node;
            node.position = first.rootPos + Vec3{0, h * k / segments, 0};
            node.parent = first.rootNode;
            node.level = 1;
            node.part = part;
            first.rootNode = static_cast<int32_t>(tree.nodes.size());
            tree.nodes.push_back(node);
        }
        first.rootPos = tree.nodes[first.rootNode].position;
        first.minY = first.rootPos.y;
    }
    std::vector<GraphJob> jobs{first};
    std::vector<EndpointRecord> allEndpoints;
    std::vector<EndpointRecord> lastEndpoints;

    for (int level = 0; level < levels && !jobs.empty(); ++level) {
        // This level's graphs in full before any is built: nodes asked for and endpoints.
        int64_t levelNodes = 0, levelEndpoints = 0;
        for (const GraphJob& job : jobs) {
            levelNodes += sys.levels[level].nodes;
            levelEndpoints += job.endpoints;
        }
        const std::string at = " at " + std::string(roots ? "roots.levels[" : "levels[") +
                               std::to_string(level) + "] (" + std::to_string(jobs.size()) +
                               " graphs)";
        guard.graphNodes(stats.graphNodes + stats.graphEndpoints + levelNodes + levelEndpoints, at);
        guard.skeletonNodes(static_cast<int64_t>(tree.nodes.size()) + levelEndpoints, at);
        guard.time();
        std::vector<GraphResult> results(jobs.size());
        auto run = [&](size_t j) {
            Rng jobRng = rng.derive(hashCombine(static_cast<uint64_t>(level), jobs[j].key));
            results[j] = buildGraph(o, sys, roots, jobs[j], jobRng, guard);
        };
        if (threaded && jobs.size() > 1) {
            tbb::parallel_for(size_t(0), jobs.size(), run);
        } else {
            for (size_t j = 0; j < jobs.size(); ++j) run(j);
        }
        // Merge in job order (deterministic).
        lastEndpoints.clear();
        for (size_t j = 0; j < jobs.size(); ++j) {
            const GraphResult& r = results[j];
            const int32_t base = static_cast<int32_t>(tree.nodes.size());
            for (size_t k = 0; k < r.pos.size(); ++k) {
                SkeletonNode node;
                node.position = r.pos[k];
                node.parent = r.parent[k] < 0 ? jobs[j].rootNode : base + r.parent[k];
                node.level = level + 1;  // levels[level] is the paper's level i = level + 1
                node.part = part;
                tree.nodes.push_back(node);
            }
            for (size_t k = 0; k < r.endpoints.size(); ++k) {
                EndpointRecord e{base + r.endpoints[k], r.pos[r.endpoints[k]], jobs[j].rootPos,
                                 r.endpointLifespan[k]};
                tree.endpoints.push_back(e.node);
                lastEndpoints.push_back(e);
                allEndpoints.push_back(e);
            }
            stats.graphNodes += r.graphNodes;
            stats.graphEndpoints += r.graphEndpoints;
            stats.bridgingEdges += r.bridged;
            ++stats.graphs;
        }
        guard.skeletonNodes(static_cast<int64_t>(tree.nodes.size()), at);
        // maketree step 4: sub-graphs around the endpoints whose lifespan remains.
        const int next = level + 1;
        if (next >= levels) break;
        const IteratedGraphLevel& nl = sys.levels[next];
        const std::vector<EndpointRecord>& candidates =
            nl.fromAllLevels ? allEndpoints : lastEndpoints;
        Rng orientRng = rng.derive(hashCombine(0x0e1e, static_cast<uint64_t>(next)));
        std::vector<GraphJob> nextJobs;
        std::vector<Vec3> orientations;
        for (size_t c = 0; c < candidates.size(); ++c) {
            const EndpointRecord& e = candidates[c];
            if (!(e.lifespan >= 1.0 - 1e-9)) continue;  // the paper's L > 0 (integer L)
            Vec3 vg = orientationFor(nl, e, orientRng);
            GraphJob job;
            job.level = next;
            job.rootNode = e.node;
            job.rootPos = e.pos;
            job.volume =
                makePlaced(subgraphVolume(nl, radius[next]), Placement{e.pos, vg, {1, 1, 1}});
            job.endpointVolume = job.volume;
            job.endpoints = nl.endpoints;
            job.lifespan = e.lifespan;
            job.key = static_cast<uint64_t>(c);
            nextJobs.push_back(job);
            orientations.push_back(vg);
        }
        if (o.light.enabled && !nextJobs.empty()) {
            // Wolff §3.4: draw n values, hand the best to the branches facing the light.
            Rng lightRng = rng.derive(hashCombine(0x11647, static_cast<uint64_t>(next)));
            const size_t n = nextJobs.size();
            const double s = o.light.spread;
            std::vector<int> bs(n);
            std::vector<double> decs(n);
            int bLo = std::max(0, static_cast<int>(std::lround(nl.endpoints * (1 - s))));
            int bHi = std::max(bLo, static_cast<int>(std::lround(nl.endpoints * (1 + s))));
            for (size_t k = 0; k < n; ++k) {
                bs[k] = bLo + static_cast<int>(lightRng.below(bHi - bLo + 1));
                decs[k] = lightRng.uniform(std::max(0.0, 1 - s), 1 + s);
            }
            std::sort(bs.begin(), bs.end(), std::greater<int>());
            std::sort(decs.begin(), decs.end());
            std::vector<size_t> byAngle(n);
            std::vector<double> angle(n);
            for (size_t k = 0; k < n; ++k) {
                byAngle[k] = k;
                angle[k] = angleBetween(orientations[k], o.light.direction);
            }
            std::stable_sort(byAngle.begin(), byAngle.end(),
                             [&](size_t a, size_t b) { return angle[a] < angle[b]; });
            for (size_t rank = 0; rank < n; ++rank) {
                GraphJob& job = nextJobs[byAngle[rank]];
                if (o.light.endpoints) job.endpoints = bs[rank];
                if (o.light.lifespan) job.decrement = decs[rank];
            }
        }
        jobs = std::move(nextJobs);
    }
}

}  // namespace

int64_t mergeParallelPaths(Tree& tree, const MergeOptions& options) {
    std::vector<SkeletonNode>& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());
    if (n < 3 || !(options.distance > 0)) return 0;
    Aabb box;
    for (const SkeletonNode& v : nodes) box.extend(v.position);
    PointGrid grid(box, options.distance);
    grid.reserve(n);
    // alias[v]: the kept node v is snapped onto (v itself when kept); parent[v]: v's kept
    // parent, defined for kept nodes. Every kept node's parent has a smaller index, so the
    // kept nodes form a rooted tree with parents first whatever is merged.
    std::vector<int32_t> alias(n), parent(n, -1);
    alias[0] = 0;
    grid.insert(0, nodes[0].position);
    const double cosMax = std::cos(options.maxAngle);
    // A kept node's direction over its last two segments (less noisy than one zig-zag edge).
    auto direction = [&](int32_t v) {
        int32_t a = v;
        for (int k = 0; k < 2 && parent[a] >= 0; ++k) a = parent[a];
        return nodes[v].position - nodes[a].position;
    };
    auto isAncestorOrSelf = [&](int32_t u, int32_t v) {
        for (int32_t a = v; a >= 0; a = parent[a]) {
            if (a == u) return true;
        }
        return false;
    };
    int64_t merged = 0;
    for (int32_t v = 1; v < n; ++v) {
        int32_t p = alias[nodes[v].parent];
        if (p != nodes[v].parent) {
            // The parent was snapped onto another path, perhaps ahead of v: hang v from the
            // last node of that path behind it, so the path never turns back (no hook).
            while (parent[p] >= 0 && dot(nodes[v].position - nodes[p].position,
                                         nodes[p].position - nodes[parent[p]].position) < 0) {
                p = parent[p];
            }
        }
        alias[v] = v;
        parent[v] = p;  // provisional: direction(v) below reads it
        const Vec3 dv = direction(v);
        const double reach =
            options.distance * std::pow(options.shrink, std::max(0, nodes[v].level - 1));
        int32_t best = -1;
        double bestD = std::numeric_limits<double>::infinity();
        grid.forEachWithin(nodes[v].position, reach, [&](int32_t u, const Vec3& q) {
            if (nodes[u].part != nodes[v].part) return;
            const double d = distance2(q, nodes[v].position);
            if (d > bestD || (d == bestD && u > best)) return;
            const Vec3 du = direction(u);
            const double len = std::sqrt(length2(du) * length2(dv));
            if (!(len > 0) || dot(du, dv) < cosMax * len) return;  // not side by side
            if (isAncestorOrSelf(u, p)) return;                    // the path's own past
            best = u;
            bestD = d;
        });
        if (best >= 0) {
            alias[v] = best;
            parent[v] = -1;
            ++merged;
        } else {
            grid.insert(v, nodes[v].position);
        }
    }
    if (merged == 0) return 0;
    // A kept node whose children were all snapped elsewhere is a stub where a path left the
    // older one and came back: it goes too (children before parents, so chains of them go).
    std::vector<char> wasTip(n, 1), hasChild(n, 0);
    for (int32_t v = 1; v < n; ++v) wasTip[nodes[v].parent] = 0;
    for (int32_t v = n - 1; v > 0; --v) {
        if (alias[v] != v) continue;
        if (!hasChild[v] && !wasTip[v]) {
            alias[v] = -1;  // removed
            ++merged;
            continue;
        }
        hasChild[parent[v]] = 1;
    }
    std::vector<int32_t> index(n, -1);
    std::vector<SkeletonNode> kept;
    kept.reserve(n - merged);
    for (int32_t v = 0; v < n; ++v) {
        if (alias[v] != v) continue;
        index[v] = static_cast<int32_t>(kept.size());
        SkeletonNode node = nodes[v];
        node.parent = v == 0 ? -1 : index[parent[v]];
        kept.push_back(node);
    }
    // Endpoints snapped onto another path are gone with their node (its twig joined that path).
    std::vector<int32_t> endpoints;
    for (int32_t e : tree.endpoints) {
        if (index[e] >= 0) endpoints.push_back(index[e]);
    }
    tree.endpoints = std::move(endpoints);
    nodes = std::move(kept);
    return merged;
}

void smoothAxes(Tree& tree, int iterations, const GrowthGuard& guard) {
    std::vector<SkeletonNode>& nodes = tree.nodes;
    const int32_t n = static_cast<int32_t>(nodes.size());
    if (iterations <= 0 || n < 3) return;
    const ChildIndex children(tree);
    // The continuing child at every node: the longest path below it (assignBranchOrder's
    // rule, so an axis is what gets one branch order), ties to the lower index.
    std::vector<double> downstream(n, 0.0);
    for (int32_t i = n - 1; i > 0; --i) {
        const int32_t p = nodes[i].parent;
        downstream[p] =
            std::max(downstream[p], distance(nodes[p].position, nodes[i].position) + downstream[i]);
    }
    std::vector<int32_t> next(n, -1);
    for (int32_t i = 1; i < n; ++i) {  // the root is every axis's fixed start, never inside one
        double best = -1.0;
        for (int32_t k = children.offset[i]; k < children.offset[i + 1]; ++k) {
            const int32_t c = children.child[k];
            const double len = distance(nodes[i].position, nodes[c].position) + downstream[c];
            if (len > best) {
                best = len;
                next[i] = c;
            }
        }
    }
    // Axes start at every node that does not continue its parent's axis; in index order, so
    // a fork (on an earlier axis) has moved before the axes leaving it are smoothed.
    std::vector<int32_t> axis;
    std::vector<Vec3> a, b;
    for (int32_t s = 1; s < n; ++s) {
        const int32_t p = nodes[s].parent;
        if (p != 0 && next[p] == s) continue;
        axis.assign(1, p);
        for (int32_t v = s; v >= 0; v = next[v]) axis.push_back(v);
        const size_t m = axis.size();
        if (m < 3) continue;
        a.resize(m);
        for (size_t k = 0; k < m; ++k) a[k] = nodes[axis[k]].position;
        b = a;
        uint64_t work = 0;
        for (int it = 0; it < iterations; ++it) {
            guard.work(work, m);
            for (size_t k = 1; k + 1 < m; ++k) b[k] = a[k] * 0.5 + (a[k - 1] + a[k + 1]) * 0.25;
            std::swap(a, b);
        }
        for (size_t k = 1; k + 1 < m; ++k) nodes[axis[k]].position = a[k];
    }
}

Tree growIteratedGraph(const IteratedGraphOptions& options, Rng& rng, bool threaded,
                       IteratedGraphStats* statsOut, const GrowthGuard& guard) {
    Tree tree;
    SkeletonNode root;
    root.position = Vec3{0, 0, 0};
    tree.nodes.push_back(root);
    IteratedGraphStats stats;
    growSystem(options, options.crown, nullptr, kShootPart, rng.derive("crown"), threaded, tree,
               stats, guard);
    if (options.roots.enabled) {
        growSystem(options, options.roots.system, &options.roots, kRootPart, rng.derive("roots"),
                   threaded, tree, stats, guard);
    }

    // Continuous limbs (issue 13): bundles merged, then every axis smoothed, before radii.
    if (options.merge.distance > 0) stats.mergedNodes = mergeParallelPaths(tree, options.merge);
    smoothAxes(tree, options.smoothing.iterations, guard);

    // Thickness (§3.2): w = (d')^ζ / (i + 1), d' the distance to the branch tip along the
    // path, taken at the middle of each node's incoming segment so tips keep a radius.
    const size_t n = tree.nodes.size();
    std::vector<double> down(n, 0.0);
    for (size_t i = n; i-- > 1;) {
        const SkeletonNode& node = tree.nodes[i];
        double len = distance(node.position, tree.nodes[node.parent].position);
        down[node.parent] = std::max(down[node.parent], down[i] + len);
    }
    for (size_t i = 0; i < n; ++i) {
        SkeletonNode& node = tree.nodes[i];
        double half =
            i == 0 ? 0.0 : 0.5 * distance(node.position, tree.nodes[node.parent].position);
        int level = std::max(1, node.level);
        node.radius = options.thicknessScale * std::pow(down[i] + half, options.zeta) / (level + 1);
    }
    // A parent is never thinner than its child (level jumps can only shrink radii, but
    // keep the invariant explicit for meshing).
    for (size_t i = n; i-- > 1;) {
        SkeletonNode& p = tree.nodes[tree.nodes[i].parent];
        p.radius = std::max(p.radius, tree.nodes[i].radius);
    }
    assignBranchOrder(tree);
    if (statsOut) *statsOut = stats;
    return tree;
}

}  // namespace sylva
