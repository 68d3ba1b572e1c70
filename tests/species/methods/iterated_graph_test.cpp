// The iterated-graph growth method (Xu & Mould 2012): least-cost search against brute force,
// CSR graph construction, tree invariants for direct options and every preset, determinism
// across thread counts, graph/endpoint counts with known answers (levels, lifespan rules,
// from-all-levels), sub-graph volumes and orientation, γ curvature, linking modes, light,
// roots, the thickness formula and Poisson saturation; the continuous-limb options (smoothing,
// merging, a single trunk, the radial weight) with known answers.
#include "species/methods/iterated_graph.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/rng.h"
#include "species/model/tree.h"
#include "species/model/tree_stats.h"
#include "species/spec/species.h"
#include "tests/test_support.h"
#include "volumes/poisson.h"
#include "volumes/volume.h"

namespace sylva {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// ------------------------------------------------------------------------------------------
// Brute-force references for the least-cost search.

struct RandomGraph {
    int n = 0;
    std::vector<std::pair<int32_t, int32_t>> edges;  // i < j, duplicates allowed
    std::vector<double> costs;
};

// n nodes, each pair linked with probability p; costs uniform in [0.1, 3) or small integers
// (to provoke ties); optionally a few duplicated pairs with a different cost.
RandomGraph randomGraph(Rng& rng, int n, double p, bool integerCosts, bool duplicates) {
    RandomGraph g;
    g.n = n;
    auto cost = [&]() {
        return integerCosts ? 1.0 + static_cast<double>(rng.below(3)) : rng.uniform(0.1, 3.0);
    };
    for (int i = 0; i < n; ++i) {
        for (int j = i + 1; j < n; ++j) {
            if (rng.uniform() < p) {
                g.edges.push_back({i, j});
                g.costs.push_back(cost());
                if (duplicates && rng.uniform() < 0.3) {
                    g.edges.push_back({i, j});
                    g.costs.push_back(cost());
                }
            }
        }
    }
    return g;
}

// Cheapest direct edge cost per ordered pair (infinity if none).
std::vector<std::vector<double>> directCosts(const RandomGraph& g) {
    std::vector<std::vector<double>> c(g.n, std::vector<double>(g.n, kInf));
    for (size_t e = 0; e < g.edges.size(); ++e) {
        auto [a, b] = g.edges[e];
        c[a][b] = std::min(c[a][b], g.costs[e]);
        c[b][a] = std::min(c[b][a], g.costs[e]);
    }
    return c;
}

std::vector<std::vector<double>> floydWarshall(const RandomGraph& g) {
    auto d = directCosts(g);
    for (int i = 0; i < g.n; ++i) d[i][i] = 0.0;
    for (int k = 0; k < g.n; ++k)
        for (int i = 0; i < g.n; ++i)
            for (int j = 0; j < g.n; ++j) d[i][j] = std::min(d[i][j], d[i][k] + d[k][j]);
    return d;
}

// Minimum cost over all simple paths from s, by exhaustive depth-first enumeration.
std::vector<double> enumeratePaths(const RandomGraph& g, int s) {
    auto c = directCosts(g);
    std::vector<double> best(g.n, kInf);
    std::vector<char> onPath(g.n, 0);
    auto dfs = [&](auto&& self, int u, double cost) -> void {
        best[u] = std::min(best[u], cost);
        onPath[u] = 1;
        for (int v = 0; v < g.n; ++v) {
            if (!onPath[v] && c[u][v] < kInf) self(self, v, cost + c[u][v]);
        }
        onPath[u] = 0;
    };
    dfs(dfs, s, 0.0);
    return best;
}

TEST(IteratedGraphLeastCost, MatchesBruteForceOnRandomGraphs) {
    Rng rng(20120501);
    int checked = 0, unreachableSeen = 0;
    for (int trial = 0; trial < 600; ++trial) {
        const int n = 2 + trial % 8;  // 2 … 9 nodes
        const double p = (trial / 8) % 3 == 0 ? 0.2 : ((trial / 8) % 3 == 1 ? 0.45 : 0.8);
        const bool integerCosts = (trial / 24) % 2 == 1;
        const bool duplicates = (trial / 48) % 2 == 1;
        RandomGraph rg = randomGraph(rng, n, p, integerCosts, duplicates);
        const int s = static_cast<int>(rng.below(n));
        SCOPED_TRACE("trial " + std::to_string(trial) + " n=" + std::to_string(n) +
                     " source=" + std::to_string(s));

        WeightedGraph g = makeGraph(n, rg.edges, rg.costs);
        std::vector<double> dist;
        std::vector<int32_t> pred;
        leastCostTree(g, s, dist, pred);
        ASSERT_EQ(dist.size(), static_cast<size_t>(n));
        ASSERT_EQ(pred.size(), static_cast<size_t>(n));

        const auto fw = floydWarshall(rg);
        const auto ex = enumeratePaths(rg, s);
        const auto direct = directCosts(rg);
        EXPECT_EQ(dist[s], 0.0);
        EXPECT_EQ(pred[s], -1);
        for (int v = 0; v < n; ++v) {
            // The two references agree with each other.
            if (fw[s][v] == kInf) {
                ASSERT_EQ(ex[v], kInf);
            } else {
                ASSERT_NEAR(ex[v], fw[s][v], 1e-12);
            }
            if (fw[s][v] == kInf) {
                ++unreachableSeen;
                EXPECT_EQ(dist[v], kInf) << "node " << v;
                EXPECT_EQ(pred[v], -1) << "node " << v;
                continue;
            }
            EXPECT_NEAR(dist[v], fw[s][v], 1e-12) << "node " << v;
            if (v == s) continue;
            // pred[] is a path back to the source whose summed cost is dist[v].
            ASSERT_GE(pred[v], 0) << "node " << v;
            ASSERT_LT(pred[v], n) << "node " << v;
            double sum = 0.0;
            int steps = 0;
            for (int u = v; u != s; u = pred[u]) {
                ASSERT_GE(pred[u], 0) << "pred chain from " << v << " breaks at " << u;
                ASSERT_LT(direct[pred[u]][u], kInf)
                    << "pred " << pred[u] << " of " << u << " is not a neighbour";
                sum += direct[pred[u]][u];
                ASSERT_LE(++steps, n) << "pred chain from " << v << " has a cycle";
            }
            EXPECT_NEAR(sum, dist[v], 1e-12) << "node " << v;
            ++checked;
        }
    }
    EXPECT_GT(checked, 1000);
    EXPECT_GT(unreachableSeen, 50);  // the sparse trials do exercise unreachable nodes
}

TEST(IteratedGraphLeastCost, HandBuiltGraph) {
    //      4          1          3
    //  0 ----- 1 --------- 3 ------- 4        5 (isolated)
    //   \     /           /
    //  1 \   / 2         / 5
    //     \ /           /
    //      2 -----------
    // Least costs from 0: 0, 3 (0-2-1), 1, 4 (0-2-1-3), 7 (…-3-4), ∞.
    std::vector<std::pair<int32_t, int32_t>> edges{{0, 1}, {0, 2}, {1, 2}, {1, 3}, {2, 3}, {3, 4}};
    std::vector<double> costs{4, 1, 2, 1, 5, 3};
    WeightedGraph g = makeGraph(6, edges, costs);
    std::vector<double> dist;
    std::vector<int32_t> pred;
    leastCostTree(g, 0, dist, pred);
    EXPECT_EQ(dist, (std::vector<double>{0, 3, 1, 4, 7, kInf}));
    EXPECT_EQ(pred, (std::vector<int32_t>{-1, 2, 0, 1, 3, -1}));

    // From node 4 the same edges give the mirrored tree.
    leastCostTree(g, 4, dist, pred);
    EXPECT_EQ(dist, (std::vector<double>{7, 4, 6, 3, 0, kInf}));
    EXPECT_EQ(pred, (std::vector<int32_t>{2, 3, 1, 4, -1, -1}));

    // From the isolated node nothing is reachable.
    leastCostTree(g, 5, dist, pred);
    for (int v = 0; v < 5; ++v) {
        EXPECT_EQ(dist[v], kInf);
        EXPECT_EQ(pred[v], -1);
    }
    EXPECT_EQ(dist[5], 0.0);
    EXPECT_EQ(pred[5], -1);
}

// ------------------------------------------------------------------------------------------
// CSR construction.

TEST(IteratedGraphCsr, HandBuiltOffsetsTargetsCosts) {
    WeightedGraph g = makeGraph(5, {{0, 1}, {1, 2}, {0, 3}}, {2.0, 3.0, 5.0});
    EXPECT_EQ(g.size(), 5);
    EXPECT_EQ(g.offset, (std::vector<int32_t>{0, 2, 4, 5, 6, 6}));
    auto neighbours = [&](int i) {
        std::vector<std::pair<int32_t, double>> r;
        for (int k = g.offset[i]; k < g.offset[i + 1]; ++k) r.push_back({g.target[k], g.cost[k]});
        std::sort(r.begin(), r.end());
        return r;
    };
    using N = std::vector<std::pair<int32_t, double>>;
    EXPECT_EQ(neighbours(0), (N{{1, 2.0}, {3, 5.0}}));
    EXPECT_EQ(neighbours(1), (N{{0, 2.0}, {2, 3.0}}));
    EXPECT_EQ(neighbours(2), (N{{1, 3.0}}));
    EXPECT_EQ(neighbours(3), (N{{0, 5.0}}));
    EXPECT_EQ(neighbours(4), N{});

    WeightedGraph empty = makeGraph(3, {}, {});
    EXPECT_EQ(empty.size(), 3);
    EXPECT_EQ(empty.offset, (std::vector<int32_t>{0, 0, 0, 0}));
    EXPECT_TRUE(empty.target.empty());
}

TEST(IteratedGraphCsr, RandomGraphsSymmetricWithDegreesAndCosts) {
    Rng rng(77);
    for (int trial = 0; trial < 200; ++trial) {
        const int n = 1 + static_cast<int>(rng.below(30));
        RandomGraph rg = randomGraph(rng, n, rng.uniform(0.0, 0.6), false, trial % 2 == 1);
        SCOPED_TRACE("trial " + std::to_string(trial));
        WeightedGraph g = makeGraph(n, rg.edges, rg.costs);
        ASSERT_EQ(g.size(), n);
        ASSERT_EQ(g.offset.size(), static_cast<size_t>(n) + 1);
        EXPECT_EQ(g.offset[0], 0);
        ASSERT_EQ(g.offset[n], static_cast<int32_t>(2 * rg.edges.size()));
        ASSERT_EQ(g.target.size(), 2 * rg.edges.size());
        ASSERT_EQ(g.cost.size(), 2 * rg.edges.size());

        // Expected adjacency multisets from the edge list.
        std::vector<std::multiset<std::pair<int32_t, double>>> want(n), got(n);
        for (size_t e = 0; e < rg.edges.size(); ++e) {
            auto [a, b] = rg.edges[e];
            want[a].insert({b, rg.costs[e]});
            want[b].insert({a, rg.costs[e]});
        }
        for (int i = 0; i < n; ++i) {
            ASSERT_LE(g.offset[i], g.offset[i + 1]);
            EXPECT_EQ(g.offset[i + 1] - g.offset[i], static_cast<int32_t>(want[i].size()))
                << "degree of " << i;
            for (int k = g.offset[i]; k < g.offset[i + 1]; ++k) {
                ASSERT_GE(g.target[k], 0);
                ASSERT_LT(g.target[k], n);
                EXPECT_NE(g.target[k], i);
                got[i].insert({g.target[k], g.cost[k]});
            }
            EXPECT_EQ(got[i], want[i]) << "adjacency of " << i;
        }
        // Symmetry: every i→j with cost c has a matching j→i with the same cost.
        for (int i = 0; i < n; ++i) {
            for (const auto& [j, c] : got[i]) {
                EXPECT_EQ(got[j].count({i, c}), got[i].count({j, c}))
                    << "asymmetric edge " << i << "-" << j;
            }
        }
    }
}

// ------------------------------------------------------------------------------------------
// Tree helpers.

bool finite(const Vec3& p) {
    return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

std::string str(const Vec3& p) {
    std::ostringstream s;
    s << "(" << p.x << ", " << p.y << ", " << p.z << ")";
    return s.str();
}

// Structural invariants every tree of the method satisfies.
::testing::AssertionResult validTree(const Tree& t) {
    const int32_t n = static_cast<int32_t>(t.nodes.size());
    if (n == 0) return ::testing::AssertionFailure() << "empty tree";
    if (t.nodes[0].parent != -1) {
        return ::testing::AssertionFailure() << "node 0 has parent " << t.nodes[0].parent;
    }
    int roots = 0;
    std::vector<int> children(n, 0);
    for (int32_t i = 0; i < n; ++i) {
        const SkeletonNode& v = t.nodes[i];
        if (v.parent == -1) ++roots;
        if (i > 0 && (v.parent < 0 || v.parent >= i)) {
            return ::testing::AssertionFailure() << "node " << i << " has parent " << v.parent;
        }
        if (!finite(v.position)) {
            return ::testing::AssertionFailure() << "node " << i << " at " << str(v.position);
        }
        if (!(std::isfinite(v.radius) && v.radius > 0)) {
            return ::testing::AssertionFailure() << "node " << i << " radius " << v.radius;
        }
        if (v.order < 0) {
            return ::testing::AssertionFailure() << "node " << i << " order " << v.order;
        }
        if (i == 0) continue;
        const SkeletonNode& p = t.nodes[v.parent];
        ++children[v.parent];
        if (p.radius < v.radius) {
            return ::testing::AssertionFailure()
                   << "node " << i << " radius " << v.radius << " > parent " << v.parent
                   << " radius " << p.radius;
        }
        if (v.level < p.level || v.level < 1) {
            return ::testing::AssertionFailure()
                   << "node " << i << " level " << v.level << ", parent level " << p.level;
        }
        if (v.parent != 0 && v.part != p.part) {
            return ::testing::AssertionFailure() << "node " << i << " changes part";
        }
    }
    if (roots != 1) return ::testing::AssertionFailure() << roots << " roots";
    std::set<int32_t> seen;
    for (int32_t e : t.endpoints) {
        if (e <= 0 || e >= n) return ::testing::AssertionFailure() << "endpoint index " << e;
        if (!seen.insert(e).second) {
            return ::testing::AssertionFailure() << "endpoint " << e << " listed twice";
        }
        int steps = 0;
        for (int32_t v = e; v != 0; v = t.nodes[v].parent) {
            if (v < 0 || ++steps > n) {
                return ::testing::AssertionFailure() << "endpoint " << e << " does not reach 0";
            }
        }
    }
    // The skeleton is the union of paths to endpoints: every tip is an endpoint.
    for (int32_t i = 1; i < n; ++i) {
        if (children[i] == 0 && !seen.count(i)) {
            return ::testing::AssertionFailure() << "tip " << i << " is not an endpoint";
        }
    }
    return ::testing::AssertionSuccess();
}

::testing::AssertionResult identicalTrees(const Tree& a, const Tree& b) {
    if (a.nodes.size() != b.nodes.size()) {
        return ::testing::AssertionFailure()
               << "node counts " << a.nodes.size() << " vs " << b.nodes.size();
    }
    for (size_t i = 0; i < a.nodes.size(); ++i) {
        const SkeletonNode &x = a.nodes[i], &y = b.nodes[i];
        if (!(x.position == y.position) || x.radius != y.radius || x.parent != y.parent ||
            x.order != y.order || x.level != y.level || x.part != y.part) {
            return ::testing::AssertionFailure()
                   << "node " << i << " differs: " << str(x.position) << " r=" << x.radius
                   << " parent=" << x.parent << " vs " << str(y.position) << " r=" << y.radius
                   << " parent=" << y.parent;
        }
    }
    if (a.endpoints != b.endpoints) return ::testing::AssertionFailure() << "endpoints differ";
    return ::testing::AssertionSuccess();
}

// The root of the graph a node belongs to: the first ancestor of a lower level (or node 0).
int32_t graphRoot(const Tree& t, int32_t i) {
    const int level = t.nodes[i].level;
    int32_t j = t.nodes[i].parent;
    while (j > 0 && t.nodes[j].level == level) j = t.nodes[j].parent;
    return j;
}

// Figure 15: lateral root endpoints lie within `lateral` of the taproot — the tree's path
// from the taproot endpoint (0, −depth, 0) to node 0.
::testing::AssertionResult lateralsNearTaproot(const Tree& t, double depth, double lateral) {
    int32_t taprootEnd = -1;
    for (int32_t e : t.endpoints) {
        const SkeletonNode& v = t.nodes[e];
        if (v.part == kRootPart && v.level == 1 && v.position == Vec3(0, -depth, 0)) {
            taprootEnd = e;
        }
    }
    if (taprootEnd < 0) return ::testing::AssertionFailure() << "no taproot endpoint";
    std::vector<Vec3> tap;
    for (int32_t v = taprootEnd; v >= 0; v = t.nodes[v].parent) tap.push_back(t.nodes[v].position);
    int laterals = 0;
    for (int32_t e : t.endpoints) {
        const SkeletonNode& v = t.nodes[e];
        if (v.part != kRootPart || v.level != 1 || e == taprootEnd) continue;
        ++laterals;
        double d = kInf;
        for (size_t k = 0; k + 1 < tap.size(); ++k) {
            const Vec3 ab = tap[k + 1] - tap[k];
            double u = std::clamp(dot(v.position - tap[k], ab) / length2(ab), 0.0, 1.0);
            d = std::min(d, distance(v.position, tap[k] + ab * u));
        }
        if (d > lateral + 1e-9) {
            return ::testing::AssertionFailure()
                   << "lateral endpoint " << e << " " << str(v.position) << " is " << d
                   << " m from the taproot, more than " << lateral;
        }
    }
    if (laterals == 0) return ::testing::AssertionFailure() << "no lateral endpoints";
    return ::testing::AssertionSuccess();
}

VolumePtr crownSphere() { return makePlaced(makeSphere(1.2), Placement{{0, 2.4, 0}}); }

// A small crown: a trunk cylinder under a sphere; level-0 endpoints in the sphere.
IteratedGraphOptions smallOptions(std::vector<int> b = {3, 2, 2},
                                  std::vector<int> nodes = {200, 40, 25}) {
    IteratedGraphOptions o;
    o.crown.volume = makeUnion({makeCylinder(0.25, 1.5), crownSphere()});
    o.crown.endpointVolume = crownSphere();
    o.crown.subgraphRadius = 0.8;
    o.crown.shrink = 0.7;
    for (size_t i = 0; i < b.size(); ++i) {
        IteratedGraphLevel l;
        l.nodes = nodes[std::min(i, nodes.size() - 1)];
        l.endpoints = b[i];
        o.crown.levels.push_back(l);
    }
    return o;
}

Tree grow(const IteratedGraphOptions& o, uint64_t seed, bool threaded = true,
          IteratedGraphStats* stats = nullptr) {
    Rng rng(seed);
    return growIteratedGraph(o, rng, threaded, stats);
}

// ------------------------------------------------------------------------------------------
// Tree invariants.

TEST(IteratedGraphTree, DirectOptionsInvariantsAndVolumes) {
    IteratedGraphOptions o = smallOptions();
    const double r1 = o.crown.subgraphRadius, r2 = r1 * o.crown.shrink;
    const double alpha = o.crown.levels[1].alpha;
    ASSERT_EQ(alpha, o.crown.levels[2].alpha);
    Aabb loose = o.crown.volume->bounds();
    const double pad = r1 + r2 + 1e-9;
    loose.lo -= Vec3{pad, pad, pad};
    loose.hi += Vec3{pad, pad, pad};

    // Link distance per level: linkFactor × spacing, spacing = f·(V/K)^(1/3) (maketree 1G).
    auto link = [&](double volume, int nodes) {
        return o.linkFactor * o.spacingFactor * std::cbrt(volume / nodes);
    };
    const double links[3] = {link(o.crown.volume->measure(), o.crown.levels[0].nodes),
                             link(makeSphereSector(r1, alpha)->measure(), o.crown.levels[1].nodes),
                             link(makeSphereSector(r2, alpha)->measure(), o.crown.levels[2].nodes)};

    for (uint64_t seed = 1; seed <= 3; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        IteratedGraphStats s;
        Tree t = grow(o, seed, true, &s);
        ASSERT_TRUE(validTree(t));
        ASSERT_EQ(t.endpoints.size(), 21u);
        // Every segment is a graph edge — shorter than its level's link distance — except
        // for edges added to bridge split graphs.
        int64_t longSegments = 0;
        for (int32_t i = 1; i < static_cast<int32_t>(t.nodes.size()); ++i) {
            const SkeletonNode& v = t.nodes[i];
            if (distance(v.position, t.nodes[v.parent].position) >= links[v.level - 1]) {
                ++longSegments;
            }
        }
        EXPECT_LE(longSegments, s.bridgingEdges);
        int level1 = 0, sub = 0;
        for (int32_t i = 1; i < static_cast<int32_t>(t.nodes.size()); ++i) {
            const SkeletonNode& v = t.nodes[i];
            EXPECT_EQ(v.part, kShootPart);
            ASSERT_GE(v.level, 1);
            ASSERT_LE(v.level, 3);
            ASSERT_TRUE(loose.contains(v.position)) << "node " << i << " " << str(v.position);
            if (v.level == 1) {
                // Level-1 paths run through the crown volume's graph.
                ++level1;
                EXPECT_LE(o.crown.volume->signedDistance(v.position), 1e-9)
                    << "level-1 node " << i << " " << str(v.position);
                EXPECT_EQ(graphRoot(t, i), 0);
                continue;
            }
            // A level-i node lies in its graph's sphere sector: within r_i of the graph root
            // and within α of v_g = (root − root's own graph root) (maketree 4B/4C).
            ++sub;
            const int32_t g = graphRoot(t, i);
            ASSERT_EQ(t.nodes[g].level, v.level - 1) << "node " << i;
            const int32_t gg = graphRoot(t, g);
            const Vec3 vg = t.nodes[g].position - t.nodes[gg].position;
            const Vec3 d = v.position - t.nodes[g].position;
            const double r = v.level == 2 ? r1 : r2;
            EXPECT_LE(length(d), r + 1e-9) << "node " << i;
            EXPECT_LE(angleBetween(d, vg), alpha + 1e-9) << "node " << i;
        }
        EXPECT_GT(level1, 3);
        EXPECT_GT(sub, 18);
        // Endpoints: level-1 endpoints inside the endpoint volume.
        for (int32_t e : t.endpoints) {
            if (t.nodes[e].level == 1) {
                EXPECT_LE(o.crown.endpointVolume->signedDistance(t.nodes[e].position), 1e-9);
            }
        }
    }
}

std::vector<std::filesystem::path> presetFiles() { return test::shippedSpeciesFiles(); }

TEST(IteratedGraphTree, EveryPresetGrowsValidTrees) {
    constexpr size_t kOneSeedAboveNodes = 20000;
    const auto files = presetFiles();
    int grown = 0, withRoots = 0;
    for (const auto& file : files) {
        SCOPED_TRACE(file.filename().string());
        SpeciesFile species = loadSpecies(file.string());
        if (species.method != "iterated-graph") continue;
        for (uint64_t seed = 1; seed <= 3; ++seed) {
            SCOPED_TRACE("seed " + std::to_string(seed));
            GrownTree g = growSpecies(species, seed, nullptr, true);
            ++grown;
            EXPECT_TRUE(validTree(g.tree));
            EXPECT_GT(g.tree.nodes.size(), 1u);
            EXPECT_FALSE(g.tree.endpoints.empty());
            // Root systems: laterals around the taproot.
            const toml::table& tbl = *species.table;
            auto depth = tbl["roots"]["taproot_depth"].value<double>();
            auto lateral = tbl["roots"]["lateral_distance"].value<double>();
            if (depth && lateral) {
                ++withRoots;
                EXPECT_TRUE(lateralsNearTaproot(g.tree, *depth, *lateral));
            }
            // Every endpoint of every graph is in the tree, unless merging snapped it onto
            // another path (then at most as many remain, and some do).
            auto it = g.methodStats.find("graph_endpoints");
            if (it != g.methodStats.end()) {
                const double ends = static_cast<double>(g.tree.endpoints.size());
                if (g.methodStats.count("merged_nodes")) {
                    EXPECT_LE(ends, it->second);
                    EXPECT_GT(ends, 0.0);
                } else {
                    EXPECT_EQ(it->second, ends);
                }
            }
            // Large presets: one seed keeps the suite fast (a fixed rule, not the clock, so
            // every machine checks the same trees).
            if (g.tree.nodes.size() > kOneSeedAboveNodes) break;
        }
    }
    EXPECT_GE(grown, 22) << "the 22 xm-* presets in " << SYLVA_SOURCE_DIR;
    EXPECT_GE(withRoots, 1) << "no preset with a [roots] table was checked";
}

// ------------------------------------------------------------------------------------------
// Determinism.

TEST(IteratedGraphDeterminism, ThreadedSerialAndOneThreadIdentical) {
    // Enough sub-graphs (16 + 64) of enough nodes that TBB workers do take part.
    IteratedGraphOptions o = smallOptions({16, 4, 2}, {300, 150, 40});
    for (uint64_t seed : {5u, 6u}) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        Tree threaded = grow(o, seed, true);
        Tree serial = grow(o, seed, false);
        EXPECT_TRUE(identicalTrees(threaded, serial));
        for (int repeat = 0; repeat < 3; ++repeat) {
            Tree again = grow(o, seed, true);
            EXPECT_TRUE(identicalTrees(threaded, again));
        }
        {
            tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
            Tree single = grow(o, seed, true);
            EXPECT_TRUE(identicalTrees(threaded, single));
        }
    }
    // A different seed gives a different tree.
    Tree a = grow(o, 5), b = grow(o, 6);
    EXPECT_FALSE(identicalTrees(a, b));
    ASSERT_GT(a.nodes.size(), 1u);
    ASSERT_GT(b.nodes.size(), 1u);
    EXPECT_FALSE(a.nodes[1].position == b.nodes[1].position);
}

TEST(IteratedGraphDeterminism, RootsAndYaoAlsoIndependentOfThreads) {
    IteratedGraphOptions o = smallOptions({3, 2}, {150, 30});
    o.linking = Linking::kYao;
    o.roots.enabled = true;
    o.roots.system.volume = makePlaced(makeHemisphere(1.3), Placement{{0, 0, 0}, {0, -1, 0}});
    o.roots.system.subgraphRadius = 0.4;
    o.roots.taprootDepth = 1.0;
    IteratedGraphLevel l0, l1;
    l0.nodes = 120;
    l0.endpoints = 3;
    l1.nodes = 20;
    l1.endpoints = 2;
    o.roots.system.levels = {l0, l1};
    Tree threaded = grow(o, 11, true);
    Tree serial = grow(o, 11, false);
    EXPECT_TRUE(identicalTrees(threaded, serial));
}

// ------------------------------------------------------------------------------------------
// Counts with known answers.

TEST(IteratedGraphCounts, FixedLifespanGraphsAndEndpoints) {
    IteratedGraphOptions o = smallOptions({3, 2, 2}, {200, 40, 25});
    for (uint64_t seed = 1; seed <= 3; ++seed) {
        IteratedGraphStats s;
        Tree t = grow(o, seed, true, &s);
        EXPECT_EQ(s.graphs, 1 + 3 + 6);
        EXPECT_EQ(s.graphEndpoints, 3 + 6 + 12);
        EXPECT_EQ(s.graphNodes, 200 + 3 * 40 + 6 * 25);
        EXPECT_EQ(t.endpoints.size(), 21u);
        // Endpoints per level: b0, b0·b1, b0·b1·b2.
        std::map<int, int> perLevel;
        for (int32_t e : t.endpoints) ++perLevel[t.nodes[e].level];
        EXPECT_EQ(perLevel, (std::map<int, int>{{1, 3}, {2, 6}, {3, 12}}));
    }

    // An explicit initial lifespan of 1 stops after the first sub-graph level (the paper's
    // "if L > 0" with L − 1 passed down): 1 + 3 graphs.
    o.initialLifespan = 1.0;
    IteratedGraphStats s;
    Tree t = grow(o, 1, true, &s);
    EXPECT_EQ(s.graphs, 1 + 3);
    EXPECT_EQ(s.graphEndpoints, 3 + 6);
    EXPECT_EQ(t.endpoints.size(), 9u);
    o.initialLifespan = 0.0;
    t = grow(o, 1, true, &s);
    EXPECT_EQ(s.graphs, 1);
    EXPECT_EQ(t.endpoints.size(), 3u);
}

TEST(IteratedGraphCounts, FromAllLevels) {
    IteratedGraphOptions o = smallOptions({3, 2, 2}, {200, 40, 25});
    o.crown.levels[2].fromAllLevels = true;
    IteratedGraphStats s;
    Tree t = grow(o, 2, true, &s);
    ASSERT_TRUE(validTree(t));
    // Level-2 sub-graphs around the 3 level-0 and the 6 level-1 endpoints.
    EXPECT_EQ(s.graphs, 1 + 3 + (3 + 6));
    EXPECT_EQ(s.graphEndpoints, 3 + 6 + 9 * 2);
    EXPECT_EQ(t.endpoints.size(), 27u);
    // Level-3 graphs hang from the level-1 endpoints as well as from the level-2 ones.
    std::set<int32_t> roots;
    for (int32_t i = 1; i < static_cast<int32_t>(t.nodes.size()); ++i) {
        if (t.nodes[i].level == 3) roots.insert(graphRoot(t, i));
    }
    std::map<int, int> rootLevels;
    for (int32_t r : roots) ++rootLevels[t.nodes[r].level];
    EXPECT_EQ(rootLevels, (std::map<int, int>{{1, 3}, {2, 6}}));
}

TEST(IteratedGraphCounts, StochasticLifespan) {
    IteratedGraphOptions o = smallOptions({3, 2, 2}, {120, 25, 15});
    o.lifespan = LifespanRule::kStochastic;

    // Certain termination: level-0 endpoints keep the initial lifespan (2), so the 3
    // level-1 sub-graphs are built; their endpoints terminate, so no level-2 graphs.
    o.terminateProbability = 1.0;
    for (uint64_t seed = 1; seed <= 3; ++seed) {
        IteratedGraphStats s;
        Tree t = grow(o, seed, true, &s);
        EXPECT_EQ(s.graphs, 1 + 3);
        EXPECT_EQ(s.graphEndpoints, 3 + 6);
        EXPECT_EQ(t.endpoints.size(), 9u);
        for (const auto& v : t.nodes) EXPECT_LE(v.level, 2);
    }

    // No termination: L' = L − u·L, u uniform in [0, 1); a level-1 endpoint (L = 2) keeps
    // L' ≥ 1 with probability 1/2, so on average 1 + 3 + 3 graphs and never more than 10.
    o.terminateProbability = 0.0;
    double meanGraphs = 0;
    int seeds = 0, fewer = 0;
    for (uint64_t seed = 1; seed <= 30; ++seed, ++seeds) {
        IteratedGraphStats s;
        Tree t = grow(o, seed, true, &s);
        EXPECT_LE(s.graphs, 10);
        EXPECT_GE(s.graphs, 4);
        EXPECT_LE(s.graphEndpoints, 21);
        EXPECT_EQ(s.graphEndpoints, 3 + 6 + 2 * (s.graphs - 4));
        EXPECT_EQ(static_cast<int64_t>(t.endpoints.size()), s.graphEndpoints);
        if (s.graphs < 10) ++fewer;
        meanGraphs += static_cast<double>(s.graphs);
    }
    meanGraphs /= seeds;
    EXPECT_GT(fewer, 15);
    EXPECT_NEAR(meanGraphs, 7.0, 1.0);
}

// ------------------------------------------------------------------------------------------
// Sub-graph orientation and curvature.

TEST(IteratedGraphOrientation, FixedModesPointTheSectors) {
    struct Case {
        Orientation mode;
        Vec3 axis;
    };
    for (const Case& c : {Case{Orientation::kDown, {0, -1, 0}}, Case{Orientation::kUp, {0, 1, 0}},
                          Case{Orientation::kFixed, {1, 0, 0}}}) {
        IteratedGraphOptions o = smallOptions({4, 3}, {200, 30});
        o.crown.levels[1].orientation = c.mode;
        o.crown.levels[1].direction = Vec3{2, 0, 0};  // normalised by the method
        const double alpha = o.crown.levels[1].alpha;
        for (uint64_t seed = 1; seed <= 2; ++seed) {
            SCOPED_TRACE("axis " + str(c.axis) + " seed " + std::to_string(seed));
            Tree t = grow(o, seed);
            ASSERT_TRUE(validTree(t));
            int count = 0;
            for (int32_t i = 1; i < static_cast<int32_t>(t.nodes.size()); ++i) {
                if (t.nodes[i].level != 2) continue;
                ++count;
                const Vec3 root = t.nodes[graphRoot(t, i)].position;
                const Vec3 d = t.nodes[i].position - root;
                EXPECT_LE(angleBetween(d, c.axis), alpha + 1e-9) << "node " << i;
                EXPECT_LE(length(d), o.crown.subgraphRadius + 1e-9);
                if (c.mode == Orientation::kDown) {
                    EXPECT_LT(t.nodes[i].position.y, root.y) << "node " << i;
                }
            }
            EXPECT_GE(count, 12);
        }
    }
}

// Mean height of the deepest level's endpoints of b = 1 chains curved by γ per level.
double deepestMeanY(double gamma) {
    IteratedGraphOptions o;
    o.crown.volume =
        makeUnion({makeCylinder(0.2, 1.2), makePlaced(makeSphere(1.0), Placement{{0, 2.0, 0}})});
    o.crown.endpointVolume = makePlaced(makeSphere(1.0), Placement{{0, 2.0, 0}});
    o.crown.subgraphRadius = 0.5;
    o.crown.shrink = 1.0;
    IteratedGraphLevel l0;
    l0.nodes = 150;
    l0.endpoints = 10;
    o.crown.levels.push_back(l0);
    for (int i = 0; i < 4; ++i) {
        IteratedGraphLevel l;
        l.nodes = 20;
        l.endpoints = 1;
        l.alpha = 0.25 * kPi;
        l.gamma = gamma;
        o.crown.levels.push_back(l);
    }
    double sum = 0;
    int count = 0;
    for (uint64_t seed = 1; seed <= 3; ++seed) {
        Tree t = grow(o, seed);
        EXPECT_TRUE(validTree(t));
        for (int32_t e : t.endpoints) {
            if (t.nodes[e].level == 5) {
                sum += t.nodes[e].position.y;
                ++count;
            }
        }
    }
    EXPECT_EQ(count, 30);
    return count > 0 ? sum / count : 0.0;
}

TEST(IteratedGraphOrientation, GammaCurvesChainsDownOrUp) {
    const double weeping = deepestMeanY(0.15 * kPi);
    const double straight = deepestMeanY(0.0);
    const double rising = deepestMeanY(-0.15 * kPi);
    EXPECT_LT(weeping + 0.3, rising) << weeping << " vs " << rising;
    EXPECT_LT(weeping, straight);
    EXPECT_LT(straight, rising);
}

// ------------------------------------------------------------------------------------------
// Linking.

TEST(IteratedGraphLinking, YaoGraphsReachAllEndpoints) {
    for (int sectors : {8, 6}) {
        IteratedGraphOptions o = smallOptions({3, 2, 2}, {200, 40, 25});
        o.linking = Linking::kYao;
        o.yaoSectors = sectors;
        for (uint64_t seed = 1; seed <= 2; ++seed) {
            SCOPED_TRACE("sectors " + std::to_string(sectors) + " seed " + std::to_string(seed));
            IteratedGraphStats s;
            Tree t = grow(o, seed, true, &s);
            EXPECT_TRUE(validTree(t));
            EXPECT_EQ(s.graphs, 10);
            EXPECT_EQ(t.endpoints.size(), 21u);
        }
    }
}

TEST(IteratedGraphLinking, TinyLinkDistanceIsBridged) {
    IteratedGraphOptions o = smallOptions({3, 2}, {100, 20});
    o.linkFactor = 1.0;  // link distance = Poisson spacing: almost no edges
    IteratedGraphStats s;
    Tree t = grow(o, 4, true, &s);
    EXPECT_TRUE(validTree(t));
    EXPECT_EQ(t.endpoints.size(), 9u);
    EXPECT_GT(s.bridgingEdges, 0);
    // Paths still follow the graph: level-1 nodes stay in the crown.
    for (const auto& v : t.nodes) {
        if (v.level == 1) {
            EXPECT_LE(o.crown.volume->signedDistance(v.position), 1e-9);
        }
    }
}

// ------------------------------------------------------------------------------------------
// Light steering.

struct SubgraphInfo {
    double angle;   // between the sub-graph orientation (from R = origin) and the light
    int endpoints;  // endpoints of the sub-graph built around this level-1 endpoint
    bool spawned;   // its endpoints got sub-graphs of their own
};

std::vector<SubgraphInfo> level1Subgraphs(const Tree& t, const Vec3& light) {
    std::map<int32_t, SubgraphInfo> byRoot;
    for (int32_t e : t.endpoints) {
        if (t.nodes[e].level == 1) {
            byRoot[e] = {angleBetween(t.nodes[e].position, light), 0, false};
        }
    }
    for (int32_t e : t.endpoints) {
        if (t.nodes[e].level == 2) ++byRoot.at(graphRoot(t, e)).endpoints;
    }
    for (int32_t i = 1; i < static_cast<int32_t>(t.nodes.size()); ++i) {
        if (t.nodes[i].level == 3) byRoot.at(graphRoot(t, graphRoot(t, i))).spawned = true;
    }
    std::vector<SubgraphInfo> r;
    for (const auto& [root, info] : byRoot) r.push_back(info);
    std::sort(r.begin(), r.end(),
              [](const SubgraphInfo& a, const SubgraphInfo& b) { return a.angle < b.angle; });
    return r;
}

// A crown symmetric about the x = 0 plane.
VolumePtr lightCrown() { return makePlaced(makeSphere(1.2), Placement{{0, 2.0, 0}}); }

TEST(IteratedGraphLight, BranchesFacingTheLightGetMoreEndpoints) {
    IteratedGraphOptions o;
    o.crown.volume = makeUnion({makeCylinder(0.2, 1.0), lightCrown()});
    o.crown.endpointVolume = lightCrown();
    o.crown.subgraphRadius = 0.6;
    IteratedGraphLevel l0, l1;
    l0.nodes = 250;
    l0.endpoints = 24;
    l1.nodes = 25;
    l1.endpoints = 4;
    o.crown.levels = {l0, l1};
    const Vec3 light{1, 0, 0};

    // Without light every sub-graph has b = 4 endpoints.
    for (const auto& g : level1Subgraphs(grow(o, 1), light)) EXPECT_EQ(g.endpoints, 4);

    o.light.enabled = true;
    o.light.direction = light;
    o.light.spread = 0.5;
    o.light.lifespan = false;
    int facing = 0, away = 0, total = 0;
    for (uint64_t seed = 1; seed <= 3; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        Tree t = grow(o, seed);
        ASSERT_TRUE(validTree(t));
        auto subs = level1Subgraphs(t, light);
        ASSERT_EQ(subs.size(), 24u);
        for (size_t k = 0; k < subs.size(); ++k) {
            // b drawn in [b(1−s), b(1+s)] = [2, 6], handed out by angle to the light.
            EXPECT_GE(subs[k].endpoints, 2);
            EXPECT_LE(subs[k].endpoints, 6);
            if (k > 0) {
                EXPECT_LE(subs[k].endpoints, subs[k - 1].endpoints) << "rank " << k;
            }
            (subs[k].angle < 0.5 * kPi ? facing : away) += subs[k].endpoints;
            total += subs[k].endpoints;
        }
    }
    // Tips in x > 0 outnumber those in x < 0 by a clear margin (expected ≈ 5 : 3).
    EXPECT_GT(facing, 1.3 * away) << facing << " vs " << away;
    EXPECT_EQ(facing + away, total);
}

TEST(IteratedGraphLight, BranchesFacingTheLightLiveLonger) {
    IteratedGraphOptions o;
    o.crown.volume = makeUnion({makeCylinder(0.2, 1.0), lightCrown()});
    o.crown.endpointVolume = lightCrown();
    o.crown.subgraphRadius = 0.6;
    IteratedGraphLevel l0, l1, l2;
    l0.nodes = 250;
    l0.endpoints = 16;
    l1.nodes = 20;
    l1.endpoints = 2;
    l2.nodes = 12;
    l2.endpoints = 2;
    o.crown.levels = {l0, l1, l2};
    o.light.enabled = true;
    o.light.direction = Vec3{1, 0, 0};
    o.light.spread = 0.5;
    o.light.endpoints = false;
    // Fixed rule: level-1 endpoints (L = 2) get L = 2 − dec, dec ∈ [0.5, 1.5) sorted by angle;
    // only dec ≤ 1 keeps L ≥ 1, so the sub-graphs that spawn are a prefix in angle order.
    int spawned = 0, notSpawned = 0;
    for (uint64_t seed = 1; seed <= 3; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        IteratedGraphStats s;
        Tree t = grow(o, seed, true, &s);
        ASSERT_TRUE(validTree(t));
        auto subs = level1Subgraphs(t, o.light.direction);
        ASSERT_EQ(subs.size(), 16u);
        int spawning = 0;
        for (size_t k = 0; k < subs.size(); ++k) {
            EXPECT_EQ(subs[k].endpoints, 2);
            if (k > 0 && subs[k].spawned) {
                EXPECT_TRUE(subs[k - 1].spawned) << "rank " << k;
            }
            spawning += subs[k].spawned;
        }
        spawned += spawning;
        notSpawned += 16 - spawning;
        EXPECT_EQ(s.graphs, 1 + 16 + 2 * spawning);
    }
    EXPECT_GT(spawned, 0);
    EXPECT_GT(notSpawned, 0);
}

// ------------------------------------------------------------------------------------------
// Roots.

TEST(IteratedGraphRoots, BelowGroundWithTaproot) {
    IteratedGraphOptions o = smallOptions({3, 2}, {150, 25});
    for (auto& l : o.crown.levels) l.orientation = Orientation::kUp;
    o.crown.levels[0].orientation = Orientation::kParent;
    o.roots.enabled = true;
    const double depth = 1.2, volumeRadius = 1.3, subRadius = 0.4;
    o.roots.system.volume =
        makePlaced(makeHemisphere(volumeRadius), Placement{{0, 0, 0}, {0, -1, 0}});
    o.roots.system.subgraphRadius = subRadius;
    o.roots.taprootDepth = depth;
    o.roots.lateralDistance = 0.5;
    IteratedGraphLevel l0, l1;
    l0.nodes = 200;
    l0.endpoints = 5;
    l1.nodes = 20;
    l1.endpoints = 2;
    l1.orientation = Orientation::kDown;
    o.roots.system.levels = {l0, l1};

    const double tol = 1e-9;
    for (uint64_t seed = 1; seed <= 8; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        IteratedGraphStats s;
        Tree t = grow(o, seed, true, &s);
        ASSERT_TRUE(validTree(t));
        // Crown 1 + 3, roots 1 + (1 taproot + 5 lateral) sub-graphs.
        EXPECT_EQ(s.graphs, 4 + 1 + 6);
        EXPECT_EQ(t.endpoints.size(), 3u + 6u + 6u + 12u);
        int rootNodes = 0;
        double minY = 0;
        int32_t taprootEnd = -1;
        for (int32_t i = 1; i < static_cast<int32_t>(t.nodes.size()); ++i) {
            const SkeletonNode& v = t.nodes[i];
            if (v.part == kRootPart) {
                ++rootNodes;
                EXPECT_LE(v.position.y, tol) << "root node " << i;
                minY = std::min(minY, v.position.y);
                if (v.level == 1 && v.position == Vec3(0, -depth, 0)) taprootEnd = i;
            } else {
                EXPECT_EQ(v.part, kShootPart);
                EXPECT_GE(v.position.y, -tol) << "shoot node " << i;
            }
        }
        EXPECT_GT(rootNodes, 10);
        // The taproot endpoint is (0, −depth, 0); only sub-graphs below it go deeper.
        ASSERT_GE(taprootEnd, 0);
        EXPECT_NE(std::find(t.endpoints.begin(), t.endpoints.end(), taprootEnd), t.endpoints.end());
        EXPECT_LE(minY, -depth + tol);
        EXPECT_GE(minY, -(volumeRadius + subRadius) - tol);

        EXPECT_TRUE(lateralsNearTaproot(t, depth, o.roots.lateralDistance));
    }
}

// ------------------------------------------------------------------------------------------
// Thickness.

TEST(IteratedGraphThickness, RadiusFollowsPathLengthToTip) {
    IteratedGraphOptions o = smallOptions({3, 2, 2}, {200, 40, 25});
    o.zeta = 0.5;
    o.thicknessScale = 0.08;
    Tree t = grow(o, 3);
    ASSERT_TRUE(validTree(t));
    const int32_t n = static_cast<int32_t>(t.nodes.size());
    // d' = longest path length from the node down to a tip, by explicit post-order DFS.
    std::vector<std::vector<int32_t>> kids(n);
    for (int32_t i = 1; i < n; ++i) kids[t.nodes[i].parent].push_back(i);
    std::vector<double> down(n, -1.0);
    std::vector<std::pair<int32_t, size_t>> stack{{0, 0}};
    while (!stack.empty()) {
        auto& [u, k] = stack.back();
        if (k < kids[u].size()) {
            int32_t c = kids[u][k++];
            stack.push_back({c, 0});
            continue;
        }
        double best = 0.0;
        for (int32_t c : kids[u]) {
            best = std::max(best, down[c] + distance(t.nodes[u].position, t.nodes[c].position));
        }
        down[u] = best;
        stack.pop_back();
    }
    int tips = 0, level1 = 0;
    for (int32_t i = 0; i < n; ++i) {
        ASSERT_GE(down[i], 0.0);
        const SkeletonNode& v = t.nodes[i];
        const double half = i == 0 ? 0.0 : 0.5 * distance(v.position, t.nodes[v.parent].position);
        // w = scale · (d' + half incoming segment)^ζ / (i + 1), i the 1-based level.
        const double want =
            o.thicknessScale * std::pow(down[i] + half, o.zeta) / (std::max(1, v.level) + 1);
        EXPECT_NEAR(v.radius, want, 1e-12 * std::max(1.0, want)) << "node " << i;
        if (kids[i].empty()) {
            ++tips;
            EXPECT_DOUBLE_EQ(v.radius, o.thicknessScale * std::sqrt(half) / (v.level + 1));
        }
        if (v.level == 1) ++level1;
    }
    EXPECT_GT(tips, 0);
    EXPECT_LE(tips, 12);  // level-3 endpoints (one may lie on another's path)
    EXPECT_GT(level1, 3);
    // The trunk base: d' is the height of the tallest path, divided by 2.
    EXPECT_NEAR(t.nodes[0].radius, o.thicknessScale * std::sqrt(down[0]) / 2, 1e-12);
}

// ------------------------------------------------------------------------------------------
// Poisson saturation.

TEST(IteratedGraphPoisson, SaturatedLevelThrows) {
    IteratedGraphOptions o = smallOptions({3, 2}, {200, 30});
    o.crown.levels[0].spacing = 1.0;  // room for a handful of nodes, 200 wanted
    EXPECT_THROW(grow(o, 1), std::runtime_error);
    EXPECT_THROW(grow(o, 1), PoissonSaturated);

    // A saturated sub-graph level throws out of the parallel level, too.
    o = smallOptions({3, 2}, {200, 300});
    o.crown.levels[1].spacing = 0.3;  // sector r = 0.8 holds a few dozen at 0.3 m
    EXPECT_THROW(grow(o, 1, true), std::runtime_error);
    EXPECT_THROW(grow(o, 1, false), std::runtime_error);
    // (That the dart throwing gives up after a bounded number of darts, whatever the machine's
    // speed: Poisson.SaturationGivesUpAfterBoundedDarts.)
}

// ------------------------------------------------------------------------------------------
// Endpoint shell (Wolff §3.1.1): level-0 endpoints on the far side of the volume.

TEST(IteratedGraphEndpoints, ShellKeepsEndpointsOnTheFarSide) {
    IteratedGraphOptions o = smallOptions({12}, {250});
    const double shell = 0.3;
    o.crown.levels[0].endpointShell = shell;
    Tree t = grow(o, 8);
    ASSERT_TRUE(validTree(t));
    ASSERT_EQ(t.endpoints.size(), 12u);
    for (int32_t e : t.endpoints) {
        const Vec3 p = t.nodes[e].position;
        EXPECT_TRUE(o.crown.endpointVolume->inside(p));
        EXPECT_FALSE(o.crown.endpointVolume->inside(p + normalize(p) * shell)) << str(p);
    }
}

// ------------------------------------------------------------------------------------------
// Continuous limbs (issue 13): smoothing, merging, a single trunk, straighter paths.

// A chain of nodes hanging from `parent` (returns the index of the last one).
int32_t addChain(Tree& t, int32_t parent, const std::vector<Vec3>& points) {
    for (const Vec3& p : points) {
        SkeletonNode v;
        v.position = p;
        v.parent = parent;
        v.level = 1;
        parent = static_cast<int32_t>(t.nodes.size());
        t.nodes.push_back(v);
    }
    return parent;
}

Tree rootOnly() {
    Tree t;
    t.nodes.push_back(SkeletonNode{});
    return t;
}

// Rooted tree with parents before children and a unique root.
bool parentsFirst(const Tree& t) {
    if (t.nodes.empty() || t.nodes[0].parent != -1) return false;
    for (size_t i = 1; i < t.nodes.size(); ++i) {
        if (t.nodes[i].parent < 0 || t.nodes[i].parent >= static_cast<int32_t>(i)) return false;
    }
    return true;
}

TEST(IteratedGraphSmoothing, ZigZagBecomesStraightWithEndsFixed) {
    // 21 nodes up the y axis, interior ones ±0.1 m off it alternately: the zig-zag of a path
    // that turns at every graph edge.
    Tree t = rootOnly();
    std::vector<Vec3> pts;
    for (int i = 1; i <= 20; ++i)
        pts.push_back({i < 20 ? 0.1 * (i % 2 ? 1 : -1) : 0.0, 0.2 * i, 0});
    addChain(t, 0, pts);
    t.endpoints = {20};
    // One pass: p_i/2 + (p_(i−1) + p_(i+1))/4 cancels an alternating offset exactly wherever
    // both neighbours alternate (nodes 2 … 18); node 1 keeps a quarter of it.
    Tree once = t;
    smoothAxes(once, 1);
    for (int i = 2; i <= 18; ++i) EXPECT_NEAR(once.nodes[i].position.x, 0.0, 1e-12) << i;
    EXPECT_NEAR(once.nodes[1].position.x, 0.5 * 0.1 + 0.25 * (0.0 - 0.1), 1e-12);
    for (int i = 1; i <= 20; ++i) EXPECT_NEAR(once.nodes[i].position.y, 0.2 * i, 1e-12) << i;
    // Many passes: straight within 1 mm, the ends exactly where they were.
    smoothAxes(t, 200);
    EXPECT_TRUE(t.nodes[0].position == Vec3(0, 0, 0));
    EXPECT_TRUE(t.nodes[20].position == Vec3(0, 4.0, 0));
    for (int i = 1; i < 20; ++i) {
        EXPECT_LT(std::abs(t.nodes[i].position.x), 1e-3) << i;
        EXPECT_GT(t.nodes[i].position.y, t.nodes[i - 1].position.y) << i;  // order kept
        EXPECT_EQ(t.nodes[i].parent, i - 1);
    }
    // Off: nothing moves.
    Tree off = once;
    smoothAxes(off, 0);
    EXPECT_TRUE(identicalTrees(off, once));
}

TEST(IteratedGraphSmoothing, ForkMovesWithItsAxisAndTheLateralFollows) {
    // A zig-zag trunk (as above, 11 nodes) with a straight lateral of 5 nodes leaving node 5
    // along +x. The fork is an interior node of the trunk's axis: it moves onto the smoothed
    // trunk, and the lateral starts from where it moved to; tips stay.
    Tree t = rootOnly();
    std::vector<Vec3> trunk;
    for (int i = 1; i <= 10; ++i)
        trunk.push_back({i < 10 ? 0.1 * (i % 2 ? 1 : -1) : 0.0, 0.2 * i, 0});
    addChain(t, 0, trunk);
    const Vec3 fork0 = t.nodes[5].position;
    std::vector<Vec3> lateral;
    for (int k = 1; k <= 5; ++k) lateral.push_back(fork0 + Vec3{0.2 * k, 0, 0});
    addChain(t, 5, lateral);
    smoothAxes(t, 100);
    EXPECT_LT(std::abs(t.nodes[5].position.x), 0.02) << str(t.nodes[5].position);  // moved
    EXPECT_TRUE(t.nodes[10].position == Vec3(0, 2.0, 0));
    EXPECT_TRUE(t.nodes[15].position == fork0 + Vec3(1.0, 0, 0));
    // The lateral is straight from the moved fork to its tip: every node on that chord.
    const Vec3 a = t.nodes[5].position, b = t.nodes[15].position;
    for (int k = 11; k < 15; ++k) {
        const Vec3 p = t.nodes[k].position;
        const Vec3 onChord = a + (b - a) * (dot(p - a, b - a) / length2(b - a));
        EXPECT_LT(distance(p, onChord), 2e-3) << k;
    }
    EXPECT_EQ(t.nodes[11].parent, 5);
    // The trunk through the fork turns by less than 2°.
    EXPECT_LT(angleBetween(t.nodes[5].position - t.nodes[4].position,
                           t.nodes[6].position - t.nodes[5].position),
              2.0 * kPi / 180);
}

TEST(IteratedGraphMerge, ParallelPathsMergeIntoOneRootedTree) {
    // Path A straight up the y axis (nodes 1–20, 0.2 m apart). Path B (later, nodes 21–36)
    // beside it 0.05 m off in x and offset 0.1 m in y, then B parts to +x (nodes 37–41).
    // Path C (nodes 42–50) crosses A at right angles 0.04 m from it.
    Tree t = rootOnly();
    std::vector<Vec3> a, b, d, c;
    for (int k = 1; k <= 20; ++k) a.push_back({0, 0.2 * k, 0});
    for (int k = 1; k <= 16; ++k) b.push_back({0.05, 0.1 + 0.2 * (k - 1), 0});
    for (int j = 1; j <= 5; ++j) d.push_back({0.05 + 0.3 * j, 3.1 + 0.2 * j, 0});
    for (int j = 0; j <= 8; ++j) c.push_back({-0.4 + 0.1 * j, 2.0, 0.04});
    addChain(t, 0, a);
    const int32_t bEnd = addChain(t, 0, b);
    addChain(t, bEnd, d);
    addChain(t, 0, c);
    t.endpoints = {20, 41, 50};
    ASSERT_EQ(t.nodes.size(), 51u);
    MergeOptions m;
    m.distance = 0.15;
    EXPECT_EQ(mergeParallelPaths(t, m), 16);  // all of B's side-by-side nodes
    ASSERT_EQ(t.nodes.size(), 35u);
    EXPECT_TRUE(parentsFirst(t));
    for (int k = 1; k <= 20; ++k) EXPECT_TRUE(t.nodes[k].position == a[k - 1]);
    // B's parting branch now leaves A at its 16th node (y = 3.2 m), the one its last merged
    // node was snapped onto; C is untouched (it crosses, it does not run beside A).
    EXPECT_TRUE(t.nodes[21].position == d[0]);
    EXPECT_EQ(t.nodes[21].parent, 16);
    for (int j = 0; j <= 8; ++j) EXPECT_TRUE(t.nodes[26 + j].position == c[j]) << j;
    EXPECT_EQ(t.nodes[26].parent, 0);
    EXPECT_EQ(t.endpoints, (std::vector<int32_t>{20, 25, 34}));
    // The root has two stems left: A (with B on it) and C.
    int rootChildren = 0;
    for (const SkeletonNode& v : t.nodes) rootChildren += v.parent == 0;
    EXPECT_EQ(rootChildren, 2);
    // Off, or a distance below the paths' 0.05 m gap: nothing merges.
    Tree again = rootOnly();
    addChain(again, 0, a);
    addChain(again, addChain(again, 0, b), d);
    m.distance = 0.045;
    EXPECT_EQ(mergeParallelPaths(again, m), 0);
    m.distance = 0;
    EXPECT_EQ(mergeParallelPaths(again, m), 0);
    EXPECT_EQ(again.nodes.size(), 42u);
}

TEST(IteratedGraphMerge, DistanceShrinksWithTheLevel) {
    // The parallel paths above, B grown at levels[2] (node level 3): with shrink 0.5 its merge
    // distance is 0.15 · 0.5² = 0.0375 m, below the 0.05 m gap, so nothing merges; with
    // shrink 1 all of B merges as before.
    for (double shrink : {0.5, 1.0}) {
        Tree t = rootOnly();
        std::vector<Vec3> a, b;
        for (int k = 1; k <= 20; ++k) a.push_back({0, 0.2 * k, 0});
        for (int k = 1; k <= 16; ++k) b.push_back({0.05, 0.1 + 0.2 * (k - 1), 0});
        addChain(t, 0, a);
        addChain(t, 0, b);
        for (size_t i = 21; i < t.nodes.size(); ++i) t.nodes[i].level = 3;
        MergeOptions m;
        m.distance = 0.15;
        m.shrink = shrink;
        EXPECT_EQ(mergeParallelPaths(t, m), shrink < 1 ? 0 : 16) << shrink;
    }
}

TEST(IteratedGraphMerge, PathRejoiningAheadHangsFromTheNodeBehindIt) {
    // B's first node is snapped onto A's second node (0, 0.4, 0); B's next node lies behind it
    // (y = 0.3) and off to the side, out of reach: hanging it from (0, 0.4, 0) would make a
    // hook back down, so it hangs from A's first node (0, 0.2, 0) instead.
    Tree t = rootOnly();
    std::vector<Vec3> a;
    for (int k = 1; k <= 5; ++k) a.push_back({0, 0.2 * k, 0});
    addChain(t, 0, a);
    addChain(t, 0, {{0.08, 0.38, 0}, {0.5, 0.3, 0}});
    t.endpoints = {5, 7};
    MergeOptions m;
    m.distance = 0.15;
    EXPECT_EQ(mergeParallelPaths(t, m), 1);
    ASSERT_EQ(t.nodes.size(), 7u);
    EXPECT_TRUE(t.nodes[6].position == Vec3(0.5, 0.3, 0));
    EXPECT_EQ(t.nodes[6].parent, 1);
    EXPECT_TRUE(parentsFirst(t));
}

TEST(IteratedGraphMerge, PathReturningToAnOlderOneLeavesNoStub) {
    // B runs beside A, steps out beyond the merge distance for one node, and comes back:
    // the node outside stays only if something hangs from it, so it is removed.
    Tree t = rootOnly();
    std::vector<Vec3> a, b;
    for (int k = 1; k <= 10; ++k) a.push_back({0, 0.2 * k, 0});
    for (int k = 1; k <= 8; ++k) b.push_back({k == 4 ? 0.3 : 0.05, 0.2 * k - 0.1, 0});
    addChain(t, 0, a);
    addChain(t, 0, b);
    t.endpoints = {10, 18};
    MergeOptions m;
    m.distance = 0.15;
    m.maxAngle = 60.0 * kPi / 180;
    EXPECT_EQ(mergeParallelPaths(t, m), 8);
    EXPECT_EQ(t.nodes.size(), 11u);
    EXPECT_TRUE(parentsFirst(t));
    EXPECT_EQ(t.endpoints, std::vector<int32_t>{10});
}

TEST(IteratedGraphTrunk, OneStemLeavesTheRoot) {
    // The small crown's level-0 graph fills a trunk cylinder (1.5 m) under the sphere: paths
    // may leave the root side by side. With a 1.6 m trunk every path passes its top.
    IteratedGraphOptions o = smallOptions({8, 2}, {300, 30});
    o.trunk.height = 1.6;
    for (uint64_t seed = 1; seed <= 4; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        Tree t = grow(o, seed);
        ASSERT_TRUE(validTree(t));
        int rootChildren = 0;
        for (const SkeletonNode& v : t.nodes) rootChildren += v.parent == 0;
        EXPECT_EQ(rootChildren, 1);
        // Below the trunk top, of the level-0 graph's nodes, only the straight bole (an
        // endpoint may lie lower, and later levels' sub-graphs may hang lower).
        const std::set<int32_t> ends(t.endpoints.begin(), t.endpoints.end());
        int bole = 0;
        for (int32_t i = 1; i < static_cast<int32_t>(t.nodes.size()); ++i) {
            const Vec3 p = t.nodes[i].position;
            if (t.nodes[i].level == 1 && !ends.count(i) && p.y < 1.6 - 1e-12) {
                ++bole;
                EXPECT_EQ(p.x, 0.0);
                EXPECT_EQ(p.z, 0.0);
            }
        }
        EXPECT_GE(bole, 1);
        EXPECT_EQ(computeStats(t).stemsAtBase, 1);
    }
}

// Mean over endpoints of path length from the root / straight distance.
double meanTortuosity(const Tree& t) {
    double sum = 0;
    for (int32_t e : t.endpoints) {
        double len = 0;
        for (int32_t v = e; v != 0; v = t.nodes[v].parent) {
            len += distance(t.nodes[v].position, t.nodes[t.nodes[v].parent].position);
        }
        sum += len / length(t.nodes[e].position);
    }
    return sum / static_cast<double>(t.endpoints.size());
}

// Mean angle (radians) between each segment (parent → child) and the ray from the root
// through the segment's midpoint.
double meanRadialAngle(const Tree& t) {
    double sum = 0;
    for (size_t i = 1; i < t.nodes.size(); ++i) {
        const Vec3 a = t.nodes[t.nodes[i].parent].position, b = t.nodes[i].position;
        sum += angleBetween(b - a, (a + b) * 0.5);
    }
    return sum / static_cast<double>(t.nodes.size() - 1);
}

TEST(IteratedGraphStraight, RadialWeightStraightensPaths) {
    // One graph in a sphere of 2 m around the root with 20 endpoints, linked densely enough
    // (3 × the spacing) that a node has neighbours in most directions. With the paper's costs
    // the least-cost paths wander with the random weights: segments 26–35° off the ray from
    // the root on average, root-to-tip paths 1.16–1.24 × the straight distance. A radial
    // weight of 4 keeps them to the ray: below 21° and 1.09 for every seed.
    IteratedGraphOptions o;
    o.crown.volume = makeSphere(2.0);
    o.linkFactor = 3.0;
    IteratedGraphLevel l;
    l.nodes = 1500;
    l.endpoints = 20;
    o.crown.levels = {l};
    IteratedGraphOptions s = o;
    s.radialWeight = 4.0;
    for (uint64_t seed = 1; seed <= 6; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        const Tree paper = grow(o, seed), straight = grow(s, seed);
        ASSERT_TRUE(validTree(straight));
        EXPECT_GT(meanRadialAngle(paper), 25.0 * kPi / 180);
        EXPECT_GT(meanTortuosity(paper), 1.15);
        EXPECT_LT(meanRadialAngle(straight), 21.0 * kPi / 180);
        EXPECT_LT(meanTortuosity(straight), 1.09);
    }
}

TEST(IteratedGraphContinuousLimbs, EveryOptionTogetherIsAValidTreeIndependentOfThreads) {
    IteratedGraphOptions o = smallOptions({16, 4, 2}, {300, 150, 40});
    o.trunk.height = 1.6;
    o.radialWeight = 1.0;
    o.merge.distance = 0.12;
    o.smoothing.iterations = 8;
    IteratedGraphStats s;
    Tree threaded = grow(o, 5, true, &s);
    ASSERT_TRUE(validTree(threaded));
    EXPECT_GT(s.mergedNodes, 0);
    Tree serial = grow(o, 5, false);
    EXPECT_TRUE(identicalTrees(threaded, serial));
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        EXPECT_TRUE(identicalTrees(threaded, grow(o, 5, true)));
    }
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        EXPECT_TRUE(identicalTrees(threaded, grow(o, 5, true)));
    }
}

}  // namespace
}  // namespace sylva
