// Pulses of TLS stations and ALS/ULS strips in closed form (scan_pattern.h).
#include "pipeline/scan/scan_pattern.h"

#include <algorithm>
#include <cmath>

#include "pipeline/scan/scan_scene.h"

namespace sylva {

namespace {

// Compass azimuth (0 = north = −z, 90° = east = +x) and elevation to a unit direction.
Vec3 compassDirection(double azimuth, double elevation) {
    const double c = std::cos(elevation);
    return {c * std::sin(azimuth), std::sin(elevation), -c * std::cos(azimuth)};
}

}  // namespace

ScanPattern::ScanPattern(const ScanScene& scene, const ScanOptions& options) : o_(options) {
    plan(scene.area(), [&scene](double x, double z) { return scene.groundHeight(x, z); });
}

ScanPattern::ScanPattern(const Aabb& area, const ScanOptions& options) : o_(options) {
    plan(area, [](double, double) { return 0.0; });
}

void ScanPattern::plan(const Aabb& area, const std::function<double(double, double)>& ground) {
    if (o_.platform == ScanPlatform::kTls) {
        for (const TlsStation& s : o_.stations) {
            stations_.push_back({s.x, ground(s.x, s.z) + s.height, s.z});
        }
        const bool full = o_.horizontalFov >= 2 * kPi - 1e-9;
        columns_ =
            full ? static_cast<uint64_t>(std::max(1.0, std::round(2 * kPi / o_.horizontalStep)))
                 : static_cast<uint64_t>(std::floor(o_.horizontalFov / o_.horizontalStep + 1e-9)) +
                       1;
        rows_ = static_cast<uint64_t>(std::floor(o_.verticalFov / o_.verticalStep + 1e-9)) + 1;
        shotsPerColumn_ =
            std::max(rows_, static_cast<uint64_t>(std::llround(o_.lineSweep / o_.verticalStep)));
        azimuth0_ = o_.azimuth - (full ? kPi : o_.horizontalFov / 2);
        elevation0_ = o_.verticalCentre - o_.verticalFov / 2;
        count_ = columns_ * rows_ * stations_.size();
        return;
    }
    const double cx = area.empty() ? 0 : (area.lo.x + area.hi.x) / 2;
    const double cz = area.empty() ? 0 : (area.lo.z + area.hi.z) / 2;
    // Along-track (ax, az) and cross-track (to the right of travel) unit vectors.
    const double ax = std::sin(o_.heading), az = -std::cos(o_.heading);
    const double rx = -az, rz = ax;
    double a0 = 0, a1 = 0, c0 = 0, c1 = 0;
    if (!area.empty()) {
        a0 = c0 = 1e300;
        a1 = c1 = -1e300;
        for (double x : {area.lo.x, area.hi.x}) {
            for (double z : {area.lo.z, area.hi.z}) {
                const double a = (x - cx) * ax + (z - cz) * az, c = (x - cx) * rx + (z - cz) * rz;
                a0 = std::min(a0, a), a1 = std::max(a1, a), c0 = std::min(c0, c),
                c1 = std::max(c1, c);
            }
        }
    }
    const double swath = 2 * o_.altitude * std::tan(std::min(o_.scanAngle, 75 * kScanDeg));
    const double spacing = o_.stripSpacing > 0 ? o_.stripSpacing : swath * (1 - o_.overlap);
    const double width = c1 - c0;
    const int n = 1 + static_cast<int>(std::ceil(std::max(0.0, width - swath) / spacing - 1e-9));
    const double y = ground(cx, cz) + o_.altitude;
    const double length = a1 - a0;
    linesPerStrip_ = static_cast<uint64_t>(std::floor(length / o_.speed * o_.scanRate + 1e-9)) + 1;
    shotsPerLine_ = static_cast<uint64_t>(std::max(1.0, std::round(o_.pulseRate / o_.scanRate)));
    if (o_.mirror == MirrorPattern::kOscillating) {
        firstShot_ = 0;
        emittedPerLine_ = shotsPerLine_;
    } else {
        firstShot_ = shotsPerLine_;
        emittedPerLine_ = 0;
        for (uint64_t j = 0; j < shotsPerLine_; ++j) {
            const double theta = -kPi + 2 * kPi * (static_cast<double>(j) + 0.5) /
                                            static_cast<double>(shotsPerLine_);
            if (std::abs(theta) <= o_.scanAngle) {
                firstShot_ = std::min(firstShot_, j);
                ++emittedPerLine_;
            }
        }
    }
    const double stripTime = static_cast<double>(linesPerStrip_) / o_.scanRate;
    for (int i = 0; i < n; ++i) {
        const double c = (c0 + c1) / 2 + (i - (n - 1) / 2.0) * spacing;
        const bool back = i % 2 == 1;
        Strip s;
        s.dx = back ? -ax : ax;
        s.dz = back ? -az : az;
        const double a = back ? a1 : a0;
        s.start = {cx + a * ax + c * rx, y, cz + a * az + c * rz};
        s.t0 = i * stripTime;
        strips_.push_back(s);
    }
    count_ = linesPerStrip_ * emittedPerLine_ * strips_.size();
}

void ScanPattern::pulse(uint64_t k, ScanPulse& p) const {
    if (o_.platform == ScanPlatform::kTls) {
        const uint64_t perStation = columns_ * rows_;
        const uint64_t s = k / perStation, local = k % perStation;
        const uint64_t col = local / rows_, row = local % rows_;
        const double az = azimuth0_ + static_cast<double>(col) * o_.horizontalStep;
        const double el = elevation0_ + static_cast<double>(row) * o_.verticalStep;
        p.origin = stations_[s];
        p.direction = compassDirection(az, el);
        p.time = static_cast<double>((s * columns_ + col) * shotsPerColumn_ + row) / o_.pulseRate;
        // The head turns clockwise (seen from above), so the beam lies to the left of its
        // travel: seen from behind, facing along it, the beam turns clockwise from the
        // downward vertical (LAS 1.4: negative) through 90° + the elevation.
        p.scanAngleDeg = static_cast<float>(-(90 + el / kScanDeg));
        p.source = static_cast<uint16_t>(s);
        p.scanDirection = true;
        p.edge = row == 0 || row + 1 == rows_;
        return;
    }
    const uint64_t perStrip = linesPerStrip_ * emittedPerLine_;
    const uint64_t i = k / perStrip, local = k % perStrip;
    const uint64_t line = local / emittedPerLine_, jj = local % emittedPerLine_;
    const uint64_t j = firstShot_ + jj;
    const Strip& s = strips_[i];
    const double L = static_cast<double>(shotsPerLine_);
    const double tLocal =
        (static_cast<double>(line) * L + static_cast<double>(j)) / (L * o_.scanRate);
    const double u = (static_cast<double>(j) + 0.5) / L;
    double theta;
    bool positive = true;
    if (o_.mirror == MirrorPattern::kOscillating) {
        positive = line % 2 == 0;
        theta =
            positive ? -o_.scanAngle + 2 * o_.scanAngle * u : o_.scanAngle - 2 * o_.scanAngle * u;
    } else {
        theta = -kPi + 2 * kPi * u;
    }
    const double rx = -s.dz, rz = s.dx;  // right of travel
    p.origin = {s.start.x + s.dx * o_.speed * tLocal, s.start.y,
                s.start.z + s.dz * o_.speed * tLocal};
    p.direction = {std::sin(theta) * rx, -std::cos(theta), std::sin(theta) * rz};
    p.time = s.t0 + tLocal;
    p.scanAngleDeg = static_cast<float>(theta / kScanDeg);
    p.source = static_cast<uint16_t>(i);
    p.scanDirection = positive;
    p.edge = jj == 0 || jj + 1 == emittedPerLine_;
}

std::vector<ScanPose> ScanPattern::trajectory(uint64_t pulses) const {
    std::vector<ScanPose> out;
    if (o_.platform == ScanPlatform::kTls) {
        const uint64_t perStation = columns_ * rows_;
        for (size_t s = 0; s < stations_.size() && s * perStation < pulses; ++s) {
            ScanPose pose;
            pose.gpsTime = static_cast<double>(s * columns_ * shotsPerColumn_) / o_.pulseRate;
            pose.x = stations_[s].x, pose.y = stations_[s].y, pose.z = stations_[s].z;
            pose.channel = static_cast<uint8_t>(s % 4);
            pose.sourceId = static_cast<uint16_t>(s + 1);
            out.push_back(pose);
        }
        return out;
    }
    if (emittedPerLine_ == 0) return out;
    const uint64_t lines = (pulses + emittedPerLine_ - 1) / emittedPerLine_;
    for (uint64_t n = 0; n < lines; ++n) {
        const uint64_t i = n / linesPerStrip_, line = n % linesPerStrip_;
        const Strip& s = strips_[i];
        const double t = static_cast<double>(line) / o_.scanRate;
        ScanPose pose;
        pose.gpsTime = s.t0 + t;
        pose.x = s.start.x + s.dx * o_.speed * t;
        pose.y = s.start.y;
        pose.z = s.start.z + s.dz * o_.speed * t;
        double heading = std::atan2(s.dx, -s.dz) / kScanDeg;
        if (heading < 0) heading += 360;
        pose.headingDeg = heading;
        pose.channel = static_cast<uint8_t>(i % 4);
        pose.sourceId = static_cast<uint16_t>(i + 1);
        out.push_back(pose);
    }
    return out;
}

}  // namespace sylva
