// Crown volumes: inside tests, exact signed distances at points with closed-form answers,
// closed-form measures, uniform sampling (all inside, centroid), placement, CSG, level sets.
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <vector>

#include "core/math.h"
#include "core/rng.h"
#include "volumes/volume.h"

namespace sylva {
namespace {

constexpr double kEps = 1e-12;
const double kSqrt2 = std::sqrt(2.0);

struct SampleStats {
    Vec3 mean;
    double meanR2 = 0;  // mean of x² + z² (radial spread about the y axis)
    bool allInside = true;
    bool allInBounds = true;
};

// Draws n samples; checks each is inside (to rounding) and inside bounds().
SampleStats sampleStats(const Volume& v, int n, uint64_t seed = 7) {
    Rng rng(seed);
    SampleStats s;
    Aabb b = v.bounds();
    const Vec3 tol{1e-9, 1e-9, 1e-9};
    b.lo -= tol;
    b.hi += tol;
    for (int i = 0; i < n; ++i) {
        auto p = v.sample(rng);
        if (!p) {
            ADD_FAILURE() << "sample() failed for " << v.describe();
            return s;
        }
        s.mean += *p;
        s.meanR2 += p->x * p->x + p->z * p->z;
        if (v.signedDistance(*p) > 1e-9) s.allInside = false;
        if (!b.contains(*p)) s.allInBounds = false;
    }
    s.mean = s.mean / n;
    s.meanR2 /= n;
    return s;
}

void expectVecNear(const Vec3& a, const Vec3& b, double tol) {
    EXPECT_NEAR(a.x, b.x, tol);
    EXPECT_NEAR(a.y, b.y, tol);
    EXPECT_NEAR(a.z, b.z, tol);
}

// Distance in the plane from (px, py) to the segment a–b.
double segDist(double px, double py, double ax, double ay, double bx, double by) {
    double ex = bx - ax, ey = by - ay;
    double t = std::clamp(((px - ax) * ex + (py - ay) * ey) / (ex * ex + ey * ey), 0.0, 1.0);
    return std::hypot(px - ax - t * ex, py - ay - t * ey);
}

// --- sphere --------------------------------------------------------------------------------

TEST(Sphere, DistanceInsideMeasure) {
    auto s = makeSphere(2.0);
    EXPECT_NEAR(s->signedDistance({0, 0, 0}), -2.0, kEps);
    EXPECT_NEAR(s->signedDistance({0, 1, 0}), -1.0, kEps);
    EXPECT_NEAR(s->signedDistance({3, 0, 0}), 1.0, kEps);
    EXPECT_NEAR(s->signedDistance({2, 2, 1}), 1.0, kEps);
    EXPECT_TRUE(s->inside({1.9, 0, 0}));
    EXPECT_FALSE(s->inside({1.5, 1.5, 0}));
    EXPECT_NEAR(s->measure(), 4.0 / 3.0 * kPi * 8.0, kEps);
    expectVecNear(s->bounds().lo, {-2, -2, -2}, kEps);
    expectVecNear(s->bounds().hi, {2, 2, 2}, kEps);
    EXPECT_EQ(s->describe(), "sphere r=2 m");
}

TEST(Sphere, SamplesUniform) {
    auto s = makeSphere(2.0);
    SampleStats st = sampleStats(*s, 20000);
    EXPECT_TRUE(st.allInside);
    EXPECT_TRUE(st.allInBounds);
    expectVecNear(st.mean, {0, 0, 0}, 0.03);
    // For a uniform ball E[x² + z²] = 2/5 R².
    EXPECT_NEAR(st.meanR2, 0.4 * 4.0, 0.04);
}

TEST(Sphere, RejectsNegativeRadius) { EXPECT_THROW(makeSphere(-1.0), std::invalid_argument); }

// --- hemisphere ----------------------------------------------------------------------------

TEST(Hemisphere, ExactDistance) {
    auto h = makeHemisphere(1.0);
    EXPECT_NEAR(h->signedDistance({0, 0.5, 0}), -0.5, kEps);  // equidistant dome / base
    EXPECT_NEAR(h->signedDistance({0, 0.2, 0}), -0.2, kEps);  // base nearer
    EXPECT_NEAR(h->signedDistance({0, 0.9, 0}), -0.1, kEps);  // dome nearer
    EXPECT_NEAR(h->signedDistance({0.5, 0.1, 0}), -0.1, kEps);
    EXPECT_NEAR(h->signedDistance({0, 2, 0}), 1.0, kEps);   // above the pole
    EXPECT_NEAR(h->signedDistance({0, -1, 0}), 1.0, kEps);  // below the base centre
    EXPECT_NEAR(h->signedDistance({0.3, -0.4, 0}), 0.4, kEps);
    EXPECT_NEAR(h->signedDistance({2, -1, 0}), kSqrt2, kEps);  // nearest is the rim
    EXPECT_NEAR(h->signedDistance({2, 0, 0}), 1.0, kEps);
    EXPECT_FALSE(h->inside({0, -0.01, 0}));
    EXPECT_TRUE(h->inside({0, 0.01, 0}));
}

TEST(Hemisphere, MeasureCentroidBounds) {
    const double r = 1.5;
    auto h = makeHemisphere(r);
    EXPECT_NEAR(h->measure(), 2.0 / 3.0 * kPi * r * r * r, kEps);
    expectVecNear(h->bounds().lo, {-r, 0, -r}, kEps);
    expectVecNear(h->bounds().hi, {r, r, r}, kEps);
    SampleStats st = sampleStats(*h, 20000);
    EXPECT_TRUE(st.allInside);
    EXPECT_TRUE(st.allInBounds);
    expectVecNear(st.mean, {0, 3.0 * r / 8.0, 0}, 0.02);
}

// --- ellipsoid -----------------------------------------------------------------------------

TEST(Ellipsoid, InsideIsExact) {
    auto e = makeEllipsoid({1, 2, 3});
    EXPECT_TRUE(e->inside({0.99, 0, 0}));
    EXPECT_TRUE(e->inside({0, 1.99, 0}));
    EXPECT_FALSE(e->inside({0, 0, 3.01}));
    EXPECT_TRUE(e->inside({0.57, 1.14, 1.71}));  // (0.57)²·3 = 0.975
    EXPECT_FALSE(e->inside({0.6, 1.2, 1.8}));    // 0.6²·3 = 1.08
    // On an axis the bound is exact.
    EXPECT_NEAR(e->signedDistance({0, 0, 4}), 1.0, kEps);
    EXPECT_NEAR(e->signedDistance({3, 0, 0}), 2.0, kEps);
    EXPECT_NEAR(e->measure(), 4.0 / 3.0 * kPi * 6.0, kEps);
}

TEST(Ellipsoid, DistanceIsAConservativeBound) {
    // A thin ellipsoid, where the common k0·(k0−1)/k1 formula over-estimates inside.
    const Vec3 r{1.0, 0.1, 1.0};
    auto e = makeEllipsoid(r);
    std::vector<Vec3> surface;
    for (int i = 0; i <= 200; ++i)
        for (int j = 0; j < 400; ++j) {
            double t = kPi * i / 200, p = 2 * kPi * j / 400;
            surface.push_back(
                cmul(r, {std::sin(t) * std::cos(p), std::cos(t), std::sin(t) * std::sin(p)}));
        }
    Rng rng(3);
    for (int k = 0; k < 60; ++k) {
        Vec3 p = cmul(r * 2.0, {rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)});
        double best = 1e300;
        for (const Vec3& s : surface) best = std::min(best, distance2(p, s));
        best = std::sqrt(best);  // ≥ the true distance (a finite subset of the surface)
        EXPECT_LE(std::abs(e->signedDistance(p)), best + 1e-9) << p.x << " " << p.y << " " << p.z;
    }
}

TEST(Ellipsoid, SamplesInsideCentred) {
    auto e = makeEllipsoid({1, 2, 0.5});
    SampleStats st = sampleStats(*e, 20000);
    EXPECT_TRUE(st.allInside);
    EXPECT_TRUE(st.allInBounds);
    expectVecNear(st.mean, {0, 0, 0}, 0.03);
}

// --- cylinder ------------------------------------------------------------------------------

TEST(Cylinder, ExactDistance) {
    auto c = makeCylinder(1.0, 2.0);
    EXPECT_NEAR(c->signedDistance({0, 1, 0}), -1.0, kEps);
    EXPECT_NEAR(c->signedDistance({0, 0.5, 0}), -0.5, kEps);  // base cap nearer
    EXPECT_NEAR(c->signedDistance({0.8, 1, 0}), -0.2, kEps);  // side nearer
    EXPECT_NEAR(c->signedDistance({2, 1, 0}), 1.0, kEps);
    EXPECT_NEAR(c->signedDistance({0, 3, 0}), 1.0, kEps);
    EXPECT_NEAR(c->signedDistance({0, -0.5, 0}), 0.5, kEps);
    EXPECT_NEAR(c->signedDistance({2, 3, 0}), kSqrt2, kEps);   // top rim
    EXPECT_NEAR(c->signedDistance({0, 2.4, 1.3}), 0.5, kEps);  // (0.3, 0.4) off the rim
    EXPECT_NEAR(c->measure(), 2.0 * kPi, kEps);
}

TEST(Cylinder, SamplesUniform) {
    auto c = makeCylinder(1.0, 2.0);
    SampleStats st = sampleStats(*c, 20000);
    EXPECT_TRUE(st.allInside);
    EXPECT_TRUE(st.allInBounds);
    expectVecNear(st.mean, {0, 1, 0}, 0.02);
    EXPECT_NEAR(st.meanR2, 0.5, 0.01);  // uniform disc: E[r²] = R²/2
}

// --- cone / frustum ------------------------------------------------------------------------

TEST(Cone, ExactDistance) {
    auto c = makeCone(1.0, 2.0);  // slant: 2r + y = 2
    const double s5 = std::sqrt(5.0);
    EXPECT_NEAR(c->signedDistance({0, 2, 0}), 0.0, kEps);          // apex
    EXPECT_NEAR(c->signedDistance({0, 3, 0}), 1.0, kEps);          // above the apex
    EXPECT_NEAR(c->signedDistance({0, -1, 0}), 1.0, kEps);         // below the base
    EXPECT_NEAR(c->signedDistance({0, 0.5, 0}), -0.5, kEps);       // base nearer than slant
    EXPECT_NEAR(c->signedDistance({0, 1.5, 0}), -0.5 / s5, kEps);  // slant nearer
    EXPECT_NEAR(c->signedDistance({2, 1, 0}), 3.0 / s5, kEps);
    EXPECT_NEAR(c->signedDistance({0, -0.5, 1.5}), std::sqrt(0.5), kEps);  // base rim
    EXPECT_TRUE(c->inside({0.45, 1.0, 0}));
    EXPECT_FALSE(c->inside({0.55, 1.0, 0}));
    EXPECT_NEAR(c->measure(), kPi * 2.0 / 3.0, kEps);
    EXPECT_EQ(c->describe(), "cone r=1 m h=2 m");
}

TEST(Cone, MatchesBruteForceProfileDistance) {
    // A frustum's distance equals the 2-D distance to its (r, y) profile.
    const double rb = 1.0, rt = 0.4, h = 1.5;
    auto c = makeCone(rb, h, rt);
    Rng rng(11);
    for (int i = 0; i < 500; ++i) {
        Vec3 p{rng.uniform(-2, 2), rng.uniform(-1, 2.5), rng.uniform(-2, 2)};
        double r = std::hypot(p.x, p.z);
        double d = std::min({segDist(r, p.y, 0, 0, rb, 0), segDist(r, p.y, rb, 0, rt, h),
                             segDist(r, p.y, 0, h, rt, h)});
        bool in = p.y >= 0 && p.y <= h && r <= rb + (rt - rb) * p.y / h;
        EXPECT_NEAR(c->signedDistance(p), in ? -d : d, 1e-12);
    }
}

TEST(Cone, CentroidQuarterHeight) {
    auto c = makeCone(1.0, 2.0);
    SampleStats st = sampleStats(*c, 20000);
    EXPECT_TRUE(st.allInside);
    EXPECT_TRUE(st.allInBounds);
    expectVecNear(st.mean, {0, 0.5, 0}, 0.02);  // h/4 from the base
}

TEST(Frustum, MeasureDistanceCentroid) {
    const double R = 1.0, r = 0.5, h = 1.0;
    auto f = makeCone(R, h, r);
    EXPECT_NEAR(f->measure(), kPi * h / 3.0 * (R * R + R * r + r * r), kEps);
    EXPECT_NEAR(f->signedDistance({0, 1.5, 0}), 0.5, kEps);                       // above top
    EXPECT_NEAR(f->signedDistance({0.75, 1.5, 0}), std::hypot(0.25, 0.5), kEps);  // top rim
    EXPECT_EQ(f->describe(), "frustum r=1..0.5 m h=1 m");
    // Centroid height of a frustum: h(R² + 2Rr + 3r²) / (4(R² + Rr + r²)).
    auto centroid = [&](double a, double b) {
        return h * (a * a + 2 * a * b + 3 * b * b) / (4 * (a * a + a * b + b * b));
    };
    SampleStats st = sampleStats(*f, 20000);
    EXPECT_TRUE(st.allInside);
    EXPECT_TRUE(st.allInBounds);
    EXPECT_NEAR(st.mean.y, centroid(R, r), 0.01);
    // Widening upwards (top radius larger than the base) uses the same inverse CDF.
    auto g = makeCone(r, h, R);
    SampleStats sg = sampleStats(*g, 20000);
    EXPECT_TRUE(sg.allInside);
    EXPECT_NEAR(sg.mean.y, centroid(r, R), 0.01);
}

// --- box -----------------------------------------------------------------------------------

TEST(Box, ExactDistanceMeasureSamples) {
    auto b = makeBox({2, 4, 6});
    EXPECT_NEAR(b->signedDistance({0, 0, 0}), -1.0, kEps);
    EXPECT_NEAR(b->signedDistance({0.5, 0, 0}), -0.5, kEps);
    EXPECT_NEAR(b->signedDistance({0, 1.8, 0}), -0.2, kEps);
    EXPECT_NEAR(b->signedDistance({2, 0, 0}), 1.0, kEps);
    EXPECT_NEAR(b->signedDistance({2, 3, 0}), kSqrt2, kEps);          // edge
    EXPECT_NEAR(b->signedDistance({2, 3, 4}), std::sqrt(3.0), kEps);  // corner
    EXPECT_NEAR(b->measure(), 48.0, kEps);
    SampleStats st = sampleStats(*b, 5000);
    EXPECT_TRUE(st.allInside);
    expectVecNear(st.mean, {0, 0, 0}, 0.06);
}

// --- sphere sector -------------------------------------------------------------------------

TEST(SphereSector, ExactDistanceNarrow) {
    const double R = 1.5, a = kPi / 4;
    auto s = makeSphereSector(R, a);
    EXPECT_NEAR(s->signedDistance({0, 1, 0}), -0.5, kEps);                  // sphere nearer
    EXPECT_NEAR(s->signedDistance({0, 0.5, 0}), -0.5 * std::sin(a), kEps);  // cone nearer
    EXPECT_NEAR(s->signedDistance({0, 0, 0}), 0.0, kEps);                   // apex
    EXPECT_NEAR(s->signedDistance({0, -1, 0}), 1.0, kEps);                  // behind the apex
    EXPECT_NEAR(s->signedDistance({1, 0, 0}), std::sin(a), kEps);           // beside the cone
    EXPECT_NEAR(s->signedDistance({0, 2, 0}), 0.5, kEps);                   // beyond the cap
    // Beyond both the cap and the cone: nearest is the rim R·(sin α, cos α).
    EXPECT_NEAR(s->signedDistance({2, 0.5, 0}),
                std::hypot(2 - R * std::sin(a), 0.5 - R * std::cos(a)), kEps);
    EXPECT_TRUE(s->inside({0.3, 1.0, 0.3}));
    EXPECT_FALSE(s->inside({0.8, 0.7, 0}));  // 48.8° off the axis
    EXPECT_EQ(s->describe(), "sphere-sector r=1.5 m α=45°");
}

TEST(SphereSector, ExactDistanceWide) {
    // α > π/2: the solid is not convex; near −y it has a conical hollow of half-angle π − α.
    const double a = 2.0 * kPi / 3.0;
    auto s = makeSphereSector(1.0, a);
    EXPECT_NEAR(s->signedDistance({0, -1, 0}), std::sin(kPi - a), kEps);
    EXPECT_NEAR(s->signedDistance({0, -0.5, 0}), 0.5 * std::sin(kPi - a), kEps);
    const Vec3 p{0.5, -0.2, 0};  // inside, 8.2° from the cone surface
    const double theta = std::atan2(p.x, p.y);
    EXPECT_NEAR(s->signedDistance(p), -length(p) * std::sin(a - theta), kEps);
    EXPECT_NEAR(s->signedDistance({1.0, -0.2, 0}), std::hypot(1.0, 0.2) - 1.0, kEps);
    EXPECT_TRUE(s->inside({0, -0.1, 0.5}));
    EXPECT_FALSE(s->inside({0, -0.5, 0.1}));
}

TEST(SphereSector, MatchesBruteForceProfileDistance) {
    // In the (r, y) half-plane the boundary is the arc θ ∈ [0, α] plus the apex segment.
    for (double a : {0.3, kPi / 4, 1.2, kPi / 2, 2.0, 2.8, 3.1}) {
        const double R = 1.0;
        auto s = makeSphereSector(R, a);
        Rng rng(5);
        for (int i = 0; i < 100; ++i) {
            Vec3 p{rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5)};
            double r = std::hypot(p.x, p.z);
            double best = segDist(r, p.y, 0, 0, R * std::sin(a), R * std::cos(a));
            for (int k = 0; k <= 4000; ++k) {
                double t = a * k / 4000;
                best = std::min(best, std::hypot(r - R * std::sin(t), p.y - R * std::cos(t)));
            }
            bool in = length(p) <= R && angleBetween(p, {0, 1, 0}) <= a;
            EXPECT_NEAR(s->signedDistance(p), in ? -best : best, 2e-4) << "alpha " << a;
        }
    }
}

TEST(SphereSector, SpecialAnglesMatchSphereAndHemisphere) {
    auto full = makeSphereSector(1.2, kPi);
    auto sphere = makeSphere(1.2);
    auto half = makeSphereSector(1.2, kPi / 2);
    auto dome = makeHemisphere(1.2);
    Rng rng(9);
    for (int i = 0; i < 1000; ++i) {
        Vec3 p = rng.inBox({{-2, -2, -2}, {2, 2, 2}});
        EXPECT_NEAR(full->signedDistance(p), sphere->signedDistance(p), 1e-12);
        EXPECT_NEAR(half->signedDistance(p), dome->signedDistance(p), 1e-12);
    }
    EXPECT_NEAR(full->measure(), sphere->measure(), 1e-12);
    EXPECT_NEAR(half->measure(), dome->measure(), 1e-12);
}

TEST(SphereSector, MeasureCentroidBounds) {
    for (double a : {kPi / 4, kPi / 2, 2.0 * kPi / 3, kPi}) {
        const double R = 1.5;
        auto s = makeSphereSector(R, a);
        EXPECT_NEAR(s->measure(), 2.0 / 3.0 * kPi * R * R * R * (1 - std::cos(a)), 1e-12);
        SampleStats st = sampleStats(*s, 20000);
        EXPECT_TRUE(st.allInside) << a;
        EXPECT_TRUE(st.allInBounds) << a;
        // Centroid of a spherical cone: 3R(1 + cos α)/8 along the axis.
        expectVecNear(st.mean, {0, 3 * R * (1 + std::cos(a)) / 8, 0}, 0.02);
    }
    auto narrow = makeSphereSector(2.0, kPi / 6);
    expectVecNear(narrow->bounds().lo, {-1, 0, -1}, 1e-12);
    expectVecNear(narrow->bounds().hi, {1, 2, 1}, 1e-12);
    auto wide = makeSphereSector(2.0, 2 * kPi / 3);
    expectVecNear(wide->bounds().lo, {-2, -1, -2}, 1e-12);
    expectVecNear(wide->bounds().hi, {2, 2, 2}, 1e-12);
    EXPECT_THROW(makeSphereSector(1.0, 0.0), std::invalid_argument);
    EXPECT_THROW(makeSphereSector(1.0, 3.5), std::invalid_argument);
}

// --- placement -----------------------------------------------------------------------------

TEST(Placed, TiltedCylinder) {
    Placement pl;
    pl.position = {1, 0, 0};
    pl.axis = {1, 1, 0};
    auto c = makePlaced(makeCylinder(0.5, 2.0), pl);
    const Vec3 ax = normalize({1, 1, 0}), perp = normalize({1, -1, 0});
    const Vec3 mid = pl.position + ax * 1.0;
    EXPECT_NEAR(c->signedDistance(mid), -0.5, 1e-12);
    EXPECT_NEAR(c->signedDistance(mid + perp * 0.8), 0.3, 1e-12);
    EXPECT_NEAR(c->signedDistance(mid + Vec3{0, 0, 0.2}), -0.3, 1e-12);
    EXPECT_NEAR(c->signedDistance(pl.position - ax * 0.5), 0.5, 1e-12);  // below the base
    EXPECT_NEAR(c->signedDistance(pl.position + ax * 2.5), 0.5, 1e-12);  // above the top
    EXPECT_FALSE(c->inside(pl.position + Vec3{0, 1, 0}));                // straight up: off axis
    EXPECT_NEAR(c->measure(), kPi * 0.25 * 2.0, 1e-12);
    SampleStats st = sampleStats(*c, 10000);
    EXPECT_TRUE(st.allInside);
    EXPECT_TRUE(st.allInBounds);
    expectVecNear(st.mean, mid, 0.02);
}

TEST(Placed, ScaledSphere) {
    Placement pl;
    pl.position = {0, 5, 0};
    pl.scale = {2, 3, 4};
    auto e = makePlaced(makeSphere(1.0), pl);
    EXPECT_NEAR(e->measure(), 4.0 / 3.0 * kPi * 24.0, 1e-9);
    // Default axis is the identity rotation: local x/y/z scale world x/y/z.
    EXPECT_TRUE(e->inside({1.9, 5, 0}));
    EXPECT_FALSE(e->inside({2.1, 5, 0}));
    EXPECT_TRUE(e->inside({0, 7.9, 0}));
    EXPECT_TRUE(e->inside({0, 5, 3.9}));
    EXPECT_FALSE(e->inside({0, 5, 4.1}));
    expectVecNear(e->bounds().lo, {-2, 2, -4}, 1e-12);
    expectVecNear(e->bounds().hi, {2, 8, 4}, 1e-12);
    // Conservative: local distance × min(scale) = 1 × 2 at the far z pole + 1.
    double d = e->signedDistance({0, 5, 5});
    EXPECT_GT(d, 0.0);
    EXPECT_LE(d, 1.0 + 1e-12);
    // Uniform scale is exact.
    Placement u;
    u.scale = {2, 2, 2};
    EXPECT_NEAR(makePlaced(makeSphere(1.0), u)->signedDistance({3, 0, 0}), 1.0, 1e-12);
    SampleStats st = sampleStats(*e, 10000);
    EXPECT_TRUE(st.allInside);
    expectVecNear(st.mean, {0, 5, 0}, 0.06);
}

TEST(Placed, AlignYFrame) {
    Frame f = Frame::alignY({0, 1, 0});
    expectVecNear(f.u, {1, 0, 0}, 1e-15);
    expectVecNear(f.w, {0, 0, 1}, 1e-15);
    for (Vec3 a : {Vec3{1, 1, 0}, Vec3{0.3, -0.2, 0.9}, Vec3{0, -1, 0}, Vec3{1e-9, -1, 0}}) {
        Frame g = Frame::alignY(a);
        expectVecNear(g.v, normalize(a), 1e-12);
        EXPECT_NEAR(dot(g.u, g.v), 0, 1e-12);
        EXPECT_NEAR(dot(g.u, g.w), 0, 1e-12);
        EXPECT_NEAR(length(g.u), 1, 1e-12);
        expectVecNear(cross(g.u, g.v), g.w, 1e-12);  // right-handed
    }
}

// --- CSG -----------------------------------------------------------------------------------

VolumePtr sphereAt(double r, const Vec3& c) {
    Placement pl;
    pl.position = c;
    return makePlaced(makeSphere(r), pl);
}

TEST(Csg, UnionOfDisjointSpheres) {
    auto u = makeUnion({sphereAt(1.0, {-2, 0, 0}), sphereAt(0.5, {2, 0, 0})});
    EXPECT_TRUE(u->inside({-2, 0.9, 0}));
    EXPECT_TRUE(u->inside({2, 0.4, 0}));
    EXPECT_FALSE(u->inside({0, 0, 0}));
    EXPECT_NEAR(u->signedDistance({0, 0, 0}), 1.0, 1e-12);
    const double expected = 4.0 / 3.0 * kPi * (1.0 + 0.125);
    EXPECT_NEAR(u->measure(), expected, 1e-9);  // disjoint: the estimator is exact
    expectVecNear(u->bounds().lo, {-3, -1, -1}, 1e-12);
    expectVecNear(u->bounds().hi, {2.5, 1, 1}, 1e-12);
    // Sampling is proportional to volume: 1/9 of the points in the small sphere.
    Rng rng(1);
    int small = 0, n = 20000;
    for (int i = 0; i < n; ++i) {
        Vec3 p = *u->sample(rng);
        ASSERT_TRUE(u->inside(p));
        small += p.x > 0;
    }
    EXPECT_NEAR(small / double(n), 0.125 / 1.125, 0.01);
}

TEST(Csg, UnionOfOverlappingSpheresIsUniform) {
    // Two unit spheres with centres 1 apart: lens volume = 5π/12.
    auto u = makeUnion({sphereAt(1.0, {0, 0, 0}), sphereAt(1.0, {1, 0, 0})});
    const double lens = 5.0 * kPi / 12.0;
    const double expected = 2 * 4.0 / 3.0 * kPi - lens;
    EXPECT_NEAR(u->measure(), expected, 0.01 * expected);
    // Uniform ⇒ the fraction of samples in the lens is lens / V.
    Rng rng(2);
    int inLens = 0, n = 40000;
    for (int i = 0; i < n; ++i) {
        Vec3 p = *u->sample(rng);
        inLens += length(p) <= 1 && distance(p, {1, 0, 0}) <= 1;
    }
    EXPECT_NEAR(inLens / double(n), lens / expected, 0.01);
}

TEST(Csg, SamplingIsDeterministic) {
    auto u = makeUnion({sphereAt(1.0, {0, 0, 0}), makeCylinder(0.3, 3.0)});
    Rng a(42), b(42);
    for (int i = 0; i < 100; ++i) EXPECT_EQ(*u->sample(a), *u->sample(b));
}

TEST(Csg, IntersectionWithHalfSpaceBox) {
    // A unit sphere cut by a box covering y ≥ 0 is a hemisphere.
    Placement pl;
    pl.position = {0, 1, 0};
    auto half = makePlaced(makeBox({4, 2, 4}), pl);
    auto i = makeIntersection({makeSphere(1.0), half});
    EXPECT_TRUE(i->inside({0, 0.5, 0}));
    EXPECT_FALSE(i->inside({0, -0.5, 0}));
    EXPECT_FALSE(i->inside({0, 1.1, 0}));
    EXPECT_NEAR(i->signedDistance({0, -0.5, 0}), 0.5, 1e-12);
    EXPECT_NEAR(i->measure(), 2.0 / 3.0 * kPi, 0.02 * 2.0 / 3.0 * kPi);
    SampleStats st = sampleStats(*i, 10000);
    EXPECT_TRUE(st.allInside);
    EXPECT_NEAR(st.mean.y, 3.0 / 8.0, 0.02);
    // Disjoint parts: empty, no sample.
    auto none = makeIntersection({sphereAt(1, {-3, 0, 0}), sphereAt(1, {3, 0, 0})});
    Rng rng(1);
    EXPECT_FALSE(none->sample(rng, 100).has_value());
    EXPECT_EQ(none->measure(), 0.0);
}

TEST(Csg, DifferenceHollowSphere) {
    auto shell = makeDifference(makeSphere(1.0), {makeSphere(0.5)});
    EXPECT_FALSE(shell->inside({0, 0, 0}));
    EXPECT_TRUE(shell->inside({0, 0.75, 0}));
    EXPECT_FALSE(shell->inside({0, 1.1, 0}));
    EXPECT_NEAR(shell->signedDistance({0, 0.2, 0}), 0.3, 1e-12);
    EXPECT_NEAR(shell->signedDistance({0, 0.75, 0}), -0.25, 1e-12);
    const double expected = 4.0 / 3.0 * kPi * (1 - 0.125);
    EXPECT_NEAR(shell->measure(), expected, 0.01 * expected);
    SampleStats st = sampleStats(*shell, 5000);
    EXPECT_TRUE(st.allInside);
}

TEST(Csg, DefaultMonteCarloMeasure) {
    // Volume::measure's default (stratified, fixed seed) on a subclass without a closed form.
    struct Slab final : Volume {
        double signedDistance(const Vec3& p) const override { return std::abs(p.y) - 0.25; }
        Aabb bounds() const override { return {{-1, -1, -1}, {1, 1, 1}}; }
        std::string describe() const override { return "slab"; }
    } slab;
    EXPECT_NEAR(slab.measure(), 4.0 * 0.5, 0.01);
    EXPECT_EQ(slab.measure(), slab.measure());
    Rng rng(1);
    auto p = slab.sample(rng);
    ASSERT_TRUE(p.has_value());
    EXPECT_TRUE(slab.inside(*p));
}

// --- OpenVDB level sets --------------------------------------------------------------------

TEST(LevelSet, SphereMatchesAnalytic) {
    const double vox = 0.05;
    auto sphere = makeSphere(1.0);
    auto ls = makeLevelSet(*sphere, vox);
    Rng rng(4);
    int checkedBand = 0;
    for (int i = 0; i < 20000; ++i) {
        Vec3 p = rng.inBox({{-1.4, -1.4, -1.4}, {1.4, 1.4, 1.4}});
        const double d = length(p) - 1.0;
        const double got = ls->signedDistance(p);
        if (std::abs(d) > vox) {
            EXPECT_EQ(ls->inside(p), d <= 0) << d;
        }
        if (std::abs(d) < 1.5 * vox) {
            EXPECT_NEAR(got, d, 0.5 * vox);
            ++checkedBand;
        }
    }
    EXPECT_GT(checkedBand, 500);
    EXPECT_TRUE(ls->inside({0, 0, 0}));   // deep inside: flood-filled tile
    EXPECT_FALSE(ls->inside({5, 5, 5}));  // far outside the grid
    EXPECT_NEAR(ls->measure(), sphere->measure(), 0.02 * sphere->measure());
    SampleStats st = sampleStats(*ls, 2000);
    EXPECT_TRUE(st.allInside);
}

TEST(LevelSet, UnionOfCylinderAndSector) {
    const double vox = 0.05;
    Placement crown;
    crown.position = {0, 1, 0};
    auto tree =
        makeUnion({makeCylinder(0.2, 1.2), makePlaced(makeSphereSector(1.0, kPi / 3), crown)});
    auto ls = makeLevelSet(*tree, vox);
    Rng rng(6);
    int disagreements = 0;
    for (int i = 0; i < 20000; ++i) {
        Vec3 p = rng.inBox(tree->bounds());
        const double d = tree->signedDistance(p);  // a bound: |d| > vox ⇒ true |d| > vox
        if (std::abs(d) > vox) disagreements += ls->inside(p) != (d <= 0);
    }
    EXPECT_EQ(disagreements, 0);
    EXPECT_NEAR(ls->measure(), tree->measure(), 0.03 * tree->measure());
    // Concurrent reads agree with serial reads.
    std::vector<Vec3> pts(2000);
    for (auto& p : pts) p = rng.inBox(tree->bounds());
    std::vector<double> serial(pts.size()), parallel(pts.size());
    for (size_t i = 0; i < pts.size(); ++i) serial[i] = ls->signedDistance(pts[i]);
    tbb::parallel_for(size_t(0), pts.size(),
                      [&](size_t i) { parallel[i] = ls->signedDistance(pts[i]); });
    EXPECT_EQ(serial, parallel);
}

// Half-space clips: a unit sphere cut at x ≤ 0.5 and z ≤ 0 — signs, the planes' distances,
// samples all inside, and the projection onto the planes.
TEST(ClippedVolume, IntersectsTheHalfSpaces) {
    const std::vector<HalfSpace> cut = {{{1, 0, 0}, 0.5}, {{0, 0, 1}, 0.0}};
    const VolumePtr v = makeClipped(makeSphere(1.0), cut);
    EXPECT_TRUE(v->inside({0, 0, -0.5}));
    EXPECT_FALSE(v->inside({0.7, 0, -0.1}));  // in the sphere, beyond x = 0.5
    EXPECT_FALSE(v->inside({0, 0, 0.1}));     // beyond z = 0
    EXPECT_NEAR(v->signedDistance({0.75, 0, -0.5}), 0.25, 1e-12);
    Rng rng(3);
    for (int i = 0; i < 200; ++i) {
        const auto p = v->sample(rng);
        ASSERT_TRUE(p);
        EXPECT_TRUE(insideAll(cut, *p));
        EXPECT_LE(length(*p), 1.0 + 1e-12);
    }
    // The sphere's measure × the fraction kept: half (z ≤ 0) minus the cap beyond x = 0.5.
    const double cap = kPi * 0.5 * 0.5 * (3 - 0.5) / 3;  // πh²(3r − h)/3, h = 0.5
    EXPECT_NEAR(v->measure(), (4 * kPi / 3 - cap) / 2, 0.05);
    const Vec3 q = projectInside(cut, {2, 1, 3});
    EXPECT_EQ(q.x, 0.5);
    EXPECT_EQ(q.z, 0.0);
    EXPECT_EQ(makeClipped(makeSphere(1.0), {})->describe(), makeSphere(1.0)->describe());
}

// A plane held only within a layer (ShyBound, as between two plot crowns up to the lower
// one's top): below y = 0.2 the half-ball beyond x = 0.5 is cut, above it the sphere is whole.
TEST(ClippedVolume, LayeredBoundsHoldOnlyWithinTheirLayer) {
    ShyBound b;
    b.plane = {{1, 0, 0}, 0.5};
    b.low = -1e300;
    b.high = 0.2;
    const VolumePtr v = makeShyClipped(makeSphere(1.0), {b});
    EXPECT_FALSE(v->inside({0.7, 0, 0}));   // in the layer, beyond the plane
    EXPECT_TRUE(v->inside({0.7, 0.3, 0}));  // above the layer
    EXPECT_TRUE(v->inside({0.4, 0, 0}));
    EXPECT_TRUE(b.holds({0.7, 0.3, 0}));
    EXPECT_FALSE(b.holds({0.7, 0.1, 0}));
    EXPECT_TRUE(keepsAll({}, {9, 9, 9}));
    Rng rng(5);
    for (int i = 0; i < 200; ++i) {
        const auto p = v->sample(rng);
        ASSERT_TRUE(p);
        EXPECT_TRUE(b.holds(*p));
    }
    // The cap beyond x = 0.5 (h = 0.5, volume πh²(3r − h)/3) loses its part below y = 0.2:
    // what stays of it is the sphere clipped to x ≥ 0.5, y ≥ 0.2.
    const double cap = kPi * 0.5 * 0.5 * (3 - 0.5) / 3;
    const VolumePtr capAbove =
        makeClipped(makeSphere(1.0), {{{-1, 0, 0}, -0.5}, {{0, -1, 0}, -0.2}});
    EXPECT_NEAR(v->measure(), 4 * kPi / 3 - cap + capAbove->measure(), 0.05);
    EXPECT_EQ(makeShyClipped(makeSphere(1.0), {})->describe(), makeSphere(1.0)->describe());
}

}  // namespace
}  // namespace sylva
