// The form stage: what every growth method's tree goes through before leaves are placed and
// statistics taken (issue 13's "all methods" and "thickness" options). None of it is in the
// papers; each step is off by default, so the papers' reproductions keep the papers' rules.
//
//  1. clear bole    branches leaving the trunk (the order-0 axis) below a height are removed
//  2. pipe model    radii from the tips: r_parent^n = Σ r_child^n at forks (Shinozaki et al.
//                   1964's pipe model; n = 2 is Leonardo's rule, measured 1.8–2.3 across
//                   species by Eloy 2011, n = 3 Murray's law), a tip radius, an optional taper
//                   along the branch between forks, optionally rescaled to a base radius; n may
//                   be drawn per fork around the species' mean (real forks spread widely about
//                   it: Eloy 2011, Fig. 2; the TreeQSM reference's interquartile range 1.9–4.5)
//  2b. shade       a branch whose tips are shaded by the crown above them (Palubicki et al. 2009
//                   §4's shadow propagation, cast by every shoot tip) is shed: the self-pruning
//                   that clears a crown's lower and inner shoots; after the pipe model, so the
//                   shed shoots' pipes stay in what carried them (Shinozaki's disused pipes)
//  3. branches      each branch leaving the stem turned at its insertion by an angle drawn per
//                   branch; every branch's length × a factor drawn per branch (its vigour: the
//                   median branch keeps its length, suppressed ones fall well short) and bent along
//                   its length (gravitropic sag or upturned tips) at a rate drawn per branch: a
//                   branch leaves at one angle and bends
//  4. scale         the whole tree (positions, radii) by a factor: per-instance size; a
//                   horizontal factor on top widens or narrows the crown per instance
//  5. asymmetry     the shoot stretched by (1 + a) along a horizontal direction, (1 − a) across
//  6. lean          the shoot tilted from the vertical about the base
//  7. ground        a shoot branch that goes below y = 0 is cut where it meets the ground
//
// Leaves carried by a node (Leaf::node ≥ 0) keep their offset from it (turned with its branch
// and the lean), so they stay on their twigs; free leaves (node −1) move as points, and with
// step 3 they move with the shoot node nearest them. The root system below the
// base (part == kRootPart) is only scaled; aerial roots hanging from a shoot node (prop roots)
// move with it horizontally and stretch vertically, so a root standing on the ground stays on
// it and a vertical one stays vertical. Frame: +y up, metres, the root node at the origin.
#pragma once

#include "core/rng.h"
#include "species/model/tree.h"

namespace sylva {

enum class GroundRule {
    kNone,   // the method's tree as grown
    kPrune,  // shoot branches cut at y = 0; the trunk (order 0) is lifted to y = 0 instead
};

struct FormOptions {
    double clearBole = 0.0;       // metres (before scaling); 0: keep every branch
    double shadeShed = 0.0;       // fraction of full light: a branch whose tips' mean exposure
                                  // is below it is shed; 0: off
    double shadeVoxel = 0.5;      // metres (before scaling): the shadow grid's voxel edge
    double shadeStrength = 0.1;   // a: the shade one tip casts into its own voxel (full light 1)
    double shadeDecay = 2.0;      // b > 1: the shade divided by b per voxel layer below
    int shadeDepth = 6;           // voxel layers the shade reaches below a tip
    int shadeMinOrder = 1;        // the lowest branch order shed (2: first-order limbs stay)
    double pipeExponent = 0.0;    // n of the pipe model; 0: the method's own radii
    double tipRadius = 0.003;     // metres (before scaling): radius at every shoot tip
    double pipeTaper = 0.0;       // per metre: radius × (1 + taper · segment length) per segment
                                  // toward the base between forks (≈ e^(taper · length))
    double baseRadius = 0.0;      // metres (before scaling); > 0: pipe radii rescaled so the
                                  // base has it (the tips follow); 0: radii from tipRadius
    double pipeExponentSd = 0.0;  // per fork: n ~ N(pipeExponent, sd), redrawn outside
                                  // [kMinForkExponent, kMaxForkExponent]; 0: n at every fork
    double pipeExponentLogSd = 0.0;  // per fork instead: n = pipeExponent · e^(σz), z ~ N(0, 1),
                                     // held to [kMinLogForkExponent, kMaxForkExponent] (the
                                     // median fork keeps pipeExponent; a long tail of near-
                                     // continuations); excludes pipeExponentSd
    double pipeExponentLogMedian = 0.0;  // the log-normal draws' median; 0: pipeExponent (the base
                                         // keeps pipeExponent's radius either way)
    double pipeMinChildRatio = 0.0;  // with log-normal forks: the thickest child of a fork is at
                                     // least this fraction of the fork's radius (a draw that would
                                     // make the fork thicker is drawn again, then the fork held to
                                     // it); 0: off
    double angleSdRad = 0.0;         // per branch leaving the stem: its insertion angle + N(0, sd),
                                     // radians
    double angleShiftRad = 0.0;      // and + this mean (radians; > 0 wider from the stem), both
                                     // weighted by the branch's spread weight
    double lengthSd = 0.0;       // per branch: its length × e^(σ(0.674 − |z|)), z ~ N(0, 1),
                                 // at least 0.25: the median branch keeps the method's length,
                                 // none grows past e^(0.674σ) of it, and the shortened half has
                                 // a long tail (suppressed shoots)
    double spreadReach = 0.2;    // × tree height: a branch reaching farther (its longest path
                                 // to a tip) turns and shortens less, by spreadReach·H / reach
    double bendRadPerM = 0.0;    // per branch: radians per metre (before scaling) turned
                                 // toward the ground along the branch; < 0 turns it upward
    double bendSdRadPerM = 0.0;  // per branch: spread of that rate, radians per metre
    double scale = 1.0;          // ×, the whole tree
    double width = 1.0;          // ×, the shoot's horizontal extent about the base (crown
                                 // width per instance, over `scale`)
    double asymmetry = 0.0;      // fraction in [0, 0.9)
    double leanRad = 0.0;        // radians from the vertical
    GroundRule ground = GroundRule::kNone;

    // True when step 3 turns or bends branches.
    bool turnsBranches() const;
    // True when any step changes the tree.
    bool active() const;
};

// The range a fork's drawn pipe exponent is held to (the reference's own bounds are [0.5, 6];
// below 1.2 the parent of two equal children would be more than 1.78 × as thick as each).
constexpr double kMinForkExponent = 1.2;
constexpr double kMaxForkExponent = 6.0;
// The log-normal draw's floor: the reference's own (a parent of two equal children 4 × as thick).
constexpr double kMinLogForkExponent = 0.5;
constexpr int kChildRatioDraws = 8;  // draws of a fork's exponent under pipeMinChildRatio

// How a fork's own exponent is drawn about the species' n.
enum class ForkSpread {
    kNormal,     // N(n, sd), redrawn outside [kMinForkExponent, kMaxForkExponent]
    kLogNormal,  // n · e^(sd · z), held to [kMinLogForkExponent, kMaxForkExponent]
};

// Applies the steps in the order above. `rng` gives the per-fork exponents, the per-branch
// turns and bends, and the asymmetry's and the lean's azimuths (each its own derived stream,
// keyed per fork and per branch by the node index). Removed nodes are dropped with their subtrees,
// leaves and endpoints; indices stay parent-before-child.
void applyForm(Tree& tree, const FormOptions& options, const Rng& rng);

// What shade shedding removed: the branches shed (each with its subtree) and the nodes in all.
struct ShadeShedResult {
    int64_t branches = 0;
    int64_t nodes = 0;
};

// Step 2b alone, exposed for tests: every shoot tip casts shade a·b^(−q) into the (2q + 1)²
// voxels q layers below it (q = 0 … depth; Palubicki et al. 2009 §4), a tip's exposure is
// max(1 − s + a, 0) of its voxel's shade s, and every branch (a shoot node of higher order than
// its parent, of order ≥ shadeMinOrder; never the order-0 stem) whose tips' mean exposure is
// under `shadeShed` is removed with its subtree, its leaves and endpoints; a node left without
// children becomes an endpoint. Computed once on the tree as grown (before step 3's turns); no
// randomness. The radii stay (the shed shoots' disused pipes), but with pipeMinChildRatio a node
// that lost a child is held to its thickest remaining child ÷ the ratio, and its ancestors in turn
// where that thins them.
ShadeShedResult shedShadedBranches(Tree& tree, const FormOptions& options);

// The pipe model alone (step 2), exposed for tests: shoot radii from the tips. With
// exponentSd > 0 each fork draws its own exponent from `rng` (keyed by the fork's node index);
// without a base radius the radii are then rescaled so the base keeps the radius the mean
// exponent gives it (the spread changes the forks, not the tree's thickness). A log-normal
// spread draws about `logMedian` when it is > 0, about `exponent` otherwise.
// With minChildRatio > 0 (log-normal spread only) a fork's radius is at most its thickest child's
// ÷ minChildRatio: while the drawn exponent would make it thicker, the fork's stream draws again
// (up to kChildRatioDraws draws in all), and then the fork is held to that radius. The rescaling
// sweep with the mean exponent obeys the same bound.
void pipeModelRadii(Tree& tree, double exponent, double tipRadius, double taper, double baseRadius,
                    double exponentSd = 0.0, const Rng* rng = nullptr,
                    ForkSpread spread = ForkSpread::kNormal, double logMedian = 0.0,
                    double minChildRatio = 0.0);

// Step 3 alone, exposed for tests: every branch (a node whose order is above its parent's and
// that does not continue it — the continuing child as the reference distributions define it,
// so a grammar stem whose rule changes the state goes on as the stem) draws its insertion
// change, length factor and bend rate, the first two weighted by min(1, spreadReach · height /
// the branch's reach); a branch leaving the stem (of branch order 1, counted along continuing
// children as TreeQSM counts) is turned about its fork by its insertion change, insertion angles
// held within [5°, 150°] (unless the method's are outside); every segment of a branch is scaled by
// the branch's length factor and then turned toward (or away from) the ground by the branch's rate
// × its length, elevations held within ±80°. Whole subtrees move with their segment; leaves go with
// their node, at their own size and offset (free leaves with the shoot node nearest them, within 1
// m); roots stay where they are (applyForm then moves a hanging root with the node it hangs from,
// so that a root standing on the ground stays on it).
void turnBranches(Tree& tree, const FormOptions& options, const Rng& rng);

}  // namespace sylva
