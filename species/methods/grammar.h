// The `grammar` growth method: a stochastic grammar (an automaton of states and
// input → output-set rules) whose every transition draws one stem as a noisy spline, with
// particle leaves emitted along the stems (Jain et al. 2021, "Automated Tree Generation
// Using Grammar & Particle System", §3.1 structure, §3.2 leaves).
//
// Frame: +y up, metres. Angles in the species file are degrees, in the options radians.
//
// ---------------------------------------------------------------------------------------------
// Species-file format (method = "grammar"): every key of [grammar], [rules], [geometry.*],
// [particles.*], [fruit.*] and [seasons.*], with units, defaults and ranges, is documented in
// docs/methods/grammar.md (tests/project/spec_keys_test.cpp checks it against the reader,
// grammar_spec.cpp); the defaults are the structs' below. Worked example:
// species/papers/jain-2021/grammar-fir.toml. The generic [leaves] table is rejected for grammar
// species (leaves are per state here).
//
// ---------------------------------------------------------------------------------------------
// Conventions
// - Derivation: the start state draws no stem; each output β of a rule applied to a state α
//   draws one stem for β attached to α's stem (to the ground point, node 0, for the start
//   rule's outputs); stop states draw nothing. A stem's level c is its derivation depth:
//   0 for the start rule's outputs, parent's c + 1 below. Level c is SkeletonNode::level;
//   states at level D − 1 are not expanded.
// - Branch order (SkeletonNode::order): the first output equal to its input state continues
//   the parent's axis (Fir's leader a → a…, Bamboo's culm a → a) and keeps its order; every
//   other output gets order + 1. The start rule's outputs have order 0.
// - Growth stages (paper Fig. 4): every draw is keyed by the stem's derivation path (the
//   output indices from the start), never consumed in sequence, so the same seed at depth
//   D + 1 adds stems to the tree at D without moving any: a `max_depth` sweep is a growth
//   series.
// - Euler angles are intrinsic: azimuth about the parent's tangent (from the parent frame's
//   reference normal), then tilt away from it, then roll about the child's axis (which turns
//   the child's reference normal, hence its children's azimuth origin).
// - Width is a diameter: SkeletonNode::radius = width / 2, linear along the stem from
//   w·r_wb to w·r_we.
// - Leaf colour classes (Jain §3.2: lighter higher, mixed in the middle): with the season's
//   palette of k classes, a leaf at relative height h ∈ [0, 1] of the tree takes palette
//   entry ⌊h·k − 0.5 + u⌋ (u uniform, clamped), so low leaves are the darkest class, high
//   leaves the lightest, and between two class centres the two mix in proportion.
//   Class numbers: 0–3 greens dark → light, 4 dark red, 5 red, 6 orange, 7 yellow, 8 fruit,
//   9 flower.
// - Our extensions for realistic species (issue 13), each off by default: a per-instance
//   length scale, a ground clearance that bends descending shoot stems level above y = 0, a
//   straight vertical leader, leaves per metre of stem, and root states whose stems are
//   aerial roots (part = root) that end on the ground and thicken into pillars there.
// ---------------------------------------------------------------------------------------------
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/budget.h"
#include "core/rng.h"
#include "species/model/season.h"
#include "species/model/tree.h"
#include "volumes/volume.h"

namespace sylva {

// Geometry of one transition α → β (Jain §3.1.2). Angles radians, lengths metres.
struct GrammarGeometry {
    double lengthLo = 1.0, lengthHi = 1.0;  // b_l range
    double reduceLength = 1.0;              // r_l
    double azimuthLo = 0.0, azimuthHi = 2 * kPi;
    double tiltLo = 0.0, tiltHi = 0.0;
    double rollLo = 0.0, rollHi = 0.0;
    Vec3 reduceAngle{1, 1, 1};  // r_a for (azimuth, tilt, roll)
    bool evenSpread = false;    // phyllotaxis = "even"
    bool distichous = false;    // phyllotaxis = "distichous" (our extension): two ranks
    double positionLo = 1.0, positionHi = 1.0;
    double reduceWidthBegin = 1.0;  // r_wb
    double reduceWidthEnd = 0.7;    // r_we
    double curveLo = 0.0, curveHi = 0.0;
    int controlPoints = 4;
    double tropism = 0.0;  // radians toward −y over the stem
};

struct GrammarAlternative {
    std::vector<int> out;  // output states (indices into GrammarOptions::states)
    double p = 1.0;
};

// Particle leaves on the stems of one state (Jain §3.2).
struct GrammarParticles {
    bool enabled = false;
    int count = 0;
    double sizeLo = 0.05, sizeHi = 0.1;  // metres
    double aspect = 0.5;
    LeafShape shape = LeafShape::kCard;  // the outline on each card (species/model/leaf_shape.h)
    double rotationLo = 30 * (kPi / 180), rotationHi = 60 * (kPi / 180);  // radians
    double randomness = 0.5;
    double alongLo = 0.0, alongHi = 1.0;
    int minLevel = 0;
    bool twoRows = false;  // arrangement = "two-rows" (else "spiral")
    // Our extension: leaves per metre of the leafy stretch (`along`) of the stem's sampled
    // curve, added to `count` (rounded to the nearest integer); with it, leaves are spread
    // evenly along the stretch (one per equal sub-interval, jittered) instead of uniformly.
    double perMetre = 0.0;  // leaves / m; 0: `count` only (Jain's rule)
};

// How a root state's stems run (our extension; Jain §4 shows the banyan's aerial roots but
// gives no rule for them).
enum class RootForm {
    kVertical,  // straight down from the attachment (gravitropic aerial / prop roots)
    kArching,   // along the transition's geometry (tilt, tropism, curve): stilt roots
};

// The stems of a root state are aerial roots: part of the root system (SkeletonNode::part =
// kRootPart, with every stem drawn from them), never bent by the ground clearance. A root
// whose drawn length reaches the ground ends exactly at y = 0 (cut where it meets it) and is
// *rooted*: it thickens into a pillar of the drawn width along its whole length; a shorter one
// hangs free with the transition's widths.
struct GrammarRoots {
    bool enabled = false;
    RootForm form = RootForm::kVertical;
    double pillarWidthLo = 0.0, pillarWidthHi = 0.0;  // metres (diameter); 0: no thickening
};

// Fruit / flower cards on the stems of one state.
struct GrammarFruit {
    bool enabled = false;
    int count = 0;
    double sizeLo = 0.06, sizeHi = 0.1;
    double aspect = 1.0;
    uint8_t colour = 8;
    double alongLo = 0.5, alongHi = 1.0;
    int minLevel = 0;
    std::array<bool, 4> seasons{true, true, true, false};  // indexed by Season
};

struct GrammarOptions {
    std::vector<std::string> states;  // state names; index = state id
    int start = 0;
    std::vector<bool> stop;                              // per state
    std::vector<std::vector<GrammarAlternative>> rules;  // per state (empty: none)
    int maxDepth = 0;                                    // D; 0 = unbounded (cap kMaxLevels)
    int maxStems = 50000;
    double trunkWidthLo = 0.2, trunkWidthHi = 0.2;  // W, metres (diameter)
    double segmentLength = 0.1;                     // metres
    // Our extensions (issue 13), each off by default so Jain's grammars grow as before:
    double lengthScale = 1.0;      // × every stem's length t_l (a distribution: per instance)
    double groundClearance = 0.0;  // metres; > 0: a shoot stem descending below this height
                                   // bends toward the horizontal and never reaches y = 0
    bool straightLeader = false;   // order-0 stems straight up (+y): no tilt, curve, tropism
    // Plots (species/plot/plot_growth.h): a light/shade tropism away from the neighbours'
    // crowns, horizontal, its length the strength. An order-0 stem's initial direction gets
    // half of it added before it is normalised (the trunk leans); a branch's horizontal part
    // gets it added to its unit horizontal direction, then its horizontal length and its rise
    // are restored (the branch turns about the vertical, no higher than alone). Not a straight
    // leader, not roots. Zero: none.
    Vec3 lightTropism{0, 0, 0};
    // Plots: crown shyness up to the lower of two crowns' tops (ShyBound, in the tree's frame;
    // plot_growth.h). A branch (a shoot stem of order ≥ 1) stops growing at its last sample
    // inside every bound — each bound's plane moved back for this stem by one keyed draw
    // u ∈ [0, 1) times the bound's slack, so the crown's edge toward a neighbour is ragged, not
    // a cut — unless the stretch that crosses rises more than 30° above the horizontal: that
    // sample is moved onto the plane and the branch grows on up along it. A stem is never
    // begun beyond its parent's end: branches that would have grown from the part of the
    // parent not grown are not drawn (the open L-systems' branch collision: Měch &
    // Prusinkiewicz 1996). A trunk (order 0) is never stopped: its samples beyond a plane are
    // moved onto it. Leaf and fruit cards whose centres lie beyond a bound are dropped.
    // Empty: none.
    std::vector<ShyBound> shyBounds;
    Season season = Season::kSummer;
    std::array<SeasonPalette, 4> seasons = grammarSeasons();

    GrammarGeometry fallback;                                   // when no table matches
    std::map<std::pair<int, int>, GrammarGeometry> transition;  // (from, to) → geometry
    std::vector<GrammarParticles> particles;                    // per state
    std::vector<GrammarFruit> fruit;                            // per state
    std::vector<GrammarRoots> roots;                            // per state

    static constexpr int kMaxLevels = 64;

    // Builder helpers (tests and the spec reader): the id of a state, added if new.
    int state(const std::string& name);
    const GrammarGeometry& geometry(int from, int to) const;
};

// One drawn stem, for statistics and tests.
struct GrammarStem {
    int state = 0;
    int parent = -1;             // index of the parent stem, −1 for the start rule's outputs
    int level = 0;               // c
    int order = 0;               // branch order
    uint64_t key = 0;            // derivation-path key
    int32_t baseNode = 0;        // skeleton node it grows from (on the parent, or node 0)
    std::vector<int32_t> nodes;  // its own skeleton nodes, base excluded, tip last
    double length = 0.0;         // true length t_l (the control polygon's arc before noise), m
    Vec3 direction;              // initial direction (unit), after the Euler angles
    Vec3 parentTangent;          // parent's tangent at the attachment (+y for the start rule)
    double widthBegin = 0.0, widthEnd = 0.0;  // metres
    bool root = false;                        // part of the root system (a root state's stem)
    bool rooted = false;                      // a root that reaches the ground (ends at y = 0)
};

struct GrammarStats {
    int64_t stems = 0;
    int depthReached = 0;    // deepest level c + 1 with a stem
    int64_t stopStates = 0;  // stop states produced
    int64_t truncated = 0;   // states not expanded because of D or max_stems
    int64_t leaves = 0;
    int64_t fruit = 0;
    int64_t roots = 0;       // stems of root states (aerial roots)
    int64_t rooted = 0;      // of them, those reaching the ground
    int64_t shyStopped = 0;  // branches stopped short, or never begun, at a shyness bound
    int64_t shyLeaves = 0;   // leaf and fruit cards not kept beyond a bound (in leaves, fruit)
};

// Grows one tree. Deterministic in rng's seed; independent of thread count (serial). Every
// stem's nodes and every stem's leaves are held to `guard`'s budgets before they are made,
// and its deadline is checked as the stems are drawn (BudgetExceeded).
Tree growGrammar(const GrammarOptions& options, Rng& rng, GrammarStats* stats = nullptr,
                 std::vector<GrammarStem>* stems = nullptr,
                 const GrowthGuard& guard = GrowthGuard::unlimited());

// Smooth 3-D value noise in [−1, 1] (trilinear with smoothstep weights over a hashed lattice).
double valueNoise3(const Vec3& p, uint64_t seed);

}  // namespace sylva
