// @brief The `canopy` growth method (Shesh et al., "GPU-friendly parameterized canopies", §3):
// a tree is a canopy C and a branch structure B designed independently (§3.1).
//
//   canopy   (§3.2): leaves on the surface of a canopy envelope (volumes/canopy_envelope.h),
//            spread evenly by area, oriented randomly or turned toward the sun, optionally a
//            small cluster of leaves per position (Figure 4(a)'s five-leaf branch);
//   branches (§3.4–3.5): a template from a small bracketed L-system with radii by Murray's
//            rule, scaled so it "outgrows" the canopy, then clipped: a segment whose end lies
//            beyond the envelope's radius in its direction (by more than a threshold) is cut,
//            with everything above it;
//   support  (issue 13, not in the paper; off by default): the template clipped a leaf-layer
//            margin inside the envelope, and twigs grown from it to the leaves by space
//            colonization, so every leaf is carried by wood (or dropped) — see
//            CanopySupportOptions.
//
// Frame: +y up, metres, radians. The tree stands at the origin; the envelope's own frame is
// shifted by `position` (its centre for the ellipsoid, its base centre for the cone).
//
// L-system alphabet (turtle after Prusinkiewicz & Lindenmayer 1990, ch. 1.5; the turtle starts
// at the origin heading +y with left = −x and up = +z):
//   F          move forward one step, drawing a segment (a skeleton node at its end)
//   A–Z but F  variables: rewritten by rules, no turtle action
//   + −        yaw: turn left / right by the angle about the turtle's up vector
//   & ^        pitch down / up by the angle about the turtle's left vector
//   \ /        roll left / right by the roll angle about the heading
//   |          turn around (yaw by 180°)
//   [ ]        push / pop the turtle state (position, frame, current node, step length)
// Whitespace is ignored. No `f` (moving without drawing would disconnect the skeleton) and no
// `!` (widths come from Murray's rule, not from the string).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/budget.h"
#include "core/rng.h"
#include "species/geometry/leaves.h"
#include "species/model/tree.h"
#include "volumes/canopy_envelope.h"

namespace sylva {

// --- L-system ------------------------------------------------------------------------------

struct LSystemSuccessor {
    std::string text;          // the successor word
    double probability = 1.0;  // stochastic rules: the successors of a symbol sum to 1
};

// A bracketed (stochastic) 0L-system: every occurrence of a symbol with a rule is rewritten
// by one of its successors, drawn independently per occurrence.
struct LSystem {
    std::string axiom;
    std::map<char, std::vector<LSystemSuccessor>> rules;  // keys: letters A–Z
};

// True for every symbol of the alphabet above (whitespace excluded).
bool isLSystemSymbol(char c);
// The first problem with a word ("unknown symbol 'x' at 3", unbalanced brackets), or "".
std::string checkLSystemWord(const std::string& word);

// The word after `iterations` parallel rewrites (rng draws only for stochastic rules).
std::string expandLSystem(const LSystem& system, int iterations, Rng& rng);

// Upper bounds after `iterations` (exact for deterministic systems): word length and the
// number of F (segments), per symbol the largest count any successor produces.
struct LSystemSize {
    double length = 0.0;
    double segments = 0.0;
};
LSystemSize lsystemSizeBound(const LSystem& system, int iterations);

// --- branch templates ------------------------------------------------------------------------

struct BranchTemplate {
    LSystem lsystem;
    int iterations = 0;                   // rewriting steps (a species file must give them)
    double angle = 25.0 * (kPi / 180.0);  // yaw and pitch angle δ, radians
    double roll = 25.0 * (kPi / 180.0);   // roll angle, radians (a species file: the same δ)
    double step = 1.0;                    // segment length at bracket depth 0, metres
    double lengthRatio = 1.0;             // step multiplied by this per bracket depth
    double angleJitter = 0.0;             // every turn's angle + uniform(−j, j), radians
    double weight = 1.0;                  // relative chance of being chosen per instance
};

// Turtle interpretation of a word: node 0 at the origin, one node per F (parent = the node
// the turtle stands on, order = level = bracket depth), radii 0. Draws only for jitter.
Tree interpretTurtle(const std::string& word, const BranchTemplate& t, Rng& rng);

// Murray's rule (Murray 1927; Shesh §3.4) from the tips up: every tip gets `tipRadius`,
// every other node r = (Σ r_childⁿ)^(1/n), n = `exponent` (3: Murray; 2: the pipe model).
void murrayRadii(Tree& tree, double tipRadius, double exponent = 3.0);

// --- the envelope test (§3.5) ------------------------------------------------------------------

// The paper's clipping test as a ratio: the point's distance from the envelope's centre over
// the distance of the surface point at the same angles (φ, θ). `local` is in the envelope's
// frame. Ellipsoid: |p| / |surfacePoint(angles(p))| (= |q| / f). Cone, whose θ is a height:
// the distance from the axis over the surface's at that height, and at least y/ky above the
// apex and 1 − y/ky below the base. ≤ 1 inside.
double envelopeRatio(const CanopyEnvelope& envelope, const Vec3& local);

// How far inside the surface `local` lies, metres, measured as envelopeRatio measures: along
// the ray from the centre (ellipsoid: |surfacePoint(angles(p))| − |p|) or horizontally from
// the axis at the point's height (cone: the surface's distance from the axis minus the
// point's; above the apex the surface radius is 0). Negative outside.
double envelopeDepth(const CanopyEnvelope& envelope, const Vec3& local);

// Area-uniform points on the envelope's surface (§3.2 leaf positions): a 256 × 128 grid of
// cells over (φ, θ), each weighted by the area of its quad of surface points; within a cell
// φ is uniform and θ follows the linear change of the cell's width, so pole cells (triangles)
// are not crowded at their tip.
class CanopySurfaceSampler {
  public:
    explicit CanopySurfaceSampler(const CanopyEnvelope& envelope);
    Vec2 sample(Rng& rng) const;            // (φ, θ)
    double area() const { return total_; }  // m², the sum of the cell quads

  private:
    std::vector<double> cdf_;                     // per cell, running area
    std::vector<double> widthTop_, widthBottom_;  // per cell, edge lengths at θ_j, θ_{j+1}
    double total_ = 0.0;
};

// --- the method -------------------------------------------------------------------------------

enum class TemplateFit { kUniform, kStretch, kNone };
enum class MurrayOn { kClipped, kTemplate };

struct CanopyBranchOptions {
    // Top of the trunk, metres above the ground. < 0: 10 % of the way from the envelope's
    // lowest point on its axis to its centre (ellipsoid), or the base (cone).
    double trunkHeight = -1.0;
    // The crown part of the template (above its first fork) is scaled so its height above
    // the trunk top and its horizontal reach are this many times the envelope's.
    double outgrow = 1.25;
    // kUniform: one scale (the larger of the two), angles kept; kStretch: height and reach
    // scaled separately; kNone: the template as drawn (step in metres).
    TemplateFit fit = TemplateFit::kStretch;
    double clipThreshold = 0.05;  // cut where envelopeRatio > 1 + this (§3.5's threshold)
    double tipRadius = 0.01;      // metres
    double murrayExponent = 3.0;
    MurrayOn murrayOn = MurrayOn::kClipped;  // radii of the clipped tree or of the template
    bool randomYaw = true;                   // turn the template about the vertical per tree
    // Metres. > 0: a crown node is also cut where it lies less than this far inside the surface
    // (envelopeDepth), so no template wood reaches into the leaf layer and no stub pokes out
    // through the leaves. 0: the paper's threshold rule alone.
    double leafMargin = 0.0;
    // True: a segment that leaves the envelope (or enters the leaf margin) is shortened to where
    // it does instead of dropped with its end node (§3.5's "ideally …" surface clipping).
    bool cutAtSurface = false;
};

enum class LeafSupport { kNone, kTwigs };

// Leaf support (issue 13). Shesh's leaves float: "our trees are not guaranteed to support all
// leaves" (§1), and §5 proposes fitting the branches to the canopy "by taking a growth-based
// approach". kTwigs does that with space colonization (Runions et al. 2007, §3): the leaves'
// attachment points are the markers; each attracts the nearest crown node within the radius
// of influence `reach`; a node attracted by markers grows a twig node `step` toward the mean
// of their unit directions; a marker is removed once a node is within the kill distance
// `attach` (the nearest of the nodes that first come that close carries its leaf; a cluster's
// leaves share one marker). New nodes stay inside the envelope, and a twig is
// at most `length` long from the crown node it sprouts from (longer ones would crawl along
// the leaf layer); a marker whose node stops growing (at its longest, blocked by the
// envelope, or caught between markers) turns to the nearest growing node within reach, up to
// three times, then gives up. A leaf with no wood within reach, or one the twigs cannot
// reach, is dropped; a twig that carries no leaf is shed. Twigs continue the order of a tip they
// extend and are one order higher than a node that already has children; radii follow Murray's rule
// over the final tree
// (`radii = "template"`: the clipped-off template still counts, as before).
struct CanopySupportOptions {
    LeafSupport mode = LeafSupport::kNone;  // kNone: the paper's leaves (node within
                                            // leaves.supportDistance, else −1)
    double reach = 1.0;                     // radius of influence d_i, metres
    double length = 2.0;     // longest twig (path from the crown node it sprouts from), metres
    double step = 0.08;      // twig segment length D, metres
    double attach = 0.12;    // kill distance d_k, metres (step ≤ attach ≤ reach)
    bool pruneBare = false;  // crown branches of the template that carry no leaf are removed
                             // too (self-pruning of shaded or bare limbs; the bole stays)
    double droop = 0.0;      // λ: weight of gravity in a twig's direction (Liu et al. 2020), ≥ 0
    double sproutSpacing = 0.3;  // crown segments cut into pieces ≤ this, metres, so twigs can
                                 // sprout along them (the bole is left whole)
};

struct CanopyLeafOptions : LeafCardOptions {  // size, shape and orientation of the cards
    int count = 10000;   // leaf positions (§4: "each tree … has 10000 leaves")
    double depth = 0.0;  // each position pulled inward by uniform [0, depth] of its radius
    // Fraction of the polar range θ ∈ [0, π] left bare at the bottom: no leaf with
    // θ > π (1 − openBase) (ellipsoid: a cap around the lowest point, where the trunk enters
    // an open crown base; cone: the lowest part of the flank). 0: leaves everywhere (§3.2).
    double openBase = 0.0;
    int cluster = 1;     // leaves per position, fanned around a short twig (Fig. 4(a): 5)
    double twig = 0.06;  // twig length of a cluster, metres
    std::vector<double> colourFractions{1.0};  // share of positions per colour entry
    std::vector<uint8_t> colourClasses;        // Leaf::colour per entry (empty: 0, 1, 2, …)
    double colourPatchiness = 0.5;             // 0: classes at random; 1: in patches over (φ, θ)
    double supportDistance = 0.3;  // a leaf is supported by a branch node this close, metres
};

struct CanopyOptions {
    std::shared_ptr<const CanopyEnvelope> envelope;
    Vec3 position{0, 5, 0};  // the envelope's origin in the tree frame, metres (a species file
                             // must give it: canopy.position)
    std::vector<BranchTemplate> templates;
    CanopyBranchOptions branches;
    CanopyLeafOptions leaves;
    CanopySupportOptions support;
    // Plots (crown shyness): half-spaces the crown keeps to, tree frame. Branch nodes outside
    // are cut like nodes beyond the envelope, leaf positions outside are moved onto the
    // nearest clip plane (the crown's cut face), twigs stay inside. Empty: no clip.
    std::vector<HalfSpace> clip;
};

struct CanopyStats {
    int templateIndex = 0;
    int64_t templateSegments = 0;  // F segments of the expanded template (plus a bole if added)
    int64_t keptSegments = 0;      // after clipping
    double scaleY = 1.0, scaleXZ = 1.0;  // crown scale of the template
    double trunkHeight = 0.0;
    int64_t leaves = 0;
    int64_t unsupportedLeaves = 0;
    double unsupportedLeafFraction = 0.0;
    int64_t twigNodes = 0;      // support: nodes grown (the last ones of the tree)
    int64_t droppedLeaves = 0;  // support: leaves no twig reached (removed)
};

// Space colonization of twigs toward the leaves (see CanopySupportOptions), on any tree: the
// markers are the leaves' attachment points (centre − tangent · size / 2). Nodes i with
// sprouts[i] (one flag per node) may sprout twigs; every node may carry a leaf. A new node is
// kept only where `inside(position)` holds, and a marker outside attracts nothing. Every leaf
// left gets `node` = a node within `attach` of its attachment; the others are removed. New
// nodes are appended (parents first) with radius 0; those that carry no leaf (nor any node
// above them) are removed again. Returns the number of leaves dropped;
// `grown` gets the number of nodes added.
// The twigs grown are held to `guard`'s max_skeleton_nodes, and its deadline is checked every
// round (BudgetExceeded).
int64_t growSupportTwigs(Tree& tree, const std::vector<char>& sprouts,
                         const CanopySupportOptions& options,
                         const std::function<bool(const Vec3&)>& inside, int64_t* grown = nullptr,
                         const GrowthGuard& guard = GrowthGuard::unlimited());

// The trunk top actually used (resolves trunkHeight < 0), metres.
double canopyTrunkHeight(const CanopyOptions& options);

// Grows one tree: the template chosen by weight, expanded, fitted and clipped; then the
// leaves. The surface sampler may be passed in (built once per envelope); else it is built.
// The leaves (before they are placed), the support's crown pieces and twigs are held to
// `guard`'s budgets (BudgetExceeded).
Tree growCanopy(const CanopyOptions& options, Rng& rng, CanopyStats* stats = nullptr,
                const CanopySurfaceSampler* sampler = nullptr,
                const GrowthGuard& guard = GrowthGuard::unlimited());

}  // namespace sylva
