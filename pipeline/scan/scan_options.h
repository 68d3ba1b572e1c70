// The laser scanner's options: platform (TLS stations, ALS/ULS flight strips), scan pattern and
// what every pulse does (beam divergence sub-rays, noise, returns, intensity, leaf transmission),
// and their reader from a dataset's [scan] table. Keys, units, defaults and their sources:
// docs/scanning.md. Angles are radians here, degrees in spec files (`*_deg`).
//
// Frame: the scene's metres, +y up; azimuths and headings are compass angles on the ground,
// 0 = north (−z), 90° = east (+x), as the plot's aspect (species/plot/plot.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/math.h"
#include "core/params.h"

namespace sylva {

constexpr double kScanDeg = kPi / 180.0;  // radians per degree

enum class ScanPlatform : uint8_t { kTls, kAls, kUls };
// Line scanners' mirrors: an oscillating mirror sweeps −max → +max and back (a zig-zag on the
// ground); a rotating mirror (polygon or 360° scanners such as the RIEGL miniVUX) turns one
// way, and shots farther than the maximum scan angle from nadir are not emitted.
enum class MirrorPattern : uint8_t { kOscillating, kRotating };

// The most pulses one survey may emit (after a `pulses` cap): more is a typo (a step of 0.0004°)
// rather than a scan, 10⁹ pulses being ~10⁹ points, tens of gigabytes of files (the points are
// spooled to disk, not held: pipeline/scan/scan_spool.h). The reader refuses a TLS grid or a
// plot's ALS/ULS strips over it, and a tree's strips when even the smallest ground square would
// be over it; the scanner any other survey (a tree's ground square follows its crown, known once
// grown).
inline constexpr double kMaxScanSurveyPulses = 1e9;

// The ground square under a single tree reaches this far (metres) beyond the tree's horizontal
// reach and its farthest TLS station.
inline constexpr double kTreeGroundMargin = 2.0;

// A terrestrial scanner's position: x, z on the ground and the height of its optical centre
// above the terrain there (metres).
struct TlsStation {
    double x = 0, z = 0;
    double height = 1.5;
};

struct ScanOptions {
    ScanPlatform platform = ScanPlatform::kTls;

    // --- TLS (defaults: RIEGL VZ-400 datasheet 2014: 360° × 100° (+60°/−40°) field of view)
    std::vector<TlsStation> stations;         // at least one
    double horizontalStep = 0.04 * kScanDeg;  // radians between columns
    double verticalStep = 0.04 * kScanDeg;    // radians between shots of a column
    double horizontalFov = 2 * kPi;           // radians, (0, 2π]
    double verticalFov = 100 * kScanDeg;      // radians, (0, π]
    double verticalCentre = 10 * kScanDeg;    // elevation of the vertical field's centre
    double azimuth = 0;                       // compass azimuth of the horizontal field's centre
    // The angle the mirror sweeps the beam through per column, of which the vertical field is
    // shot and the rest is dead time (the laser fires at pulseRate throughout). The VZ-400's
    // polygon mirror: 240° (HELIOS++ data/scanners_tls.xml, riegl_vz400: scanAngleMax 120°,
    // effective 50°, i.e. 100° of a ±120° line).
    double lineSweep = 240 * kScanDeg;  // radians, [verticalFov, 2π]

    // --- ALS / ULS (defaults per platform: defaultScanOptions)
    double altitude = 500;             // metres above the terrain at the scene's centre
    double speed = 60;                 // metres per second along the strips
    double stripSpacing = 0;           // metres between strip centre lines; 0: from `overlap`
    double overlap = 0.2;              // side overlap of neighbouring swaths, [0, 1)
    double heading = 0;                // compass heading of the first strip (radians)
    double scanRate = 70;              // scan lines per second
    double scanAngle = 20 * kScanDeg;  // maximum angle from nadir (radians)
    MirrorPattern mirror = MirrorPattern::kOscillating;

    // --- every pulse
    double pulseRate = 300000;              // pulses per second (GPS time; lines of ALS/ULS)
    double beamDivergence = 0.35e-3;        // radians, full angle of the beam (1/e² diameter)
    int subRays = 1;                        // rays sampling the beam's footprint (1 = its axis)
    double rangeNoise = 0.005;              // metres, sd of the Gaussian range error
    double minRange = 1.5;                  // metres
    double maxRange = 600;                  // metres
    int maxReturns = 15;                    // returns recorded per pulse, 1 … 15
    double minSeparation = 0.75;            // metres between returns of one pulse
    double reflectanceBark = 0.5;           // of wood (stems, branches, roots)
    double reflectanceLeaf = 0.3;           // of leaves
    double reflectanceGround = 0.3;         // of the terrain
    double reflectanceLowVegetation = 0.3;  // of the ground cover
    double leafTransmission = 0.2;          // probability a sub-ray goes on through a leaf it hits
    double referenceRange = 0;              // metres; > 0: intensity × min(1, (ref / range)²)
    // A return is recorded when its intensity (the echo as a fraction of a whole beam's, head-on,
    // off a surface of reflectance 1; × (ref / range)² beyond referenceRange) reaches this: the
    // detector's threshold over the summed sub-ray echoes, which weak partial hits (an outer
    // sub-ray grazing a twig) fall below. 0: every echo is a return.
    double detectionThreshold = 0;  // fraction, [0, 1)
    uint64_t maxPulses = 0;         // 0: every pulse of the survey; else the first this many
};

// The defaults of a platform (the struct's own are TLS):
//   TLS: RIEGL VZ-400 — 300 kHz, 0.35 mrad, 5 mm, 1.5–600 m, 0.04° steps;
//   ULS: RIEGL miniVUX-1UAV — 100 kHz, rotating 360° mirror at 100 lines/s, 0.9 mrad (the
//        geometric mean of 1.6 × 0.5 mrad), 15 mm, 3–250 m, 5 returns, 60 m at 6 m/s;
//   ALS: Leica ALS50-II (HELIOS++ data/scanners_als.xml) — 150 kHz, oscillating ±20° at 70
//        lines/s, 0.22 mrad, 50 mm, 4 returns 3.5 m apart, 500 m at 60 m/s, 20 % overlap.
ScanOptions defaultScanOptions(ScanPlatform platform);

// The platform's word in spec files and the manifest: "tls", "als", "uls".
const char* scanPlatformName(ScanPlatform platform);

// Reads a [scan] table (Params of that table). Errors name file:line:col and the key, e.g.
// `d.toml:12:14: scan.pulse_rate: expected a number > 0, got -5`. Keys of another platform
// (`stations` with platform = "als") are errors. Finishes the table (unknown keys are errors).
ScanOptions readScanOptions(Params& scan);

// The [scan] table of a TOML file (a file of its own, as tests/data/scan/scan-*.toml; a dataset
// reads its [scan] table with readScanOptions). Keys are recorded as "dataset.scan.<key>".
ScanOptions loadScanSpec(const std::string& file, KeyLog* keyLog = nullptr);

}  // namespace sylva
