// Reading a [scan] table into ScanOptions (scan_options.h); keys in docs/scanning.md.
#include <cmath>
#include <string>
#include <vector>

#include "pipeline/scan/scan_options.h"

namespace sylva {

namespace {

const std::vector<std::string> kTlsKeys = {
    "stations",         "horizontal_step_deg", "vertical_step_deg", "horizontal_fov_deg",
    "vertical_fov_deg", "vertical_centre_deg", "azimuth_deg",       "line_sweep_deg"};
const std::vector<std::string> kAirborneKeys = {"altitude",       "speed",       "strip_spacing",
                                                "overlap",        "heading_deg", "scan_rate",
                                                "scan_angle_deg", "mirror"};

void refuseKeys(Params& p, const std::vector<std::string>& keys, const char* owner,
                ScanPlatform platform) {
    for (const std::string& k : keys) {
        if (p.has(k)) {
            p.fail(k, std::string("a key of ") + owner + " scans; platform is \"" +
                          scanPlatformName(platform) + "\"");
        }
    }
}

}  // namespace

const char* scanPlatformName(ScanPlatform p) {
    return p == ScanPlatform::kTls ? "tls" : p == ScanPlatform::kAls ? "als" : "uls";
}

ScanOptions defaultScanOptions(ScanPlatform platform) {
    ScanOptions o;  // TLS: RIEGL VZ-400
    o.platform = platform;
    if (platform == ScanPlatform::kUls) {  // RIEGL miniVUX-1UAV datasheet
        o.altitude = 60;
        o.speed = 6;
        o.overlap = 0.5;
        o.scanRate = 100;
        o.scanAngle = 60 * kScanDeg;
        o.mirror = MirrorPattern::kRotating;
        o.pulseRate = 100000;
        o.beamDivergence = 0.9e-3;
        o.rangeNoise = 0.015;
        o.minRange = 3;
        o.maxRange = 250;
        o.maxReturns = 5;
        o.minSeparation = 0.6;                    // 4 ns pulse: c·τ/2
    } else if (platform == ScanPlatform::kAls) {  // Leica ALS50-II (HELIOS++ scanners_als.xml)
        o.altitude = 500;
        o.speed = 60;
        o.overlap = 0.2;
        o.scanRate = 70;
        o.scanAngle = 20 * kScanDeg;
        o.mirror = MirrorPattern::kOscillating;
        o.pulseRate = 150000;
        o.beamDivergence = 0.22e-3;
        o.rangeNoise = 0.05;
        o.minRange = 200;
        o.maxRange = 1500;
        o.maxReturns = 4;
        o.minSeparation = 3.5;
    }
    return o;
}

ScanOptions readScanOptions(Params& p) {
    const ScanPlatform platform = p.choice(
        "platform", ScanPlatform::kTls,
        {{"tls", ScanPlatform::kTls}, {"als", ScanPlatform::kAls}, {"uls", ScanPlatform::kUls}});
    ScanOptions o = defaultScanOptions(platform);
    const bool tls = platform == ScanPlatform::kTls;
    if (tls) {
        refuseKeys(p, kAirborneKeys, "als and uls", platform);
        std::vector<Params> stations = p.tableArray("stations");
        if (stations.empty()) {
            if (p.has("stations")) p.fail("stations", "expected at least one station");
            p.failHere("stations: expected at least one station ({x, z, height}) for a tls scan");
        }
        for (Params& s : stations) {
            TlsStation st;
            st.x = s.number("x", Range::any());
            st.z = s.number("z", Range::any());
            // Metres above the terrain: at or below it the scanner would be inside the ground.
            st.height = s.number("height", st.height, Range::leftOpen(0, 1000));
            s.finish();
            o.stations.push_back(st);
        }
        o.horizontalStep =
            p.degrees("horizontal_step_deg", o.horizontalStep, Range::leftOpen(0, 90));
        o.verticalStep = p.degrees("vertical_step_deg", o.verticalStep, Range::leftOpen(0, 90));
        o.horizontalFov = p.degrees("horizontal_fov_deg", o.horizontalFov, Range::leftOpen(0, 360));
        o.verticalFov = p.degrees("vertical_fov_deg", o.verticalFov, Range::leftOpen(0, 180));
        o.verticalCentre =
            p.degrees("vertical_centre_deg", o.verticalCentre, Range::closed(-90, 90));
        o.azimuth = p.degrees("azimuth_deg", o.azimuth, Range::closed(-360, 360));
        o.lineSweep = p.degrees("line_sweep_deg", std::max(o.lineSweep, o.verticalFov),
                                Range::closed(o.verticalFov / kScanDeg, 360));
        if (std::abs(o.verticalCentre) + o.verticalFov / 2 > kPi / 2 + 1e-9) {
            p.fail(p.has("vertical_centre_deg") ? "vertical_centre_deg" : "vertical_fov_deg",
                   "expected the vertical field within ±90° of the horizon, got " +
                       formatNumber((o.verticalCentre - o.verticalFov / 2) / kScanDeg) + "° … " +
                       formatNumber((o.verticalCentre + o.verticalFov / 2) / kScanDeg) + "°");
        }
    } else {
        refuseKeys(p, kTlsKeys, "tls", platform);
        o.altitude = p.number("altitude", o.altitude, Range::leftOpen(0, 10000));
        o.speed = p.number("speed", o.speed, Range::leftOpen(0, 1000));
        if (p.has("strip_spacing") && p.has("overlap")) {
            p.fail("overlap", "expected either strip_spacing or overlap, not both");
        }
        o.stripSpacing = p.number("strip_spacing", o.stripSpacing, Range::leftOpen(0, 1e5));
        o.overlap = p.number("overlap", o.overlap, Range{0, 0.95, false, false});
        o.heading = p.degrees("heading_deg", o.heading, Range::closed(-360, 360));
        o.mirror = p.choice(
            "mirror", o.mirror,
            {{"oscillating", MirrorPattern::kOscillating}, {"rotating", MirrorPattern::kRotating}});
        const bool rotating = o.mirror == MirrorPattern::kRotating;
        o.scanAngle = p.degrees("scan_angle_deg", o.scanAngle,
                                rotating ? Range::leftOpen(0, 180) : Range{0, 90, true, true});
        o.scanRate = p.number("scan_rate", o.scanRate, Range::leftOpen(0, 10000));
    }

    o.pulseRate = p.number("pulse_rate", o.pulseRate, Range::leftOpen(0, 1e8));
    if (!tls && o.scanRate > o.pulseRate) {
        p.fail("scan_rate", "expected at most pulse_rate (" + formatNumber(o.pulseRate) +
                                " Hz: one pulse per scan line), got " + formatNumber(o.scanRate));
    }
    o.beamDivergence =
        p.number("beam_divergence_mrad", o.beamDivergence * 1e3, Range::closed(0, 100)) * 1e-3;
    o.subRays = static_cast<int>(p.integer("sub_rays", o.subRays, Range::closed(1, 1000)));
    o.rangeNoise = p.number("range_noise", o.rangeNoise, Range::closed(0, 10));
    o.minRange = p.number("min_range", o.minRange, Range::nonNegative());
    o.maxRange = p.number("max_range", o.maxRange, Range::leftOpen(0, 1e6));
    if (o.maxRange <= o.minRange) {
        p.fail(p.has("max_range") ? "max_range" : "min_range",
               "expected min_range < max_range, got " + formatNumber(o.minRange) + " and " +
                   formatNumber(o.maxRange));
    }
    o.maxReturns = static_cast<int>(p.integer("max_returns", o.maxReturns, Range::closed(1, 15)));
    o.minSeparation = p.number("min_separation", o.minSeparation, Range::closed(0, 1000));
    if (std::optional<Params> r = p.optionalTable("reflectance")) {
        const Range unit = Range::closed(0, 1);
        o.reflectanceBark = r->number("bark", o.reflectanceBark, unit);
        o.reflectanceLeaf = r->number("leaf", o.reflectanceLeaf, unit);
        o.reflectanceGround = r->number("ground", o.reflectanceGround, unit);
        o.reflectanceLowVegetation = r->number("low_vegetation", o.reflectanceLowVegetation, unit);
        r->finish();
    }
    o.leafTransmission = p.number("leaf_transmission", o.leafTransmission, Range::closed(0, 1));
    o.referenceRange = p.number("reference_range", o.referenceRange, Range::closed(0, 1e5));
    o.detectionThreshold =
        p.number("detection_threshold", o.detectionThreshold, Range{0, 1, false, true});
    o.maxPulses = static_cast<uint64_t>(p.integer("pulses", 0, Range::closed(0, 1e12)));

    if (!tls) {
        const char* key = p.has("altitude") ? "altitude" : "min_range";
        if (o.altitude <= o.minRange || o.altitude >= o.maxRange) {
            p.fail(key, "expected the altitude (" + formatNumber(o.altitude) +
                            " m) between min_range (" + formatNumber(o.minRange) +
                            " m) and max_range (" + formatNumber(o.maxRange) + " m)");
        }
    } else {
        // A cap (`pulses`) bounds the survey only where it is below the limit itself: a cap of
        // 1e12 over a 0.001° grid is a survey of 3.6e10 pulses all the same.
        const double columns = std::floor(o.horizontalFov / o.horizontalStep + 1e-9) + 1;
        const double rows = std::floor(o.verticalFov / o.verticalStep + 1e-9) + 1;
        const double total = columns * rows * static_cast<double>(o.stations.size());
        const bool capped = o.maxPulses > 0 && static_cast<double>(o.maxPulses) < total;
        if (capped && static_cast<double>(o.maxPulses) > kMaxScanSurveyPulses) {
            p.fail("pulses", "expected at most 1e9 pulses in the survey, got a cap of " +
                                 formatNumber(static_cast<double>(o.maxPulses), 3) + " over " +
                                 formatNumber(total, 3) + " (" + formatNumber(columns, 6) +
                                 " columns × " + formatNumber(rows, 6) + " rows × " +
                                 std::to_string(o.stations.size()) + " stations)");
        }
        if (!capped && total > kMaxScanSurveyPulses) {
            p.fail(p.has("horizontal_step_deg") ? "horizontal_step_deg" : "vertical_step_deg",
                   "expected at most 1e9 pulses in the survey, got " + formatNumber(total, 3) +
                       " (" + formatNumber(columns, 6) + " columns × " + formatNumber(rows, 6) +
                       " rows × " + std::to_string(o.stations.size()) +
                       " stations); use larger steps or cap them with `pulses`");
        }
    }
    p.finish();
    return o;
}

ScanOptions loadScanSpec(const std::string& file, KeyLog* keyLog) {
    const toml::table t = parseTomlFile(file);
    DrawContext draw;
    draw.draw = false;
    draw.keyLog = keyLog;
    Params top(t, file, "", &draw);
    top.documentAs("dataset");
    Params scan = top.table("scan");
    return readScanOptions(scan);
}

}  // namespace sylva
