// Leaf inclination: de Wit's distributions (species/geometry/leaves.h) against their closed
// forms — the cumulative distribution and the mean of the leaf normal's angle from the vertical
// — for the leaves of a hand-made tree, and every card's blade lying in its plane.
#include "species/geometry/leaves.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "tests/plot_fixture.h"

namespace sylva {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Known {
    LeafOrientation orientation;
    const char* name;
    double meanDeg;                     // E[θ]
    std::function<double(double)> cdf;  // F(θ), θ in [0, π/2]
};

TEST(LeafInclination, DeWitDistributionsHaveTheirClosedForms) {
    const std::vector<Known> known = {
        {LeafOrientation::kPlanophile, "planophile", (kPi / 4 - 1 / kPi) * 180 / kPi,
         [](double t) { return 2 / kPi * (t + std::sin(2 * t) / 2); }},
        {LeafOrientation::kErectophile, "erectophile", (kPi / 4 + 1 / kPi) * 180 / kPi,
         [](double t) { return 2 / kPi * (t - std::sin(2 * t) / 2); }},
        {LeafOrientation::kPlagiophile, "plagiophile", 45,
         [](double t) { return 2 / kPi * (t - std::sin(4 * t) / 4); }},
        {LeafOrientation::kExtremophile, "extremophile", 45,
         [](double t) { return 2 / kPi * (t + std::sin(4 * t) / 4); }},
        {LeafOrientation::kUniform, "uniform", 45, [](double t) { return 2 * t / kPi; }},
        {LeafOrientation::kSpherical, "spherical", 180 / kPi,
         [](double t) { return 1 - std::cos(t); }},
    };
    for (const Known& k : known) {
        SCOPED_TRACE(k.name);
        Tree tree = test::handTree(6, 0.2, 2.0, 0.3);
        tree.leaves.clear();  // its own cards, all facing one way
        LeafOptions o;
        o.enabled = true;
        o.perTip = 1000;
        o.orientation = k.orientation;
        Rng rng(7);
        placeLeaves(tree, o, rng);
        ASSERT_GE(tree.leaves.size(), 5000u);
        std::vector<double> theta;
        double mean = 0;
        for (const Leaf& l : tree.leaves) {
            ASSERT_NEAR(length(l.normal), 1.0, 1e-9);
            ASSERT_NEAR(length(l.tangent), 1.0, 1e-9);
            ASSERT_NEAR(dot(l.normal, l.tangent), 0.0, 1e-9);  // the blade in the card's plane
            theta.push_back(std::acos(std::min(1.0, std::abs(l.normal.y))));
            mean += theta.back();
        }
        mean /= static_cast<double>(theta.size());
        EXPECT_NEAR(mean * 180 / kPi, k.meanDeg, 1.0);
        std::sort(theta.begin(), theta.end());
        const double n = static_cast<double>(theta.size());
        double d = 0;  // two-sided KS against the closed form
        for (size_t i = 0; i < theta.size(); ++i) {
            const double f = k.cdf(theta[i]);
            d = std::max({d, std::abs((i + 1) / n - f), std::abs(i / n - f)});
        }
        EXPECT_LT(d, 1.63 / std::sqrt(n)) << "KS D " << d;  // p = 0.01
    }
}

}  // namespace
}  // namespace sylva
