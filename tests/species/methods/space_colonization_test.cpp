// The space-colonization growth method (Palubicki 2009 baseline, Liu 2020 improved variant):
// growth toward markers with the exact first internode, occupancy removal with exact counts,
// the closest-bud competition against brute force, gravity and guide strokes bending growth,
// crown containment, tree invariants, the pipe model at every fork, determinism across
// thread counts, limits, stats and the spec reader's errors; Palubicki 2009's Borchert–Honda
// allocation in closed form, shedding, shadow propagation, the per-instance crown, whorls and
// the leader.
#include "species/methods/space_colonization.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/rng.h"
#include "species/methods/space_colonization_detail.h"
#include "species/model/realism_metrics.h"
#include "species/model/tree.h"
#include "species/model/tree_stats.h"
#include "species/spec/species.h"
#include "tests/test_support.h"
#include "volumes/shadow_grid.h"
#include "volumes/volume.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

constexpr double kDeg = kPi / 180.0;

// A crown far from the root: it bounds nothing near the tree, so the only markers there are
// the guides a test places.
VolumePtr farCrown() { return makePlaced(makeSphere(0.1), {{50, 50, 50}, {0, 1, 0}, {1, 1, 1}}); }

SpaceColonizationOptions baseOptions(ColonizationVariant v) {
    SpaceColonizationOptions o;
    o.variant = v;
    o.internode = 0.1;
    o.crown = makePlaced(makeSphere(1.2), {{0, 1.1, 0}, {0, 1, 0}, {1, 1, 1}});
    o.markers = 4000;
    o.markersPerBud = 64;
    o.maxInternodes = 3000;
    return o;
}

Tree grow(const SpaceColonizationOptions& o, uint64_t seed,
          std::map<std::string, double>* stats = nullptr) {
    Rng rng(seed);
    return growSpaceColonization(o, rng, stats);
}

std::vector<int> childCounts(const Tree& t) {
    std::vector<int> c(t.nodes.size(), 0);
    for (const SkeletonNode& n : t.nodes) {
        if (n.parent >= 0) ++c[n.parent];
    }
    return c;
}

// Mean unit direction of the internodes grown in iterations (level ≥ 1).
Vec3 meanInternodeDirection(const Tree& t) {
    Vec3 sum;
    for (const SkeletonNode& n : t.nodes) {
        if (n.parent < 0 || n.level < 1) continue;
        sum += normalize(n.position - t.nodes[n.parent].position);
    }
    return sum;
}

double meanAngleTo(const Tree& t, const Vec3& dir) {
    double sum = 0;
    int count = 0;
    for (const SkeletonNode& n : t.nodes) {
        if (n.parent < 0 || n.level < 1) continue;
        sum += angleBetween(n.position - t.nodes[n.parent].position, dir);
        ++count;
    }
    return count ? sum / count : 0.0;
}

bool sameTree(const Tree& a, const Tree& b) {
    if (a.nodes.size() != b.nodes.size() || a.endpoints != b.endpoints) return false;
    for (size_t i = 0; i < a.nodes.size(); ++i) {
        const SkeletonNode &x = a.nodes[i], &y = b.nodes[i];
        if (!(x.position == y.position) || x.radius != y.radius || x.parent != y.parent ||
            x.order != y.order || x.level != y.level) {
            return false;
        }
    }
    return true;
}

// ------------------------------------------------------------------------------------------
// Growth toward markers, occupancy, competition.

TEST(SpaceColonizationGrowth, SingleBudGrowsTowardItsMarkers) {
    // Three markers to the upper right of the root, inside its perception cone (θ = 75°, r =
    // 4 internodes) and outside its occupancy zone (ρ = 2): the first internode points along
    // the normalised sum of the unit vectors to them (Palubicki 2009; Liu 2020 §3 v_opt).
    const std::vector<Vec3> markers = {{0.25, 0.22, 0.0}, {0.2, 0.3, 0.05}, {0.28, 0.25, -0.04}};
    Vec3 sum;
    for (const Vec3& m : markers) sum += normalize(m);
    const Vec3 expected = normalize(sum) * 0.1;
    for (auto variant : {ColonizationVariant::kBaseline, ColonizationVariant::kImproved}) {
        SCOPED_TRACE(variant == ColonizationVariant::kBaseline ? "baseline" : "improved");
        SpaceColonizationOptions o = baseOptions(variant);
        o.crown = farCrown();  // no crown markers near the tree; improved: own markers dropped
        o.markers = 0;
        for (const Vec3& m : markers) o.guides.push_back({m, {0, 0, 0}, 0.0});
        o.maxIterations = 1;
        const Tree t = grow(o, 3);
        ASSERT_EQ(t.nodes.size(), 2u);
        EXPECT_NEAR(t.nodes[1].position.x, expected.x, 1e-12);
        EXPECT_NEAR(t.nodes[1].position.y, expected.y, 1e-12);
        EXPECT_NEAR(t.nodes[1].position.z, expected.z, 1e-12);
        EXPECT_GT(t.nodes[1].position.x, 0.05);  // bent well away from the bud's +y

        // ξ adds the bud's direction (+y) to v_opt; tropism is added to the normalised result.
        o.budDirectionWeight = 0.7;
        o.tropism = {0, 0, -0.3};
        const Vec3 bent = normalize(normalize(sum) + Vec3{0, 0.7, 0});
        const Vec3 turned = normalize(bent + o.tropism) * 0.1;
        const Tree u = grow(o, 3);
        ASSERT_EQ(u.nodes.size(), 2u);
        EXPECT_NEAR(distance(u.nodes[1].position, turned), 0.0, 1e-12);
    }
}

TEST(SpaceColonizationGrowth, MarkersInAnOccupancyZoneAreRemoved) {
    // ρ = 0.2 m. Marker A (0.15 m above the root) is in the root's zone: removed at the start,
    // never perceived. Marker B (0.35 m up) is perceived, drawing two internodes straight up;
    // the second ends 0.15 m from B, which removes it; then nothing is left to grow toward.
    SpaceColonizationOptions o = baseOptions(ColonizationVariant::kBaseline);
    o.crown = farCrown();
    o.markers = 0;
    o.guides = {{{0, 0.15, 0}, {0, 0, 0}, 0.0}, {{0, 0.35, 0}, {0, 0, 0}, 0.0}};
    std::map<std::string, double> stats;
    const Tree t = grow(o, 1, &stats);
    ASSERT_EQ(t.nodes.size(), 3u);
    EXPECT_NEAR(t.nodes[1].position.y, 0.1, 1e-12);
    EXPECT_NEAR(t.nodes[2].position.y, 0.2, 1e-12);
    EXPECT_EQ(t.nodes[1].position.x, 0.0);
    EXPECT_EQ(t.nodes[2].position.x, 0.0);
    EXPECT_EQ(stats["markers_generated"], 2.0);
    EXPECT_EQ(stats["markers_removed"], 2.0);
    EXPECT_EQ(stats["internodes"], 2.0);
    EXPECT_EQ(stats["iterations"], 3.0);  // the third grows nothing and ends the run
    EXPECT_EQ(stats["buds_live_final"], 0.0);

    // Without marker B nothing grows at all: A was removed before the first iteration.
    o.guides.pop_back();
    stats.clear();
    EXPECT_EQ(grow(o, 1, &stats).nodes.size(), 1u);
    EXPECT_EQ(stats["markers_removed"], 1.0);
}

TEST(SpaceColonizationGrowth, BaselineMarkersNeverSurviveNearANode) {
    // After a full baseline run every crown marker within ρ of a node has been removed, so the
    // count of removed markers is at least the count of markers within ρ of the final skeleton
    // — checked by regenerating the same markers from the same stream key.
    SpaceColonizationOptions o = baseOptions(ColonizationVariant::kBaseline);
    std::map<std::string, double> stats;
    const Tree t = grow(o, 7, &stats);
    Rng markerRng = Rng(7).derive("crown-markers");
    int near = 0;
    for (int i = 0; i < o.markers; ++i) {
        const Vec3 m = *o.crown->sample(markerRng);
        for (const SkeletonNode& n : t.nodes) {
            if (distance(n.position, m) <= o.occupancy * o.internode) {
                ++near;
                break;
            }
        }
    }
    EXPECT_GT(near, o.markers / 2);
    EXPECT_EQ(stats["markers_removed"], static_cast<double>(near));
}

// Brute force: the closest bud that perceives each marker, ties to the lower index.
std::vector<int32_t> bruteOwners(const std::vector<detail::PerceivingBud>& buds,
                                 const std::vector<Vec3>& markers, double radius, double angle) {
    std::vector<int32_t> owner(markers.size(), -1);
    for (size_t m = 0; m < markers.size(); ++m) {
        double best = std::numeric_limits<double>::infinity();
        for (size_t b = 0; b < buds.size(); ++b) {
            const Vec3 v = markers[m] - buds[b].position;
            const double d = length(v);
            if (d == 0 || d > radius || angleBetween(v, buds[b].direction) > angle + 1e-12) {
                continue;
            }
            if (d < best) {
                best = d;
                owner[m] = static_cast<int32_t>(b);
            }
        }
    }
    return owner;
}

// Growth packs the marker grid anew from the living markers once most have died; what a bud
// perceives, and in which order (sums over it depend on the order), must not change.
TEST(SpaceColonizationCompetition, PerceptionIsTheSameAfterTheDeadAreDropped) {
    Rng rng(5);
    std::vector<detail::PerceivingBud> buds;
    for (int i = 0; i < 200; ++i)
        buds.push_back({rng.inBox({{0, 0, 0}, {3, 3, 3}}), rng.unitVector()});
    std::vector<Vec3> markers;
    std::vector<char> dead;
    for (int i = 0; i < 20000; ++i) {
        markers.push_back(rng.inBox({{0, 0, 0}, {3, 3, 3}}));
        dead.push_back(rng.uniform() < 0.7);
    }
    const double radius = 0.35, angle = 70 * kDeg;
    size_t full = 0, packed = 0;
    const auto before = detail::perceivedMarkers(buds, markers, dead, radius, angle, false, &full);
    const auto after = detail::perceivedMarkers(buds, markers, dead, radius, angle, true, &packed);
    EXPECT_EQ(after, before);
    EXPECT_EQ(full, markers.size());
    EXPECT_EQ(packed, static_cast<size_t>(std::count(dead.begin(), dead.end(), 0)));
    size_t seen = 0;
    for (size_t b = 0; b < buds.size(); ++b) {
        for (const auto& [m, d2] : after[b]) {
            ASSERT_FALSE(dead[m]);
            EXPECT_EQ(d2, length2(markers[m] - buds[b].position));
            ++seen;
        }
        // Every living marker in the bud's perception volume is listed.
        size_t expected = 0;
        const Vec3 dir = normalize(buds[b].direction);
        for (size_t m = 0; m < markers.size(); ++m) {
            const Vec3 v = markers[m] - buds[b].position;
            const double d2 = length2(v);
            expected += !dead[m] && d2 > 0 && d2 <= radius * radius &&
                        dot(v, dir) >= std::cos(angle) * std::sqrt(d2);
        }
        EXPECT_EQ(after[b].size(), expected) << b;
    }
    EXPECT_GT(seen, 1000u);
}

TEST(SpaceColonizationCompetition, SharedMarkerGoesToTheCloserBud) {
    using detail::PerceivingBud;
    // Two buds facing each other along x, 0.5 m apart; r = 0.4 m, θ = 75°.
    const std::vector<PerceivingBud> buds = {{{0, 0, 0}, {1, 0, 0}}, {{0.5, 0, 0}, {-1, 0, 0}}};
    const std::vector<Vec3> markers = {
        {0.3, 0, 0},    // both perceive it; bud 1 is closer (0.2 vs 0.3)
        {0.15, 0, 0},   // both perceive it; bud 0 is closer (0.15 vs 0.35)
        {0.25, 0, 0},   // equidistant: the lower index
        {-0.1, 0, 0},   // behind bud 0, beyond bud 1's radius: nobody
        {0.2, 0.3, 0},  // 56° off bud 0's axis (0.36 m) and 124° off bud 1's: bud 0
    };
    const std::vector<int32_t> owner = detail::closestPerceivingBud(buds, markers, 0.4, 75 * kDeg);
    EXPECT_EQ(owner, (std::vector<int32_t>{1, 0, 0, -1, 0}));
}

TEST(SpaceColonizationCompetition, MatchesBruteForceThreadedOrNot) {
    Rng rng(11);
    std::vector<detail::PerceivingBud> buds;
    for (int i = 0; i < 300; ++i)
        buds.push_back({rng.inBox({{0, 0, 0}, {2, 2, 2}}), rng.unitVector()});
    buds.push_back(buds[17]);  // an exact duplicate: every tie goes to bud 17
    std::vector<Vec3> markers;
    for (int i = 0; i < 5000; ++i) markers.push_back(rng.inBox({{0, 0, 0}, {2, 2, 2}}));
    const double radius = 0.3, angle = 60 * kDeg;
    const std::vector<int32_t> expected = bruteOwners(buds, markers, radius, angle);
    EXPECT_EQ(detail::closestPerceivingBud(buds, markers, radius, angle, false), expected);
    EXPECT_EQ(detail::closestPerceivingBud(buds, markers, radius, angle, true), expected);
    EXPECT_EQ(std::count(expected.begin(), expected.end(), 300), 0);
    EXPECT_GT(std::count(expected.begin(), expected.end(), -1), 100);  // some unclaimed
    EXPECT_GT(std::count(expected.begin(), expected.end(), 17), 0);
}

TEST(SpaceColonizationMarkers, BinomialCountsHaveTheExactDistribution) {
    // The improved variant draws how many of a bud's N markers land within the radius where
    // they can matter; these counts must be Binomial(N, p): exact pmf for a small case
    // (χ² over all outcomes), mean and variance across the symmetric and chunked paths.
    Rng rng(17);
    {
        const int n = 6, draws = 60000;
        const double p = 0.3;
        std::vector<int> hist(n + 1, 0);
        for (int i = 0; i < draws; ++i) ++hist[detail::binomial(rng, n, p)];
        double chi2 = 0, pmf = std::pow(1 - p, n);
        for (int k = 0; k <= n; ++k) {
            const double expected = draws * pmf;
            chi2 += (hist[k] - expected) * (hist[k] - expected) / expected;
            pmf *= (p / (1 - p)) * (n - k) / (k + 1.0);
        }
        EXPECT_LT(chi2, 22.5);  // 6 degrees of freedom: p ≈ 0.001
    }
    struct Case {
        int64_t n;
        double p;
    };
    for (const Case& c : {Case{64, 0.0588}, Case{1300, 0.7}, Case{2000, 0.3}, Case{50, 1.0}}) {
        SCOPED_TRACE(std::to_string(c.n) + ", " + std::to_string(c.p));
        const int draws = 20000;
        double sum = 0, sum2 = 0;
        for (int i = 0; i < draws; ++i) {
            const double k = static_cast<double>(detail::binomial(rng, c.n, c.p));
            ASSERT_GE(k, 0);
            ASSERT_LE(k, c.n);
            sum += k;
            sum2 += k * k;
        }
        const double mean = sum / draws, var = sum2 / draws - mean * mean;
        const double mu = c.n * c.p, sigma2 = c.n * c.p * (1 - c.p);
        EXPECT_NEAR(mean, mu, 5 * std::sqrt(sigma2 / draws) + 1e-12);
        EXPECT_NEAR(var, sigma2, 0.05 * sigma2 + 1e-12);
    }
    EXPECT_EQ(detail::binomial(rng, 100, 0.0), 0);
}

// ------------------------------------------------------------------------------------------
// Directions: gravity, guide strokes.

TEST(SpaceColonizationDirection, GravityBendsImprovedGrowthDown) {
    // Liu 2020 §3: v = norm(v_opt + Σ ω v_m + λ (0, −1, 0)); only λ differs.
    SpaceColonizationOptions o = baseOptions(ColonizationVariant::kImproved);
    o.maxInternodes = 1500;
    double upFree = 0, upGravity = 0, tipFree = 0, tipGravity = 0;
    for (uint64_t seed = 1; seed <= 3; ++seed) {
        for (double lambda : {0.0, 0.6}) {
            o.gravityWeight = lambda;
            const Tree t = grow(o, seed);
            const Vec3 d = normalize(meanInternodeDirection(t));
            double tipY = 0;
            for (int32_t e : t.endpoints) tipY += t.nodes[e].position.y;
            tipY /= static_cast<double>(t.endpoints.size());
            (lambda == 0 ? upFree : upGravity) += d.y;
            (lambda == 0 ? tipFree : tipGravity) += tipY;
        }
    }
    EXPECT_GT(upFree / 3, 0.3);  // without gravity the tree grows up
    EXPECT_LT(upGravity, upFree - 0.3 * 3) << upGravity / 3 << " vs " << upFree / 3;
    EXPECT_LT(tipGravity, tipFree - 0.1 * 3) << tipGravity / 3 << " m vs " << tipFree / 3;
}

TEST(SpaceColonizationDirection, GuideStrokesPullGrowthAlongTheirDirection) {
    // Directional guide markers through the crown, all drawn along +x (Liu 2020 §4.3:
    // v_final = norm(v_opt + Σ ω v_stroke)): the same markers without a direction give
    // space only, so the difference in the mean internode angle to +x is the pull alone.
    const Vec3 stroke = {1, 0, 0};
    for (auto variant : {ColonizationVariant::kBaseline, ColonizationVariant::kImproved}) {
        SCOPED_TRACE(variant == ColonizationVariant::kBaseline ? "baseline" : "improved");
        SpaceColonizationOptions o = baseOptions(variant);
        o.maxInternodes = 1500;
        Rng g(5);
        std::vector<GuideMarker> guides;
        for (int i = 0; i < 600; ++i) guides.push_back({*o.crown->sample(g), stroke, 0.4});
        double with = 0, without = 0;
        for (uint64_t seed = 1; seed <= 2; ++seed) {
            o.guides = guides;
            with += meanAngleTo(grow(o, seed), stroke);
            for (GuideMarker& m : o.guides) m = {m.position, {0, 0, 0}, 0.0};
            without += meanAngleTo(grow(o, seed), stroke);
        }
        EXPECT_LT(with, without - 2 * 10 * kDeg)
            << with / 2 / kDeg << "° vs " << without / 2 / kDeg << "°";
    }
}

// ------------------------------------------------------------------------------------------
// Tree form.

TEST(SpaceColonizationTree, RootedTreeOfInternodesWithinTheCrown) {
    for (auto variant : {ColonizationVariant::kBaseline, ColonizationVariant::kImproved}) {
        SCOPED_TRACE(variant == ColonizationVariant::kBaseline ? "baseline" : "improved");
        SpaceColonizationOptions o = baseOptions(variant);
        o.trunkLength = 0.35;  // three straight internodes, then colonization
        for (uint64_t seed = 1; seed <= 3; ++seed) {
            SCOPED_TRACE("seed " + std::to_string(seed));
            std::map<std::string, double> stats;
            const Tree t = grow(o, seed, &stats);
            ASSERT_GT(t.nodes.size(), 200u);
            EXPECT_EQ(t.nodes[0].parent, -1);
            EXPECT_TRUE(t.nodes[0].position == Vec3(0, 0, 0));
            const std::vector<int> children = childCounts(t);
            std::vector<int32_t> tips;
            for (size_t i = 1; i < t.nodes.size(); ++i) {
                const SkeletonNode& n = t.nodes[i];
                const SkeletonNode& p = t.nodes[n.parent];
                ASSERT_GE(n.parent, 0);
                ASSERT_LT(n.parent, static_cast<int32_t>(i));
                EXPECT_NEAR(distance(n.position, p.position), o.internode, 1e-12);
                EXPECT_TRUE(n.order == p.order || n.order == p.order + 1);
                EXPECT_GE(n.level, p.level);
                EXPECT_LE(o.crown->signedDistance(n.position), o.internode + 1e-9);
                if (i <= 3) {
                    EXPECT_EQ(n.level, 0);  // the bole
                    EXPECT_NEAR(n.position.y, 0.1 * static_cast<double>(i), 1e-12);
                    EXPECT_EQ(children[i - 1], 1);
                }
            }
            for (size_t i = 0; i < t.nodes.size(); ++i) {
                if (children[i] == 0) tips.push_back(static_cast<int32_t>(i));
                EXPECT_LE(children[i], 2);  // its terminal and its lateral bud
            }
            EXPECT_EQ(t.endpoints, tips);
            EXPECT_EQ(stats["internodes"], static_cast<double>(t.nodes.size() - 1));
            EXPECT_EQ(stats["variant"], variant == ColonizationVariant::kImproved ? 1.0 : 0.0);
            int maxOrder = 0;
            for (const SkeletonNode& n : t.nodes) maxOrder = std::max(maxOrder, n.order);
            EXPECT_GE(maxOrder, 2);
        }
    }
}

TEST(SpaceColonizationTree, PipeModelHoldsAtEveryFork) {
    for (double n : {2.0, 2.5, 3.0}) {
        SpaceColonizationOptions o = baseOptions(ColonizationVariant::kBaseline);
        o.pipeExponent = n;
        o.tipRadius = 0.003;
        const Tree t = grow(o, 2);
        std::vector<double> sum(t.nodes.size(), 0.0);
        const std::vector<int> children = childCounts(t);
        for (const SkeletonNode& c : t.nodes) {
            if (c.parent >= 0) sum[c.parent] += std::pow(c.radius, n);
        }
        int forks = 0;
        for (size_t i = 0; i < t.nodes.size(); ++i) {
            if (children[i] == 0) {
                EXPECT_EQ(t.nodes[i].radius, 0.003);
                continue;
            }
            forks += children[i] > 1;
            const double lhs = std::pow(t.nodes[i].radius, n);
            EXPECT_NEAR(lhs, sum[i], 1e-9 * sum[i]) << "node " << i << ", n = " << n;
        }
        EXPECT_GT(forks, 50);
        // The root carries every tip: r₀ⁿ = (tips)·r_tipⁿ.
        EXPECT_NEAR(std::pow(t.nodes[0].radius, n),
                    static_cast<double>(t.endpoints.size()) * std::pow(0.003, n),
                    1e-9 * std::pow(t.nodes[0].radius, n));
    }
}

TEST(SpaceColonizationTree, LimitsAreExact) {
    for (auto variant : {ColonizationVariant::kBaseline, ColonizationVariant::kImproved}) {
        SpaceColonizationOptions o = baseOptions(variant);
        o.maxInternodes = 777;
        std::map<std::string, double> stats;
        EXPECT_EQ(grow(o, 4, &stats).nodes.size(), 778u);
        o.maxInternodes = 100000;
        o.maxIterations = 9;
        const Tree t = grow(o, 4, &stats);
        EXPECT_EQ(stats["iterations"], 9.0);
        int maxLevel = 0;
        for (const SkeletonNode& n : t.nodes) maxLevel = std::max(maxLevel, n.level);
        EXPECT_EQ(maxLevel, 9);
        EXPECT_LE(t.nodes.size(), 1u + (1u << 9));  // each bud one metamer per iteration
    }
}

// ------------------------------------------------------------------------------------------
// Determinism.

TEST(SpaceColonizationDeterminism, SameSeedSameTreeForAnyThreadCount) {
    for (auto variant : {ColonizationVariant::kBaseline, ColonizationVariant::kImproved}) {
        SCOPED_TRACE(variant == ColonizationVariant::kBaseline ? "baseline" : "improved");
        SpaceColonizationOptions o = baseOptions(variant);
        Rng g(9);
        for (int i = 0; i < 100; ++i) o.guides.push_back({*o.crown->sample(g), {1, 0, 0}, 0.2});
        const Tree serial = grow(o, 21);
        EXPECT_TRUE(sameTree(serial, grow(o, 21)));
        o.threaded = true;
        EXPECT_TRUE(sameTree(serial, grow(o, 21)));
        {
            tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
            EXPECT_TRUE(sameTree(serial, grow(o, 21)));
        }
        EXPECT_FALSE(sameTree(serial, grow(o, 22)));
    }
}

// ------------------------------------------------------------------------------------------
// Borchert–Honda allocation and shedding (Palubicki 2009 §4), on hand-built skeletons.

using detail::AllocationBud;
using detail::borchertHonda;

TEST(SpaceColonizationAllocation, TwoBudsSplitByTheClosedForm) {
    // Root 0 — node 1 (continuing the axis); on node 1 a terminal bud (Q_m) and a lateral bud
    // (Q_l). v_base = α(Q_m + Q_l) reaches node 1 whole (the root has only its main side), where
    // v_m = v·λQ_m / (λQ_m + (1−λ)Q_l) and v_l = v·(1−λ)Q_l / (λQ_m + (1−λ)Q_l).
    const std::vector<int32_t> parent = {-1, 0};
    const std::vector<uint8_t> lateral = {0, 0};
    std::vector<int32_t> starved(2, 0);
    for (double lambda : {0.3, 0.5, 0.62, 0.9}) {
        for (auto [qm, ql] : {std::pair{1.0, 1.0}, {1.0, 0.25}, {0.4, 2.0}}) {
            SCOPED_TRACE(lambda);
            const double alpha = 2.7;
            const auto r = borchertHonda(parent, lateral, {{1, false, qm}, {1, true, ql}}, {},
                                         lambda, alpha, 0.0, 3, starved);
            const double v = alpha * (qm + ql);
            const double d = lambda * qm + (1 - lambda) * ql;
            EXPECT_NEAR(r.nodeQ[0], qm + ql, 1e-15);
            EXPECT_NEAR(r.nodeResource[0], v, 1e-12);
            EXPECT_NEAR(r.nodeResource[1], v, 1e-12);
            EXPECT_NEAR(r.budResource[0], v * lambda * qm / d, 1e-12);
            EXPECT_NEAR(r.budResource[1], v * (1 - lambda) * ql / d, 1e-12);
        }
    }
    // λ = 0.5 and equal Q: an even split.
    const auto even = borchertHonda(parent, lateral, {{1, false, 1.0}, {1, true, 1.0}}, {}, 0.5,
                                    2.0, 0.0, 3, starved);
    EXPECT_DOUBLE_EQ(even.budResource[0], 2.0);
    EXPECT_DOUBLE_EQ(even.budResource[1], 2.0);
}

TEST(SpaceColonizationAllocation, ResourceIsConservedAndFollowsTheSkeleton) {
    // 0 → 1 → 2 (axis), 1 → 3 (lateral axis) → 4; 2 → 5 (lateral). Buds: terminal on 2, lateral
    // on 2, terminal and lateral on 4, lateral on 5, terminal on 5, a lateral on 1 with Q = 0.
    const std::vector<int32_t> parent = {-1, 0, 1, 1, 3, 2};
    const std::vector<uint8_t> lateral = {0, 0, 0, 1, 0, 1};
    const std::vector<AllocationBud> buds = {{2, false, 1.0}, {2, true, 0.5}, {4, false, 1.0},
                                             {4, true, 1.0},  {5, true, 0.3}, {5, false, 0.7},
                                             {1, true, 0.0}};
    std::vector<int32_t> starved(6, 0);
    const double lambda = 0.6, alpha = 1.5;
    const auto r = borchertHonda(parent, lateral, buds, {}, lambda, alpha, 0.0, 3, starved);
    // Basipetal Q.
    EXPECT_NEAR(r.nodeQ[5], 1.0, 1e-15);
    EXPECT_NEAR(r.nodeQ[4], 2.0, 1e-15);
    EXPECT_NEAR(r.nodeQ[2], 2.5, 1e-15);
    EXPECT_NEAR(r.nodeQ[1], 4.5, 1e-15);
    EXPECT_NEAR(r.nodeQ[0], 4.5, 1e-15);
    // Everything the base receives reaches the buds (no node has only Q = 0 sides here).
    double total = 0;
    for (double v : r.budResource) total += v;
    EXPECT_NEAR(total, alpha * 4.5, 1e-12);
    // By hand at node 1: Q_m = 2.5 (node 2), Q_l = 2 (node 3) + 0 (its own lateral bud).
    const double v1 = alpha * 4.5;
    const double d1 = lambda * 2.5 + (1 - lambda) * 2.0;
    EXPECT_NEAR(r.nodeResource[2], v1 * lambda * 2.5 / d1, 1e-12);
    EXPECT_NEAR(r.nodeResource[3], v1 * (1 - lambda) * 2.0 / d1, 1e-12);
    EXPECT_EQ(r.budResource[6], 0.0);
    // At node 2: main = its terminal bud (1), lateral side = its lateral bud (0.5) + node 5
    // (1.0), shared in proportion to Q.
    const double v2 = r.nodeResource[2];
    const double d2 = lambda * 1.0 + (1 - lambda) * 1.5;
    EXPECT_NEAR(r.budResource[0], v2 * lambda * 1.0 / d2, 1e-12);
    EXPECT_NEAR(r.budResource[1], v2 * (1 - lambda) * 0.5 / d2, 1e-12);
    EXPECT_NEAR(r.nodeResource[5], v2 * (1 - lambda) * 1.0 / d2, 1e-12);
    EXPECT_TRUE(std::all_of(r.shed.begin(), r.shed.end(), [](uint8_t x) { return x == 0; }));
}

TEST(SpaceColonizationAllocation, ShedsABranchThatStaysInTheShadeAfterItsDelay) {
    // 0 → 1 → 2 (axis); lateral branch A = 3 → 4 off node 1, lateral branch B = 5 off node 2.
    // Mean light: A (0.1 + 0.2) / 2 = 0.15, B 0.6. Threshold 0.3, delay 2: A goes at the
    // second call, with node 4; B stays. A's buds then get nothing and its Q leaves node 1.
    const std::vector<int32_t> parent = {-1, 0, 1, 1, 3, 2};
    const std::vector<uint8_t> lateral = {0, 0, 0, 1, 0, 1};
    const std::vector<double> light = {1, 1, 1, 0.1, 0.2, 0.6};
    const std::vector<AllocationBud> buds = {{2, false, 1.0}, {4, false, 1.0}, {5, false, 1.0}};
    std::vector<int32_t> starved(6, 0);
    auto r = borchertHonda(parent, lateral, buds, light, 0.5, 2.0, 0.3, 2, starved);
    EXPECT_TRUE(std::all_of(r.shed.begin(), r.shed.end(), [](uint8_t x) { return x == 0; }));
    EXPECT_EQ(starved[3], 1);
    EXPECT_EQ(starved[4], 0);  // not a lateral node: never a branch of its own
    EXPECT_EQ(starved[5], 0);
    EXPECT_NEAR(r.nodeQ[1], 3.0, 1e-15);
    r = borchertHonda(parent, lateral, buds, light, 0.5, 2.0, 0.3, 2, starved);
    EXPECT_EQ(r.shed, (std::vector<uint8_t>{0, 0, 0, 1, 1, 0}));
    EXPECT_EQ(r.budResource[1], 0.0);
    EXPECT_NEAR(r.nodeQ[1], 2.0, 1e-15);
    EXPECT_NEAR(r.budResource[0] + r.budResource[2], 2.0 * 2.0, 1e-12);
    // A branch lit again starts counting afresh.
    std::vector<int32_t> again(6, 0);
    std::vector<double> flicker = light;
    borchertHonda(parent, lateral, buds, flicker, 0.5, 2.0, 0.3, 2, again);
    flicker[3] = flicker[4] = 0.9;
    borchertHonda(parent, lateral, buds, flicker, 0.5, 2.0, 0.3, 2, again);
    EXPECT_EQ(again[3], 0);
    r = borchertHonda(parent, lateral, buds, light, 0.5, 2.0, 0.3, 2, again);
    EXPECT_EQ(r.shed[3], 0);
}

TEST(SpaceColonizationAllocation, ShadowPyramidHasTheClosedFormShade) {
    // A node at the centre of voxel (5, 5, 5) of a 0.1 m grid shades the voxels q layers below
    // it within q horizontally by a·b^(−q) (q ≤ depth). Exposure is 1 − s + a, capped at 1, for
    // a node that casts its own a into its voxel: so a node q layers below sees 1 − a·b^(−q).
    const double a = 0.3, b = 2.0;
    Aabb box;
    box.extend(Vec3{0, 0, 0});
    box.extend(Vec3{1, 1, 1});
    ShadowGrid grid(box, 0.1, a, b, 3);
    const Vec3 p{0.55, 0.55, 0.55};
    grid.cast(p, +1);
    EXPECT_DOUBLE_EQ(grid.exposure(p), 1.0);  // a lone node sees full light
    auto below = [&](const Vec3& offset) {    // the exposure of a node placed at p + offset
        grid.cast(p + offset, +1);
        const double e = grid.exposure(p + offset);
        grid.cast(p + offset, -1);
        return e;
    };
    EXPECT_NEAR(below({0, -0.1, 0}), 1 - a / b, 1e-12);
    EXPECT_NEAR(below({0.1, -0.1, -0.1}), 1 - a / b, 1e-12);
    EXPECT_NEAR(below({-0.2, -0.2, 0.2}), 1 - a / (b * b), 1e-12);
    EXPECT_NEAR(below({0, -0.3, 0.3}), 1 - a / (b * b * b), 1e-12);
    EXPECT_NEAR(below({0, 0.1, 0}), 1.0, 1e-12);     // above: no shade
    EXPECT_NEAR(below({0.1, 0, 0}), 1.0, 1e-12);     // beside, same layer
    EXPECT_NEAR(below({0.3, -0.2, 0}), 1.0, 1e-12);  // outside the pyramid
    EXPECT_NEAR(below({0, -0.4, 0}), 1.0, 1e-12);    // below its depth
    // Five nodes over one: their shade adds up, the exposure stops at 0.
    for (int i = 0; i < 4; ++i) grid.cast(p, +1);
    EXPECT_NEAR(below({0, -0.1, 0}), 1 - 5 * a / b, 1e-12);
    for (int i = 0; i < 5; ++i) grid.cast(p, +1);
    EXPECT_EQ(below({0, -0.1, 0}), 0.0);
    for (int i = 0; i < 10; ++i) grid.cast(p, -1);  // removing the nodes gives the light back
    EXPECT_NEAR(below({0, -0.1, 0}), 1.0, 1e-12);
    EXPECT_DOUBLE_EQ(grid.exposure({5, 5, 5}), 1.0);  // outside the grid
}

// A crown full of markers for the whole-tree tests below.
SpaceColonizationOptions treeOptions() {
    SpaceColonizationOptions o;
    o.internode = 0.1;
    o.crown = makePlaced(makeEllipsoid({1.2, 1.5, 1.2}), {{0, 1.8, 0}, {0, 1, 0}, {1, 1, 1}});
    o.markers = 6000;
    o.trunkLength = 0.4;
    o.maxInternodes = 4000;
    o.allocation = Allocation::kBorchertHonda;
    o.apicalControl = 0.55;
    o.resourceCoefficient = 2.0;
    return o;
}

TEST(SpaceColonizationAllocation, ShootsOfSeveralMetamersPerIteration) {
    // Alone at first, the bole's bud receives α·Q_base = α (Q = 1): with α = 3.5 its first
    // shoot has ⌊3.5⌋ = 3 metamers, all of level 1, then the crown fills in fewer iterations
    // than one metamer per bud and iteration would take.
    SpaceColonizationOptions o = treeOptions();
    o.resourceCoefficient = 3.5;
    o.maxIterations = 1;
    std::map<std::string, double> stats;
    Tree t = grow(o, 2, &stats);
    int level1 = 0;
    for (const SkeletonNode& n : t.nodes) level1 += n.level == 1;
    EXPECT_EQ(level1, 3);
    EXPECT_EQ(t.nodes.size(), 5u + 3u);  // root, 4 bole nodes, the shoot
    for (int i = 6; i < 8; ++i) EXPECT_EQ(t.nodes[i].parent, i - 1);  // one axis
    // α < 1: no bud ever receives a whole metamer, so nothing grows.
    o.resourceCoefficient = 0.9;
    o.maxIterations = 50;
    EXPECT_EQ(grow(o, 2).nodes.size(), 5u);
    // Without allocation the same crown takes more iterations to fill than with it.
    std::map<std::string, double> plain, bh;
    o = treeOptions();
    o.resourceCoefficient = 3;
    grow(o, 2, &bh);
    o.allocation = Allocation::kNone;
    grow(o, 2, &plain);
    EXPECT_LT(bh["iterations"], plain["iterations"]);
}

TEST(SpaceColonizationAllocation, AShootFillsOnlyTheSpaceItsBudWon) {
    // One bud at the root (+y), ρ = 0.2 m, r = 0.7 m, α = 10 (ten metamers' worth), one
    // iteration. It wins the markers at y = 0.35 and 0.65 (within r); the one at 0.95 is beyond
    // r at the start. Metamers at 0.1 … 0.5: the node at 0.2 removes 0.35, the node at 0.5
    // removes 0.65, and the shoot ends there, five metamers long, although the tip at 0.3 and
    // later perceives the marker at 0.95: it was not its bud's.
    SpaceColonizationOptions o = baseOptions(ColonizationVariant::kBaseline);
    o.crown = farCrown();
    o.markers = 0;
    o.perception = 7;
    o.allocation = Allocation::kBorchertHonda;
    o.resourceCoefficient = 10;
    o.maxIterations = 1;
    for (double y : {0.35, 0.65, 0.95}) o.guides.push_back({{0, y, 0}, {0, 0, 0}, 0.0});
    const Tree t = grow(o, 1);
    ASSERT_EQ(t.nodes.size(), 6u);
    for (int i = 1; i < 6; ++i) {
        EXPECT_NEAR(t.nodes[i].position.y, 0.1 * i, 1e-12);
        EXPECT_EQ(t.nodes[i].parent, i - 1);
        EXPECT_EQ(t.nodes[i].level, 1);
    }
    // The next iteration's bud at the shoot's top perceives the last marker and goes on.
    o.maxIterations = 2;
    EXPECT_GT(grow(o, 1).nodes.size(), 6u);
}

TEST(SpaceColonizationForm, ABoleOutOfItsOwnCrownsReachGrowsOnToIt) {
    // The crown (a sphere of 0.3 m at y = 2) lies far beyond r = 0.4 m of the 0.2 m bole. As
    // given, the spec reader rejects it; a per-tree crown that drifted out of reach instead
    // lengthens the bole, straight up, until its top perceives the crown's markers.
    SpaceColonizationOptions o = baseOptions(ColonizationVariant::kBaseline);
    o.crown = makePlaced(makeSphere(0.3), {{0, 2, 0}, {0, 1, 0}, {1, 1, 1}});
    o.markers = 400;
    o.trunkLength = 0.2;
    o.allocation = Allocation::kBorchertHonda;
    EXPECT_EQ(grow(o, 3).nodes.size(), 3u);  // the crown as given: a bare bole
    o.envelopeScaleSd = 1e-12;               // a per-tree crown, the same shape
    const Tree t = grow(o, 3);
    int bole = 0;
    while (t.nodes[bole + 1].level == 0) ++bole;
    const double top = t.nodes[bole].position.y;
    for (int i = 1; i <= bole; ++i) {
        EXPECT_EQ(t.nodes[i].position.x, 0.0);
        EXPECT_NEAR(t.nodes[i].position.y, 0.1 * i, 1e-12);
    }
    EXPECT_GT(top, 2 - 0.3 - 0.4 - 1e-9);        // no earlier than the crown came in reach
    EXPECT_LT(top, 2 - 0.3 - 0.4 + 0.1 + 0.05);  // one internode past at most (sampling slack)
    EXPECT_GT(t.nodes.size(), static_cast<size_t>(bole + 20));
}

TEST(SpaceColonizationAllocation, ApicalControlFavoursTheMainAxes) {
    // λ > 0.5 gives the continuing axes more of the resource at every fork, so the order-0
    // axis (summed over three seeds) grows longer than with λ < 0.5.
    auto axis0 = [](double lambda) {
        SpaceColonizationOptions o = treeOptions();
        o.apicalControl = lambda;
        double length = 0;
        for (uint64_t seed = 1; seed <= 3; ++seed) {
            for (const SkeletonNode& n : grow(o, seed).nodes) {
                if (n.parent >= 0 && n.order == 0) length += o.internode;
            }
        }
        return length;
    };
    EXPECT_GT(axis0(0.7), axis0(0.35) * 1.2);
}

// treeOptions() under shadow-propagation light.
SpaceColonizationOptions shadedTreeOptions() {
    SpaceColonizationOptions o = treeOptions();
    o.light = Light::kShadow;
    o.shadowStrength = 0.15;
    return o;
}

TEST(SpaceColonizationAllocation, SheddingClearsTheShadedInterior) {
    SpaceColonizationOptions o = shadedTreeOptions();
    std::map<std::string, double> kept, shed;
    const Tree full = grow(o, 5, &kept);
    o.shedThreshold = 0.5;
    const Tree thinned = grow(o, 5, &shed);
    EXPECT_EQ(kept.count("shed_branches"), 0u);
    EXPECT_GT(shed["shed_branches"], 10.0);
    EXPECT_LT(thinned.nodes.size(), full.nodes.size());
    // The compacted node list is still a rooted tree whose branch orders follow its axes.
    for (size_t i = 1; i < thinned.nodes.size(); ++i) {
        const int32_t p = thinned.nodes[i].parent;
        ASSERT_GE(p, 0);
        ASSERT_LT(p, static_cast<int32_t>(i));
        const int32_t step = thinned.nodes[i].order - thinned.nodes[p].order;
        EXPECT_TRUE(step == 0 || step == 1);
        EXPECT_NEAR(distance(thinned.nodes[i].position, thinned.nodes[p].position), o.internode,
                    1e-9);
    }
}

TEST(SpaceColonizationAllocation, SpaceLimitedQScalesWithTheMarkersWon) {
    EXPECT_DOUBLE_EQ(detail::spaceLimitedQ(0.8, 2, 8), 0.2);   // a quarter of the space
    EXPECT_DOUBLE_EQ(detail::spaceLimitedQ(0.8, 8, 8), 0.8);   // enough: the light itself
    EXPECT_DOUBLE_EQ(detail::spaceLimitedQ(0.8, 30, 8), 0.8);  // never above it
    EXPECT_DOUBLE_EQ(detail::spaceLimitedQ(0.8, 0, 8), 0.0);
    EXPECT_DOUBLE_EQ(detail::spaceLimitedQ(0.8, 3, 0), 0.8);  // off: the paper's Q
}

TEST(SpaceColonizationAllocation, SpaceSteersTheResourceAndLightSetsIt) {
    // Q (the shares) apart from the vigour (the light): the base receives α·Σvigour, split by
    // the shares' closed form. Root 0 — node 1; on node 1 a terminal bud and a lateral bud.
    const std::vector<int32_t> parent = {-1, 0};
    const std::vector<uint8_t> lateral = {0, 0};
    std::vector<int32_t> starved(2, 0);
    const double lambda = 0.6, alpha = 2.0;
    const double qm = 0.9, ql = 0.9 * 2 / 8.0;  // light 0.9 each; the lateral won 2 of 8
    const auto r = borchertHonda(parent, lateral, {{1, false, qm, 0.9}, {1, true, ql, 0.9}}, {},
                                 lambda, alpha, 0.0, 3, starved);
    const double v = alpha * 1.8;
    const double d = lambda * qm + (1 - lambda) * ql;
    EXPECT_NEAR(r.nodeResource[0], v, 1e-12);
    EXPECT_NEAR(r.budResource[0], v * lambda * qm / d, 1e-12);
    EXPECT_NEAR(r.budResource[1], v * (1 - lambda) * ql / d, 1e-12);
    EXPECT_NEAR(r.budResource[0] + r.budResource[1], v, 1e-12);
}

TEST(SpaceColonizationAllocation, SpaceMarkersChangeOnlyWhatTheyShould) {
    SpaceColonizationOptions o = shadedTreeOptions();
    std::map<std::string, double> paperStats, limitedStats;
    const Tree paper = grow(o, 4, &paperStats);
    // One marker is all a growing bud ever needs for min(1, m / 1) = 1: the paper's tree, bit
    // for bit.
    o.spaceMarkers = 1;
    const Tree one = grow(o, 4);
    ASSERT_EQ(one.nodes.size(), paper.nodes.size());
    for (size_t i = 0; i < one.nodes.size(); ++i) {
        EXPECT_EQ(one.nodes[i].position, paper.nodes[i].position);
    }
    // Eight: another tree, which still uses up its crown (the resource is the light's, so
    // buds short of space do not stall growth).
    o.spaceMarkers = 8;
    const Tree limited = grow(o, 4, &limitedStats);
    bool differs = limited.nodes.size() != paper.nodes.size();
    for (size_t i = 0; !differs && i < limited.nodes.size(); ++i) {
        differs = !(limited.nodes[i].position == paper.nodes[i].position);
    }
    EXPECT_TRUE(differs);
    EXPECT_GT(limitedStats["markers_removed"], 0.9 * paperStats["markers_removed"]);
}

TEST(SpaceColonizationForm, LateralShootsTurnByTheirDrawnAngles) {
    // ξ huge: without turns every metamer continues its bud's direction exactly, so an axis is
    // straight. With σ = 10°, each lateral-axis metamer is turned by |θ|, θ ~ N(0, σ), from the
    // one before: the mean angle between consecutive internodes is σ·√(2/π) = 7.98°; the
    // order-0 axis stays straight.
    SpaceColonizationOptions o = treeOptions();
    o.budDirectionWeight = 1e9;
    auto angles = [](const Tree& t, bool lateral) {
        std::vector<double> a;
        for (size_t i = 1; i < t.nodes.size(); ++i) {
            const SkeletonNode& n = t.nodes[i];
            const SkeletonNode& p = t.nodes[n.parent];
            if (p.parent < 0 || p.order != n.order || t.nodes[p.parent].order != n.order) continue;
            if ((n.order > 0) != lateral) continue;
            a.push_back(
                angleBetween(n.position - p.position, p.position - t.nodes[p.parent].position));
        }
        return a;
    };
    const Tree straight = grow(o, 6);
    for (double a : angles(straight, true)) EXPECT_LT(a, 1e-6);
    o.turnSd = 10 * kDeg;
    const Tree zigzag = grow(o, 6);
    const std::vector<double> lateral = angles(zigzag, true);
    ASSERT_GT(lateral.size(), 200u);
    double mean = 0;
    for (double a : lateral) mean += a / static_cast<double>(lateral.size());
    // The standard error of the mean is σ·0.60/√n < 0.5° here.
    EXPECT_NEAR(mean / kDeg, 10 * std::sqrt(2 / kPi), 1.2);
    for (double a : angles(zigzag, false)) EXPECT_LT(a, 1e-6);
}

// A whorled conifer on a vertical leader (w = 30): its order-1 laterals set out at exactly
// 70° from +y (the stem), the frame of the whorl, held-heading and flat-spray tests.
SpaceColonizationOptions whorledOptions() {
    SpaceColonizationOptions o = treeOptions();
    o.crown = makePlaced(makeCone(1.0, 3.0), {{0, 0.2, 0}, {0, 1, 0}, {1, 1, 1}});
    o.trunkLength = 0.3;
    o.markers = 8000;
    o.leaderWeight = 30;
    o.whorlLaterals = 5;
    o.branchAngle = 70 * kDeg;
    return o;
}

// The largest angle to +y of any internode of order `order` grown in an iteration.
double steepestFromUp(const Tree& t, int order) {
    double worst = 0;
    for (const SkeletonNode& n : t.nodes) {
        if (n.parent < 0 || n.order != order || t.nodes[n.parent].order != order) continue;
        worst = std::max(worst, angleBetween(n.position - t.nodes[n.parent].position, {0, 1, 0}));
    }
    return worst;
}

TEST(SpaceColonizationForm, AHeldAxisStaysWithinItsHeading) {
    // Only order-1 axes, pulled down hard (tropism −0.8 ŷ on every step; the held leader
    // leans at most a degree or two). Free, the laterals droop far below the level; held
    // within 30° of the direction they set out in, 70° from the stem internode below them, no
    // internode of theirs is more than 100° from +y, plus the stem's lean there.
    SpaceColonizationOptions o = whorledOptions();
    o.maxOrder = 1;
    o.tropism = {0, -0.8, 0};
    const Tree free = grow(o, 7);
    EXPECT_GT(steepestFromUp(free, 1) / kDeg, 120);
    o.axisTurnMax = 30 * kDeg;
    const Tree held = grow(o, 7);
    ASSERT_GT(held.nodes.size(), 300u);
    const double lean = steepestFromUp(held, 0) / kDeg;
    EXPECT_LT(lean, 3);
    EXPECT_LE(steepestFromUp(held, 1) / kDeg, 100 + lean + 1e-6);
    EXPECT_GT(steepestFromUp(held, 1) / kDeg, 99);  // the cone's edge is reached
    // A cone of 180° holds nothing: the tree is the free one.
    o.axisTurnMax = kPi;
    EXPECT_TRUE(sameTree(free, grow(o, 7)));
}

TEST(SpaceColonizationForm, AHeldLimbKeepsItsSpraysOnItsSide) {
    // ξ huge: every axis grows straight along its bud's direction (to ~1/ξ), so a limb's
    // first internode is its heading. Laterals leave their axis at 70° all round it: order-3
    // axes may point up to 140° from their limb. Held limbs (90°) turn every internode of order
    // ≥ 2 back within 90° of its limb's heading.
    SpaceColonizationOptions o = whorledOptions();
    o.maxOrder = 4;
    o.budDirectionWeight = 1e9;
    auto widest = [](const Tree& t) {
        double worst = 0;
        for (size_t i = 1; i < t.nodes.size(); ++i) {
            const SkeletonNode& n = t.nodes[i];
            if (n.order < 2) continue;
            size_t limb = i;  // the order-1 ancestor's first node
            while (!(t.nodes[limb].order == 1 && t.nodes[t.nodes[limb].parent].order == 0)) {
                limb = t.nodes[limb].parent;
            }
            const Vec3 heading = t.nodes[limb].position - t.nodes[t.nodes[limb].parent].position;
            worst = std::max(worst, angleBetween(n.position - t.nodes[n.parent].position, heading));
        }
        return worst / kDeg;
    };
    EXPECT_GT(widest(grow(o, 3)), 110);
    o.limbTurnMax = 90 * kDeg;
    const Tree held = grow(o, 3);
    ASSERT_GT(held.nodes.size(), 300u);
    EXPECT_LE(widest(held), 90 + 1e-4);
    EXPECT_GT(widest(held), 89);
}

TEST(SpaceColonizationForm, FlatSpraysSetShootsLeftOrRightAtTheBranchletAngle) {
    // ξ huge: an axis' first internode is its bud's direction (to ~1/ξ). Order-1 laterals leave the
    // stem at branch_angle (70°); their own laterals at branchlet_angle (40°) from the internode g
    // they grow from, and with flat sprays across g horizontally: the part of the direction ⊥ g
    // has no vertical component. Without flat sprays the laterals go all round their axis.
    SpaceColonizationOptions o = whorledOptions();
    o.maxOrder = 2;
    o.budDirectionWeight = 1e9;
    const Tree plain = grow(o, 5);
    o.branchletAngle = o.branchAngle;  // the same angle set explicitly: the same tree
    EXPECT_TRUE(sameTree(plain, grow(o, 5)));
    o.branchletAngle = 40 * kDeg;
    auto firstInternodes = [](const Tree& t, int order, auto&& check) {
        int n = 0;
        for (const SkeletonNode& c : t.nodes) {
            if (c.parent < 0 || c.order != order || t.nodes[c.parent].order != order - 1) continue;
            const SkeletonNode& p = t.nodes[c.parent];
            if (p.parent < 0) continue;
            check(normalize(c.position - p.position),
                  normalize(p.position - t.nodes[p.parent].position));
            ++n;
        }
        return n;
    };
    double steepestAcross = 0;
    const Tree round = grow(o, 5);
    EXPECT_GT(firstInternodes(round, 2,
                              [&](const Vec3& d, const Vec3& g) {
                                  EXPECT_NEAR(angleBetween(d, g), 40 * kDeg, 1e-6);
                                  const Vec3 across = normalize(d - g * dot(d, g));
                                  steepestAcross = std::max(steepestAcross, std::abs(across.y));
                              }),
              50);
    EXPECT_GT(steepestAcross, 0.5);
    o.flatSprays = true;
    const Tree flat = grow(o, 5);
    EXPECT_GT(firstInternodes(flat, 1,
                              [](const Vec3& d, const Vec3& g) {
                                  EXPECT_NEAR(angleBetween(d, g), 70 * kDeg, 1e-6);
                              }),
              10);
    EXPECT_GT(firstInternodes(flat, 2,
                              [](const Vec3& d, const Vec3& g) {
                                  EXPECT_NEAR(angleBetween(d, g), 40 * kDeg, 1e-6);
                                  EXPECT_NEAR(normalize(d - g * dot(d, g)).y, 0, 1e-6);
                              }),
              50);
}

TEST(SpaceColonizationForm, LeaderStaysVerticalAndWhorlsHoldKLaterals) {
    // A conifer: the leader pulled to +y (w = 30), whorls of k = 5 at the top of each shoot.
    // With ξ huge every bud's first internode follows the bud's own direction, so the whorl's
    // laterals leave the stem at exactly branch_angle and 72° apart about it.
    SpaceColonizationOptions o = whorledOptions();
    o.maxOrder = 2;
    o.budDirectionWeight = 1e9;
    const Tree t = grow(o, 7);
    const ChildIndex kids(t);
    int whorls = 0, maxOrder = 0;
    for (size_t i = 0; i < t.nodes.size(); ++i) {
        maxOrder = std::max(maxOrder, t.nodes[i].order);
        if (t.nodes[i].order != 0) continue;
        std::vector<Vec3> laterals;
        Vec3 stem{0, 1, 0};
        for (int c = kids.offset[i]; c < kids.offset[i + 1]; ++c) {
            const SkeletonNode& child = t.nodes[kids.child[c]];
            const Vec3 d = normalize(child.position - t.nodes[i].position);
            if (child.order == 1) laterals.push_back(d);
        }
        if (t.nodes[i].parent >= 0) {
            stem = normalize(t.nodes[i].position - t.nodes[t.nodes[i].parent].position);
        }
        ASSERT_LE(laterals.size(), 5u);
        for (const Vec3& d : laterals) EXPECT_NEAR(angleBetween(d, stem), 70 * kDeg, 1e-6);
        if (laterals.size() != 5) continue;
        ++whorls;
        // Azimuths about the stem: every pair differs by a multiple of 72°.
        for (size_t a = 1; a < laterals.size(); ++a) {
            const Vec3 u = normalize(laterals[0] - stem * dot(laterals[0], stem));
            const Vec3 v = normalize(laterals[a] - stem * dot(laterals[a], stem));
            const double turns = angleBetween(u, v) / (72 * kDeg);
            EXPECT_NEAR(turns, std::round(turns), 1e-6);
        }
    }
    EXPECT_GE(whorls, 3);
    EXPECT_EQ(maxOrder, 2);

    // A sideways tropism and free growth toward the markers (ξ = 0): the leader's pull keeps
    // the top within 1° of the vertical, where without it the top leans.
    o.budDirectionWeight = 0;
    o.tropism = {0.4, 0, 0};
    TreeStats s;
    addRealismMetrics(grow(o, 7), s);
    EXPECT_LT(s.leaderLeanDeg, 1.0);
    o.leaderWeight = 0;
    TreeStats bent;
    addRealismMetrics(grow(o, 7), bent);
    EXPECT_TRUE(std::isnan(bent.leaderLeanDeg) || bent.leaderLeanDeg > 3.0) << bent.leaderLeanDeg;
}

TEST(SpaceColonizationForm, AHeldLeaderGrowsToTheTopOfItsCrown) {
    // A 3 m cylinder crown with almost no markers (r = 0.4 m): an unheld leader stops where
    // its markers end; a held one (leader_weight > 0) grows straight on, one metamer per
    // iteration, until the crown no longer continues r above it: its top is at 2.6 m or above
    // (beyond only toward markers it won).
    SpaceColonizationOptions o = baseOptions(ColonizationVariant::kBaseline);
    o.crown = makeCylinder(0.5, 3.0);
    o.markers = 20;
    o.trunkLength = 0.2;
    o.allocation = Allocation::kBorchertHonda;
    auto top = [](const Tree& t) {
        double y = 0;
        for (const SkeletonNode& n : t.nodes) {
            if (n.order == 0) y = std::max(y, n.position.y);
        }
        return y;
    };
    EXPECT_LT(top(grow(o, 6)), 2.0);
    o.leaderWeight = 30;
    const Tree held = grow(o, 6);
    EXPECT_GE(top(held), 2.6 - 1e-9);
    EXPECT_LE(top(held), 3.0);
    for (const SkeletonNode& n : held.nodes) {
        if (n.order == 0) {
            EXPECT_LT(std::hypot(n.position.x, n.position.z), 0.02);
        }
    }
}

TEST(SpaceColonizationForm, BranchletTropismActsOnOrderTwoAndAbove) {
    // Unset, the branchlets follow `tropism`; set to the same vector, the tree is the same.
    SpaceColonizationOptions o = treeOptions();
    o.tropism = {0, 0.05, 0};
    const Tree plain = grow(o, 4);
    o.branchletTropism = o.tropism;
    EXPECT_TRUE(sameTree(plain, grow(o, 4)));
    // A hanging tropism on orders ≥ 2 turns their internodes down, not the trunk's: the first
    // internodes of order 0 and 1 (grown before any order-2 axis exists) are unchanged.
    o.branchletTropism = Vec3{0, -0.8, 0};
    const Tree hanging = grow(o, 4);
    auto meanY = [](const Tree& t, int minOrder) {
        double y = 0;
        int n = 0;
        for (const SkeletonNode& node : t.nodes) {
            if (node.parent < 0 || node.order < minOrder || node.level < 1) continue;
            y += normalize(node.position - t.nodes[node.parent].position).y;
            ++n;
        }
        return y / n;
    };
    EXPECT_LT(meanY(hanging, 2), meanY(plain, 2) - 0.2);
    for (size_t i = 0; i < 12; ++i) {
        EXPECT_TRUE(hanging.nodes[i].position == plain.nodes[i].position) << i;
    }
}

TEST(SpaceColonizationForm, PerturbedCrownInvertsExactlyAndVariesPerTree) {
    const VolumePtr base = makePlaced(makeEllipsoid({2, 3, 2}), {{0, 4, 0}, {0, 1, 0}, {1, 1, 1}});
    Rng rng(3);
    const detail::PerturbedCrown crown(base, 1.2, 0.3, Rng(11));
    for (int i = 0; i < 2000; ++i) {
        const Aabb b = base->bounds();
        const Vec3 size = b.size() * 1.2;
        const Vec3 p = b.lo - size * 0.05 +
                       Vec3{rng.uniform() * size.x, rng.uniform() * size.y, rng.uniform() * size.z};
        const Vec3 q = crown.image(p);
        EXPECT_NEAR(distance(crown.preimage(q), p), 0.0, 1e-9);
        EXPECT_EQ(crown.inside(q), base->inside(p));
        if (base->inside(p)) {
            EXPECT_GE(q.x, crown.bounds().lo.x);
            EXPECT_LE(q.y, crown.bounds().hi.y);
        }
    }
    // Scale only: exactly the crown scaled about the root.
    const detail::PerturbedCrown scaled(base, 0.8, 0.0, Rng(1));
    EXPECT_TRUE(scaled.inside({0, 0.8 * 6.9, 0}));
    EXPECT_FALSE(scaled.inside({0, 0.8 * 7.1, 0}));

    // Trees of one species differ: heights over 8 seeds vary by a few percent or more with a
    // perturbed crown, and the crown is the same for every seed without.
    auto heights = [](double sd, double noise) {
        SpaceColonizationOptions o = treeOptions();
        o.markers = 3000;
        o.envelopeScaleSd = sd;
        o.envelopeNoise = noise;
        std::vector<double> h;
        for (uint64_t seed = 1; seed <= 8; ++seed) {
            const Tree t = grow(o, seed);
            double top = 0;
            for (const SkeletonNode& n : t.nodes) top = std::max(top, n.position.y);
            h.push_back(top);
        }
        double mean = 0, var = 0;
        for (double x : h) mean += x / h.size();
        for (double x : h) var += (x - mean) * (x - mean) / h.size();
        return std::sqrt(var) / mean;
    };
    EXPECT_LT(heights(0, 0), 0.03);
    EXPECT_GT(heights(0.15, 0.2), 0.05);
}

TEST(SpaceColonizationDeterminism, AllocationSheddingAndCrownsAreThreadIndependent) {
    SpaceColonizationOptions o = treeOptions();
    o.light = Light::kShadow;
    o.shedThreshold = 0.4;
    o.envelopeScaleSd = 0.1;
    o.envelopeNoise = 0.2;
    o.whorlLaterals = 3;
    o.leaderWeight = 2;
    const Tree serial = grow(o, 31);
    o.threaded = true;
    EXPECT_TRUE(sameTree(serial, grow(o, 31)));
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        EXPECT_TRUE(sameTree(serial, grow(o, 31)));
    }
    EXPECT_FALSE(sameTree(serial, grow(o, 32)));
}

// ------------------------------------------------------------------------------------------
// The spec reader.

using sylva::test::TempDir;

const char* kCrown = "[crown]\ntype = \"sphere\"\nradius = 1.5\nposition = [0, 1.5, 0]\n";

// Validates a species whose top-level keys are `keys` (the crown table appended); returns the
// error message, or "" when it is valid.
std::string specError(const std::string& keys, const std::string& crown = kCrown) {
    TempDir dir;
    const fs::path file = dir / "sc.toml";
    {
        std::ofstream out(file);
        out << "name = \"sc\"\nmethod = \"space-colonization\"\n" << keys << crown;
    }
    try {
        validateSpecies(loadSpecies(file.string()), nullptr);
    } catch (const SpecError& e) {
        return e.what();
    }
    return "";
}

TEST(SpaceColonizationSpec, BadParametersNameFileLineAndKey) {
    struct Case {
        std::string keys, where, what;
    };
    const std::vector<Case> cases = {
        {"perception_angle_deg = 0\n",
         "sc.toml:3:", "perception_angle_deg: expected a number in (0, 180)"},
        {"perception_angle_deg = 180\n", "sc.toml:3:", "got 180"},
        {"occupancy = 2\nperception = 2\n",
         "sc.toml:4:", "perception: the perception radius r must exceed"},
        {"occupancy = 5\n", "sc.toml:3:", "occupancy: the perception radius r must exceed"},
        {"variant = \"improved\"\nkappa = 4.5\n",
         "sc.toml:4:", "kappa: expected a number in [1, 4], got 4.5"},
        {"variant = \"improved\"\nkappa = 0.5\n", "sc.toml:4:", "got 0.5"},
        {"variant = \"improved\"\nmarkers = 10\n",
         "sc.toml:4:", "markers: applies to variant = \"baseline\" only"},
        {"gravity = 1\n", "sc.toml:3:", "gravity: applies to variant = \"improved\" only"},
        {"pipe_exponent = 4\n", "sc.toml:3:", "pipe_exponent"},
        {"variant = \"fancy\"\n", "sc.toml:3:", "variant: expected one of"},
        {"internode = 0.1\nmarkes = 10\n", "sc.toml:4:", "did you mean \"markers\""},
        {"variant = \"improved\"\nallocation = \"borchert-honda\"\n",
         "sc.toml:4:", "allocation: applies to variant = \"baseline\" only"},
        {"apical_control = 0.6\n",
         "sc.toml:3:", "apical_control: applies to allocation = \"borchert-honda\" only"},
        {"allocation = \"borchert-honda\"\napical_control = 1\n",
         "sc.toml:4:", "apical_control: expected a number in (0, 1), got 1"},
        {"allocation = \"borchert-honda\"\nshed_threshold = 0.3\n",
         "sc.toml:4:", "shed_threshold: applies to light = \"shadow\" only"},
        {"space_markers = 8\n",
         "sc.toml:3:", "space_markers: applies to allocation = \"borchert-honda\" only"},
        {"allocation = \"borchert-honda\"\nspace_markers = -1\n",
         "sc.toml:4:", "space_markers: expected a number in [0, 1000000], got -1"},
        {"shoot_turn_sd_deg = 91\n",
         "sc.toml:3:", "shoot_turn_sd_deg: expected a number in [0, 90]"},
        {"axis_turn_max_deg = 181\n",
         "sc.toml:3:", "axis_turn_max_deg: expected a number in [0, 180]"},
        {"limb_turn_max_deg = -1\n",
         "sc.toml:3:", "limb_turn_max_deg: expected a number in [0, 180]"},
        {"branchlet_angle_deg = 0\n",
         "sc.toml:3:", "branchlet_angle_deg: expected a number in (0, 180), got 0"},
        {"flat_sprays = 1\n", "sc.toml:3:", "flat_sprays: expected"},
        {"allocation = \"borchert-honda\"\nlight = \"moon\"\n",
         "sc.toml:4:", "light: expected one of"},
        {"allocation = \"borchert-honda\"\nlight = \"shadow\"\nshadow_decay = 1\n",
         "sc.toml:5:", "shadow_decay: expected a number > 1, got 1"},
        {"envelope_noise = 0.95\n", "sc.toml:3:", "envelope_noise: expected a number in [0, 0.9]"},
        {"whorl_laterals = 13\n", "sc.toml:3:", "whorl_laterals: expected an integer in [0, 12]"},
        {"max_order = -1\n", "sc.toml:3:", "max_order"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.keys);
        const std::string e = specError(c.keys);
        EXPECT_NE(e.find(c.where), std::string::npos) << e;
        EXPECT_NE(e.find(c.what), std::string::npos) << e;
        EXPECT_EQ(e.find('\n'), std::string::npos) << e;
    }
    EXPECT_NE(specError("variant = \"baseline\"\n", "").find("[crown] is required"),
              std::string::npos);
    EXPECT_EQ(specError("variant = \"improved\"\n", ""), "");  // no crown: unbounded

    // A crown out of the bole top's reach (r = 0.4 m): the tree could never start.
    const std::string high = "[crown]\ntype = \"sphere\"\nradius = 1\nposition = [0, 3, 0]\n";
    std::string e = specError("trunk_length = 0.75\n", high);  // top at 0.7 m, 1.3 m away
    EXPECT_NE(e.find("sc.toml:3:"), std::string::npos) << e;
    EXPECT_NE(e.find("trunk_length: growth starts at the bole top (0, 0.7, 0), 1.3 m from the "
                     "crown, beyond the 0.4 m"),
              std::string::npos)
        << e;
    e = specError("variant = \"improved\"\n", high);  // no bole: reported at [crown]
    EXPECT_NE(e.find("sc.toml:4:"), std::string::npos) << e;
    EXPECT_NE(e.find("2 m from the crown"), std::string::npos) << e;
    EXPECT_EQ(specError("trunk_length = 1.75\n", high), "");  // top 0.3 m away: in reach
    EXPECT_EQ(specError("variant = \"improved\"\nkappa = 2\nsigma = 1.5\ngravity = 0.3\n"), "");
    e = specError("variant = \"improved\"\nenvelope_scale_sd = 0.1\n", "");
    EXPECT_NE(e.find("sc.toml:4:"), std::string::npos) << e;
    EXPECT_NE(e.find("envelope_scale_sd: needs a [crown] to deform"), std::string::npos) << e;
    EXPECT_EQ(specError("allocation = \"borchert-honda\"\napical_control = 0.6\n"
                        "resource_coefficient = 2.5\nlight = \"shadow\"\nshadow_strength = 0.2\n"
                        "shadow_decay = 1.5\nshadow_depth = 4\nshed_threshold = 0.3\n"
                        "shed_delay = 2\nenvelope_scale_sd = 0.1\nenvelope_noise = 0.2\n"
                        "leader_weight = 5\nwhorl_laterals = 4\nmax_order = 4\n"),
              "");
}

TEST(SpaceColonizationSpec, SpeciesGrowsAndReportsItsCrown) {
    TempDir dir;
    const fs::path file = dir / "sc.toml";
    {
        std::ofstream out(file);
        out << "name = \"sc\"\nmethod = \"space-colonization\"\nvariant = \"improved\"\n"
               "internode = 0.08\ntrunk_length = 0.5\nmax_internodes = 800\n"
            << kCrown;
    }
    const SpeciesFile species = loadSpecies(file.string());
    DrawContext draw;
    draw.draw = false;
    const auto method = instantiateSpecies(species, draw, nullptr);
    const auto volumes = method->volumes();
    ASSERT_EQ(volumes.size(), 1u);
    EXPECT_EQ(volumes[0].first, "crown");
    EXPECT_TRUE(volumes[0].second->inside({0, 2.9, 0}));
    EXPECT_FALSE(volumes[0].second->inside({0, 3.1, 0}));
    const GrownTree a = growSpecies(species, 5, nullptr, true);
    const GrownTree b = growSpecies(species, 5, nullptr, false);
    EXPECT_TRUE(sameTree(a.tree, b.tree));
    EXPECT_EQ(a.tree.nodes.size(), 801u);
    EXPECT_NEAR(a.tree.nodes[6].position.y, 0.48, 1e-12);  // six bole internodes of 0.08 m
    EXPECT_EQ(a.methodStats.at("variant"), 1.0);
    EXPECT_EQ(a.methodStats.at("internodes"), 800.0);
}

// ------------------------------------------------------------------------------------------
// Shipped presets.

TEST(SpaceColonizationPresets, EveryPresetGrowsARootedTreeInItsCrown) {
    const std::vector<fs::path> files = test::shippedSpeciesFiles();
    int grown = 0;
    for (const fs::path& file : files) {
        const SpeciesFile species = loadSpecies(file.string());
        if (species.method != "space-colonization") continue;
        SCOPED_TRACE(file.filename().string());
        DrawContext draw;
        draw.draw = false;
        const auto method = instantiateSpecies(species, draw, nullptr);
        const VolumePtr crown = method->volumes().empty() ? nullptr : method->volumes()[0].second;
        const bool guided = species.table->contains("guides");
        // A per-tree crown (envelope keys) is the crown scaled about the root by s ≤ 1.5 and
        // radially about its centre by ≤ 1 + noise: within those bounds, not within the crown.
        const double noise = species.table->get("envelope_noise")
                                 ? *(*species.table)["envelope_noise"].value<double>()
                                 : 0.0;
        const bool perturbed = noise > 0 || species.table->contains("envelope_scale_sd");
        Aabb reach;
        if (crown && perturbed) {
            const Aabb b = crown->bounds();
            const Vec3 c = (b.lo + b.hi) * 0.5, h = (b.hi - b.lo) * (0.5 * (1 + noise));
            reach.extend((c - h) * 1.5);
            reach.extend((c + h) * 1.5);
        }
        const double internode =
            species.table->get("internode") ? *(*species.table)["internode"].value<double>() : 0.1;
        // The tree as colonization grew it: the form stage then moves branches on purpose
        // (a crown width per tree, wider insertion angles, bends), beyond any crown's reach.
        PreparedTree prepared = prepareSpecies(species, 1, nullptr);
        const GrowthGuard guard(prepared.out.budget);
        Rng rng(1);
        const Tree t = prepared.method->grow(rng, true, prepared.out.methodStats, guard);
        ++grown;
        ASSERT_GT(t.nodes.size(), 100u);
        EXPECT_EQ(t.nodes[0].parent, -1);
        // A bole that stops short of the crown starts colonization outside it: allow for that.
        int32_t boleTop = 0;
        while (boleTop + 1 < static_cast<int32_t>(t.nodes.size()) &&
               t.nodes[boleTop + 1].level == 0) {
            ++boleTop;
        }
        const double tolerance =
            internode * (1 + 1e-9) +
            (crown ? std::max(0.0, crown->signedDistance(t.nodes[boleTop].position)) : 0.0);
        int outside = 0;
        for (size_t i = 1; i < t.nodes.size(); ++i) {
            ASSERT_GE(t.nodes[i].parent, 0);
            ASSERT_LT(t.nodes[i].parent, static_cast<int32_t>(i));
            if (crown && perturbed && t.nodes[i].level > 0) {
                const Vec3& p = t.nodes[i].position;
                EXPECT_TRUE(p.x >= reach.lo.x - tolerance && p.x <= reach.hi.x + tolerance &&
                            p.y <= reach.hi.y + tolerance && p.z >= reach.lo.z - tolerance &&
                            p.z <= reach.hi.z + tolerance)
                    << "node " << i << " beyond the reach of every per-tree crown";
                continue;
            }
            if (crown && !guided && t.nodes[i].level > 0 &&
                crown->signedDistance(t.nodes[i].position) > tolerance) {
                ++outside;
                ADD_FAILURE() << "node " << i << " is "
                              << crown->signedDistance(t.nodes[i].position)
                              << " m outside the crown";
            }
        }
        // Guide markers may lie outside the crown (strokes reaching out, silhouettes), so
        // containment is checked for unguided presets only.
        EXPECT_EQ(outside, 0);
    }
    EXPECT_EQ(grown, 14) << "the four sc-* species (species/papers/liu-2020) and the ten of "
                            "the library (species/presets)";
}

}  // namespace
}  // namespace sylva
