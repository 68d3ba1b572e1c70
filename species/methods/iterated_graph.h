// The `iterated-graph` growth method: least-cost paths through random-weighted Poisson-disc
// graphs, iterated in sub-graphs (Xu & Mould 2012, "Synthetic Tree Models from Iterated
// Discrete Graphs"; journal-version details as summarised by Wolff 2013).
//
// Frame: +y up, metres, radians. The tree's root point R is the origin.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/budget.h"
#include "core/rng.h"
#include "species/model/tree.h"
#include "volumes/volume.h"

namespace sylva {

enum class Linking { kDistance, kYao };
enum class EdgeWeightKind { kUniform, kNormal };
enum class LifespanRule { kFixed, kStochastic };
enum class Orientation { kParent, kUp, kDown, kRandom, kFixed };
// Sub-graph volume: the paper's sphere sector, or a cone with its apex at the endpoint,
// opening along v_g with half-angle α and height r ("cone" sub-graphs of Table 2, j and l).
enum class SubgraphShape { kSector, kCone };

// Parameters of one level (iteration) k, the index of its [[levels]] table (the paper's level
// i = k + 1). Level 0 is the user's initial graph; levels ≥ 1 are sub-graphs built around the
// endpoints of the level before. These defaults are the species file's.
struct IteratedGraphLevel {
    int nodes = 0;               // k / K: graph nodes in each graph of this level (required)
    double spacing = 0.0;        // Poisson-disc minimum distance, metres; 0 = from K and volume
    int endpoints = 0;           // b: endpoints (branching factor) per graph (required)
    double endpointShell = 0.0;  // d_e: endpoints only within this depth of the far side of
                                 // the volume (Wolff §3.1.1, Abb. 9), metres; 0 = anywhere
    SubgraphShape shape = SubgraphShape::kSector;
    double alpha = 54.0 * (kPi / 180.0);  // sub-graph half-angle α (0.3π), radians (levels ≥ 1)
    double radius = 0.0;  // sub-graph sphere radius r, metres; 0 = previous level × a
    double gamma = 0.0;   // rotation of v_g about the horizontal per level, radians;
                          // positive turns branches down (weeping), negative up
    Orientation orientation = Orientation::kParent;  // how v_g is chosen
    Vec3 direction{0, 1, 0};                         // v_g when orientation == kFixed
    bool fromAllLevels = false;  // build this level's sub-graphs around the endpoints of
                                 // all previous levels (Table 2, trees e and g)
};

// Light steering (journal version; Wolff §3.4): at each sub-graph level, n branching factors
// and n lifespan decrements are drawn from ranges around the level's values and handed out
// in order of the angle between the light direction and each sub-graph's orientation:
// the branch facing the light gets the most endpoints and the smallest decrement.
struct LightOptions {
    bool enabled = false;
    Vec3 direction{0, 1, 0};  // towards the light (unit after parsing)
    double spread = 0.5;      // b drawn in [b(1−s), b(1+s)], decrement in [1−s, 1+s]
    bool endpoints = true;    // light modulates the branching factor
    bool lifespan = true;     // light modulates the lifespan decrement
};

// A system of levels grown from the root point: the crown (above ground) or the roots.
struct GraphSystem {
    VolumePtr volume;          // level-0 graph volume
    VolumePtr endpointVolume;  // where level-0 endpoints go (default: volume)
    std::vector<IteratedGraphLevel> levels;
    double subgraphRadius = 1.0;  // r at level 1, metres (Maketree argument r); roots: 0.5
    double shrink = 0.7;          // a: sub-graph radius ratio between successive levels
};

// The root system's defaults: sub-graph radius r = 0.5 m (the crown's is 1 m).
inline GraphSystem rootSystemDefaults() {
    GraphSystem s;
    s.subgraphRadius = 0.5;
    return s;
}

// Root system (Xu & Mould 2012 §4, Figure 15): a graph below the ground, a taproot as the
// path to one deep endpoint, lateral roots from endpoints placed around the taproot, then
// sub-graph levels as for the crown.
struct RootOptions {
    bool enabled = false;
    GraphSystem system = rootSystemDefaults();  // system.volume: below-ground graph volume
    double taprootDepth = 2.0;                  // depth of the taproot endpoint, metres
    double lateralDistance = 0.5;  // lateral endpoints lie within this distance of the taproot
};

// Continuous limbs (issue 13; not in the papers). The paper's paths turn at every graph edge,
// wander with the random weights, run side by side as bundles and may leave the root as
// several stems. Each option below is off by default, so the papers' trees are unchanged.

// A single trunk (bole): level-0 paths of the crown start at a trunk node T = (0, h, 0),
// joined to the root by a straight chain of nodes, instead of at the root; the level-0 graph
// keeps only nodes at or above h, so no path can run down beside the bole.
struct TrunkOptions {
    double height = 0.0;  // h, metres; 0 = off (paths start at the root, as in the paper)
};

// Merging of paths that run side by side (parallel bundles → one limb). Nodes are visited in
// creation order (older paths first); a node within `distance` of a kept node of another
// path whose direction is within `maxAngle` of its own is snapped onto it: its children hang
// from that node instead, so the later path follows the older one until they part.
// A kept node's parent that was snapped ahead of it is replaced by the last node behind it
// on the path it was snapped onto, so a path never turns back where it rejoins.
struct MergeOptions {
    double distance = 0.0;               // metres, for nodes of levels[0]; 0 = off
    double shrink = 1.0;                 // the distance × shrink^k for nodes of levels[k]
    double maxAngle = 30.0 * kPi / 180;  // radians: directions (over two segments) this close
};

// Smoothing of each axis — a chain from its first node (the root, or the fork it leaves) to
// its tip, following at every fork the child with the longest path below it (the child that
// keeps the branch order). Laplacian (umbrella) smoothing with λ = 1/2,
// p_i ← p_i/2 + (p_(i−1) + p_(i+1))/4, with the axis's first node and its tip fixed: a
// zig-zag between neighbours is removed in one pass, bends over n nodes after about n²
// passes. Forks on an axis move with it (they are interior nodes of their parent axis) and
// the lateral axes leaving them are smoothed afterwards from the moved fork, so there is no
// kink at a fork either. Axes are smoothed parents first.
struct SmoothingOptions {
    int iterations = 0;  // passes; 0 = off
};

struct IteratedGraphOptions {
    GraphSystem crown;
    RootOptions roots;
    TrunkOptions trunk;
    MergeOptions merge;
    SmoothingOptions smoothing;

    // Graph construction (maketree step 1). The paper uses one d for rejection and linking,
    // which would leave no edges at all (every pair of nodes is ≥ d apart); we keep the
    // Poisson spacing and the linking distance apart: link distance = linkFactor × spacing.
    Linking linking = Linking::kDistance;
    double linkFactor = 1.8;
    int yaoSectors = 8;          // Yao graph: 8 octants or 6 cube-face pyramids
    double spacingFactor = 0.7;  // spacing = f·(V/K)^(1/3) when a level gives none

    // Edge costs: weight × length^lengthExponent, weight drawn per edge.
    EdgeWeightKind edgeWeightKind = EdgeWeightKind::kUniform;
    double edgeWeightA = 0.5;  // uniform: low bound; normal: mean
    double edgeWeightB = 1.5;  // uniform: high bound; normal: sigma (clamped at 0.01)
    double lengthExponent = 1.0;
    // Straighter growth (issue 13; 0 = the paper): the cost of the step u → v away from the
    // graph root R is multiplied by 1 + radialWeight·(1 − cos θ), θ the angle between v − u and
    // the direction from R to the step's midpoint. Outward steps along a ray from R cost the
    // paper's weight, sideways steps up to 1 + w times more, backward ones 1 + 2w: least-cost
    // paths approach straight rays from R (from the trunk top with [trunk], along v_g in
    // sub-graphs) instead of wandering with the random weights.
    double radialWeight = 0.0;

    // Lifespan (§3.3.3): fixed decrement L − 1, or stochastic: terminate with probability
    // terminateProbability, otherwise decrement by a uniform amount in (0, L).
    LifespanRule lifespan = LifespanRule::kFixed;
    double terminateProbability = 0.3;
    double initialLifespan = -1.0;  // < 0: number of levels − 1
    LightOptions light;

    // Thickness (§3.2): w = scale · (d')^ζ / (i + 1), d' = path length to the branch tip,
    // i = k + 1 the paper's level of the segment's levels[k].
    double zeta = 0.3;
    double thicknessScale = 0.05;  // metres per m^ζ
};

struct IteratedGraphStats {
    int64_t graphNodes = 0;      // Poisson nodes in all graphs (Table 1 "number of graph nodes")
    int64_t graphEndpoints = 0;  // endpoints in all graphs
    int64_t graphs = 0;
    int64_t bridgingEdges = 0;  // edges added to join a component holding an endpoint to
                                // the root's (closest node pair), when the graph was split
    int64_t mergedNodes = 0;    // nodes snapped onto an older path (MergeOptions)
};

// Grows one tree. `threaded`: build the sub-graphs of a level in parallel (TBB); the result
// is the same for any thread count because every graph draws from its own keyed stream.
// Before each level its graph nodes and endpoints are held to `guard`'s budgets (and the
// skeleton after it), and the deadline is checked within the graphs (BudgetExceeded).
Tree growIteratedGraph(const IteratedGraphOptions& options, Rng& rng, bool threaded = true,
                       IteratedGraphStats* stats = nullptr,
                       const GrowthGuard& guard = GrowthGuard::unlimited());

// Sub-graph sphere radius per level of a system: r at level 1 (index 1), then × a, unless a
// level gives its own (maketree 4D). Index 0 (the user's graph) is 0.
std::vector<double> subgraphRadii(const GraphSystem& system);

// A level's sub-graph volume in its local frame: apex at the origin, opening along +y.
VolumePtr subgraphVolume(const IteratedGraphLevel& level, double radius);

// --- pieces, exposed for tests ---------------------------------------------------------------
// A weighted undirected graph in CSR form.
struct WeightedGraph {
    std::vector<int32_t> offset;  // size n + 1
    std::vector<int32_t> target;
    std::vector<double> cost;
    int size() const { return static_cast<int>(offset.size()) - 1; }
};
// Edges (i < j) with costs into CSR form.
WeightedGraph makeGraph(int n, const std::vector<std::pair<int32_t, int32_t>>& edges,
                        const std::vector<double>& costs);
// Continuous-limb post-processing (applied by growIteratedGraph when enabled, before radii).
// Snaps nodes of later paths onto older paths running side by side (MergeOptions); the result
// is a rooted tree again (parents before children), and nodes left without children that
// were not tips (stubs where a path left an older one and came back) are removed. Endpoints
// merged away leave tree.endpoints. Returns the number of nodes removed.
int64_t mergeParallelPaths(Tree& tree, const MergeOptions& options);
// Laplacian smoothing of every axis with its first node and tip fixed (SmoothingOptions).
void smoothAxes(Tree& tree, int iterations, const GrowthGuard& guard = GrowthGuard::unlimited());

// Single-source least-cost search (Dijkstra, binary heap). Returns cost per node (infinity
// if unreachable) and the predecessor (−1 for the source and unreached nodes).
void leastCostTree(const WeightedGraph& g, int source, std::vector<double>& dist,
                   std::vector<int32_t>& pred);

}  // namespace sylva
