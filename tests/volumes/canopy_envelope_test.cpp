// Canopy envelope (Shesh §3.2, Eq. 1): p = 0 is exactly the ellipsoid / cone, constant layers
// give f = Σ pⁱ cᵢ, blobs peak at their amplitude, packed image channels, seeds, jitter,
// measure against Monte Carlo, samples inside, bounds hold the surface, the spec reader.
#include "volumes/canopy_envelope.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/params.h"
#include "species/spec/volume_spec.h"
#include "species/spec/volume_spec_canopy_envelope.h"
#include "volumes/poisson.h"
#include "volumes/volume.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

CanopyLayer blobs(int count, double sigma, double amplitude = 1.0) {
    CanopyLayer l;
    l.kind = CanopyLayer::Kind::kBlobs;
    l.count = count;
    l.sigma = sigma;
    l.amplitude = amplitude;
    return l;
}

CanopyLayer noise(int resolution, double amplitude) {
    CanopyLayer l;
    l.kind = CanopyLayer::Kind::kNoise;
    l.resolution = resolution;
    l.amplitude = amplitude;
    return l;
}

CanopyLayer constantLayer(double c) {
    CanopyLayer l;
    l.kind = CanopyLayer::Kind::kGrid;
    l.grid.width = 4;
    l.grid.height = 3;
    l.grid.values.assign(12, static_cast<float>(c));
    return l;
}

// Three layers of blobs and noise: the Figure 2 kind of canopy.
CanopyEnvelopeOptions blobby(CanopyDomain domain, Vec3 radii) {
    CanopyEnvelopeOptions o;
    o.domain = domain;
    o.radii = radii;
    o.layers = {blobs(12, 0.08), blobs(10, 0.1), noise(16, 0.5)};
    return o;
}

// Same inside() on n points drawn in the box `b`; returns how many were inside.
int expectSameInside(const Volume& a, const Volume& b, const Aabb& box, int n, uint64_t seed) {
    Rng rng(seed);
    int in = 0, mismatches = 0;
    for (int i = 0; i < n; ++i) {
        const Vec3 p = rng.inBox(box);
        const bool ia = a.inside(p), ib = b.inside(p);
        in += ia;
        if (ia != ib && ++mismatches <= 3) {
            ADD_FAILURE() << "inside differs at (" << p.x << ", " << p.y << ", " << p.z
                          << "): " << ia << " vs " << ib;
        }
    }
    EXPECT_EQ(mismatches, 0);
    return in;
}

TEST(CanopyEnvelope, PersistenceZeroIsExactlyTheEllipsoid) {
    CanopyEnvelopeOptions o = blobby(CanopyDomain::kEllipsoid, {3, 2, 1.5});
    o.persistence = 0.0;  // p⁰ = 1 keeps g₀ = 1; every other layer is weighted 0
    Rng rng(11);
    auto env = makeCanopyEnvelope(o, rng);
    auto ell = makeEllipsoid({3, 2, 1.5});
    const int in = expectSameInside(*env, *ell, {{-4, -2.6, -2}, {4, 2.6, 2}}, 20000, 1);
    EXPECT_GT(in, 4000);  // the test saw both sides
    EXPECT_NEAR(env->measure(), 4.0 / 3.0 * kPi * 3 * 2 * 1.5, 0.005 * ell->measure());
    EXPECT_NEAR(env->fMax(), 1.0, 1e-9);
}

TEST(CanopyEnvelope, PersistenceZeroIsExactlyTheCone) {
    CanopyEnvelopeOptions o = blobby(CanopyDomain::kCone, {2, 5, 2});
    o.persistence = 0.0;
    Rng rng(12);
    auto env = makeCanopyEnvelope(o, rng);
    auto cone = makeCone(2, 5);
    expectSameInside(*env, *cone, {{-2.6, -0.5, -2.6}, {2.6, 5.5, 2.6}}, 20000, 2);
    EXPECT_NEAR(env->measure(), kPi * 4 * 5 / 3.0, 0.005 * cone->measure());
    // Elliptic base: the cone scaled in x and z.
    o.radii = {2, 5, 1.2};
    auto env2 = makeCanopyEnvelope(o, rng);
    Placement scaled;
    scaled.scale = {2, 1, 1.2};
    auto cone2 = makePlaced(makeCone(1, 5), scaled);
    expectSameInside(*env2, *cone2, {{-2.6, -0.5, -1.6}, {2.6, 5.5, 1.6}}, 20000, 3);
    EXPECT_NEAR(env2->measure(), kPi * 2 * 1.2 * 5 / 3.0, 0.005 * cone2->measure());
}

TEST(CanopyEnvelope, ConstantLayersGiveTheWeightedSum) {
    CanopyEnvelopeOptions o;
    o.radii = {2, 3, 1};
    o.persistence = 0.6;
    o.layers = {constantLayer(0.4), constantLayer(0.25)};
    Rng rng(1);
    auto env = makeCanopyEnvelope(o, rng);  // jitter on: it cannot matter for a constant f
    const double want = 1 + 0.6 * 0.4 + 0.36 * 0.25;
    for (double phi : {0.0, 0.7, 2.0, 3.3, 5.9}) {
        for (double theta : {0.0, 0.4, 1.5, 2.9, kPi}) {
            EXPECT_NEAR(env->f(phi, theta), want, 1e-6);
            const Vec3 s = env->surfacePoint(phi, theta);
            const Vec3 dir{std::sin(theta) * std::cos(phi) * 2, std::cos(theta) * 3,
                           std::sin(theta) * std::sin(phi) * 1};
            EXPECT_NEAR(distance(s, dir * want), 0.0, 1e-6);
            EXPECT_TRUE(env->inside(s * 0.999));
            EXPECT_FALSE(env->inside(s * 1.001));
        }
    }
    EXPECT_NEAR(env->measure(), 4.0 / 3.0 * kPi * 6 * want * want * want, 1e-3);
    EXPECT_LE(env->fMax(), want + 1e-6);
    EXPECT_GE(env->fMax(), want - 1e-6);
}

TEST(CanopyEnvelope, BlobPeaksAtItsAmplitude) {
    CanopyEnvelopeOptions o;
    o.persistence = 0.7;
    o.jitter = 0.0;
    CanopyLayer b = blobs(1, 0.05, 0.8);
    b.centres = {{0.25, 0.5}};
    o.layers = {b};  // layer 1: read at (frac(2u), frac(2v))
    Rng rng(1);
    auto env = makeCanopyEnvelope(o, rng);
    // Tile (0.25, 0.5) is global (u, v) = (0.125 or 0.625, 0.25 or 0.75).
    for (double u : {0.125, 0.625}) {
        for (double v : {0.25, 0.75}) {
            EXPECT_NEAR(env->f(2 * kPi * u, kPi * v), 1 + 0.7 * 0.8, 2e-3);
        }
    }
    // One σ away in the tile (σ/2 globally): the Gaussian's e^(−1/2).
    EXPECT_NEAR(env->f(2 * kPi * (0.125 + 0.025), kPi * 0.25), 1 + 0.56 * std::exp(-0.5), 2e-3);
    // Half a tile away in both directions: nothing left.
    EXPECT_NEAR(env->f(2 * kPi * 0.375, kPi * 0.5), 1.0, 1e-6);
    // The radius along the blob's direction grows by the same factor.
    const Vec3 s = env->surfacePoint(2 * kPi * 0.125, kPi * 0.25);
    EXPECT_NEAR(length(s), 1.56, 3e-3);
}

TEST(CanopyEnvelope, PackedChannelsReadTheRightChannel) {
    const fs::path dir = fs::temp_directory_path() / "sylva_canopy_channels";
    fs::create_directories(dir);
    const fs::path png = dir / "packed.png";
    {
        const int w = 8, h = 4, nc = 4;
        std::vector<uint8_t> px(w * h * nc);
        for (int i = 0; i < w * h; ++i)
            for (int c = 0; c < nc; ++c) px[i * nc + c] = static_cast<uint8_t>(51 * (c + 1));
        auto out = OIIO::ImageOutput::create(png.string());
        ASSERT_TRUE(out);
        OIIO::ImageSpec spec(w, h, nc, OIIO::TypeDesc::UINT8);
        spec.attribute("oiio:UnassociatedAlpha", 1);  // store the values as given
        ASSERT_TRUE(out->open(png.string(), spec));
        ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px.data()));
        out->close();
    }
    const CanopyImage img = readCanopyImage(png.string());
    ASSERT_EQ(img.channels, 4);
    for (int c = 0; c < 4; ++c) {
        const CanopyGrid g = img.channel(c);
        EXPECT_NEAR(g.at(0.3, 0.6), 0.2 * (c + 1), 1e-6) << "channel " << c;
    }
    // Through the envelope: layer 1 = channel 2 (0.6), layer 2 = channel 0 (0.2).
    CanopyEnvelopeOptions o;
    o.persistence = 0.5;
    CanopyLayer a, b;
    a.kind = b.kind = CanopyLayer::Kind::kGrid;
    a.grid = img.channel(2);
    b.grid = img.channel(0);
    o.layers = {a, b};
    Rng rng(1);
    auto env = makeCanopyEnvelope(o, rng);
    EXPECT_NEAR(env->f(1.0, 1.0), 1 + 0.5 * 0.6 + 0.25 * 0.2, 1e-6);
    EXPECT_THROW(readCanopyImage((dir / "missing.png").string()), std::runtime_error);
}

TEST(CanopyEnvelope, SameSeedSameEnvelopeOtherSeedDiffers) {
    const CanopyEnvelopeOptions o = blobby(CanopyDomain::kEllipsoid, {2, 2, 2});
    Rng r1(5), r2(5), r3(6);
    auto a = makeCanopyEnvelope(o, r1), b = makeCanopyEnvelope(o, r2),
         c = makeCanopyEnvelope(o, r3);
    int differ = 0;
    for (int i = 0; i < 50; ++i) {
        for (int j = 0; j <= 25; ++j) {
            const double phi = 2 * kPi * i / 50, theta = kPi * j / 25;
            EXPECT_EQ(a->f(phi, theta), b->f(phi, theta));
            differ += std::abs(a->f(phi, theta) - c->f(phi, theta)) > 1e-3;
        }
    }
    EXPECT_EQ(a->measure(), b->measure());
    EXPECT_GT(differ, 500);  // most of the 1300 directions
}

TEST(CanopyEnvelope, ZeroJitterIsThePureSum) {
    CanopyEnvelopeOptions o = blobby(CanopyDomain::kEllipsoid, {1, 1, 1});
    o.jitter = 0.0;
    Rng r0(9);
    auto pure = makeCanopyEnvelope(o, r0);
    o.jitter = 5.0 * kPi / 180;
    Rng r1(9);
    auto jittered = makeCanopyEnvelope(o, r1);  // same layers: the jitter has its own stream
    ASSERT_EQ(pure->layerCount(), 4u);
    Rng rng(3);
    int moved = 0;
    for (int i = 0; i < 1000; ++i) {
        const double phi = rng.uniform(0, 2 * kPi), theta = rng.uniform(0, kPi);
        double sum = 0.0, w = 1.0;
        for (size_t l = 0; l < pure->layerCount(); ++l, w *= 0.7) {
            sum += w * pure->layerValue(l, phi, theta);
            EXPECT_EQ(pure->layerValue(l, phi, theta), jittered->layerValue(l, phi, theta));
        }
        EXPECT_NEAR(pure->f(phi, theta), sum, 1e-12);
        moved += std::abs(jittered->f(phi, theta) - sum) > 1e-6;
    }
    EXPECT_GT(moved, 900);
}

TEST(CanopyEnvelope, MeasureMatchesMonteCarlo) {
    for (CanopyDomain d : {CanopyDomain::kEllipsoid, CanopyDomain::kCone}) {
        Rng rng(21);
        auto env = makeCanopyEnvelope(blobby(d, {2, 3, 1.5}), rng);
        const Aabb b = env->bounds();
        Rng mc(4);
        const int n = 200000;
        int hits = 0;
        for (int i = 0; i < n; ++i) hits += env->inside(mc.inBox(b));
        const double estimate = b.volume() * hits / n;  // ±~0.5 % at this n
        EXPECT_NEAR(env->measure(), estimate, 0.02 * estimate) << env->describe();
        // Blobs made it bigger than the plain domain.
        const double plain = (d == CanopyDomain::kCone ? 1.0 / 3.0 : 4.0 / 3.0) * kPi * 2 * 3 * 1.5;
        EXPECT_GT(env->measure(), 1.5 * plain);
    }
}

TEST(CanopyEnvelope, BoundsHoldTheSurfaceAndSamplesLieInside) {
    for (CanopyDomain d : {CanopyDomain::kEllipsoid, CanopyDomain::kCone}) {
        Rng rng(31);
        auto env = makeCanopyEnvelope(blobby(d, {2, 3, 1.5}), rng);
        Aabb b = env->bounds();
        double fMaxSeen = 0;
        for (int i = 0; i < 400; ++i) {
            for (int j = 0; j <= 200; ++j) {
                const double phi = 2 * kPi * (i + 0.37) / 400, theta = kPi * j / 200;
                fMaxSeen = std::max(fMaxSeen, env->f(phi, theta));
                ASSERT_TRUE(b.contains(env->surfacePoint(phi, theta)));
            }
        }
        EXPECT_LE(fMaxSeen, env->fMax());
        EXPECT_LT(env->fMax(), 1.15 * fMaxSeen);  // not needlessly loose
        PoissonOptions po;
        po.count = 300;
        po.minDistance = 0.15;
        Rng srng(8);
        const std::vector<Vec3> pts = poissonSample(*env, po, srng);
        ASSERT_EQ(pts.size(), 300u);
        for (const Vec3& p : pts) ASSERT_TRUE(env->inside(p));
    }
}

// |signedDistance| never exceeds the distance to a dense set of surface points (which is at
// least the true distance), and its sign is the inside test.
TEST(CanopyEnvelope, SignedDistanceIsABound) {
    for (CanopyDomain d : {CanopyDomain::kEllipsoid, CanopyDomain::kCone}) {
        Rng rng(41);
        auto env = makeCanopyEnvelope(blobby(d, {2, 3, 1.5}), rng);
        std::vector<Vec3> surface;
        for (int i = 0; i < 200; ++i)
            for (int j = 0; j <= 100; ++j)
                surface.push_back(env->surfacePoint(2 * kPi * i / 200, kPi * j / 100));
        Rng prng(5);
        Aabb b = env->bounds();
        int violations = 0;
        for (int k = 0; k < 400; ++k) {
            const Vec3 p = prng.inBox(b);
            double nearest = 1e300;
            for (const Vec3& s : surface) nearest = std::min(nearest, distance2(p, s));
            const double sd = env->signedDistance(p);
            if (d == CanopyDomain::kCone && env->inside({p.x, 0.0, p.z})) {
                nearest = std::min(nearest, p.y * p.y);  // the base disc is surface too
            }
            violations += std::abs(sd) > std::sqrt(nearest) + 1e-9;
        }
        EXPECT_EQ(violations, 0) << env->describe();
    }
}

// --- the spec reader -------------------------------------------------------------------

struct Parsed {
    VolumePtr volume;
    bool perInstance = false;
};

Parsed parseCrown(const std::string& toml, uint64_t seed, const fs::path& file) {
    toml::table t = toml::parse(toml, file.string());
    DrawContext draw;
    draw.seed = seed;
    Params p(t, file.string(), "crown", &draw);
    Parsed out;
    out.volume = parseVolume(p);
    out.perInstance = draw.perInstance;
    return out;
}

TEST(CanopyEnvelopeSpec, SeedFixesTheEnvelopeOtherwiseDrawnPerTree) {
    const fs::path file = fs::temp_directory_path() / "sylva_canopy_spec.toml";
    const std::string body =
        "type = \"canopy-envelope\"\nradii = [2, 3, 2]\n"
        "layers = [ { type = \"blobs\", count = 8, sigma = 0.1 }, { type = \"noise\" } ]\n";
    Parsed a = parseCrown(body + "seed = 4\n", 1, file);
    Parsed b = parseCrown(body + "seed = 4\n", 2, file);
    EXPECT_FALSE(a.perInstance);
    EXPECT_EQ(a.volume->measure(), b.volume->measure());
    Parsed c = parseCrown(body, 1, file), d = parseCrown(body, 2, file),
           e = parseCrown(body, 1, file);
    EXPECT_TRUE(c.perInstance);
    EXPECT_NE(c.volume->measure(), d.volume->measure());
    EXPECT_EQ(c.volume->measure(), e.volume->measure());
    // Nothing random (no layers, no jitter): not drawn per tree.
    Parsed f =
        parseCrown("type = \"canopy-envelope\"\nradii = [1, 1, 1]\njitter_deg = 0\n", 1, file);
    EXPECT_FALSE(f.perInstance);
    EXPECT_NEAR(f.volume->measure(), 4.0 / 3.0 * kPi, 1e-9);
}

TEST(CanopyEnvelopeSpec, ErrorsNameTheKey) {
    const fs::path dir = fs::temp_directory_path() / "sylva_canopy_spec_errors";
    fs::create_directories(dir);
    const fs::path png = dir / "grey.png";
    {
        std::vector<uint8_t> px(16 * 8 * 2, 128);
        auto out = OIIO::ImageOutput::create(png.string());
        OIIO::ImageSpec spec(16, 8, 2, OIIO::TypeDesc::UINT8);
        ASSERT_TRUE(out && out->open(png.string(), spec));
        ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px.data()));
        out->close();
    }
    const fs::path file = dir / "s.toml";
    auto error = [&](const std::string& body) -> std::string {
        try {
            parseCrown("type = \"canopy-envelope\"\n" + body, 1, file);
        } catch (const SpecError& e) {
            return e.what();
        }
        return "(no error)";
    };
    EXPECT_NE(error("radii = [1, 1, 1]\npersistence = 1.3\n")
                  .find("crown.persistence: expected a number in [0, 1], got 1.3"),
              std::string::npos);
    EXPECT_NE(error("radii = [1, 0, 1]\n").find("crown.radii[1]"), std::string::npos);
    EXPECT_NE(error("persistence = 0.5\n").find("crown.radii: required"), std::string::npos);
    EXPECT_NE(error("radii = [1, 1, 1]\nlayers = [ { type = \"image\", image = \"nope.png\" } ]\n")
                  .find("crown.layers[0].image: file not found"),
              std::string::npos);
    EXPECT_NE(error("radii = [1, 1, 1]\n"
                    "layers = [ { type = \"image\", image = \"grey.png\", channel = 2 } ]\n")
                  .find("crown.layers[0].channel: the image has 2 channels (0–1), got 2"),
              std::string::npos);
    EXPECT_NE(error("radii = [1, 1, 1]\nlayers = [ { type = \"blob\" } ]\n")
                  .find("did you mean \"blobs\""),
              std::string::npos);
    EXPECT_NE(error("radii = [1, 1, 1]\nlayers = [ { type = \"noise\", sigma = 2 } ]\n")
                  .find("crown.layers[0].sigma: unknown key"),
              std::string::npos);
    // Two layers from the same packed image, and a base channel.
    Parsed ok = parseCrown(
        "type = \"canopy-envelope\"\nradii = [1, 1, 1]\njitter_deg = 0\npersistence = 0.5\n"
        "base_image = \"grey.png\"\nbase_channel = 1\n"
        "layers = [ { type = \"image\", image = \"grey.png\", channel = 1 } ]\n",
        1, file);
    const double g = 128.0 / 255.0;
    EXPECT_NEAR(ok.volume->measure(), 4.0 / 3.0 * kPi * std::pow(1.5 * g, 3), 1e-4);
}

}  // namespace
}  // namespace sylva
