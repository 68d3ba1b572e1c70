// The scanner: pulses → sub-rays → Embree → returns (scanner.h).
#include "pipeline/scan/scanner.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>

#include "core/errors.h"
#include "core/rng.h"
#include "pipeline/scan/scan_pattern.h"
#include "pipeline/scan/scan_scene_impl.h"

namespace sylva {

namespace {

constexpr int kMaxHitsPerSubRay = 16;  // surfaces one sub-ray may pass through and echo from
constexpr double kGoldenAngle = 2.39996322972865332;  // π (3 − √5)

// The beam's sub-ray pattern: offsets (in units of the beam's 1/e² radius) and weights.
struct BeamPattern {
    std::vector<double> r, cosTheta, sinTheta, weight;
    std::vector<double> tilt, scale;  // r·tan(divergence/2), 1/√(1 + tilt²)
    double totalWeight = 0;
    BeamPattern(int n, double tanHalf) {
        for (int i = 0; i < n; ++i) {
            // A sunflower (Vogel) disc: even coverage for any count, the axis first.
            const double ri = n == 1 ? 0.0 : std::sqrt(i / (n - 0.5));
            r.push_back(ri);
            cosTheta.push_back(std::cos(i * kGoldenAngle));
            sinTheta.push_back(std::sin(i * kGoldenAngle));
            weight.push_back(std::exp(-2 * ri * ri));  // Gaussian beam: 1/e² at r = 1
            totalWeight += weight.back();
            tilt.push_back(ri * tanHalf);
            scale.push_back(1 / std::sqrt(1 + tilt.back() * tilt.back()));
        }
    }
};

double unitFromHash(uint64_t h) { return static_cast<double>(mix64(h) >> 11) * 0x1.0p-53; }

// One ray in flight.
struct RayState {
    float o[3], d[3];
    float tnear, tfar;
    uint32_t pulse;  // within the block
    uint16_t sub;
    uint16_t hits;  // echoes this sub-ray already gave
};

struct RayHitOut {
    float t;
    float ng[3];
    unsigned geomID, primID, instID;
};

struct HitRec {
    uint32_t pulse;
    uint16_t sub;
    float t;
    float d[3];  // the sub-ray's direction
    float cosine;
    unsigned geomID, primID, instID;
};

void initContext(RTCIntersectContext& ctx, bool coherent) {
    rtcInitIntersectContext(&ctx);
    ctx.flags =
        coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
}

// Closest hits of rays[0 … n) (geomID RTC_INVALID_GEOMETRY_ID: none).
template <class Ray>
void trace(RTCScene scene, RayMode mode, const Ray* rays, size_t n, RayHitOut* out,
           std::vector<RTCRayHit>& scratch) {
    auto fill1 = [](const Ray& r, RTCRayHit& rh) {
        rh.ray.org_x = r.o[0], rh.ray.org_y = r.o[1], rh.ray.org_z = r.o[2];
        rh.ray.dir_x = r.d[0], rh.ray.dir_y = r.d[1], rh.ray.dir_z = r.d[2];
        rh.ray.tnear = r.tnear;
        rh.ray.tfar = r.tfar;
        rh.ray.time = 0;
        rh.ray.mask = 0xFFFFFFFFu;
        rh.ray.id = 0;
        rh.ray.flags = 0;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    };
    auto take1 = [](const RTCRayHit& rh, RayHitOut& o) {
        o.t = rh.ray.tfar;
        o.ng[0] = rh.hit.Ng_x, o.ng[1] = rh.hit.Ng_y, o.ng[2] = rh.hit.Ng_z;
        o.geomID = rh.hit.geomID, o.primID = rh.hit.primID, o.instID = rh.hit.instID[0];
    };
    RTCIntersectContext ctx;
    if (mode == RayMode::kSingle) {
        initContext(ctx, false);
        for (size_t i = 0; i < n; ++i) {
            RTCRayHit rh;
            fill1(rays[i], rh);
            rtcIntersect1(scene, &ctx, &rh);
            take1(rh, out[i]);
        }
    } else if (mode == RayMode::kStream) {
        initContext(ctx, true);
        scratch.resize(n);
        for (size_t i = 0; i < n; ++i) fill1(rays[i], scratch[i]);
        rtcIntersect1M(scene, &ctx, scratch.data(), static_cast<unsigned>(n), sizeof(RTCRayHit));
        for (size_t i = 0; i < n; ++i) take1(scratch[i], out[i]);
    } else {
        initContext(ctx, true);
        alignas(64) RTCRayHit16 p;
        alignas(64) int valid[16];
        for (size_t b = 0; b < n; b += 16) {
            const size_t m = std::min<size_t>(16, n - b);
            for (size_t i = 0; i < 16; ++i) {
                const Ray& r = rays[b + std::min(i, m - 1)];
                valid[i] = i < m ? -1 : 0;
                p.ray.org_x[i] = r.o[0], p.ray.org_y[i] = r.o[1], p.ray.org_z[i] = r.o[2];
                p.ray.dir_x[i] = r.d[0], p.ray.dir_y[i] = r.d[1], p.ray.dir_z[i] = r.d[2];
                p.ray.tnear[i] = r.tnear;
                p.ray.tfar[i] = r.tfar;
                p.ray.time[i] = 0;
                p.ray.mask[i] = 0xFFFFFFFFu;
                p.ray.id[i] = 0;
                p.ray.flags[i] = 0;
                p.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
                p.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
            }
            rtcIntersect16(valid, scene, &ctx, &p);
            for (size_t i = 0; i < m; ++i) {
                RayHitOut& o = out[b + i];
                o.t = p.ray.tfar[i];
                o.ng[0] = p.hit.Ng_x[i], o.ng[1] = p.hit.Ng_y[i], o.ng[2] = p.hit.Ng_z[i];
                o.geomID = p.hit.geomID[i], o.primID = p.hit.primID[i];
                o.instID = p.hit.instID[0][i];
            }
        }
    }
}

double reflectance(const ScanOptions& o, SurfaceKind k) {
    switch (k) {
        case SurfaceKind::kWood:
            return o.reflectanceBark;
        case SurfaceKind::kLeaf:
            return o.reflectanceLeaf;
        case SurfaceKind::kGround:
            return o.reflectanceGround;
        case SurfaceKind::kLowVegetation:
            return o.reflectanceLowVegetation;
    }
    return 0;
}

// Scratch of one thread.
struct Work {
    std::vector<ScanPulse> pulses;
    std::vector<uint64_t> pulseSeed;
    std::vector<RayState> rays, next;
    std::vector<RayHitOut> out;
    std::vector<RTCRayHit> scratch;
    std::vector<HitRec> hits, sorted;
    std::vector<uint32_t> offset;
    // returns(): per sub-ray, its strongest echo in the return being made (−1: none yet) and
    // that hit; per (tree, semantic class) group, its echo energy and strongest hit.
    std::vector<double> subEcho;
    std::vector<const HitRec*> subHit;
    struct Group {
        int32_t tree;
        uint8_t semantic;
        double energy, weight;        // summed over the group's sub-rays
        double bestEcho, bestWeight;  // its strongest hit (by echo, then beam weight)
        const HitRec* hit;
    };
    std::vector<Group> groups;
};

class Scanner {
  public:
    Scanner(const ScanScene& scene, const ScanOptions& o, uint64_t seed, const ScanTuning& tuning)
        : s_(scene.impl()),
          o_(o),
          pattern_(scene, o),
          beam_(o.subRays, std::tan(o.beamDivergence / 2)),
          base_(seed),
          tuning_(tuning) {
        count_ = pattern_.count();
        if (o.maxPulses > 0) count_ = std::min<uint64_t>(count_, o.maxPulses);
        if (pattern_.sources() > 65535) {
            throw InputError("scan: the survey has " + std::to_string(pattern_.sources()) +
                             " stations or strips, more than the 65,535 point source IDs of LAS:"
                             " widen strip_spacing or use fewer stations");
        }
        if (static_cast<double>(count_) > kMaxScanSurveyPulses) {
            throw InputError("scan: the survey has " + std::to_string(count_) +
                             " pulses, more than 1e9: cap it with [scan] pulses or scan less");
        }
    }

    uint64_t count() const { return count_; }
    const ScanPattern& pattern() const { return pattern_; }

    // The sub-rays of pulses [k0, k0 + n) into w.rays (and their pulses into w.pulses).
    void makeRays(uint64_t k0, uint64_t n, Work& w) const {
        w.pulses.resize(n);
        w.pulseSeed.resize(n);
        w.rays.clear();
        const int S = o_.subRays;
        for (uint64_t i = 0; i < n; ++i) {
            ScanPulse& p = w.pulses[i];
            pattern_.pulse(k0 + i, p);
            Rng rng = base_.derive(k0 + i);
            w.pulseSeed[i] = rng.seed();
            const double phi = rng.uniform() * 2 * kPi;
            const Vec3 d0 = p.direction;
            const Vec3 u = anyPerpendicular(d0);
            const Vec3 v = cross(d0, u);
            // The pattern turned by φ: (cos, sin)(θ_j + φ) from (cos, sin) θ_j, one sincos.
            const double cphi = std::cos(phi), sphi = std::sin(phi);
            for (int j = 0; j < S; ++j) {
                Vec3 d = d0;
                if (beam_.r[j] > 0) {
                    const double c = beam_.cosTheta[j] * cphi - beam_.sinTheta[j] * sphi;
                    const double sn = beam_.sinTheta[j] * cphi + beam_.cosTheta[j] * sphi;
                    // d0 ⟂ u, v: the tilted direction's length is √(1 + tilt²).
                    d = (d0 + (u * c + v * sn) * beam_.tilt[j]) * beam_.scale[j];
                }
                RayState ray;
                ray.o[0] = static_cast<float>(p.origin.x);
                ray.o[1] = static_cast<float>(p.origin.y);
                ray.o[2] = static_cast<float>(p.origin.z);
                ray.d[0] = static_cast<float>(d.x);
                ray.d[1] = static_cast<float>(d.y);
                ray.d[2] = static_cast<float>(d.z);
                ray.tnear = static_cast<float>(o_.minRange);
                ray.tfar = static_cast<float>(o_.maxRange);
                ray.pulse = static_cast<uint32_t>(i);
                ray.sub = static_cast<uint16_t>(j);
                ray.hits = 0;
                w.rays.push_back(ray);
            }
        }
    }

    // Pulses [k0, k0 + n) → their points, in pulse then return order, appended to `points`.
    void block(uint64_t k0, uint64_t n, Work& w, std::vector<ScanPoint>& points) const {
        makeRays(k0, n, w);
        w.hits.clear();
        const bool transmit = o_.leafTransmission > 0;
        while (!w.rays.empty()) {
            w.out.resize(w.rays.size());
            trace(s_.scene, tuning_.mode, w.rays.data(), w.rays.size(), w.out.data(), w.scratch);
            w.next.clear();
            for (size_t i = 0; i < w.rays.size(); ++i) {
                const RayHitOut& h = w.out[i];
                if (h.geomID == RTC_INVALID_GEOMETRY_ID) continue;
                const RayState& r = w.rays[i];
                HitRec rec;
                rec.pulse = r.pulse;
                rec.sub = r.sub;
                rec.t = h.t;
                rec.d[0] = r.d[0], rec.d[1] = r.d[1], rec.d[2] = r.d[2];
                float n[3] = {h.ng[0], h.ng[1], h.ng[2]};
                if (h.instID != RTC_INVALID_GEOMETRY_ID) {
                    // Embree gives an instance's normals in its prototype's frame: rotate them
                    // as the copy was (about +y; column-major x' = c x + s z, z' = −s x + c z).
                    const ScanInstance& inst = s_.instances[s_.instanceOf[h.instID]];
                    const float x = n[0], z = n[2];
                    n[0] = inst.cosY * x + inst.sinY * z;
                    n[2] = -inst.sinY * x + inst.cosY * z;
                }
                const double ng =
                    std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
                const double dn = r.d[0] * n[0] + r.d[1] * n[1] + r.d[2] * n[2];
                rec.cosine = ng > 0 ? static_cast<float>(std::abs(dn) / ng) : 0.f;
                rec.geomID = h.geomID, rec.primID = h.primID, rec.instID = h.instID;
                w.hits.push_back(rec);
                if (!transmit || r.hits + 1 >= kMaxHitsPerSubRay) continue;
                if (s_.geometry(h.geomID, h.instID).kind != SurfaceKind::kLeaf) continue;
                const uint64_t key = (static_cast<uint64_t>(r.sub) << 8) | r.hits;
                if (unitFromHash(hashCombine(w.pulseSeed[r.pulse], key)) >= o_.leafTransmission) {
                    continue;
                }
                RayState go = r;
                go.tnear = h.t + 1e-4f + 1e-6f * h.t;  // just past the leaf
                go.hits = static_cast<uint16_t>(r.hits + 1);
                if (go.tnear < go.tfar) w.next.push_back(go);
            }
            std::swap(w.rays, w.next);
        }
        // Hits by pulse (counting sort), then by range within a pulse (insertion sort: few).
        w.offset.assign(n + 1, 0);
        for (const HitRec& h : w.hits) ++w.offset[h.pulse + 1];
        for (uint64_t i = 0; i < n; ++i) w.offset[i + 1] += w.offset[i];
        w.sorted.resize(w.hits.size());
        {
            std::vector<uint32_t>& at = w.offset;  // reuse: fill positions then restore
            std::vector<uint32_t> fill(at.begin(), at.end() - 1);
            for (const HitRec& h : w.hits) w.sorted[fill[h.pulse]++] = h;
        }
        auto before = [](const HitRec& a, const HitRec& b) {
            return a.t < b.t || (a.t == b.t && a.sub < b.sub);
        };
        for (uint64_t i = 0; i < n; ++i) {
            HitRec* first = w.sorted.data() + w.offset[i];
            HitRec* last = w.sorted.data() + w.offset[i + 1];
            for (HitRec* a = first + 1; a < last; ++a) {
                HitRec x = *a;
                HitRec* b = a;
                for (; b > first && before(x, *(b - 1)); --b) *b = *(b - 1);
                *b = x;
            }
            if (first != last) {
                returns(k0 + i, w.pulses[i], w.pulseSeed[i], first, last, w, points);
            }
        }
    }

  private:
    // The returns of one pulse from its hits sorted by range: clusters of hits closer than
    // min_separation, nearest first, each recorded when its intensity reaches the detection
    // threshold, until max_returns are.
    void returns(uint64_t k, const ScanPulse& p, uint64_t pulseSeed, const HitRec* first,
                 const HitRec* last, Work& w, std::vector<ScanPoint>& points) const {
        Rng rng(pulseSeed);
        rng.uniform();  // φ, drawn by makeRays
        const size_t firstPoint = points.size();
        // The ray origin as Embree had it (float).
        const Vec3 o{static_cast<float>(p.origin.x), static_cast<float>(p.origin.y),
                     static_cast<float>(p.origin.z)};
        const double elevation = std::asin(std::clamp(p.direction.y, -1.0, 1.0)) / kScanDeg;
        // Every entry is back at (−1, none) after each return (below), so sized once per thread.
        if (w.subEcho.size() != beam_.weight.size()) {
            w.subEcho.assign(beam_.weight.size(), -1.0);
            w.subHit.assign(beam_.weight.size(), nullptr);
        }
        int recorded = 0;
        for (const HitRec *start = first, *end = first; start < last && recorded < o_.maxReturns;
             start = end) {
            end = start + 1;
            while (end < last && end->t - (end - 1)->t < o_.minSeparation) ++end;
            // Position: the beam-weighted mean of every hit. Energy: every sub-ray counts once,
            // at its strongest echo w ρ |cos| in the return. A sub-ray that went on through a
            // leaf (leaf_transmission) and met another surface within the same return would
            // otherwise add its whole weight again, making a few returns in dense foliage
            // brighter than any bark; across returns the draw stands (in expectation the
            // transmitted share of its energy).
            double wsum = 0;
            Vec3 pos{0, 0, 0};
            for (const HitRec* h = start; h < end; ++h) {
                const double wt = beam_.weight[h->sub];
                const Vec3 d{h->d[0], h->d[1], h->d[2]};  // the ray Embree traced
                pos += (o + d * static_cast<double>(h->t)) * wt;
                wsum += wt;
                const SurfaceKind kind = s_.geometry(h->geomID, h->instID).kind;
                const double echo = wt * reflectance(o_, kind) * h->cosine;
                if (echo > w.subEcho[h->sub]) w.subEcho[h->sub] = echo, w.subHit[h->sub] = h;
            }
            // The label: the (tree, semantic class) whose surfaces echo most of the energy (by
            // beam weight where nothing echoes), named by its strongest hit; its share of the
            // energy is the point's label purity. The position mixes every surface of the
            // return, the label the one that dominates it.
            w.groups.clear();
            double energy = 0;
            for (const HitRec* h = start; h < end; ++h) {
                if (w.subHit[h->sub] != h) continue;
                const double echo = w.subEcho[h->sub], wt = beam_.weight[h->sub];
                w.subEcho[h->sub] = -1.0, w.subHit[h->sub] = nullptr;  // ready for the next
                energy += echo;
                // The tree and class of a hit are its geometry's (a wood triangle's node only
                // names which wood): the full label is resolved for the winner alone.
                const ScanGeometry& geo = s_.geometry(h->geomID, h->instID);
                const int32_t tree = h->instID == RTC_INVALID_GEOMETRY_ID
                                         ? geo.base.treeId
                                         : s_.instances[s_.instanceOf[h->instID]].treeId;
                Work::Group* g = nullptr;
                for (Work::Group& x : w.groups) {
                    if (x.tree == tree && x.semantic == geo.semantic) g = &x;
                }
                if (!g) {
                    w.groups.push_back({tree, geo.semantic, 0, 0, -1, -1, nullptr});
                    g = &w.groups.back();
                }
                g->energy += echo, g->weight += wt;
                if (echo > g->bestEcho || (echo == g->bestEcho && wt > g->bestWeight)) {
                    g->bestEcho = echo, g->bestWeight = wt, g->hit = h;
                }
            }
            const bool byEnergy = energy > 0;
            double total = 0;
            const Work::Group* top = &w.groups.front();
            for (const Work::Group& g : w.groups) {
                const double v = byEnergy ? g.energy : g.weight;
                total += v;
                if (v > (byEnergy ? top->energy : top->weight)) top = &g;
            }
            const double purity = total > 0 ? (byEnergy ? top->energy : top->weight) / total : 1;
            pos = pos / wsum;
            pos += p.direction * rng.normal(0.0, o_.rangeNoise);
            double intensity = energy / beam_.totalWeight;
            if (o_.referenceRange > 0) {
                const double range = distance(pos, o);
                if (range > o_.referenceRange) {
                    intensity *= (o_.referenceRange / range) * (o_.referenceRange / range);
                }
            }
            if (intensity < o_.detectionThreshold) continue;  // too weak to detect
            const ResolvedHit res =
                s_.resolve(top->hit->geomID, top->hit->primID, top->hit->instID);
            ScanPoint pt;
            pt.x = pos.x, pt.y = pos.y, pt.z = pos.z;
            pt.gpsTime = p.time;
            pt.intensity =
                static_cast<uint16_t>(std::lround(65535.0 * std::clamp(intensity, 0.0, 1.0)));
            pt.returnNumber = static_cast<uint8_t>(++recorded);
            pt.channel = static_cast<uint8_t>(p.source % 4);
            pt.sourceId = static_cast<uint16_t>(p.source + 1);  // LAS: 0 is "no source"
            pt.scanDirection = p.scanDirection;
            pt.edgeOfFlightLine = p.edge;
            pt.scanAngleDeg = p.scanAngleDeg;
            pt.elevationDeg = static_cast<float>(elevation);
            pt.labelPurity = static_cast<float>(purity);
            pt.pulse = k;
            pt.label = res.label;
            pt.classification = res.classification;
            pt.semantic = res.semantic;
            points.push_back(pt);
        }
        for (size_t i = firstPoint; i < points.size(); ++i) {
            points[i].numberOfReturns = static_cast<uint8_t>(recorded);
        }
    }

    const ScanScene::Impl& s_;
    const ScanOptions& o_;
    ScanPattern pattern_;
    BeamPattern beam_;
    Rng base_;
    ScanTuning tuning_;
    uint64_t count_ = 0;
};

}  // namespace

ScanResult scanInto(const ScanScene& scene, const ScanOptions& options, uint64_t seed,
                    const std::function<void(std::vector<ScanPoint>&)>& sink,
                    const ScanTuning& tuning, const ScanProgress& progress) {
    const Scanner scanner(scene, options, seed, tuning);
    ScanResult result;
    result.pulses = scanner.count();
    result.trajectory = scanner.pattern().trajectory(result.pulses);
    const uint64_t B = static_cast<uint64_t>(std::max(1, tuning.pulsesPerBlock));
    const uint64_t blocks = (result.pulses + B - 1) / B;
    tbb::enumerable_thread_specific<Work> work;
    uint64_t nextBlock = 0, done = 0;  // blocks handed out; pulses through the sink
    const size_t tokens = static_cast<size_t>(4 * tbb::this_task_arena::max_concurrency());
    tbb::parallel_pipeline(
        tokens, tbb::make_filter<void, uint64_t>(tbb::filter_mode::serial_in_order,
                                                 [&](tbb::flow_control& fc) -> uint64_t {
                                                     if (nextBlock >= blocks) {
                                                         fc.stop();
                                                         return 0;
                                                     }
                                                     return nextBlock++;
                                                 }) &
                    tbb::make_filter<uint64_t, std::vector<ScanPoint>>(
                        tbb::filter_mode::parallel,
                        [&](uint64_t b) {
                            std::vector<ScanPoint> points;
                            const uint64_t k0 = b * B;
                            scanner.block(k0, std::min(B, result.pulses - k0), work.local(),
                                          points);
                            return points;
                        }) &
                    tbb::make_filter<std::vector<ScanPoint>, void>(
                        tbb::filter_mode::serial_in_order, [&](std::vector<ScanPoint> points) {
                            sink(points);
                            done = std::min(result.pulses, done + B);
                            if (progress) progress(done, result.pulses);
                        }));
    return result;
}

ScanResult scan(const ScanScene& scene, const ScanOptions& options, uint64_t seed,
                const ScanTuning& tuning, const ScanProgress& progress) {
    std::vector<ScanPoint> all;
    ScanResult r = scanInto(
        scene, options, seed,
        [&](std::vector<ScanPoint>& points) {
            all.insert(all.end(), points.begin(), points.end());
        },
        tuning, progress);
    r.points = std::move(all);
    return r;
}

uint64_t surveyPulses(const ScanScene& scene, const ScanOptions& options) {
    const uint64_t n = ScanPattern(scene, options).count();
    return options.maxPulses > 0 ? std::min<uint64_t>(n, options.maxPulses) : n;
}

std::vector<ScanRay> scanRays(const ScanScene& scene, const ScanOptions& options, uint64_t seed,
                              uint64_t first, uint64_t count) {
    ScanOptions o = options;
    o.maxPulses = first + count;
    const Scanner scanner(scene, o, seed, {});
    Work w;
    scanner.makeRays(first, std::min(count, scanner.count() - std::min(first, scanner.count())), w);
    std::vector<ScanRay> out;
    out.reserve(w.rays.size());
    for (const RayState& r : w.rays) {
        out.push_back({r.o[0], r.o[1], r.o[2], r.d[0], r.d[1], r.d[2], r.tnear, r.tfar});
    }
    return out;
}

uint64_t traceRays(const ScanScene& scene, const std::vector<ScanRay>& rays, RayMode mode,
                   int raysPerBlock) {
    struct R {
        float o[3], d[3], tnear, tfar;
    };
    static_assert(sizeof(R) == sizeof(ScanRay), "same layout");
    const auto* rs = reinterpret_cast<const R*>(rays.data());
    std::atomic<uint64_t> hits{0};
    const size_t B = static_cast<size_t>(std::max(16, raysPerBlock));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, (rays.size() + B - 1) / B, 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                          std::vector<RayHitOut> out(B);
                          std::vector<RTCRayHit> scratch;
                          uint64_t n = 0;
                          for (size_t b = r.begin(); b < r.end(); ++b) {
                              const size_t first = b * B, m = std::min(B, rays.size() - first);
                              trace(scene.impl().scene, mode, rs + first, m, out.data(), scratch);
                              for (size_t i = 0; i < m; ++i) {
                                  n += out[i].geomID != RTC_INVALID_GEOMETRY_ID;
                              }
                          }
                          hits += n;
                      });
    return hits.load();
}

}  // namespace sylva
