// The form stage: what every growth method's tree goes through before leaves are placed and
// statistics taken (issue 13's "all methods" and "thickness" options). None of it is in the
// papers; each step is off by default, so the papers' reproductions keep the papers' rules.
//
//  1. clear bole    branches leaving the trunk (the order-0 axis) below a height are removed
//  2. pipe model    radii from the tips: r_parent^n = Σ r_child^n at forks (Shinozaki et al.
//                   1964's pipe model; n = 2 is Leonardo's rule, measured 1.8–2.3 across
//                   species by Eloy 2011, n = 3 Murray's law), a tip radius, an optional taper
//                   along the branch between forks, optionally rescaled to a base radius
//  3. scale         the whole tree (positions, radii) by a factor: per-instance size
//  4. asymmetry     the shoot stretched by (1 + a) along a horizontal direction, (1 − a) across
//  5. lean          the shoot tilted from the vertical about the base
//  6. ground        a shoot branch that goes below y = 0 is cut where it meets the ground
//
// Leaves carried by a node (Leaf::node ≥ 0) keep their offset from it (turned with the lean),
// so they stay on their twigs; free leaves (node −1) move as points. The root system below the
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
    double clearBole = 0.0;     // metres (before scaling); 0: keep every branch
    double pipeExponent = 0.0;  // n of the pipe model; 0: the method's own radii
    double tipRadius = 0.003;   // metres (before scaling): radius at every shoot tip
    double pipeTaper = 0.0;     // per metre: radius × (1 + taper · segment length) per segment
                                // toward the base between forks (≈ e^(taper · length))
    double baseRadius = 0.0;    // metres (before scaling); > 0: pipe radii rescaled so the
                                // base has it (the tips follow); 0: radii from tipRadius
    double scale = 1.0;         // ×, the whole tree
    double asymmetry = 0.0;     // fraction in [0, 0.9)
    double leanRad = 0.0;       // radians from the vertical
    GroundRule ground = GroundRule::kNone;

    // True when any step changes the tree.
    bool active() const;
};

// Applies the steps in the order above. `rng` gives the asymmetry's and the lean's azimuths
// (their own derived streams). Removed nodes are dropped with their subtrees, leaves and
// endpoints; indices stay parent-before-child.
void applyForm(Tree& tree, const FormOptions& options, const Rng& rng);

// The pipe model alone (step 2), exposed for tests: shoot radii from the tips.
void pipeModelRadii(Tree& tree, double exponent, double tipRadius, double taper, double baseRadius);

}  // namespace sylva
