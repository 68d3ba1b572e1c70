// The `grammar` growth method: a stochastic grammar (an automaton of states and
// input → output-set rules) whose every transition draws one stem as a noisy spline, with
// particle leaves emitted along the stems (Jain et al. 2021, "Automated Tree Generation
// Using Grammar & Particle System", §3.1 structure, §3.2 leaves).
//
// Frame: +y up, metres. Angles in the species file are degrees, in the options radians.
//
// ---------------------------------------------------------------------------------------------
// Species-file format (method = "grammar"). Worked example: species/presets/grammar-fir.toml.
//
// [grammar]                                   global parameters
// | key            | type          | default | meaning |
// |----------------|---------------|---------|-------------------------------------------------|
// | start          | state name    | "s"     | start state S (§3.1); draws no stem itself       |
// | stop           | [names]       | ["t"]   | stop states 𝒯; a stop state draws NO stem         |
// | max_depth      | integer ≥ 1   | absent  | D, maximum branching depth (§3.1.1): stems have   |
// |                |               |         | level c = 0 … D−1; absent = unbounded, allowed    |
// |                |               |         | only if every reachable state can reach a stop    |
// |                |               |         | state (then an internal cap of 64 levels applies) |
// | trunk_width    | [lo, hi] m    | [0.2,0.2] | W, width (diameter) of the stems drawn by the   |
// |                |               |         | start rule, uniform per tree (§3.1.2)            |
// | segment_length | metres        | 0.1     | skeleton sampling step along each stem spline     |
// | max_stems      | integer       | 50000   | safety cap; states past it are not expanded       |
// | season         | string        | "summer"| "spring", "summer", "autumn" or "winter" (§3.2)   |
//
// [rules]                                     the grammar 𝒢 (§3.1.1), one key per input state
//   a = [ { out = ["a", "b1", "b1", "b2*2"], p = 0.4 }, { out = ["a", "b1*2"], p = 0.6 } ]
//   - `out`: the output set; "name*N" repeats a state N times (Table 1's "bb…b").
//   - `p`: probability of the alternative; may be omitted when a rule has one alternative;
//     the alternatives' p must sum to 1 (±1e-6).
//   - every state named in `out` must have a rule or be a stop state; the start state must
//     have a rule; stop states must not have one.
//
// [geometry.default], [geometry.<state>], [geometry."<from>-><to>"]   the geometry ℋ (§3.1.2)
//   Each key is looked up in the most specific table that sets it: the transition's own
//   table ("a->b1"), then the output state's ("b1"), then "default", then the built-in
//   default below. A transition table must name a transition some rule can make.
// | key                | type        | default  | meaning |
// |--------------------|-------------|----------|----------------------------------------------|
// | length             | [lo, hi] m  | [1, 1]   | base length b_l, uniform                      |
// | reduce_length      | number > 0  | 1.0      | r_l: true length t_l = b_l · r_l^c            |
// | azimuth_deg        | [lo, hi]    | [0, 360] | Euler angle 1: turn about the parent's axis   |
// | tilt_deg           | [lo, hi]    | [0, 0]   | Euler angle 2: away from the parent's axis    |
// | roll_deg           | [lo, hi]    | [0, 0]   | Euler angle 3: about the child's own axis     |
// | reduce_angle       | [3 numbers] | [1,1,1]  | r_a per Euler angle: t_a = b_a · r_a^c        |
// | phyllotaxis        | string      | "random" | "random": azimuth drawn from azimuth_deg;     |
// |                    |             |          | "even": the "even" siblings of one rule       |
// |                    |             |          | application share a random offset and sit     |
// |                    |             |          | 360°/n apart, azimuth_deg added as jitter     |
// | position           | [lo, hi]    | [1, 1]   | attachment as a fraction of the parent stem's |
// |                    |             |          | length (1 = its end); snapped to the nearest  |
// |                    |             |          | parent skeleton node (never its base node)    |
// | reduce_width_begin | (0, 1]      | 1.0      | r_wb: child base width w · r_wb               |
// | reduce_width_end   | (0, 1]      | 0.7      | r_we: child tip width w · r_we (w = parent's  |
// |                    |             |          | width at the attachment; widths interpolated) |
// | curve              | [lo, hi]    | [0, 0]   | curviness: control points displaced by smooth |
// |                    |             |          | 3-D value noise × curve × stem length         |
// | control_points     | integer ≥ 2 | 4        | spline control points (Catmull–Rom)           |
// | tropism_deg        | [-180, 180] | 0        | extension (Jain §5 future work): the stem     |
// |                    |             |          | turns this far toward −y over its length      |
// |                    |             |          | (negative: toward +y), never past vertical    |
//
// [particles.<state>]                         leaves on every stem of that state (§3.2)
// | key          | type         | default      | meaning |
// |--------------|--------------|--------------|------------------------------------------------|
// | count        | integer ≥ 0  | required     | leaves per stem (before the season's density)  |
// | size         | [lo, hi] m   | [0.05, 0.1]  | card length; larger low in the tree, smaller   |
// |              |              |              | high up, mixed by `randomness`                 |
// | aspect       | number       | 0.5          | card width / length                            |
// | rotation_deg | [lo, hi]     | [30, 60]     | angle between the leaf axis and the stem tangent|
// | randomness   | [0, 1]       | 0.5          | 0: size by height only, rotation mid-range;    |
// |              |              |              | 1: uniform in the ranges                       |
// | along        | [lo, hi]     | [0, 1]       | stretch of the stem (fractions of its length)  |
// | min_level    | integer ≥ 0  | 0            | only on stems with level c ≥ min_level         |
// | arrangement  | string       | "spiral"     | "spiral": anywhere around the stem; "two-rows":|
// |              |              |              | alternately either side of the stem's plane    |
// |              |              |              | (its reference normal ± 90°: pinnate fronds)   |
//
// [fruit.<state>]                             fruit or flower cards on stems of that state
// | count   | integer ≥ 0 | required      | per stem |
// | size    | [lo, hi] m  | [0.06, 0.1]   | card size |
// | aspect  | number      | 1.0           | width / length |
// | colour  | integer     | 8             | colour class (8 fruit, 9 flower by convention) |
// | along   | [lo, hi]    | [0.5, 1]      | stretch of the stem |
// | min_level | integer   | 0             | as for particles |
// | seasons | [names]     | all but winter| seasons in which the cards appear |
// Fruit cards hang: their long axis points down (−y) from the stem point.
//
// [seasons.<season>]                          overrides of the built-in season palettes
// | classes | [integers] | see below | leaf colour classes, darkest/lowest first |
// | density | [0, 1]     | see below | fraction of `count` kept (a per-leaf draw, so   |
// |         |            |           | a sparser season's leaves are a subset)         |
// Built-in: spring [1, 2, 3] × 0.6; summer [0, 1, 2, 3] × 1; autumn [4, 5, 6, 7] × 0.8;
// winter [] × 0 (bare). An evergreen sets e.g. [seasons.winter] classes = [0, 1], density = 1.
//
// The generic [leaves] table is rejected for grammar species (leaves are per state here).
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
// ---------------------------------------------------------------------------------------------
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/rng.h"
#include "species/model/tree.h"

namespace sylva {

enum class Season { kSpring = 0, kSummer = 1, kAutumn = 2, kWinter = 3 };

// Geometry of one transition α → β (Jain §3.1.2). Angles radians, lengths metres.
struct GrammarGeometry {
    double lengthLo = 1.0, lengthHi = 1.0;  // b_l range
    double reduceLength = 1.0;              // r_l
    double azimuthLo = 0.0, azimuthHi = 2 * kPi;
    double tiltLo = 0.0, tiltHi = 0.0;
    double rollLo = 0.0, rollHi = 0.0;
    Vec3 reduceAngle{1, 1, 1};  // r_a for (azimuth, tilt, roll)
    bool evenSpread = false;    // phyllotaxis = "even"
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
    double rotationLo = 30 * (kPi / 180), rotationHi = 60 * (kPi / 180);  // radians
    double randomness = 0.5;
    double alongLo = 0.0, alongHi = 1.0;
    int minLevel = 0;
    bool twoRows = false;  // arrangement = "two-rows" (else "spiral")
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

struct GrammarSeason {
    std::vector<uint8_t> classes;  // darkest (lowest) first
    double density = 1.0;
};

// Built-in palettes (see the format comment).
std::array<GrammarSeason, 4> defaultSeasons();

struct GrammarOptions {
    std::vector<std::string> states;  // state names; index = state id
    int start = 0;
    std::vector<bool> stop;                              // per state
    std::vector<std::vector<GrammarAlternative>> rules;  // per state (empty: none)
    int maxDepth = 0;                                    // D; 0 = unbounded (cap kMaxLevels)
    int maxStems = 50000;
    double trunkWidthLo = 0.2, trunkWidthHi = 0.2;  // W, metres (diameter)
    double segmentLength = 0.1;                     // metres
    Season season = Season::kSummer;
    std::array<GrammarSeason, 4> seasons = defaultSeasons();

    GrammarGeometry fallback;                                   // when no table matches
    std::map<std::pair<int, int>, GrammarGeometry> transition;  // (from, to) → geometry
    std::vector<GrammarParticles> particles;                    // per state
    std::vector<GrammarFruit> fruit;                            // per state

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
};

struct GrammarStats {
    int64_t stems = 0;
    int depthReached = 0;    // deepest level c + 1 with a stem
    int64_t stopStates = 0;  // stop states produced
    int64_t truncated = 0;   // states not expanded because of D or max_stems
    int64_t leaves = 0;
    int64_t fruit = 0;
};

// Grows one tree. Deterministic in rng's seed; independent of thread count (serial).
Tree growGrammar(const GrammarOptions& options, Rng& rng, GrammarStats* stats = nullptr,
                 std::vector<GrammarStem>* stems = nullptr);

// Smooth 3-D value noise in [−1, 1] (trilinear with smoothstep weights over a hashed lattice).
double valueNoise3(const Vec3& p, uint64_t seed);

}  // namespace sylva
