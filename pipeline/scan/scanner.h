// The laser scanner: pulses of a TLS, ALS or ULS survey (scan_pattern.h) cast through a scan
// scene's BVH (scan_scene.h) on every core of the calling oneTBB arena, each pulse's beam sampled
// by sub-rays, its hits grouped into returns, with range noise, intensity and the label and
// FOR-instance class of the surface hit.
//
//   ScanScene scene = makeScanScene(plot, plotScene);
//   ScanOptions o = readScanOptions(scanTable);          // or defaultScanOptions(...) + edits
//   ScanResult r = scan(scene, o, seed);                  // points in pulse order
//
// A pulse, per sub-ray i of S (S = sub_rays): the direction tilted from the beam axis by
// r_i · divergence/2 at angle θ_i + φ (a sunflower pattern over the beam's disc, r_0 = 0 the
// axis, φ a random turn per pulse), weighted by the Gaussian beam profile exp(−2 r_i²). Each
// sub-ray hits the nearest surface between min_range and max_range; a leaf lets it go on with
// probability leaf_transmission (and still returns an echo). The sub-rays' hits sorted by range
// fall into returns wherever two consecutive hits are at least min_separation apart ("full
// waveform lite"); the first max_returns are recorded, each at the weighted mean of its hits plus
// Gaussian noise along the beam, with intensity Σ w ρ |cos incidence| / Σ w over the whole beam
// — every sub-ray counted once, at its strongest echo in the return — (× (reference_range /
// range)² when reference_range > 0), scaled to 0 … 65535, and labelled by the (tree, semantic
// class) whose echoes carry most of that energy, their share being the point's label purity.
//
// Determinism: pulse k's draws (φ, transmission, noise) come from Rng(seed) keyed by k, and the
// points are gathered in pulse order, so the points are the same, bit for bit, on any number of
// threads.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "pipeline/scan/scan_options.h"
#include "pipeline/scan/scan_point.h"
#include "pipeline/scan/scan_scene.h"

namespace sylva {

// How rays go to Embree (benchmarks compare them; results are identical).
enum class RayMode : uint8_t { kSingle, kPacket16, kStream };

struct ScanTuning {
    RayMode mode = RayMode::kPacket16;
    int pulsesPerBlock = 256;  // pulses traced together (one task)
};

// The whole survey, points in pulse order (then return order) and the trajectory (one pose per
// TLS station, one per ALS/ULS scan line). Throws InputError when the survey has more than 10⁹
// pulses and no `pulses` cap. Runs in the caller's oneTBB arena (its thread count). `progress`,
// when set, is called (from one thread at a time) after each block with the pulses done so far
// and the survey's.
using ScanProgress = std::function<void(uint64_t done, uint64_t total)>;
ScanResult scan(const ScanScene& scene, const ScanOptions& options, uint64_t seed,
                const ScanTuning& tuning = {}, const ScanProgress& progress = {});

// The same, handing the points to `sink` in pulse order, a block of pulses at a time (memory
// stays bounded: a few blocks per thread in flight), and `progress` after each; the result's
// points stay empty.
ScanResult scanInto(const ScanScene& scene, const ScanOptions& options, uint64_t seed,
                    const std::function<void(std::vector<ScanPoint>&)>& sink,
                    const ScanTuning& tuning = {}, const ScanProgress& progress = {});

// The survey's pulse count (under the `pulses` cap).
uint64_t surveyPulses(const ScanScene& scene, const ScanOptions& options);

// --- the physical limit (benchmarks) ----------------------------------------------------------

// One ray: origin, unit direction, [tnear, tfar] in metres.
struct ScanRay {
    float ox, oy, oz, dx, dy, dz, tnear, tfar;
};
// Every sub-ray of pulses [first, first + count) as the scanner casts them first (before leaf
// transmission), in pulse then sub-ray order.
std::vector<ScanRay> scanRays(const ScanScene& scene, const ScanOptions& options, uint64_t seed,
                              uint64_t first, uint64_t count);
// Closest hits of `rays` and nothing else (no labels, returns, noise), on the calling arena's
// threads in blocks of `raysPerBlock`: the rate Embree alone reaches. Returns the hit count.
uint64_t traceRays(const ScanScene& scene, const std::vector<ScanRay>& rays, RayMode mode,
                   int raysPerBlock = 4096);

}  // namespace sylva
