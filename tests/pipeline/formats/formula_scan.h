// The hand-made scan the scan-writer tests share (scan_writers_test.cpp, laz_writer_test.cpp).
#pragma once

#include <cstdint>

#include "pipeline/scan/scan_point.h"

namespace sylva::test {

// The hand-made scan every reader test shares: point i from closed-form expressions, so the
// readers (tests/js/check_scan.mjs, tests/python/test_scan_outputs.py) compute the same known
// answers on their own. Varied on purpose: negative and positive coordinates on every axis,
// every return number 1 … 15, channels 0 … 3, every FOR-instance class, node_id −1.
inline ScanResult formulaScan(int n) {
    ScanResult scan;
    for (int i = 0; i < n; ++i) {
        ScanPoint p;
        p.x = -12.5 + 0.0731 * i;
        p.y = -1.0 + 0.043 * i;
        p.z = 7.25 - 0.0517 * i;
        p.gpsTime = 0.001 * i + 0.000001 * (i % 7);
        p.intensity = static_cast<uint16_t>((int64_t{i} * 40503) % 65536);
        p.numberOfReturns = static_cast<uint8_t>(1 + (i / 4) % 15);
        p.returnNumber = static_cast<uint8_t>(1 + i % p.numberOfReturns);
        p.channel = static_cast<uint8_t>(i % 4);
        p.sourceId = static_cast<uint16_t>(i % 8);  // a station index; channel = it mod 4
        p.scanDirection = i % 2 == 1;
        p.edgeOfFlightLine = i % 11 == 0;
        p.scanAngleDeg = static_cast<float>(-45 + 0.3 * i);
        p.elevationDeg = static_cast<float>(-40 + 0.37 * i);
        p.labelPurity = static_cast<float>(0.2 + 0.1 * (i % 9));
        p.pulse = static_cast<uint64_t>(i);
        p.label.treeId = i % 6;
        p.label.nodeId = i % 9 - 1;
        p.label.objectId = (i * 13) % 1000;
        p.label.species = static_cast<uint16_t>((i * 37) % 1000);
        p.label.part = static_cast<uint8_t>(i % 6);
        p.label.branchOrder = static_cast<uint8_t>(i % 4);
        p.classification = static_cast<uint8_t>(i % 7);
        p.semantic = static_cast<uint8_t>(i % 4);
        scan.points.push_back(p);
    }
    for (int k = 0; k < 3; ++k) {
        ScanPose pose;
        pose.gpsTime = 0.1 * k;
        pose.x = 1.5 * k;
        pose.y = 60 + k;
        pose.z = -20 + 2.25 * k;
        pose.headingDeg = 90;
        pose.channel = static_cast<uint8_t>(k);
        scan.trajectory.push_back(pose);
    }
    scan.pulses = static_cast<uint64_t>(n);
    return scan;
}

}  // namespace sylva::test
