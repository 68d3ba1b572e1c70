// The `space-colonization` growth method (see space_colonization.h for the two variants).
//
// Tree form (Palubicki et al. 2009 §3, metamers): every internode ends in a node that carries
// a terminal bud (the internode's direction; it continues the axis, same branch order) and a
// lateral bud (at branchAngle from the internode, turned about it by the phyllotaxis angle
// from the previous lateral bud on the same axis; when it grows it starts a new axis, order
// + 1). A bud grows at most one metamer per iteration. The root (node 0) sits at the origin
// with one terminal bud pointing +y; a trunk of trunkLength is grown straight up first, its
// nodes carrying no lateral buds (a clear bole).
//
// Conventions decided here (not fixed by the papers):
//  - Occupancy and perception are tested against the skeleton *nodes* (each bud sits on one).
//  - Baseline: markers never come back, so a bud that perceives no marker at all is dropped
//    (it could never grow); a bud that perceives markers but wins none stays dormant.
//    Growth stops when an iteration grows nothing (the state is then fixed).
//  - Improved: a bud "has space" when at least one of its own surviving markers, or a guide
//    marker, lies in its perception volume (within r, angle ≤ θ); markers of *other* buds
//    there only push it (Σ ω v_m). A bud without space does not grow; after kMaxFailures
//    such iterations in a row it dies, except that the tree's last bud is kept (see grow()),
//    so this variant ends at max_iterations or max_internodes. Markers drawn outside the crown are
//    dropped (not redrawn), so marker density is uniform wherever the crown is. v_opt is
//    the normalised mean of the unit vectors to the bud's markers, so λ and the guide
//    weights are relative to a unit vector; ω takes d and σ in internode lengths.
//  - Guides: directional guide markers add weight·direction to every bud that perceives
//    them (Liu 2020 §4.3); tropism is added last and the direction normalised again.
//  - Radii: pipe model from the tips up, r_parentⁿ = Σ r_childⁿ; a node's radius is that of
//    the internode ending at it.
//
// Trees rather than brooms (all off by default):
//  - Borchert–Honda allocation (Palubicki 2009 §4, baseline only): after the competition, a
//    bud's Q is 1 if it won markers, else 0 (the paper's space-colonization case); Q is summed
//    basipetally, the base's resource α·Q_base is split acropetally by λ (borchertHonda), and
//    a bud given v grows ⌊v + 10⁻⁹⌋ metamers (the tolerance keeps an exact split such as
//    2 × 1.0 from rounding down). The first metamer follows the bud's won markers; each further
//    one is re-aimed at those of them still there that the shoot's new tip perceives (shoots
//    grow serially in bud order), and the shoot stops early when none is left: a shoot fills
//    the space its bud won and no more. Only the top node of a shoot keeps a terminal bud.
//  - Shedding: lateral branches whose Q per internode has stayed below the threshold (a
//    fraction of the whole tree's Q per internode) for shedDelay iterations in a row are removed
//    before the resource is distributed (the node list is compacted; markers they cleared stay
//    gone). One iteration is not enough: a bud's binary Q flickers with the competition, and every
//    young branch has iterations in which none of its buds wins a marker.
//  - Perturbed crown: a deformed copy of the crown (PerturbedCrown), drawn from the stream
//    "envelope", replaces it for markers and bounds.
//  - Leader and whorls: see SpaceColonizationOptions.
//
// Determinism: per-bud work of an iteration (perception, marker generation from a stream
// keyed by (bud id, iteration), directions) reads only the iteration's start state and writes
// its own slot; everything that changes state (competition for markers, new nodes, marker
// removal) runs serially in bud order. Threaded and serial runs give identical trees.
//
// Frame: +y up, metres, radians.
#include "species/methods/space_colonization.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "species/methods/space_colonization_detail.h"
#include "volumes/point_grid.h"
#include "volumes/shadow_grid.h"

namespace sylva {

namespace {

constexpr int kMaxFailures = 3;  // improved: iterations in a row without space before a bud dies
constexpr double kOmegaCutoff = 4.3;  // improved: ω(4.3σ) < 1e-4·ω(0): such markers push nothing

// Runs f(i) for every i in [0, n), across TBB workers when `threaded`.
template <class F>
void forEachIndex(size_t n, bool threaded, const F& f) {
    if (threaded && n > 32) {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16),
                          [&](const tbb::blocked_range<size_t>& r) {
                              for (size_t i = r.begin(); i != r.end(); ++i) f(i);
                          });
    } else {
        for (size_t i = 0; i < n; ++i) f(i);
    }
}

// A uniform hash grid of point indices. Queries visit the cells a ball touches in a fixed
// order, each cell's indices in insertion order, so sums over query results are reproducible.
class HashGrid {
  public:
    explicit HashGrid(double cell) : inv_(1.0 / cell) {}

    void clear() { cells_.clear(); }
    void insert(int32_t index, const Vec3& p) {
        cells_[key(coord(p.x), coord(p.y), coord(p.z))].push_back(index);
    }

    // f(index) for every point in the cells the ball (p, radius) touches; the caller tests the
    // actual distance.
    template <class F>
    void forEachNear(const Vec3& p, double radius, F&& f) const {
        visitCells(*this, p, radius, [&](const std::vector<int32_t>& cell) {
            for (int32_t i : cell) f(i);
            return false;
        });
    }

    // The cell coordinate of v in a grid of cells 1 / inv wide, and the cell's key, which
    // orders cells by x, then y, then z.
    static int64_t coordOf(double v, double inv) {
        const double c = std::floor(v * inv);
        return static_cast<int64_t>(std::clamp(c, double(-kHalf), double(kHalf - 1)));
    }
    static uint64_t key(int64_t x, int64_t y, int64_t z) {
        return uint64_t(z + kHalf) | uint64_t(y + kHalf) << 21 | uint64_t(x + kHalf) << 42;
    }

    // True as soon as hit(index) is true for a point in a cell the ball touches.
    template <class F>
    bool anyNear(const Vec3& p, double radius, F&& hit) const {
        return visitCells(*this, p, radius, [&](const std::vector<int32_t>& cell) {
            return std::any_of(cell.begin(), cell.end(), hit);
        });
    }

  private:
    static constexpr int64_t kHalf = int64_t(1) << 20;  // 21 bits per axis
    int64_t coord(double v) const { return coordOf(v, inv_); }

    // visit(cell) for every non-empty cell the ball touches, x then y then z ascending, until
    // visit returns true (then true). Self is HashGrid or const HashGrid.
    template <class Self, class V>
    static bool visitCells(Self& self, const Vec3& p, double radius, V&& visit) {
        const int64_t x0 = self.coord(p.x - radius), x1 = self.coord(p.x + radius);
        const int64_t y0 = self.coord(p.y - radius), y1 = self.coord(p.y + radius);
        const int64_t z0 = self.coord(p.z - radius), z1 = self.coord(p.z + radius);
        for (int64_t x = x0; x <= x1; ++x) {
            for (int64_t y = y0; y <= y1; ++y) {
                for (int64_t z = z0; z <= z1; ++z) {
                    auto it = self.cells_.find(key(x, y, z));
                    if (it != self.cells_.end() && visit(it->second)) return true;
                }
            }
        }
        return false;
    }

    double inv_;
    std::unordered_map<uint64_t, std::vector<int32_t>> cells_;
};

// Persistent markers: the guides (indices [0, guides)), then, in the baseline, the crown's.
// All are added before the first query; then seal() packs them by cells half of `cell` wide
// (a narrow perception cone touches few of them), and markers die in place (alive = 0).
// perceive lists them in the order of a grid of `cell`: cell by cell (x, then y, then z), by
// index within a cell, which is what sums over the lists depend on.
struct MarkerSet {
    static constexpr double kFine = 2.0;
    std::vector<Vec3> position;
    std::vector<Vec3> pull;  // weight · direction of a directional guide marker, else zero
    std::vector<uint8_t> alive;
    double cell;
    PackedPointGrid grid;
    bool sealed = false;
    explicit MarkerSet(double cell_) : cell(cell_) {}
    int32_t add(const Vec3& p, const Vec3& pull_) {
        if (sealed) throw std::logic_error("MarkerSet::add after seal");
        const auto i = static_cast<int32_t>(position.size());
        position.push_back(p);
        pull.push_back(pull_);
        alive.push_back(1);
        return i;
    }
    void seal() {
        if (sealed) return;
        grid.assign(position, cell / kFine);
        sealed = true;
    }

    // The grid's ids are marker indices until compact() drops the dead: then gridMarker maps.
    std::vector<int32_t> gridMarker;
    int64_t deadInGrid = 0;
    int32_t markerOf(int32_t gridId) const {
        return gridMarker.empty() ? gridId : gridMarker[gridId];
    }
    void kill(int32_t m) {
        alive[m] = 0;
        ++deadInGrid;
    }
    // Packs the grid anew with the living markers only, once the dead are most of it: late in
    // growth the queries scanned mostly markers the shoots had taken (the perception scan
    // was 7% of a library build's CPU). Which markers a query visits is a superset of those
    // in its box either way, and perceive orders what it keeps by itself, so no result
    // depends on when this runs. Call it where no query runs.
    void compact() {
        if (!sealed || grid.size() < 4096 || 2 * deadInGrid <= static_cast<int64_t>(grid.size())) {
            return;
        }
        std::vector<Vec3> living;
        std::vector<int32_t> ids;
        for (size_t m = 0; m < position.size(); ++m) {
            if (!alive[m]) continue;
            living.push_back(position[m]);
            ids.push_back(static_cast<int32_t>(m));
        }
        grid.assign(living, cell / kFine);
        gridMarker = std::move(ids);
        deadInGrid = 0;
    }
};

// A marker in a bud's perception volume, with its squared distance to the bud.
struct Perceived {
    int32_t marker;
    double d2;
};

// The perception volume (Palubicki 2009 §4, Liu 2020 Fig. 3a): within `radius` of the bud and
// at most θ from its direction (cosAngle = cos θ). Markers on the bud itself are not seen.
inline bool inCone(const Vec3& v, double d2, const Vec3& direction, double cosAngle) {
    return d2 > 0.0 && dot(v, direction) >= cosAngle * std::sqrt(d2);
}

// The bounding box of the perception volume: the apex and, per axis, the farthest reach of
// the cone's directions (1 when the axis lies inside the cone, else cos(α − θ) for an axis α
// from the cone's axis), times the radius; the whole ball's box for a cone wider than a
// half-space. Widened by a margin far above rounding.
void perceptionBox(const Vec3& at, const Vec3& direction, double radius, double cosAngle, Vec3& lo,
                   Vec3& hi) {
    const double margin =
        1e-9 * (radius + std::abs(at.x) + std::abs(at.y) + std::abs(at.z)) + 1e-12;
    const double sinAngle = std::sqrt(std::max(0.0, 1.0 - cosAngle * cosAngle));
    for (int a = 0; a < 3; ++a) {
        double up = 1.0, down = -1.0;
        if (cosAngle >= 0.0) {
            const double c = std::clamp(direction[a], -1.0, 1.0);
            const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
            up = c >= cosAngle ? 1.0 : c * cosAngle + s * sinAngle;
            down = -c >= cosAngle ? -1.0 : -(-c * cosAngle + s * sinAngle);
        }
        lo[a] = at[a] + radius * std::min(0.0, down) - margin;
        hi[a] = at[a] + radius * std::max(0.0, up) + margin;
    }
}

std::vector<Perceived> perceive(const MarkerSet& set, const Vec3& at, const Vec3& direction,
                                double radius, double cosAngle) {
    std::vector<Perceived> out;
    const double r2 = radius * radius;
    Vec3 lo, hi;
    perceptionBox(at, direction, radius, cosAngle, lo, hi);
    set.grid.forEachInBox(lo, hi, [&](int32_t g, const Vec3& position) {
        const int32_t m = set.markerOf(g);
        if (!set.alive[m]) return;
        const Vec3 v = position - at;
        const double d2 = length2(v);
        if (d2 <= r2 && inCone(v, d2, direction, cosAngle)) out.push_back({m, d2});
    });
    if (out.size() > 1) {  // into the order of a HashGrid of `set.cell`
        const double inv = 1.0 / set.cell;
        std::vector<std::pair<uint64_t, Perceived>> keyed(out.size());
        for (size_t k = 0; k < out.size(); ++k) {
            const Vec3& p = set.position[out[k].marker];
            keyed[k] = {HashGrid::key(HashGrid::coordOf(p.x, inv), HashGrid::coordOf(p.y, inv),
                                      HashGrid::coordOf(p.z, inv)),
                        out[k]};
        }
        std::sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) {
            return a.first != b.first ? a.first < b.first : a.second.marker < b.second.marker;
        });
        for (size_t k = 0; k < out.size(); ++k) out[k] = keyed[k].second;
    }
    return out;
}

// The baseline competition: each perceived marker goes to the closest bud, ties to the lower
// bud index (serial, in bud order). `owner` must hold −1 for every listed marker on entry.
// Bud b of `lists` is bud base + b of the competition (several trees: each tree's buds after
// the previous trees').
void resolveOwners(const std::vector<std::vector<Perceived>>& lists, std::vector<int32_t>& owner,
                   std::vector<double>& best, int32_t base = 0) {
    for (size_t b = 0; b < lists.size(); ++b) {
        for (const Perceived& p : lists[b]) {
            if (owner[p.marker] < 0 || p.d2 < best[p.marker]) {
                owner[p.marker] = base + static_cast<int32_t>(b);
                best[p.marker] = p.d2;
            }
        }
    }
}

struct Bud {
    Vec3 position;
    Vec3 direction;  // unit
    // Terminal bud: the azimuth (unit, ⊥ its internode) of the previous lateral bud on its
    // axis. Lateral bud: its parent internode's direction (the new axis' first reference).
    Vec3 reference;
    int32_t node = 0;
    int32_t order = 0;  // the branch order of the axis it grows
    uint64_t id = 0;    // creation number: keys its marker stream (improved)
    int failures = 0;   // improved: iterations in a row without space
    Vec3 heading;       // a lateral axis: the direction its bud was set at (axisTurnMax)
    Vec3 limb;          // an axis of order ≥ 2: its order-1 ancestor's heading (limbTurnMax)
};

// What a bud does this iteration.
struct Step {
    bool grow = false;
    bool dies = false;
    Vec3 direction;
    std::vector<int32_t> won;  // with allocation: the markers the bud won, for its shoot
};

// An improved-variant marker of this iteration (Liu 2020 §3, Fig. 4).
struct BudMarker {
    Vec3 position;
    Vec3 push;  // ω · v_m: its weight times the unit vector from its bud to it
};

Vec3 uniformInBall(Rng& rng) {
    const Vec3 u = rng.unitVector();
    return u * std::cbrt(rng.uniform());
}

void validate(const SpaceColonizationOptions& o) {
    auto bad = [](const std::string& what) {
        throw std::invalid_argument("space-colonization: " + what);
    };
    if (!(o.internode > 0)) bad("internode must be > 0");
    if (!(o.occupancy >= 0)) bad("occupancy must be ≥ 0");
    if (!(o.perception > o.occupancy)) bad("perception must exceed occupancy");
    if (!(o.perceptionAngle > 0 && o.perceptionAngle < kPi)) bad("perception angle not in (0, π)");
    if (o.variant == ColonizationVariant::kBaseline && !o.crown) bad("the baseline needs a crown");
    if (o.variant == ColonizationVariant::kImproved && o.markersPerBud < 1) {
        bad("markersPerBud must be ≥ 1");
    }
    if (!(o.kappa > 0) || !(o.sigma > 0)) bad("kappa and sigma must be > 0");
    if (!(o.pipeExponent > 0) || !(o.tipRadius > 0)) bad("pipe exponent and tip radius > 0");
    if (o.markers < 0 || o.maxIterations < 0 || o.maxInternodes < 0) bad("negative limit");
    if (o.allocation == Allocation::kBorchertHonda) {
        if (o.variant != ColonizationVariant::kBaseline) bad("allocation needs the baseline");
        if (!(o.apicalControl > 0 && o.apicalControl < 1)) bad("apical control not in (0, 1)");
        if (!(o.resourceCoefficient > 0)) bad("resource coefficient must be > 0");
    }
    if (o.light == Light::kShadow &&
        (!(o.shadowStrength > 0) || !(o.shadowDecay > 1) || o.shadowDepth < 0)) {
        bad("shadow strength > 0, decay > 1, depth ≥ 0");
    }
    if (o.shedThreshold > 0 &&
        (o.allocation != Allocation::kBorchertHonda || o.light != Light::kShadow)) {
        bad("shedding needs allocation with light = shadow");
    }
    if (!(o.shedThreshold >= 0) || o.shedDelay < 1) bad("shed threshold ≥ 0, delay ≥ 1");
    if (!(o.spaceMarkers >= 0)) bad("space markers must be ≥ 0");
    if (!(o.turnSd >= 0 && o.turnSd <= kPi / 2)) bad("shoot turn σ must be in [0, π/2]");
    if (!(o.axisTurnMax >= 0 && o.axisTurnMax <= kPi) ||
        !(o.limbTurnMax >= 0 && o.limbTurnMax <= kPi)) {
        bad("axis and limb turns must be in [0, π]");
    }
    if (o.branchletAngle && !(*o.branchletAngle > 0 && *o.branchletAngle < kPi)) {
        bad("branchlet angle must be in (0, π)");
    }
    if (o.spaceMarkers > 0 && o.allocation != Allocation::kBorchertHonda) {
        bad("space markers need allocation");
    }
    if (!(o.envelopeScaleSd >= 0) || !(o.envelopeNoise >= 0 && o.envelopeNoise <= 0.9)) {
        bad("envelope scale σ must be ≥ 0 and noise in [0, 0.9]");
    }
    if (!(o.leaderWeight >= 0) || o.whorlLaterals < 0 || o.maxOrder < 0) bad("negative form key");
}

// The crown a tree grows in: the given one, or its per-instance deformed copy.
VolumePtr treeCrown(const SpaceColonizationOptions& o, const Rng& rng) {
    if (!o.crown || (o.envelopeScaleSd <= 0 && o.envelopeNoise <= 0)) return o.crown;
    Rng r = rng.derive("envelope");
    const double scale = std::clamp(1.0 + o.envelopeScaleSd * r.normal(), 0.5, 1.5);
    return std::make_shared<detail::PerturbedCrown>(o.crown, scale, o.envelopeNoise,
                                                    r.derive("waves"));
}

class Grower {
  public:
    // Alone (shared == nullptr): the tree's own markers, root at the origin. Together
    // (growSpaceColonizationTogether): the crown's markers go into the plot's shared set, the
    // root stands at `origin` and the tree grows in the plot's frame until end() moves it back.
    // `territory` (together only): the markers a bud may perceive (ColonizingTree::territory).
    Grower(const SpaceColonizationOptions& o, Rng& rng, const GrowthGuard& guard,
           MarkerSet* shared = nullptr, const Vec3& origin = {0, 0, 0},
           const std::vector<ShyBound>* territory = nullptr)
        : o_(o),
          rng_(rng),
          turns_(rng.derive("shoot-turns")),
          guard_(guard),
          L_(o.internode),
          rho_(o.occupancy * o.internode),
          r_(o.perception * o.internode),
          cosTheta_(std::cos(o.perceptionAngle)),
          crown_(treeCrown(o, rng)),
          allocating_(o.allocation == Allocation::kBorchertHonda),
          nodeGrid_(std::max(o.occupancy, 0.5) * o.internode),
          own_(o.perception * o.internode),
          persistent_(shared ? *shared : own_),
          shared_(shared != nullptr),
          origin_(origin),
          territory_(territory && !territory->empty() ? territory : nullptr),
          owner_(),
          best_() {}

    Tree grow(std::map<std::string, double>* stats);

    // The steps of grow(), for the multi-tree driver.
    void begin();       // addMarkers(), then plant()
    void addMarkers();  // the guides' and (baseline) the crown's markers
    void plant();       // the root, the bole and the first bud
    bool live() const {
        return iterations_ < o_.maxIterations && !buds_.empty() &&
               static_cast<int>(nodes_.size()) - 1 < o_.maxInternodes;
    }
    void beginIteration();  // counts the iteration, checks the budgets
    std::vector<std::vector<Perceived>> perceiveBuds() const;
    // Apical dominance of a held leader: every marker its order-0 bud perceives is its own.
    void leaderOwns(const std::vector<std::vector<Perceived>>& lists, std::vector<int32_t>& owner,
                    int32_t base) const;
    // The baseline's steps once the competition has given every perceived marker an owner
    // (bud base + i is this tree's bud i).
    std::vector<Step> stepsFrom(const std::vector<std::vector<Perceived>>& lists,
                                const std::vector<int32_t>& owner, int32_t base);
    bool advance(std::vector<Step> steps);  // grows the steps' buds; true when anything grew
    Tree end(std::map<std::string, double>* stats);
    int iterations() const { return iterations_; }
    bool improved() const { return o_.variant == ColonizationVariant::kImproved; }

  private:
    Vec3 world(const Vec3& p) const { return shared_ ? p + origin_ : p; }  // tree → plot
    Vec3 local(const Vec3& p) const { return shared_ ? p - origin_ : p; }  // plot → tree

    int32_t addNode(const Vec3& p, int32_t parent, int32_t order, int32_t level);
    bool occupied(const Vec3& p) const;
    Vec3 finish(Vec3 v, const Vec3& fallback, int32_t order) const;
    std::vector<Step> baselineSteps();
    std::vector<Step> improvedSteps(int iteration);
    std::vector<double> allocate(std::vector<Step>& steps);
    void compact(const std::vector<uint8_t>& shed);
    bool shootDirection(const Bud& tip, const std::vector<int32_t>& won, Vec3& direction) const;
    void growShoot(const Bud& b, const Step& s, int metamers, int level, std::vector<Bud>& born);
    Vec3 turned(const Vec3& g, uint64_t bud, int level, int k) const;

    const SpaceColonizationOptions& o_;
    Rng& rng_;
    const Rng turns_;  // the shoot turns' stream (turned), keyed below by bud, iteration, metamer
    const GrowthGuard& guard_;
    const double L_, rho_, r_, cosTheta_;
    const VolumePtr crown_;               // o_.crown, or its per-instance deformed copy
    const bool allocating_;               // Borchert–Honda allocation
    std::unique_ptr<ShadowGrid> shadow_;  // light = "shadow" only
    std::vector<SkeletonNode> nodes_;
    HashGrid nodeGrid_;
    MarkerSet own_;          // the tree's markers when it grows alone
    MarkerSet& persistent_;  // own_, or the plot's shared set
    const bool shared_;
    const Vec3 origin_;                       // the root's place in the plot (shared only)
    const std::vector<ShyBound>* territory_;  // null: every marker (shared only)
    int iterations_ = 0;
    std::vector<int32_t> owner_;  // baseline competition scratch, −1 between iterations
    std::vector<double> best_;
    std::vector<Bud> buds_;
    std::vector<int32_t> starved_;  // shedding: iterations in a row each node's branch failed
    uint64_t nextBudId_ = 0;
    double generated_ = 0, removed_ = 0, budIterations_ = 0;
    double shedBranches_ = 0, shedInternodes_ = 0;
};

int32_t Grower::addNode(const Vec3& p, int32_t parent, int32_t order, int32_t level) {
    SkeletonNode n;
    n.position = p;
    n.parent = parent;
    n.order = order;
    n.level = level;
    const auto index = static_cast<int32_t>(nodes_.size());
    nodes_.push_back(n);
    nodeGrid_.insert(index, p);
    if (shadow_) shadow_->cast(p, +1);
    // The new node's occupancy zone: persistent markers within ρ are gone for good.
    const double rho2 = rho_ * rho_;
    const double reach = rho_ * (1 + 1e-9) + 1e-12;  // the box around the ball, with a margin
    const Vec3 pad{reach, reach, reach};
    persistent_.grid.forEachInBox(p - pad, p + pad, [&](int32_t g, const Vec3& q) {
        const int32_t m = persistent_.markerOf(g);
        if (!persistent_.alive[m] || distance2(q, p) > rho2) return;
        persistent_.kill(m);
        removed_ += 1;
    });
    return index;
}

bool Grower::occupied(const Vec3& p) const {
    const double rho2 = rho_ * rho_;
    return nodeGrid_.anyNear(p, rho_,
                             [&](int32_t i) { return distance2(nodes_[i].position, p) <= rho2; });
}

// The growth direction from the summed contributions, then tropism (the branchlets' own on
// orders ≥ 2 when set), each normalised; on the order-0 axis, then the leader's pull to +y.
Vec3 Grower::finish(Vec3 v, const Vec3& fallback, int32_t order) const {
    v += fallback * o_.budDirectionWeight;
    Vec3 g = length2(v) > 1e-24 ? normalize(v) : fallback;
    const Vec3 t = g + (order >= 2 && o_.branchletTropism ? *o_.branchletTropism : o_.tropism);
    g = length2(t) > 1e-24 ? normalize(t) : g;
    if (order == 0 && o_.leaderWeight > 0) g = normalize(g + Vec3{0, o_.leaderWeight, 0});
    return g;
}

// Baseline (Palubicki 2009 §4; Runions 2007): perception per bud in parallel, the
// competition serially, then each bud's direction v = norm(Σ unit vectors to its markers)
// plus Σ ω·v_stroke over the guide markers it perceives (Liu 2020 §4.3).
std::vector<std::vector<Perceived>> Grower::perceiveBuds() const {
    const size_t n = buds_.size();
    std::vector<std::vector<Perceived>> lists(n);
    forEachIndex(n, o_.threaded, [&](size_t i) {
        lists[i] = perceive(persistent_, buds_[i].position, buds_[i].direction, r_, cosTheta_);
        if (territory_) {
            std::vector<Perceived>& l = lists[i];
            l.erase(std::remove_if(l.begin(), l.end(),
                                   [&](const Perceived& p) {
                                       return !keepsAll(*territory_,
                                                        persistent_.position[p.marker]);
                                   }),
                    l.end());
        }
    });
    return lists;
}

// A held leader (leaderWeight > 0) is apically dominant: every marker it perceives is its
// own, however close another bud is, so laterals crowding round it never starve it.
void Grower::leaderOwns(const std::vector<std::vector<Perceived>>& lists,
                        std::vector<int32_t>& owner, int32_t base) const {
    if (o_.leaderWeight <= 0) return;
    for (size_t b = 0; b < lists.size(); ++b) {
        if (buds_[b].order != 0) continue;
        for (const Perceived& p : lists[b]) owner[p.marker] = base + static_cast<int32_t>(b);
    }
}

std::vector<Step> Grower::stepsFrom(const std::vector<std::vector<Perceived>>& lists,
                                    const std::vector<int32_t>& owner, int32_t base) {
    const size_t n = buds_.size();
    std::vector<Step> steps(n);
    forEachIndex(n, o_.threaded, [&](size_t i) {
        const Bud& b = buds_[i];
        Step& s = steps[i];
        if (lists[i].empty()) {
            s.dies = true;  // markers never return: this bud can never grow
            return;
        }
        Vec3 sum, pull;
        int count = 0;
        for (const Perceived& p : lists[i]) {
            pull += persistent_.pull[p.marker];
            if (owner[p.marker] != base + static_cast<int32_t>(i)) continue;
            sum += (persistent_.position[p.marker] - b.position) / std::sqrt(p.d2);
            ++count;
            if (allocating_) s.won.push_back(p.marker);
        }
        if (count == 0) return;  // dormant: every marker it sees went to a closer bud
        s.grow = true;
        s.direction = finish(normalize(sum) + pull, b.direction, b.order);
    });
    // A held leader keeps growing up while the crown goes on above it, even where the space
    // round it is used up: the markers only say where laterals may go.
    if (o_.leaderWeight > 0) {
        for (size_t b = 0; b < n; ++b) {
            Step& st = steps[b];
            if (buds_[b].order != 0 || st.grow || !crown_ ||
                !crown_->inside(local(buds_[b].position) + Vec3{0, r_, 0})) {
                continue;
            }
            st.grow = true;
            st.dies = false;
            st.direction = finish({0, 1, 0}, buds_[b].direction, 0);
        }
    }
    return steps;
}

// Baseline (Palubicki 2009 §4; Runions 2007): perception per bud in parallel, the
// competition serially, then each bud's direction v = norm(Σ unit vectors to its markers)
// plus Σ ω·v_stroke over the guide markers it perceives (Liu 2020 §4.3).
std::vector<Step> Grower::baselineSteps() {
    if (&persistent_ == &own_) persistent_.compact();  // (a plot's shared set: its loop does)
    const std::vector<std::vector<Perceived>> lists = perceiveBuds();
    owner_.resize(persistent_.position.size(), -1);
    best_.resize(persistent_.position.size(), 0.0);
    resolveOwners(lists, owner_, best_);
    leaderOwns(lists, owner_, 0);
    std::vector<Step> steps = stepsFrom(lists, owner_, 0);
    for (const auto& l : lists) {
        for (const Perceived& p : l) owner_[p.marker] = -1;
    }
    return steps;
}

// Liu 2020 §3: every live bud draws markersPerBud markers within κ·r of itself (inside the
// crown), drops those in any node's occupancy zone, and grows along
// norm(v_opt + Σ ωᵢ v_m(i) + λ v_g + Σ ω v_stroke).
std::vector<Step> Grower::improvedSteps(int iteration) {
    const size_t n = buds_.size();
    const double reach = o_.kappa * r_;
    // Only markers within `cutoff` of their bud can matter: farther ones lie outside its own
    // perception radius and push other buds with ω < 1e-4 of its peak. Their number is drawn
    // binomially and their positions uniformly in the smaller ball — the same distribution
    // as drawing all markersPerBud in the κ·r ball and dropping the rest, at a fraction of
    // the cost (κ = 3, σ = 1: 6 % of the markers).
    const double cutoff = std::min(reach, std::max(r_, kOmegaCutoff * o_.sigma * L_));
    const double within = std::pow(cutoff / reach, 3);
    const Rng streams = rng_.derive("bud-markers");
    std::vector<std::vector<BudMarker>> own(n);
    std::vector<int> drawn(n, 0), dropped(n, 0);
    // How many markers each bud draws, summed and held to the budget before any is made.
    std::vector<Rng> budRng(n);
    std::vector<int64_t> counts(n, 0);
    forEachIndex(n, o_.threaded, [&](size_t i) {
        budRng[i] = streams.derive(hashCombine(buds_[i].id, static_cast<uint64_t>(iteration)));
        counts[i] = detail::binomial(budRng[i], o_.markersPerBud, within);
    });
    int64_t total = 0;
    for (int64_t c : counts) total += c;
    guard_.graphNodes(static_cast<int64_t>(generated_) + total,
                      " (markers of iteration " + std::to_string(iteration) + ", " +
                          std::to_string(n) + " buds)");
    forEachIndex(n, o_.threaded, [&](size_t i) {
        const Bud& b = buds_[i];
        Rng& rng = budRng[i];
        const int64_t count = counts[i];
        for (int64_t k = 0; k < count; ++k) {
            const Vec3 p = b.position + uniformInBall(rng) * cutoff;
            if (crown_ && !crown_->inside(p)) continue;  // markers stay in the crown
            ++drawn[i];
            if (occupied(p)) {
                ++dropped[i];
                continue;
            }
            const Vec3 v = p - b.position;
            const double d = length(v) / L_;  // ω's d in internode lengths
            const double omega =
                std::exp(-d * d / (2 * o_.sigma * o_.sigma)) / (std::sqrt(2 * kPi) * o_.sigma);
            own[i].push_back({p, d > 0 ? v * (omega / (d * L_)) : Vec3{}});
        }
    });

    // This iteration's markers in one grid, for the other buds' perception.
    std::vector<const BudMarker*> field;
    std::vector<int32_t> fieldBud;
    HashGrid grid(r_);
    for (size_t i = 0; i < n; ++i) {
        generated_ += drawn[i];
        removed_ += dropped[i];
        for (const BudMarker& m : own[i]) {
            grid.insert(static_cast<int32_t>(field.size()), m.position);
            field.push_back(&m);
            fieldBud.push_back(static_cast<int32_t>(i));
        }
    }

    std::vector<Step> steps(n);
    const double r2 = r_ * r_;
    forEachIndex(n, o_.threaded, [&](size_t i) {
        const Bud& b = buds_[i];
        Vec3 sum, pull, push;
        int count = 0;
        for (const BudMarker& m : own[i]) {
            const Vec3 v = m.position - b.position;
            const double d2 = length2(v);
            if (d2 > r2 || !inCone(v, d2, b.direction, cosTheta_)) continue;
            sum += v / std::sqrt(d2);
            ++count;
        }
        // Guide markers give space like the bud's own markers (and pull along their stroke).
        for (const Perceived& p : perceive(persistent_, b.position, b.direction, r_, cosTheta_)) {
            sum += (persistent_.position[p.marker] - b.position) / std::sqrt(p.d2);
            pull += persistent_.pull[p.marker];
            ++count;
        }
        if (count == 0) return;  // no space this iteration
        // Markers of other buds in this bud's perception volume push it away from them.
        grid.forEachNear(b.position, r_, [&](int32_t j) {
            if (fieldBud[j] == static_cast<int32_t>(i)) return;
            const Vec3 v = field[j]->position - b.position;
            const double d2 = length2(v);
            if (d2 <= r2 && inCone(v, d2, b.direction, cosTheta_)) push += field[j]->push;
        });
        Step& s = steps[i];
        s.grow = true;
        s.direction = finish(normalize(sum) + push + pull + Vec3{0, -o_.gravityWeight, 0},
                             b.direction, b.order);
    });
    return steps;
}

// The extended Borchert–Honda model (Palubicki 2009 §4) on this iteration's competition: a
// bud that won markers (steps[i].grow) has Q = 1 (light = "space") or its exposure in the
// shadow grid (light = "shadow"), any other bud Q = 0. With spaceMarkers, a lateral-axis
// bud's share in the splits is its Q scaled by the space it won, while the base's resource
// stays α·ΣQ: space steers the resource, light sets it. Lateral branches that do not pay off
// (mean exposure of their nodes) are shed first (nodes_, buds_ and `steps` compacted alike).
// Returns each remaining bud's resource v.
std::vector<double> Grower::allocate(std::vector<Step>& steps) {
    const size_t n = nodes_.size();
    std::vector<int32_t> parent(n);
    std::vector<uint8_t> lateral(n, 0);
    for (size_t i = 0; i < n; ++i) {
        parent[i] = nodes_[i].parent;
        if (parent[i] >= 0) lateral[i] = nodes_[i].order != nodes_[parent[i]].order;
    }
    // Q: 1 for a bud that won markers (space), or its light exposure (shadow); 0 without space.
    std::vector<detail::AllocationBud> buds(buds_.size());
    for (size_t i = 0; i < buds_.size(); ++i) {
        const Bud& b = buds_[i];
        const double light = !steps[i].grow ? 0.0 : shadow_ ? shadow_->exposure(b.position) : 1.0;
        const double q = b.order == 0
                             ? light
                             : detail::spaceLimitedQ(light, steps[i].won.size(), o_.spaceMarkers);
        buds[i] = {b.node, b.order != nodes_[b.node].order, q, light};
    }
    std::vector<double> light;
    if (o_.shedThreshold > 0) {
        light.resize(n);
        for (size_t i = 0; i < n; ++i) light[i] = shadow_->exposure(nodes_[i].position);
    }
    starved_.resize(n, 0);
    detail::AllocationResult a =
        detail::borchertHonda(parent, lateral, buds, light, o_.apicalControl,
                              o_.resourceCoefficient, o_.shedThreshold, o_.shedDelay, starved_);
    if (std::find(a.shed.begin(), a.shed.end(), 1) == a.shed.end()) return a.budResource;

    std::vector<Step> keptSteps;
    std::vector<double> keptResource;
    for (size_t i = 0; i < buds_.size(); ++i) {
        if (a.shed[buds_[i].node]) continue;
        keptSteps.push_back(steps[i]);
        keptResource.push_back(a.budResource[i]);
    }
    compact(a.shed);
    steps = std::move(keptSteps);
    return keptResource;
}

// Removes the nodes marked in `shed` (whole subtrees: a shed node's descendants are shed too)
// and the buds on them, keeping the order of the rest.
void Grower::compact(const std::vector<uint8_t>& shed) {
    std::vector<int32_t> index(nodes_.size(), -1);
    std::vector<SkeletonNode> kept;
    kept.reserve(nodes_.size());
    for (size_t i = 0; i < nodes_.size(); ++i) {
        if (shed[i]) {
            if (shadow_) shadow_->cast(nodes_[i].position, -1);
            shedInternodes_ += 1;
            if (nodes_[i].parent >= 0 && !shed[nodes_[i].parent]) shedBranches_ += 1;
            continue;
        }
        starved_[index[i] = static_cast<int32_t>(kept.size())] = starved_[i];
        kept.push_back(nodes_[i]);
        if (kept.back().parent >= 0) kept.back().parent = index[kept.back().parent];
    }
    nodes_ = std::move(kept);
    starved_.resize(nodes_.size());
    nodeGrid_.clear();
    for (size_t i = 0; i < nodes_.size(); ++i) {
        nodeGrid_.insert(static_cast<int32_t>(i), nodes_[i].position);
    }
    std::vector<Bud> buds;
    for (Bud b : buds_) {
        if (index[b.node] < 0) continue;
        b.node = index[b.node];
        buds.push_back(b);
    }
    buds_ = std::move(buds);
}

// The direction of a shoot's next metamer from its tip: toward those of the markers its bud
// won this iteration that are still there and that the tip perceives (within r, inside its
// cone). False when none is left: the shoot ends. So a shoot never reaches beyond the space
// its bud claimed — at most about r + ρ internodes — and turns at most as its markers lie.
bool Grower::shootDirection(const Bud& tip, const std::vector<int32_t>& won,
                            Vec3& direction) const {
    Vec3 sum, pull;
    int count = 0;
    const double r2 = r_ * r_;
    for (int32_t m : won) {
        if (!persistent_.alive[m]) continue;
        const Vec3 v = persistent_.position[m] - tip.position;
        const double d2 = length2(v);
        if (d2 > r2 || !inCone(v, d2, tip.direction, cosTheta_)) continue;
        sum += v / std::sqrt(d2);
        pull += persistent_.pull[m];
        ++count;
    }
    if (count == 0) return false;
    direction = finish(normalize(sum) + pull, tip.direction, tip.order);
    return true;
}

// A lateral-axis metamer's direction g turned by a random angle ~ N(0, turnSd) about a random
// axis ⊥ g, from the stream of (bud, iteration, metamer): the zigzag of real shoots, whose
// buds do not grow exactly where the last shoot pointed.
Vec3 Grower::turned(const Vec3& g, uint64_t bud, int level, int k) const {
    Rng r = turns_.derive(
        hashCombine(hashCombine(bud, static_cast<uint64_t>(level)), static_cast<uint64_t>(k)));
    const Vec3 axis = rotate(anyPerpendicular(g), g, r.uniform(0.0, 2 * kPi));
    return normalize(rotate(g, axis, o_.turnSd * r.normal()));
}

// g turned back onto the cone of half-angle `half` about h when it points outside it
// (rotated toward h in the plane of the two); g itself when inside.
Vec3 withinCone(const Vec3& g, const Vec3& h, double half) {
    if (angleBetween(g, h) <= half) return g;
    Vec3 n = cross(h, g);
    n = length2(n) > 1e-24 ? normalize(n) : anyPerpendicular(h);
    return normalize(rotate(h, n, half));
}

// Flat sprays: the horizontal unit vector ⊥ g on the side of azimuth a; a itself when g is
// (nearly) vertical and has no left or right.
Vec3 sideways(const Vec3& a, const Vec3& g) {
    const Vec3 s = cross(Vec3{0, 1, 0}, g);
    if (length2(s) < 1e-6) return a;
    return dot(s, a) >= 0 ? normalize(s) : -normalize(s);
}

// A shoot of up to `metamers` metamers from bud b, the first along g (Palubicki 2009 §3–4).
// Every metamer ends in a node with a lateral bud (at branchAngle, turned about the axis by
// the phyllotaxis angle from the previous one); the shoot's top node also gets the terminal
// bud. On a whorled order-0 axis only the top node carries laterals: whorlLaterals of them,
// 360°/k apart. No lateral buds beyond maxOrder. With one metamer and no whorls this is the
// papers' metamer: the terminal bud, then the lateral bud. Realism additions, each off by
// default: on lateral axes the metamers zigzag (turnSd) and keep within axisTurnMax of the
// direction the axis' bud was set at (and, from order 2, within limbTurnMax of its limb's), and
// their laterals leave at branchletAngle, to the left or right (flatSprays).
void Grower::growShoot(const Bud& b, const Step& s, int metamers, int level,
                       std::vector<Bud>& born) {
    Vec3 g = s.direction;
    const bool whorled = o_.whorlLaterals > 0 && b.order == 0;
    const bool laterals = b.order + 1 <= o_.maxOrder;
    Bud tip = b;
    const bool held = o_.axisTurnMax > 0 && b.order > 0;
    const bool limbHeld = o_.limbTurnMax > 0 && b.order > 1;
    const double angle = b.order > 0 && o_.branchletAngle ? *o_.branchletAngle : o_.branchAngle;
    for (int k = 0; k < metamers; ++k) {
        if (o_.turnSd > 0 && b.order > 0) g = turned(g, b.id, level, k);
        if (held) g = withinCone(g, b.heading, o_.axisTurnMax);
        if (limbHeld) g = withinCone(g, b.limb, o_.limbTurnMax);
        const Vec3 p = tip.position + g * L_;
        const int32_t node = addNode(p, tip.node, tip.order, level);
        // Phyllotaxis: the previous lateral azimuth carried onto the plane ⊥ g, then turned.
        Vec3 a = tip.reference - g * dot(tip.reference, g);
        a = length2(a) > 1e-12 ? normalize(a) : anyPerpendicular(g);
        tip = {p, g, a, node, b.order, 0, 0, b.heading, b.limb};
        Vec3 next;
        const bool room = static_cast<int>(nodes_.size()) - 1 < o_.maxInternodes;
        const bool top = k + 1 == metamers || !room || !shootDirection(tip, s.won, next);
        if (!whorled || top) a = rotate(a, g, o_.phyllotaxis);
        tip.reference = a;
        if (top) {
            tip.id = nextBudId_++;
            born.push_back(tip);
        }
        if (laterals && (!whorled || top)) {
            const int count = whorled ? o_.whorlLaterals : 1;
            for (int j = 0; j < count; ++j) {
                Vec3 aj = j == 0 ? a : rotate(a, g, 2 * kPi * j / count);
                if (o_.flatSprays && b.order > 0) aj = sideways(aj, g);
                const Vec3 lateral = normalize(g * std::cos(angle) + aj * std::sin(angle));
                const Vec3 limb = b.order == 0 ? lateral : b.limb;
                born.push_back({p, lateral, g, node, b.order + 1, nextBudId_++, 0, lateral, limb});
            }
        }
        if (top) return;
        g = next;
    }
}

Tree Grower::grow(std::map<std::string, double>* stats) {
    const bool improved = o_.variant == ColonizationVariant::kImproved;
    begin();
    while (live()) {
        beginIteration();
        std::vector<Step> steps = improved ? improvedSteps(iterations_) : baselineSteps();
        if (!advance(std::move(steps)) && !improved) break;  // the baseline's state is fixed
    }
    return end(stats);
}

void Grower::begin() {
    addMarkers();
    plant();
}

void Grower::addMarkers() {
    const bool improved = o_.variant == ColonizationVariant::kImproved;
    const bool allocating = o_.allocation == Allocation::kBorchertHonda;
    for (const GuideMarker& g : o_.guides) {
        persistent_.add(world(g.position), g.direction * g.weight);
    }
    if (allocating && o_.light == Light::kShadow) {
        // The shade grid covers everything the tree can reach: the crown, the guides and the
        // root, with room for a pyramid's spread (depth voxels) and a step outside.
        Aabb box = crown_ ? crown_->bounds() : Aabb{};
        box.extend(Vec3{0, 0, 0});
        for (const GuideMarker& g : o_.guides) box.extend(g.position);
        const double margin = (o_.shadowDepth + 2) * L_ + r_;
        box.lo = world(box.lo - Vec3{margin, margin, margin});
        box.hi = world(box.hi + Vec3{margin, margin, margin});
        shadow_ = std::make_unique<ShadowGrid>(box, L_, o_.shadowStrength, o_.shadowDecay,
                                               o_.shadowDepth);
    }
    generated_ += static_cast<double>(o_.guides.size());
    if (!improved) {
        guard_.graphNodes(static_cast<int64_t>(o_.guides.size()) + o_.markers,
                          " (markers in the crown)");
        Rng markerRng = rng_.derive("crown-markers");
        for (int i = 0; i < o_.markers; ++i) {
            if (auto p = crown_->sample(markerRng)) {
                persistent_.add(world(*p), {0, 0, 0});
                generated_ += 1;
            }
        }
    }
}

void Grower::plant() {
    const bool improved = o_.variant == ColonizationVariant::kImproved;
    persistent_.seal();  // every tree's markers are in (a plot's trees add theirs first)
    // Root and trunk; their occupancy zones clear the markers around them.
    addNode(world({0, 0, 0}), -1, 0, 0);
    const int trunk =
        std::min(o_.maxInternodes, static_cast<int>(std::floor(o_.trunkLength / L_ + 1e-9)));
    for (int k = 1; k <= trunk; ++k) addNode(world({0, k * L_, 0}), k - 1, 0, 0);
    // A tree's own deformed crown may have moved out of the bole top's reach (the spec reader
    // checks the crown as given): the bole then grows on, straight up, until its top perceives
    // the crown — a longer bole for this instance rather than a bare pole.
    if (crown_ != o_.crown) {
        const double top = crown_->bounds().hi.y;
        auto inReach = [&](const Vec3& p) {
            return improved ? crown_->signedDistance(local(p)) < r_
                            : !perceive(persistent_, p, {0, 1, 0}, r_, cosTheta_).empty();
        };
        while (!inReach(nodes_.back().position) && local(nodes_.back().position).y < top &&
               static_cast<int>(nodes_.size()) - 1 < o_.maxInternodes) {
            const int32_t last = static_cast<int32_t>(nodes_.size()) - 1;
            addNode(nodes_.back().position + Vec3{0, L_, 0}, last, 0, 0);
        }
    }
    const double azimuth = rng_.derive("phyllotaxis").uniform(0.0, 2 * kPi);
    buds_.push_back({nodes_.back().position,
                     {0, 1, 0},
                     rotate({1, 0, 0}, {0, 1, 0}, azimuth),
                     static_cast<int32_t>(nodes_.size() - 1),
                     0,
                     nextBudId_++,
                     0,
                     {},
                     {}});
}

void Grower::beginIteration() {
    ++iterations_;
    guard_.time();
    guard_.skeletonNodes(static_cast<int64_t>(nodes_.size()),
                         " at iteration " + std::to_string(iterations_));
    guard_.graphNodes(static_cast<int64_t>(generated_),
                      " at iteration " + std::to_string(iterations_));
    budIterations_ += static_cast<double>(buds_.size());
}

bool Grower::advance(std::vector<Step> steps) {
    const bool improved = o_.variant == ColonizationVariant::kImproved;
    const bool allocating = o_.allocation == Allocation::kBorchertHonda;
    const int iterations = iterations_;
    // Borchert–Honda: each bud's resource v (and shedding, which may drop buds).
    const std::vector<double> resource = allocating ? allocate(steps) : std::vector<double>{};
    std::vector<Bud> kept, born;
    bool grew = false;
    int firstStarved = -1;  // improved: the first bud that just died of failures
    for (size_t i = 0; i < buds_.size(); ++i) {
        const Step& s = steps[i];
        const bool room = static_cast<int>(nodes_.size()) - 1 < o_.maxInternodes;
        if (s.grow && room) {
            const int metamers = allocating ? static_cast<int>(std::floor(resource[i] + 1e-9)) : 1;
            if (metamers >= 1) {
                growShoot(buds_[i], s, metamers, iterations, born);
                grew = true;
                continue;
            }
            // Too little resource this iteration: the bud waits (Palubicki 2009 §4).
        }
        if (s.dies) continue;
        Bud b = buds_[i];
        if (improved && !s.grow && ++b.failures >= kMaxFailures) {
            if (firstStarved < 0) firstStarved = static_cast<int>(i);
            continue;
        }
        kept.push_back(b);
    }
    // Improved: the tree's last bud is not given up. A bud in free space still finds no
    // marker in its perception volume with probability e^(−N·(1/κ)³·(1−cos θ)/2) per
    // iteration (N = markersPerBud), so a young tree of one or two buds would otherwise
    // end as a bare trunk in a few percent of seeds.
    if (kept.empty() && born.empty() && firstStarved >= 0) {
        kept.push_back(buds_[firstStarved]);
        kept.back().failures = kMaxFailures - 1;
    }
    // Survivors first, then the new buds: the list stays in creation (id) order.
    kept.insert(kept.end(), born.begin(), born.end());
    buds_ = std::move(kept);
    return grew;
}

Tree Grower::end(std::map<std::string, double>* stats) {
    const bool improved = o_.variant == ColonizationVariant::kImproved;
    const bool allocating = o_.allocation == Allocation::kBorchertHonda;
    const int iterations = iterations_;
    Tree tree;
    tree.nodes = std::move(nodes_);
    if (shared_) {
        for (SkeletonNode& node : tree.nodes) node.position = local(node.position);
    }
    // Pipe model (da Vinci / Murray; Palubicki 2009 §3): from the tips down, rⁿ = Σ childrenⁿ.
    const double n = o_.pipeExponent;
    std::vector<double> sum(tree.nodes.size(), 0.0);
    std::vector<uint8_t> hasChild(tree.nodes.size(), 0);
    for (size_t i = tree.nodes.size(); i-- > 0;) {
        SkeletonNode& node = tree.nodes[i];
        node.radius = hasChild[i] ? std::pow(sum[i], 1.0 / n) : o_.tipRadius;
        if (node.parent >= 0) {
            sum[node.parent] += std::pow(node.radius, n);
            hasChild[node.parent] = 1;
        }
    }
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
        if (!hasChild[i]) tree.endpoints.push_back(static_cast<int32_t>(i));
    }

    // markers_generated: guides + crown markers (baseline) or + the markers drawn near buds
    // inside the crown (improved; only those within the cutoff radius exist, see
    // improvedSteps); markers_removed: those lost to an occupancy zone; bud_iterations: live
    // buds summed over iterations (improved: × markersPerBud = the nominal marker budget).
    if (stats) {
        (*stats)["variant"] = improved ? 1.0 : 0.0;
        (*stats)["bud_iterations"] = budIterations_;
        (*stats)["iterations"] = iterations;
        (*stats)["internodes"] = static_cast<double>(tree.nodes.size() - 1);
        (*stats)["markers_generated"] = generated_;
        (*stats)["markers_removed"] = removed_;
        (*stats)["buds_live_final"] = static_cast<double>(buds_.size());
        if (o_.shedThreshold > 0 && allocating) {
            (*stats)["shed_branches"] = shedBranches_;
            (*stats)["shed_internodes"] = shedInternodes_;
        }
    }
    return tree;
}

}  // namespace

Tree growSpaceColonization(const SpaceColonizationOptions& options, Rng& rng,
                           std::map<std::string, double>* stats, const GrowthGuard& guard) {
    validate(options);
    Grower grower(options, rng, guard);
    return grower.grow(stats);
}

void growSpaceColonizationTogether(std::vector<ColonizingTree>& trees, bool threaded) {
    std::vector<size_t> together;
    for (size_t t = 0; t < trees.size(); ++t) {
        validate(trees[t].options);
        if (trees[t].options.variant == ColonizationVariant::kBaseline) together.push_back(t);
    }
    auto guardOf = [&](size_t t) -> const GrowthGuard& {
        return trees[t].guard ? *trees[t].guard : GrowthGuard::unlimited();
    };
    // The improved variant's trees, alone (in parallel: they share nothing).
    std::vector<size_t> alone;
    for (size_t t = 0; t < trees.size(); ++t) {
        if (trees[t].options.variant != ColonizationVariant::kBaseline) alone.push_back(t);
    }
    forEachIndex(alone.size(), threaded, [&](size_t k) {
        ColonizingTree& c = trees[alone[k]];
        c.tree = growSpaceColonization(c.options, c.rng, &c.stats, guardOf(alone[k]));
    });
    if (together.empty()) return;

    double cell = 0;
    for (size_t t : together) {
        cell = std::max(cell, trees[t].options.perception * trees[t].options.internode);
    }
    MarkerSet shared(cell);
    std::vector<std::unique_ptr<Grower>> growers;
    for (size_t t : together) {
        growers.push_back(std::make_unique<Grower>(trees[t].options, trees[t].rng, guardOf(t),
                                                   &shared, trees[t].origin, &trees[t].territory));
    }
    // Every tree's markers, then every bole (whose occupancy zones clear any tree's markers),
    // in tree order: the shared set's order is fixed.
    for (auto& g : growers) g->addMarkers();
    for (auto& g : growers) g->plant();

    const size_t n = growers.size();
    std::vector<int32_t> owner;
    std::vector<double> best;
    std::vector<std::vector<std::vector<Perceived>>> lists(n);
    std::vector<std::vector<Step>> steps(n);
    std::vector<uint8_t> active(n);
    std::vector<int32_t> base(n);
    auto eachTree = [&](const auto& f) {
        if (threaded && n > 1) {
            tbb::parallel_for(size_t(0), n, f);
        } else {
            for (size_t t = 0; t < n; ++t) f(t);
        }
    };
    for (;;) {
        bool any = false;
        for (size_t t = 0; t < n; ++t) {
            active[t] = growers[t]->live();
            if (active[t]) {
                growers[t]->beginIteration();
                any = true;
            }
        }
        if (!any) break;
        // Perception: each tree reads the shared markers only.
        shared.compact();
        eachTree([&](size_t t) {
            lists[t].clear();
            if (active[t]) lists[t] = growers[t]->perceiveBuds();
        });
        // The competition over every tree's buds, serially in tree then bud order.
        owner.resize(shared.position.size(), -1);
        best.resize(shared.position.size(), 0.0);
        int32_t next = 0;
        for (size_t t = 0; t < n; ++t) {
            base[t] = next;
            resolveOwners(lists[t], owner, best, next);
            next += static_cast<int32_t>(lists[t].size());
        }
        for (size_t t = 0; t < n; ++t) growers[t]->leaderOwns(lists[t], owner, base[t]);
        eachTree([&](size_t t) {
            steps[t].clear();
            if (active[t]) steps[t] = growers[t]->stepsFrom(lists[t], owner, base[t]);
        });
        for (size_t t = 0; t < n; ++t) {
            for (const auto& l : lists[t]) {
                for (const Perceived& p : l) owner[p.marker] = -1;
            }
        }
        // Growth changes the shared markers: serially, in tree order.
        bool grew = false;
        for (size_t t = 0; t < n; ++t) {
            if (active[t] && growers[t]->advance(std::move(steps[t]))) grew = true;
        }
        if (!grew) break;  // nothing changed: no tree can grow any more
    }
    for (size_t k = 0; k < n; ++k) {
        ColonizingTree& c = trees[together[k]];
        c.tree = growers[k]->end(&c.stats);
    }
}

namespace detail {

// By inversion: p ≤ 1/2 by symmetry and chunks of 512 trials, so that P(k = 0) =
// (1 − p)^512 never underflows; O(n·p + n/512) steps.
int64_t binomial(Rng& rng, int64_t n, double p) {
    if (p <= 0.0 || n <= 0) return 0;
    if (p >= 1.0) return n;
    if (p > 0.5) return n - binomial(rng, n, 1.0 - p);
    const double q = p / (1.0 - p);
    int64_t total = 0;
    for (int64_t left = n; left > 0; left -= 512) {
        const int64_t m = std::min<int64_t>(left, 512);
        double pk = std::pow(1.0 - p, static_cast<double>(m));
        double cdf = pk;
        const double u = rng.uniform();
        int64_t k = 0;
        while (u > cdf && k < m) {
            pk *= q * static_cast<double>(m - k) / static_cast<double>(k + 1);
            ++k;
            cdf += pk;
        }
        total += k;
    }
    return total;
}

double spaceLimitedQ(double light, size_t won, double spaceMarkers) {
    if (!(spaceMarkers > 0)) return light;
    return light * std::min(1.0, static_cast<double>(won) / spaceMarkers);
}

// Palubicki et al. 2009 §4, the extended Borchert–Honda model, and branch shedding.
AllocationResult borchertHonda(const std::vector<int32_t>& parent,
                               const std::vector<uint8_t>& lateralNode,
                               const std::vector<AllocationBud>& buds,
                               const std::vector<double>& nodeLight, double lambda, double alpha,
                               double shedThreshold, int shedDelay, std::vector<int32_t>& starved) {
    const size_t n = parent.size();
    AllocationResult r;
    r.nodeQ.assign(n, 0.0);
    r.nodeResource.assign(n, 0.0);
    r.budResource.assign(buds.size(), 0.0);
    r.shed.assign(n, 0);

    // Shedding first: per node, the light and the internode count of its subtree
    // (basipetally); a lateral branch whose mean light stays below the threshold goes.
    if (shedThreshold > 0) {
        std::vector<double> light(nodeLight.begin(), nodeLight.end()), size(n, 1.0);
        for (size_t i = n; i-- > 1;) {
            if (parent[i] < 0) continue;
            light[parent[i]] += light[i];
            size[parent[i]] += size[i];
        }
        for (size_t i = 1; i < n; ++i) {
            const bool low = lateralNode[i] && light[i] < shedThreshold * size[i];
            starved[i] = low ? starved[i] + 1 : 0;
            if ((low && starved[i] >= shedDelay) || (parent[i] >= 0 && r.shed[parent[i]])) {
                r.shed[i] = 1;
            }
        }
    }

    // Basipetally: Q_m and Q_l of every node — its buds, then its (unshed) child nodes.
    std::vector<double> qMain(n, 0.0), qLateral(n, 0.0);
    for (const AllocationBud& b : buds) {
        if (!r.shed[b.node]) (b.lateral ? qLateral : qMain)[b.node] += b.q;
    }
    for (size_t i = n; i-- > 0;) {
        if (r.shed[i]) continue;
        r.nodeQ[i] = qMain[i] + qLateral[i];
        if (parent[i] >= 0) (lateralNode[i] ? qLateral : qMain)[parent[i]] += r.nodeQ[i];
    }

    // Acropetally: v_base = α·Q_base (times Σvigour / ΣQ over the unshed buds where their vigour
    // is not their Q); at each node v_m = v·λQ_m / D, v_l = v·(1−λ)Q_l / D with
    // D = λQ_m + (1−λ)Q_l, the lateral side's share divided among its laterals by their Q.
    double q = 0, vigour = 0;
    for (const AllocationBud& b : buds) {
        if (r.shed[b.node]) continue;
        q += b.q;
        vigour += b.vigour < 0 ? b.q : b.vigour;
    }
    const double base = q > 0 && vigour != q ? alpha * vigour / q : alpha;
    std::vector<double> perQMain(n, 0.0), perQLateral(n, 0.0);  // v_m / Q_m, v_l / Q_l
    for (size_t i = 0; i < n; ++i) {
        if (r.shed[i]) continue;
        const int32_t p = parent[i];
        r.nodeResource[i] =
            p < 0 ? base * r.nodeQ[i] : (lateralNode[i] ? perQLateral : perQMain)[p] * r.nodeQ[i];
        const double d = lambda * qMain[i] + (1 - lambda) * qLateral[i];
        if (d > 0) {
            perQMain[i] = r.nodeResource[i] * lambda / d;
            perQLateral[i] = r.nodeResource[i] * (1 - lambda) / d;
        }
    }
    for (size_t b = 0; b < buds.size(); ++b) {
        const AllocationBud& bud = buds[b];
        if (r.shed[bud.node]) continue;
        r.budResource[b] = (bud.lateral ? perQLateral : perQMain)[bud.node] * bud.q;
    }
    return r;
}

PerturbedCrown::PerturbedCrown(VolumePtr base, double scale, double noise, Rng rng)
    : base_(std::move(base)), s_(scale), a_(noise) {
    const Aabb b = base_->bounds();
    c_ = (b.lo + b.hi) * 0.5;
    for (int j = 0; j < kWaves; ++j) {
        d_[j] = rng.unitVector();
        m_[j] = rng.uniform(1.0, 2.0);
        phi_[j] = rng.uniform(0.0, 2 * kPi);
    }
    const Vec3 h = (b.hi - b.lo) * (0.5 * (1 + a_));  // |1 + a·f| ≤ 1 + a about c
    bounds_.extend((c_ - h) * s_);
    bounds_.extend((c_ + h) * s_);
}

double PerturbedCrown::wave(const Vec3& u) const {
    double f = 0;
    for (int j = 0; j < kWaves; ++j) f += std::cos(kPi * m_[j] * dot(d_[j], u) + phi_[j]);
    return f / kWaves;
}

Vec3 PerturbedCrown::image(const Vec3& p) const {
    const Vec3 v = p - c_;
    const double l = length(v);
    return (l > 0 ? c_ + v * (1 + a_ * wave(v / l)) : c_) * s_;
}

Vec3 PerturbedCrown::preimage(const Vec3& q) const {
    const Vec3 v = q / s_ - c_;
    const double l = length(v);
    return l > 0 ? c_ + v / (1 + a_ * wave(v / l)) : c_;
}

double PerturbedCrown::signedDistance(const Vec3& q) const {
    return base_->signedDistance(preimage(q)) * s_ * (1 - a_);
}

std::string PerturbedCrown::describe() const { return "perturbed " + base_->describe(); }

std::vector<std::vector<std::pair<int32_t, double>>> perceivedMarkers(
    const std::vector<PerceivingBud>& buds, const std::vector<Vec3>& markers,
    const std::vector<char>& dead, double radius, double angle, bool compacted, size_t* gridSize) {
    MarkerSet set(radius);
    for (const Vec3& m : markers) set.add(m, {0, 0, 0});
    set.seal();
    for (size_t m = 0; m < markers.size() && m < dead.size(); ++m) {
        if (dead[m]) set.kill(static_cast<int32_t>(m));
    }
    if (compacted) set.compact();
    if (gridSize) *gridSize = set.grid.size();
    std::vector<std::vector<std::pair<int32_t, double>>> out;
    for (const PerceivingBud& b : buds) {
        out.emplace_back();
        for (const Perceived& p :
             perceive(set, b.position, normalize(b.direction), radius, std::cos(angle))) {
            out.back().push_back({p.marker, p.d2});
        }
    }
    return out;
}

std::vector<int32_t> closestPerceivingBud(const std::vector<PerceivingBud>& buds,
                                          const std::vector<Vec3>& markers, double radius,
                                          double angle, bool threaded) {
    MarkerSet set(radius);
    for (const Vec3& m : markers) set.add(m, {0, 0, 0});
    set.seal();
    std::vector<std::vector<Perceived>> lists(buds.size());
    const double cosAngle = std::cos(angle);
    forEachIndex(buds.size(), threaded, [&](size_t i) {
        lists[i] = perceive(set, buds[i].position, normalize(buds[i].direction), radius, cosAngle);
    });
    std::vector<int32_t> owner(markers.size(), -1);
    std::vector<double> best(markers.size(), 0.0);
    resolveOwners(lists, owner, best);
    return owner;
}

}  // namespace detail

}  // namespace sylva
