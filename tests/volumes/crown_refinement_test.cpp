// Crown refinement (Wolff 2013 §3.1.1, Abb. 11): sphere centres well separated and inside the
// crown, spheres and cones joined at the trunk top, empty space between the clumps, seeds,
// saturation, and the spec reader.
#include "volumes/crown_refinement.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/params.h"
#include "species/spec/volume_spec.h"
#include "volumes/poisson.h"
#include "volumes/volume.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

VolumePtr testCrown() {
    Placement at;
    at.position = {0, 5, 0};
    return makePlaced(makeEllipsoid({4, 3, 4}), at);
}

CrownRefinementOptions testOptions() {
    CrownRefinementOptions o;
    o.trunkTop = {0, 2, 0};
    o.count = 10;
    o.sphereRadius = 0.6;
    o.coneRadius = 0.25;
    o.gap = 0.2;
    return o;
}

// Distance from p to the segment a–b.
double segmentDistance(const Vec3& p, const Vec3& a, const Vec3& b) {
    const Vec3 e = b - a;
    const double t = std::clamp(dot(p - a, e) / dot(e, e), 0.0, 1.0);
    return distance(p, a + e * t);
}

TEST(CrownRefinement, CentresAreSeparatedAndInsideTheCrown) {
    const VolumePtr crown = testCrown();
    const CrownRefinementOptions o = testOptions();
    Rng rng(3);
    const RefinedCrown r = refineCrown(*crown, o, rng);
    ASSERT_EQ(r.centres.size(), 10u);
    for (size_t i = 0; i < r.centres.size(); ++i) {
        EXPECT_TRUE(crown->inside(r.centres[i]));
        for (size_t j = 0; j < i; ++j) {
            EXPECT_GE(distance(r.centres[i], r.centres[j]), 2 * 0.6 + 0.2);
        }
    }
}

TEST(CrownRefinement, SpheresAndConesReachTheTrunkTop) {
    const VolumePtr crown = testCrown();
    const CrownRefinementOptions o = testOptions();
    Rng rng(4);
    const RefinedCrown r = refineCrown(*crown, o, rng);
    const Volume& v = *r.volume;
    EXPECT_TRUE(v.inside(o.trunkTop));
    for (const Vec3& c : r.centres) {
        EXPECT_TRUE(v.inside(c));
        // The whole sphere, just inside its radius, in six directions.
        for (Vec3 d : {Vec3{1, 0, 0}, Vec3{-1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, -1, 0}, Vec3{0, 0, 1},
                       Vec3{0, 0, -1}}) {
            EXPECT_TRUE(v.inside(c + d * 0.599));
        }
        for (int k = 0; k <= 20; ++k) {
            const Vec3 p = c + (o.trunkTop - c) * (k / 20.0);
            EXPECT_TRUE(v.inside(p)) << "segment point " << k;
        }
    }
}

TEST(CrownRefinement, SpaceBetweenTheClumpsIsOutside) {
    const VolumePtr crown = testCrown();
    const CrownRefinementOptions o = testOptions();
    Rng rng(5);
    const RefinedCrown r = refineCrown(*crown, o, rng);
    Rng probe(6);
    int far = 0, near = 0;
    for (int i = 0; i < 4000; ++i) {
        const Vec3 p = *crown->sample(probe);
        double dSphere = 1e300, dCone = distance(p, o.trunkTop);
        for (const Vec3& c : r.centres) {
            dSphere = std::min(dSphere, distance(p, c));
            dCone = std::min(dCone, segmentDistance(p, c, o.trunkTop));
        }
        if (dSphere > 0.6 + 1e-6 && dCone > 0.25 + 1e-6) {
            ++far;  // farther than R from every centre and than the cone radius from every axis
            EXPECT_FALSE(r.volume->inside(p));
        } else if (dSphere < 0.6 - 1e-6) {
            ++near;
            EXPECT_TRUE(r.volume->inside(p));
        }
    }
    EXPECT_GT(far, 2000);  // most of the crown is now empty
    EXPECT_GT(near, 50);
    // The refined crown is much smaller than the crown, and at least the spheres.
    EXPECT_LT(r.volume->measure(), 0.3 * crown->measure());
    EXPECT_GT(r.volume->measure(), 0.98 * 10 * 4.0 / 3.0 * kPi * 0.216);
}

TEST(CrownRefinement, SameSeedSameCentres) {
    const VolumePtr crown = testCrown();
    Rng a(7), b(7), c(8);
    const auto ra = refineCrown(*crown, testOptions(), a);
    const auto rb = refineCrown(*crown, testOptions(), b);
    const auto rc = refineCrown(*crown, testOptions(), c);
    for (size_t i = 0; i < ra.centres.size(); ++i) {
        EXPECT_EQ(ra.centres[i], rb.centres[i]);
        EXPECT_FALSE(ra.centres[i] == rc.centres[i]);
    }
}

TEST(CrownRefinement, TooManySpheresSaturate) {
    CrownRefinementOptions o = testOptions();
    o.count = 200;  // capacity ≈ 0.7 · 151 m³ / 1.4³ ≈ 38
    Rng rng(1);
    try {
        refineCrown(*testCrown(), o, rng);
        FAIL() << "expected PoissonSaturated";
    } catch (const PoissonSaturated& e) {
        EXPECT_NE(std::string(e.what()).find("of 200 points"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("capacity"), std::string::npos) << e.what();
    }
}

TEST(CrownRefinementSpec, ReadsTheTableAndDrawsPerTreeWithoutASeed) {
    const fs::path file = fs::temp_directory_path() / "sylva_refinement_spec.toml";
    auto parse = [&](const std::string& body, uint64_t seed, bool* perInstance) {
        toml::table t = toml::parse(body, file.string());
        DrawContext draw;
        draw.seed = seed;
        Params p(t, file.string(), "crown", &draw);
        VolumePtr v = parseVolume(p);
        *perInstance = draw.perInstance;
        return v;
    };
    const std::string body =
        "type = \"crown-refinement\"\n"
        "crown = { type = \"ellipsoid\", radii = [4, 3, 4], position = [0, 5, 0] }\n"
        "trunk_top = [0, 2, 0]\ncount = 10\nsphere_radius = 0.6\n";
    bool per = false;
    VolumePtr a = parse(body, 1, &per);
    EXPECT_TRUE(per);
    EXPECT_TRUE(a->inside({0, 2, 0}));
    VolumePtr b = parse(body, 2, &per);
    EXPECT_NE(a->measure(), b->measure());
    VolumePtr c = parse(body + "seed = 3\n", 1, &per);
    EXPECT_FALSE(per);
    VolumePtr d = parse(body + "seed = 3\n", 2, &per);
    EXPECT_EQ(c->measure(), d->measure());
    try {
        parse(body + "gap = 30\n", 1, &per);
        FAIL() << "expected a SpecError";
    } catch (const SpecError& e) {
        EXPECT_NE(std::string(e.what()).find("crown.count: the spheres do not fit"),
                  std::string::npos)
            << e.what();
    }
}

}  // namespace
}  // namespace sylva
