// The scanner against known answers: ranges to a plane, a sphere and a cylinder; the beam's
// footprint; range noise; returns per pulse; labels of the triangles hit; the occlusion of a
// trunk seen from one station; the same points on 1 and 2 threads; ALS/ULS strips and angles;
// TLS times with the mirror's dead time and LAS 1.4 scan angles; a sub-ray's energy counted once
// per return; labels and their purity from the energy of the surfaces in a return.
#include "pipeline/scan/scanner.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "core/errors.h"
#include "pipeline/render/plot_render.h"
#include "pipeline/scan/scan_pattern.h"
#include "species/geometry/leaf_mesh.h"
#include "species/geometry/tube_mesh.h"
#include "tests/plot_fixture.h"
#include "tests/test_support.h"

using namespace sylva;

namespace {

// A quad (two triangles) with corners c ± a ± b.
Mesh quad(const Vec3& c, const Vec3& a, const Vec3& b) {
    Mesh m;
    for (const Vec3& p : {c - a - b, c + a - b, c + a + b, c - a + b}) {
        for (double v : {p.x, p.y, p.z}) m.positions.push_back(static_cast<float>(v));
    }
    m.indices = {0, 1, 2, 0, 2, 3};
    return m;
}

// A UV sphere of `n` rings × 2n segments.
Mesh sphere(const Vec3& c, double r, int n) {
    Mesh m;
    for (int i = 0; i <= n; ++i) {
        const double th = kPi * i / n;
        for (int j = 0; j < 2 * n; ++j) {
            const double ph = kPi * j / n;
            const Vec3 p =
                c +
                Vec3{std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)} * r;
            for (double v : {p.x, p.y, p.z}) m.positions.push_back(static_cast<float>(v));
        }
    }
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < 2 * n; ++j) {
            const uint32_t a = i * 2 * n + j, b = i * 2 * n + (j + 1) % (2 * n);
            const uint32_t c2 = a + 2 * n, d = b + 2 * n;
            m.indices.insert(m.indices.end(), {a, c2, b, b, c2, d});
        }
    }
    return m;
}

// An open vertical cylinder of `sides` around (x, z), y from y0 to y1.
Mesh cylinder(double x, double z, double r, double y0, double y1, int sides) {
    Mesh m;
    for (int j = 0; j < sides; ++j) {
        const double a = 2 * kPi * j / sides;
        for (double y : {y0, y1}) {
            for (double v : {x + r * std::cos(a), y, z + r * std::sin(a)}) {
                m.positions.push_back(static_cast<float>(v));
            }
        }
    }
    for (int j = 0; j < sides; ++j) {
        const uint32_t a = 2 * j, b = 2 * ((j + 1) % sides);
        m.indices.insert(m.indices.end(), {a, b, a + 1, b, b + 1, a + 1});
    }
    return m;
}

// A TLS looking north (−z) from (0, height 1.5, 0) over a small window, one ray per pulse, no
// noise, every leaf opaque.
ScanOptions window(double halfDeg, double stepDeg) {
    ScanOptions o = defaultScanOptions(ScanPlatform::kTls);
    o.stations = {{0, 0, 1.5}};
    o.horizontalFov = 2 * halfDeg * kScanDeg;
    o.verticalFov = 2 * halfDeg * kScanDeg;
    o.verticalCentre = 0;
    o.horizontalStep = o.verticalStep = stepDeg * kScanDeg;
    o.rangeNoise = 0;
    o.leafTransmission = 0;
    o.minRange = 0.1;
    return o;
}

const Vec3 kStation{0, 1.5, 0};

Vec3 pointOf(const ScanPoint& p) { return {p.x, p.y, p.z}; }

// Every field of every point, as bytes (ScanPoint has padding, so not memcmp of the structs).
std::string bytesOf(const std::vector<ScanPoint>& pts) {
    std::string s;
    auto put = [&](const auto& v) { s.append(reinterpret_cast<const char*>(&v), sizeof v); };
    for (const ScanPoint& p : pts) {
        put(p.x), put(p.y), put(p.z), put(p.gpsTime), put(p.intensity), put(p.returnNumber);
        put(p.numberOfReturns), put(p.channel), put(p.sourceId), put(p.scanDirection);
        put(p.edgeOfFlightLine), put(p.scanAngleDeg), put(p.pulse), put(p.label.treeId);
        put(p.label.nodeId), put(p.label.objectId), put(p.label.species), put(p.label.part);
        put(p.label.branchOrder), put(p.classification), put(p.semantic), put(p.elevationDeg);
        put(p.labelPurity);
    }
    return s;
}

// A tree's tube and leaf meshes as the build makes them, with the skeleton node of every wood
// triangle.
std::pair<TreeMesh, std::vector<int32_t>> meshTree(const Tree& tree) {
    std::pair<TreeMesh, std::vector<int32_t>> m;
    m.first.wood = tubeMesh(tree, TubeOptions{}, &m.second);
    m.first.leaves = leafMesh(tree);
    return m;
}

}  // namespace

TEST(Scanner, PlaneAtKnownDistanceGivesTheAnalyticRange) {
    ScanScene s;
    s.addMesh(quad({0, 1.5, -10}, {5, 0, 0}, {0, 5, 0}), kScanTerrain);  // the plane z = −10
    s.commit();
    const ScanResult r = scan(s, window(10, 1), 1);
    ASSERT_EQ(r.pulses, 21u * 21u);
    ASSERT_EQ(r.points.size(), r.pulses);  // every pulse within ±10° hits the 10 m wide plane
    for (const ScanPoint& p : r.points) {
        const Vec3 d = normalize(pointOf(p) - kStation);
        EXPECT_NEAR(p.z, -10.0, 1e-5);
        EXPECT_NEAR(distance(pointOf(p), kStation), 10.0 / -d.z, 1e-4);
        EXPECT_EQ(p.returnNumber, 1);
        EXPECT_EQ(p.numberOfReturns, 1);
        EXPECT_EQ(p.classification, kForTerrain);
        EXPECT_EQ(p.semantic, kSemGround);
    }
}

TEST(Scanner, SphereAndCylinderGiveTheAnalyticRangeWithinTheTessellation) {
    const Vec3 c{0, 1.5, -8};
    const double R = 1.0;
    const int n = 64;  // sagitta of the sphere's facets: R (1 − cos(π / n)) ≈ 1.2 mm
    ScanScene s;
    s.addMesh(sphere(c, R, n), kScanStem);
    s.addMesh(cylinder(3, -6, 0.4, -5, 8, 128), kScanStem);  // axis (3, ·, −6), r = 0.4
    s.commit();
    ScanOptions o = window(30, 0.5);
    const ScanResult r = scan(s, o, 2);
    int onSphere = 0, onCylinder = 0;
    for (const ScanPoint& p : r.points) {
        const Vec3 d = normalize(pointOf(p) - kStation);
        const double range = distance(pointOf(p), kStation);
        if (p.label.objectId == 0) {  // ray–sphere: |o + t d − c| = R
            const Vec3 oc = kStation - c;
            const double b = dot(oc, d), disc = b * b - (dot(oc, oc) - R * R);
            ASSERT_GE(disc, -1e-3);
            const double t = -b - std::sqrt(std::max(0.0, disc));
            // A ray near the limb meets a facet farther along it than the sphere; bound by the
            // sagitta over the cosine of incidence (within the limb's last degrees: skipped).
            const Vec3 nrm = normalize(kStation + d * t - c);
            const double cosI = -dot(d, nrm);
            if (cosI < 0.2) continue;
            EXPECT_NEAR(range, t, 1.3e-3 / cosI + 1e-4);
            ++onSphere;
        } else {  // ray–cylinder in x–z
            const double ox = kStation.x - 3, oz = kStation.z + 6;
            const double a = d.x * d.x + d.z * d.z, b = ox * d.x + oz * d.z;
            const double cc = ox * ox + oz * oz - 0.16;
            const double t = (-b - std::sqrt(b * b - a * cc)) / a;
            const Vec3 h = kStation + d * t;
            const Vec3 nrm = normalize(Vec3{h.x - 3, 0, h.z + 6});
            const double cosI = -dot(d, nrm);
            if (cosI < 0.2) continue;
            EXPECT_NEAR(range, t, 0.4 * (1 - std::cos(kPi / 128)) / cosI + 1e-4);
            ++onCylinder;
        }
    }
    EXPECT_GT(onSphere, 300);
    EXPECT_GT(onCylinder, 50);
}

TEST(Scanner, BeamDivergenceSpreadsReturnsOverTheFootprint) {
    // A 10 cm square target 20 m north; a 20 mrad beam has a footprint radius of
    // 20 · tan(10 mrad) ≈ 0.2 m there: pulses whose axis passes up to that far from the square
    // still return from it, and none farther.
    const double range = 20, half = 0.05, div = 20e-3;
    const double footprint = range * std::tan(div / 2);
    ScanScene s;
    s.addMesh(quad({0, 1.5, -range}, {half, 0, 0}, {0, half, 0}), kScanStem);
    s.commit();
    ScanOptions o = window(1.5, 0.05);
    o.beamDivergence = div;
    o.subRays = 19;
    const ScanPattern pattern(s, o);
    double farthest = 0;
    for (int subRays : {1, 19}) {
        o.subRays = subRays;
        const ScanResult r = scan(s, o, 3);
        ASSERT_FALSE(r.points.empty());
        double far = 0;
        for (const ScanPoint& p : r.points) {
            ScanPulse pulse;
            pattern.pulse(p.pulse, pulse);
            const Vec3 at = pulse.origin + pulse.direction * (range / -pulse.direction.z);
            const double dx = std::max(0.0, std::abs(at.x) - half);
            const double dy = std::max(0.0, std::abs(at.y - 1.5) - half);
            far = std::max(far, std::hypot(dx, dy));
            EXPECT_NEAR(p.z, -range, 1e-4);
        }
        if (subRays == 1) {
            EXPECT_LT(far, 0.01);  // the axis alone: only pulses aimed at the square
        } else {
            farthest = far;
        }
    }
    EXPECT_LE(farthest, footprint * 1.02);
    EXPECT_GE(farthest, footprint * 0.85);  // the outer sub-rays reach the footprint's rim
}

TEST(Scanner, TlsTimesCountTheMirrorsDeadTimeAndAnglesAreLas14s) {
    // Two stations, 21 columns × 21 rows (±10° at 1°): the mirror sweeps 240° per column at the
    // pulse rate, so a column takes 240 shot times of which the first 21 are shot.
    ScanScene s;
    s.addMesh(quad({0, 1.5, -10}, {5, 0, 0}, {0, 5, 0}), kScanTerrain);
    s.commit();
    ScanOptions o = window(10, 1);
    o.stations = {{0, 0, 1.5}, {0, 0, 1.5}};
    ASSERT_NEAR(o.lineSweep, 240 * kScanDeg, 1e-12);  // the VZ-400's
    const ScanResult r = scan(s, o, 1);
    ASSERT_EQ(r.points.size(), 2u * 21 * 21);
    for (const ScanPoint& p : r.points) {
        const uint64_t station = p.pulse / 441, col = p.pulse % 441 / 21, row = p.pulse % 21;
        EXPECT_EQ(p.gpsTime, static_cast<double>((station * 21 + col) * 240 + row) / 300000);
        EXPECT_EQ(p.sourceId, station + 1);  // LAS reads 0 as "no source"
        EXPECT_EQ(p.channel, station % 4);
        // The beam's elevation, and LAS 1.4's scan angle: from the downward vertical, clockwise
        // (negative) seen from behind the clockwise-turning head.
        const double elevation = -10.0 + static_cast<double>(row);
        EXPECT_NEAR(p.elevationDeg, elevation, 1e-4);
        EXPECT_NEAR(p.scanAngleDeg, -(90 + elevation), 1e-4);
    }
    ASSERT_EQ(r.trajectory.size(), 2u);
    EXPECT_EQ(r.trajectory[0].gpsTime, 0.0);
    EXPECT_EQ(r.trajectory[1].gpsTime, 21.0 * 240 / 300000);
    EXPECT_EQ(r.trajectory[0].sourceId, 1);
    EXPECT_EQ(r.trajectory[1].sourceId, 2);
    // A sweep no wider than the field: no dead time, pulses back to back.
    o.lineSweep = o.verticalFov;
    const ScanResult tight = scan(s, o, 1);
    for (const ScanPoint& p : tight.points) {
        EXPECT_EQ(p.gpsTime, static_cast<double>(p.pulse) / 300000);
    }
}

TEST(Scanner, ASubRayThroughStackedLeavesCountsItsEnergyOnceInTheReturn) {
    // Three parallel leaves 10 cm apart, every sub-ray passing every leaf (transmission 1): one
    // return per pulse, whose intensity is that of the first leaf alone (each sub-ray's echoes
    // are equal), not three times it.
    auto leaves = [](int n) {
        ScanScene s;
        for (int k = 0; k < n; ++k) {
            s.addMesh(quad({0, 1.5, -5.0 - 0.1 * k}, {2, 0, 0}, {0, 2, 0}), kScanLeaf);
        }
        s.commit();
        return s;
    };
    ScanOptions o = window(2, 1);
    o.leafTransmission = 1;
    o.subRays = 7;
    o.beamDivergence = 3e-3;
    const ScanScene one = leaves(1), three = leaves(3);
    const ScanResult a = scan(one, o, 4), b = scan(three, o, 4);
    ASSERT_EQ(a.points.size(), a.pulses);
    ASSERT_EQ(b.points.size(), b.pulses);
    for (size_t i = 0; i < a.points.size(); ++i) {
        EXPECT_EQ(b.points[i].numberOfReturns, 1);
        EXPECT_EQ(b.points[i].intensity, a.points[i].intensity) << "pulse " << i;
        EXPECT_NEAR(a.points[i].intensity, 65535 * 0.3, 65535 * 0.3 * 0.01);  // ρ_leaf, head-on
        EXPECT_EQ(b.points[i].labelPurity, 1.0f);
    }
}

TEST(Scanner, AReturnIsLabelledByTheSurfaceEchoingMostWithItsShareAsPurity) {
    // A leaf (ρ 0.3) left of x ≈ 0 and a bark quad (ρ 0.5) right of it, 5 m north, every beam
    // straddling the edge (a 0.25 m footprint, pulses within 4 cm of it). The leaf's and the
    // bark's energy in each return are what each scans alone (the same seed turns the sub-ray
    // pattern alike): the point takes the larger one's label, and its share as purity.
    // (The edge at x = 1.3 cm, off every pulse's axis: an axis on the edge hits the leaf
    // alone and the bark alone, and only one of them when both are there.)
    const Mesh leafHalf = quad({-0.987, 1.5, -5}, {1, 0, 0}, {0, 2, 0});
    const Mesh barkHalf = quad({1.013, 1.5, -5}, {1, 0, 0}, {0, 2, 0});
    auto sceneOf = [&](bool leaf, bool bark) {
        ScanScene s;
        if (leaf) s.addMesh(leafHalf, kScanLeaf);
        if (bark) s.addMesh(barkHalf, kScanStem);
        s.commit();
        return s;
    };
    ScanOptions o = window(0.5, 0.5);
    o.subRays = 19;
    o.beamDivergence = 0.05;
    const ScanScene both = sceneOf(true, true), leaf = sceneOf(true, false),
                    bark = sceneOf(false, true);
    const ScanResult r = scan(both, o, 9), rl = scan(leaf, o, 9), rb = scan(bark, o, 9);
    ASSERT_EQ(r.points.size(), r.pulses);
    ASSERT_EQ(rl.points.size(), r.pulses);
    ASSERT_EQ(rb.points.size(), r.pulses);
    int wood = 0, leafy = 0;
    for (size_t i = 0; i < r.points.size(); ++i) {
        const ScanPoint& p = r.points[i];
        const double el = rl.points[i].intensity, eb = rb.points[i].intensity;
        ASSERT_GT(el, 0);
        ASSERT_GT(eb, 0);
        EXPECT_NEAR(p.intensity, el + eb, 1.0);
        EXPECT_NEAR(p.labelPurity, std::max(el, eb) / (el + eb), 2.0 / (el + eb));
        EXPECT_LT(p.labelPurity, 1.0f);
        EXPECT_EQ(p.semantic, eb > el ? kSemWood : kSemLeaf) << "pulse " << i;
        (p.semantic == kSemWood ? wood : leafy) += 1;
    }
    EXPECT_GT(wood, 0);  // bark's higher reflectance wins where the footprint is shared evenly
}

TEST(Scanner, EchoesBelowTheDetectionThresholdAreNoReturns) {
    // Bark covering the left of the beams 10 m off (each pulse hits it with a different share
    // of its sub-rays) before a wall at 20 m: with a threshold, a pulse keeps exactly those of
    // its returns at threshold 0 whose intensity reaches it, the same points renumbered.
    ScanScene s;
    s.addMesh(quad({-1.0, 1.5, -10}, {1, 0, 0}, {0, 2, 0}), kScanStem);  // x from −2 to 0
    s.addMesh(quad({0, 1.5, -20}, {5, 0, 0}, {0, 5, 0}), kScanTerrain);
    s.commit();
    ScanOptions o = window(0.3, 0.1);
    o.subRays = 19;
    o.beamDivergence = 0.02;  // 10 cm footprint radius at 10 m
    const ScanResult all = scan(s, o, 2);
    std::vector<int> levels;
    for (const ScanPoint& p : all.points) levels.push_back(p.intensity);
    std::sort(levels.begin(), levels.end());
    levels.erase(std::unique(levels.begin(), levels.end()), levels.end());
    ASSERT_GT(levels.size(), 10u);
    // Halfway between two stored levels, so rounding decides nothing.
    const size_t m = levels.size() / 2;
    const double cut = 0.5 * (levels[m - 1] + levels[m]);
    o.detectionThreshold = cut / 65535.0;
    const ScanResult kept = scan(s, o, 2);
    std::map<uint64_t, std::vector<const ScanPoint*>> want;
    for (const ScanPoint& p : all.points) {
        if (p.intensity > cut) want[p.pulse].push_back(&p);
    }
    size_t n = 0;
    for (const auto& [pulse, pts] : want) n += pts.size();
    ASSERT_EQ(kept.points.size(), n);
    ASSERT_LT(n, all.points.size());
    ASSERT_GT(n, 0u);
    size_t i = 0;
    for (const auto& [pulse, pts] : want) {
        for (size_t r = 0; r < pts.size(); ++r, ++i) {
            const ScanPoint& p = kept.points[i];
            EXPECT_EQ(p.pulse, pulse);
            EXPECT_EQ(p.x, pts[r]->x);
            EXPECT_EQ(p.z, pts[r]->z);
            EXPECT_EQ(p.intensity, pts[r]->intensity);
            EXPECT_EQ(p.returnNumber, r + 1);
            EXPECT_EQ(p.numberOfReturns, pts.size());
        }
    }
}

TEST(Scanner, RangeNoiseHasTheRequestedStandardDeviation) {
    ScanScene s;
    s.addMesh(quad({0, 1.5, -10}, {5, 0, 0}, {0, 5, 0}), kScanTerrain);
    s.commit();
    ScanOptions o = window(10, 0.25);
    o.rangeNoise = 0.05;
    const ScanResult r = scan(s, o, 4);
    ASSERT_EQ(r.points.size(), 81u * 81u);
    double sum = 0, sum2 = 0;
    for (const ScanPoint& p : r.points) {
        const Vec3 d = normalize(pointOf(p) - kStation);
        const double e = distance(pointOf(p), kStation) - 10.0 / -d.z;  // along the beam
        sum += e;
        sum2 += e * e;
    }
    const double n = static_cast<double>(r.points.size());
    const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
    // n = 6561: the sd of a sample sd is σ / √(2n) ≈ 0.9 % of σ; of the mean σ / √n ≈ 1.2 %.
    EXPECT_NEAR(sd, 0.05, 0.05 * 0.05);
    EXPECT_NEAR(mean, 0.0, 0.05 * 0.05);
}

TEST(Scanner, ReturnsPerPulseNeverExceedTheMaximum) {
    // Ten leaf layers 1 m apart, half transparent: pulses echo from several.
    ScanScene s;
    for (int k = 0; k < 10; ++k) {
        s.addMesh(quad({0, 1.5, -5.0 - k}, {4, 0, 0}, {0, 4, 0}), kScanLeaf);
    }
    s.commit();
    ScanOptions o = window(10, 0.5);
    o.leafTransmission = 0.6;
    o.subRays = 7;
    o.beamDivergence = 3e-3;
    o.minSeparation = 0.5;
    for (int maxReturns : {1, 3, 15}) {
        o.maxReturns = maxReturns;
        const ScanResult r = scan(s, o, 5);
        std::map<uint64_t, std::vector<const ScanPoint*>> byPulse;
        for (const ScanPoint& p : r.points) byPulse[p.pulse].push_back(&p);
        int most = 0;
        for (const auto& [k, pts] : byPulse) {
            ASSERT_LE(pts.size(), static_cast<size_t>(maxReturns));
            for (size_t i = 0; i < pts.size(); ++i) {
                EXPECT_EQ(pts[i]->returnNumber, i + 1);
                EXPECT_EQ(pts[i]->numberOfReturns, pts.size());
                if (i > 0) {
                    EXPECT_GT(-pts[i]->z, -pts[i - 1]->z + 0.5);  // farther, separated
                }
            }
            most = std::max(most, static_cast<int>(pts.size()));
        }
        EXPECT_EQ(most, std::min(maxReturns, 10)) << "max_returns " << maxReturns;
        EXPECT_EQ(byPulse.size(), r.pulses);  // the first layer is hit by every pulse
    }
}

TEST(Scanner, EveryPointCarriesTheLabelOfTheTriangleItHit) {
    const Tree tree = test::handTree(6, 0.2, 2.0, 0.3);
    const auto [mesh, nodes] = meshTree(tree);
    const ScanScene s = makeScanScene(tree, mesh, nodes, 10);
    ScanOptions o = defaultScanOptions(ScanPlatform::kTls);
    o.stations = {{0, 6, 1.5}};
    o.horizontalStep = o.verticalStep = 0.5 * kScanDeg;
    o.rangeNoise = 0;
    o.leafTransmission = 0;
    const ScanResult r = scan(s, o, 6);
    // Brute force: the triangles each point lies on (within 0.1 mm).
    auto onTriangle = [](const Mesh& m, size_t t, const Vec3& p) {
        Vec3 v[3];
        for (int c = 0; c < 3; ++c) {
            const uint32_t i = m.indices[3 * t + c];
            v[c] = {m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]};
        }
        const Vec3 n = cross(v[1] - v[0], v[2] - v[0]);
        const double area2 = length(n);
        if (area2 <= 0 || std::abs(dot(p - v[0], n)) / area2 > 1e-4) return false;
        double sum = 0;  // barycentric areas
        for (int c = 0; c < 3; ++c) sum += length(cross(v[(c + 1) % 3] - p, v[(c + 2) % 3] - p));
        return sum <= area2 * (1 + 1e-4) + 1e-8;
    };
    int wood = 0, leaves = 0, ground = 0;
    for (const ScanPoint& p : r.points) {
        const Vec3 at = pointOf(p);
        if (p.label.part == kScanTerrain) {
            EXPECT_NEAR(p.y, 0.0, 1e-5);
            EXPECT_EQ(p.label.treeId, 0);
            EXPECT_EQ(p.classification, kForTerrain);
            ++ground;
            continue;
        }
        EXPECT_EQ(p.label.treeId, 1);
        bool found = false;
        if (p.label.part == kScanLeaf) {
            const std::vector<uint32_t>& ix = mesh.leaves.indices;
            for (size_t t = 0; t < ix.size() / 3 && !found; ++t) {
                // Leaf t / 4 (a card: 2 front + 2 back triangles) carries node leaves[t / 4].node.
                const Leaf& leaf = tree.leaves[t / 4];
                found = onTriangle(mesh.leaves, t, at) &&
                        p.label.branchOrder == tree.nodes[leaf.node].order;
            }
            EXPECT_EQ(p.classification, kForLiveBranches);
            EXPECT_EQ(p.semantic, kSemLeaf);
            ++leaves;
        } else {
            for (size_t t = 0; t < nodes.size() && !found; ++t) {
                found = nodes[t] == p.label.nodeId && onTriangle(mesh.wood, t, at);
            }
            const SkeletonNode& n = tree.nodes[p.label.nodeId];
            EXPECT_EQ(p.label.branchOrder, n.order);
            EXPECT_EQ(p.label.part, n.order == 0 ? kScanStem : kScanBranch);
            // Every branch of the hand tree bears leaves: live branches (5); the trunk is 4.
            EXPECT_EQ(p.classification, n.order == 0 ? kForStem : kForLiveBranches);
            EXPECT_EQ(p.semantic, kSemWood);
            ++wood;
        }
        EXPECT_TRUE(found) << "point " << at.x << " " << at.y << " " << at.z << " part "
                           << int(p.label.part) << " node " << p.label.nodeId;
    }
    EXPECT_GT(wood, 100);
    EXPECT_GT(leaves, 10);
    EXPECT_GT(ground, 1000);
}

TEST(Scanner, OneStationSeesOnlyTheNearHalfOfATrunk) {
    // A straight trunk (r = 0.3 m, 16-sided tube) 5 m north of the station: every trunk point
    // lies on the half facing the station.
    Tree tree;
    int32_t prev = test::addNode(tree, -1, {0, 0, -5}, 0.3);
    for (int k = 1; k <= 8; ++k) prev = test::addNode(tree, prev, {0, 0.5 * k, -5}, 0.3);
    TreeMesh mesh;
    std::vector<int32_t> nodes;
    mesh.wood = tubeMesh(tree, TubeOptions{}, &nodes);
    const ScanScene s = makeScanScene(tree, mesh, nodes, 0);
    ScanOptions o = defaultScanOptions(ScanPlatform::kTls);
    o.stations = {{0, 0, 1.5}};
    o.horizontalFov = 12 * kScanDeg;  // the trunk spans ±3.4°
    o.verticalFov = 80 * kScanDeg;
    o.horizontalStep = o.verticalStep = 0.1 * kScanDeg;
    o.subRays = 19;  // the beam's rim reaches past the silhouette, never around it
    const ScanResult r = scan(s, o, 7);
    ASSERT_GT(r.points.size(), 1000u);
    int farSide = 0;
    for (const ScanPoint& p : r.points) {
        const Vec3 radial{p.x, 0, p.z + 5};  // from the axis
        if (dot(radial, Vec3{0, 0, 5}) < -0.01 * length(radial) * 5) ++farSide;
        EXPECT_EQ(p.label.part, kScanStem);
    }
    EXPECT_EQ(farSide, 0);
}

TEST(Scanner, OneAndTwoThreadsGiveTheSamePoints) {
    const Tree tree = test::handTree(6, 0.2, 2.0, 0.3);
    const auto [mesh, nodes] = meshTree(tree);
    const ScanScene s = makeScanScene(tree, mesh, nodes, 10);
    ScanOptions o = defaultScanOptions(ScanPlatform::kTls);
    o.stations = {{0, 5, 1.5}, {4, -3, 1.2}};
    o.horizontalStep = o.verticalStep = 0.8 * kScanDeg;
    o.verticalFov = 70 * kScanDeg;  // the tree and the ground around it
    o.verticalCentre = -10 * kScanDeg;
    o.subRays = 19;
    o.beamDivergence = 2e-3;
    o.leafTransmission = 0.5;
    o.rangeNoise = 0.01;
    ScanTuning small;
    small.pulsesPerBlock = 37;  // many blocks, so threads interleave
    std::string one, two;
    tbb::task_arena(1).execute([&] { one = bytesOf(scan(s, o, 8, small).points); });
    tbb::task_arena(2).execute([&] { two = bytesOf(scan(s, o, 8, small).points); });
    ASSERT_GT(one.size(), 100000u);
    EXPECT_TRUE(one == two);
    // And the ray modes agree (the same rays, the same hits).
    for (RayMode m : {RayMode::kSingle, RayMode::kStream}) {
        ScanTuning t = small;
        t.mode = m;
        std::string other;
        tbb::task_arena(2).execute([&] { other = bytesOf(scan(s, o, 8, t).points); });
        EXPECT_TRUE(other == one) << "mode " << int(m);
    }
    // Another seed draws other noise.
    std::string seed9;
    tbb::task_arena(2).execute([&] { seed9 = bytesOf(scan(s, o, 9, small).points); });
    EXPECT_FALSE(seed9 == one);
}

// Flat ground under a 60 × 40 m survey area (x −30 … 30, z −20 … 20), committed.
static void flatGround60By40(ScanScene& s) {
    s.addMesh(quad({0, 0, 0}, {100, 0, 0}, {0, 0, 100}), kScanTerrain);
    s.commit();
    Aabb area;
    area.extend(Vec3{-30, 0, -20});
    area.extend(Vec3{30, 0, 20});
    s.setArea(area);
}

TEST(Scanner, MoreStripsThanLasHasPointSourceIdsIsAnInputError) {
    // 40 m of strips 0.5 mm apart: 79,931 strips, each a point source ID of its own, where LAS
    // has 65,535 (a cap keeps the pulses few: it is the IDs that run out).
    ScanScene s;
    flatGround60By40(s);
    ScanOptions o = defaultScanOptions(ScanPlatform::kUls);
    o.heading = 90 * kScanDeg;
    o.altitude = 1;  // a swath of 2 · tan(1°) = 3.5 cm
    o.scanAngle = 1 * kScanDeg;
    o.stripSpacing = 0.0005;
    o.maxPulses = 1000;
    try {
        scan(s, o, 1);
        ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("65,535 point source IDs"), std::string::npos)
            << e.what();
    }
    o.stripSpacing = 0.01;  // 3,998 strips
    EXPECT_EQ(scan(s, o, 1).pulses, 1000u);
}

TEST(Scanner, AirborneStripsCoverTheAreaWithinTheScanAngle) {
    // A 60 × 40 m ground plane scanned by ULS (rotating mirror) and ALS (oscillating).
    ScanScene s;
    flatGround60By40(s);
    for (ScanPlatform platform : {ScanPlatform::kUls, ScanPlatform::kAls}) {
        ScanOptions o = defaultScanOptions(platform);
        o.rangeNoise = 0;
        o.heading = 90 * kScanDeg;  // east: strips along x, spread along z
        if (platform == ScanPlatform::kUls) {
            o.altitude = 40;
            o.scanAngle = 30 * kScanDeg;
            o.pulseRate = 20000;
        } else {
            o.altitude = 500;
            o.pulseRate = 20000;
            o.scanRate = 40;
        }
        const ScanResult r = scan(s, o, 10);
        ASSERT_GT(r.points.size(), 1000u);
        const double swath = 2 * o.altitude * std::tan(o.scanAngle);
        const double spacing = swath * (1 - o.overlap);
        const int strips = 1 + static_cast<int>(std::ceil(std::max(0.0, 40 - swath) / spacing));
        int seen = 0;
        double lastTime = -1;
        for (const ScanPoint& p : r.points) {
            EXPECT_LE(std::abs(p.scanAngleDeg), o.scanAngle / kScanDeg + 1e-3);
            EXPECT_GE(p.gpsTime, lastTime);
            lastTime = p.gpsTime;
            EXPECT_GE(p.sourceId, 1);  // LAS reads 0 as "no source": strips count from 1
            seen = std::max(seen, static_cast<int>(p.sourceId));
            EXPECT_GE(p.x, -30 - 1e-6);  // strips run over the area's length
            EXPECT_LE(p.x, 30 + 1e-6 + o.speed / o.scanRate);
        }
        EXPECT_EQ(seen, strips);
        ASSERT_FALSE(r.trajectory.empty());
        for (const ScanPose& pose : r.trajectory) EXPECT_NEAR(pose.y, o.altitude, 1e-9);
        EXPECT_NEAR(r.trajectory.front().headingDeg, 90, 1e-9);
        // Every 5 × 5 m cell of the area has points (the strips leave no gap).
        std::vector<int> cells(12 * 8, 0);
        for (const ScanPoint& p : r.points) {
            const int cx = static_cast<int>(std::floor((p.x + 30) / 5));
            const int cz = static_cast<int>(std::floor((p.z + 20) / 5));
            if (cx >= 0 && cx < 12 && cz >= 0 && cz < 8) ++cells[cz * 12 + cx];
        }
        EXPECT_EQ(std::count(cells.begin(), cells.end(), 0), 0) << int(platform);
    }
}

TEST(Scanner, APlotScanLabelsEveryTreeTheTerrainAndTheGroundCover) {
    PlotSpec spec;
    const GrownPlot plot = test::handPlot(spec, {{-4, -3}, {3, -2}, {0, 4}});
    const PlotScene scene = makePlotScene(plot, TubeOptions{}, true, true);
    const ScanScene s = makeScanScene(plot, scene);
    EXPECT_NEAR(s.groundHeight(3, 2), plot.layout.terrain.height(3, 2), 1e-12);
    ScanOptions o = defaultScanOptions(ScanPlatform::kTls);
    o.stations = {{0, 0, 1.5}, {-8, 8, 2.0}};
    o.horizontalStep = o.verticalStep = 0.3 * kScanDeg;
    o.leafTransmission = 0;
    o.rangeNoise = 0;
    const ScanResult r = scan(s, o, 11);
    ASSERT_EQ(r.trajectory.size(), 2u);
    EXPECT_NEAR(r.trajectory[1].y, plot.layout.terrain.height(-8, 8) + 2.0, 1e-9);
    std::vector<Aabb> boxes(plot.trees.size());
    for (size_t k = 0; k < plot.trees.size(); ++k) {
        for (const Mesh* m : {&scene.trees[k].mesh.wood, &scene.trees[k].mesh.leaves}) {
            for (size_t i = 0; i < m->positions.size(); i += 3) {
                boxes[k].extend(Vec3{m->positions[i], m->positions[i + 1], m->positions[i + 2]});
            }
        }
    }
    std::vector<int> perTree(plot.trees.size() + 1, 0);
    int cover = 0;
    for (const ScanPoint& p : r.points) {
        ASSERT_GE(p.label.treeId, 0);
        ASSERT_LE(p.label.treeId, static_cast<int>(plot.trees.size()));
        ++perTree[p.label.treeId];
        if (p.label.treeId > 0) {
            const Aabb& b = boxes[p.label.treeId - 1];
            EXPECT_TRUE(p.x >= b.lo.x - 1e-4 && p.x <= b.hi.x + 1e-4 && p.y >= b.lo.y - 1e-4 &&
                        p.y <= b.hi.y + 1e-4 && p.z >= b.lo.z - 1e-4 && p.z <= b.hi.z + 1e-4);
            EXPECT_EQ(p.label.species, plot.trees[p.label.treeId - 1].stem.species);
        } else if (p.label.part == kScanTerrain) {
            EXPECT_NEAR(p.y, plot.layout.terrain.height(p.x, p.z), 1e-3);
            EXPECT_EQ(p.classification, kForTerrain);
        } else {
            EXPECT_EQ(p.label.part, kScanLowVegetation);
            EXPECT_EQ(p.classification, kForLowVegetation);
            EXPECT_EQ(p.semantic, kSemGround);
            ++cover;
        }
    }
    for (size_t k = 0; k <= plot.trees.size(); ++k) EXPECT_GT(perTree[k], 50) << k;
    EXPECT_GT(cover, 0);
}

TEST(Scanner, AnInstancedTreeScansAsTheSameTreePlacedFlat) {
    // The hand tree turned 70° about +y and moved to (2, 0, −6): as a flat copy of its meshes,
    // and as an instance of its prototype. The same pulses give the same points, intensities
    // (incidence from the instance's rotated normals) and labels, with the instance's tree id.
    const Tree tree = test::handTree(5, 0.2, 1.8, 0.0);
    const auto [mesh, nodes] = meshTree(tree);
    const double a = 70 * kScanDeg;
    const Vec3 base{2, 0, -6};
    TreeMesh placed = mesh;
    for (Mesh* m : {&placed.wood, &placed.leaves}) {
        for (size_t i = 0; i < m->positions.size(); i += 3) {
            const double x = m->positions[i], z = m->positions[i + 2];
            m->positions[i] = static_cast<float>(std::cos(a) * x + std::sin(a) * z + base.x);
            m->positions[i + 2] = static_cast<float>(-std::sin(a) * x + std::cos(a) * z + base.z);
        }
    }
    ScanTreeInput in;
    in.tree = &tree;
    in.mesh = &placed;
    in.woodNodes = &nodes;
    in.treeId = 7;
    ScanScene flat;
    flat.addTree(in);
    flat.commit();
    ScanScene inst;
    in.mesh = &mesh;
    const int proto = inst.addPrototype(in);
    inst.addInstance(proto, base, a, 7);
    inst.commit();
    EXPECT_EQ(inst.triangles(), flat.triangles());
    ScanOptions o = window(25, 0.2);
    o.verticalCentre = 15 * kScanDeg;
    const ScanResult rf = scan(flat, o, 12), ri = scan(inst, o, 12);
    ASSERT_GT(rf.points.size(), 2000u);
    std::map<std::pair<uint64_t, int>, const ScanPoint*> byReturn;
    for (const ScanPoint& p : rf.points) byReturn[{p.pulse, p.returnNumber}] = &p;
    size_t matched = 0;
    for (const ScanPoint& p : ri.points) {
        EXPECT_EQ(p.label.treeId, 7);
        auto it = byReturn.find({p.pulse, p.returnNumber});
        if (it == byReturn.end() || distance(pointOf(p), pointOf(*it->second)) > 1e-3) continue;
        ++matched;
        EXPECT_NEAR(p.intensity, it->second->intensity, 40);  // 0.06 %
        EXPECT_EQ(p.label.nodeId, it->second->label.nodeId);
        EXPECT_EQ(p.label.part, it->second->label.part);
        EXPECT_EQ(p.classification, it->second->classification);
    }
    EXPECT_GT(matched, rf.points.size() * 98 / 100);
}
