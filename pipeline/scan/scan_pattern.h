// Where and when every pulse of a survey leaves the scanner, in closed form (pulse k → origin,
// direction, time), so any block of pulses can be made on any thread.
//
// TLS: per station (in order) a grid of columns (azimuth, clockwise from the start of the
// horizontal field) × rows (elevation, bottom to top within a column, as a rotating mirror
// sweeps); pulse k of a station is column k / rows, row k % rows. The laser fires at pulse_rate
// while the mirror sweeps `line_sweep` per column, of which only the vertical field is shot: a
// column takes round(line_sweep / vertical_step) shot times, so row r of column c leaves at
// (c · that + r) / pulse_rate seconds after the station's first pulse (the rest is the mirror's
// dead time); stations follow each other without a pause.
// ALS/ULS: parallel strips over the scene's area (serpentine: every other strip flown back),
// `L = round(pulse_rate / scan_rate)` shots per scan line; an oscillating mirror sweeps −max →
// +max and back (every shot emitted), a rotating one turns a full circle per line (shots within
// the maximum angle of nadir emitted). The platform moves along the strip during a line; strips
// follow each other without a pause.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/math.h"
#include "pipeline/scan/scan_options.h"
#include "pipeline/scan/scan_point.h"

namespace sylva {

class ScanScene;

struct ScanPulse {
    Vec3 origin;
    Vec3 direction;              // unit
    double time = 0;             // seconds since the survey began
    float scanAngleDeg = 0;      // LAS 1.4: from the downward vertical, + counter-clockwise
                                 // seen from behind facing along the travel (ScanPoint)
    uint16_t source = 0;         // station or strip index
    bool scanDirection = false;  // mirror moving left → right (+)
    bool edge = false;           // first or last shot of a scan line
};

class ScanPattern {
  public:
    ScanPattern(const ScanScene& scene, const ScanOptions& options);
    // The pattern over `area` (the strips' extent in x and z) on flat ground at y = 0: the same
    // count as over a scene of that area, known before the scene is built.
    ScanPattern(const Aabb& area, const ScanOptions& options);

    uint64_t count() const { return count_; }  // every pulse of the survey (no cap)
    size_t sources() const { return stations_.size() + strips_.size(); }  // stations or strips
    void pulse(uint64_t k, ScanPulse& out) const;
    // Stations (TLS) or the platform at the start of every scan line (ALS/ULS), for the pulses
    // [0, pulses).
    std::vector<ScanPose> trajectory(uint64_t pulses) const;

  private:
    void plan(const Aabb& area, const std::function<double(double, double)>& ground);

    ScanOptions o_;
    uint64_t count_ = 0;
    // TLS
    std::vector<Vec3> stations_;
    uint64_t columns_ = 0, rows_ = 0, shotsPerColumn_ = 0;
    double azimuth0_ = 0, elevation0_ = 0;
    // ALS/ULS
    struct Strip {
        Vec3 start;             // platform at the strip's first line
        double dx = 0, dz = 0;  // unit direction of travel
        double t0 = 0;          // time of its first pulse
    };
    std::vector<Strip> strips_;
    uint64_t shotsPerLine_ = 1, firstShot_ = 0, emittedPerLine_ = 0, linesPerStrip_ = 0;
};

}  // namespace sylva
