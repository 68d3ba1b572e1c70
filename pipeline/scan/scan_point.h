// The points a simulated laser scan returns (pipeline/scan/scanner.h makes them, the LAS, PLY and
// TreeLearn writers in pipeline/formats/scan_writers.h write them), and the codes they carry.
//
// Frame: the scene's metres, +y up (a tree's local frame, or plot-local metres with the plot
// centre at x = z = 0). The writers turn this into the survey frame LAS readers expect
// (x east, y north, z up: LAS x = x, LAS y = −z, LAS z = y).
#pragma once

#include <cstdint>
#include <vector>

namespace sylva {

// Point classes in the FOR-instance benchmark's codes (Puliti et al. 2023, "FOR-instance: a
// UAV laser scanning benchmark dataset for semantic and instance segmentation of individual
// trees", Table 2), written as LAS `classification`.
enum ForInstanceClass : uint8_t {
    kForUnclassified = 0,
    kForLowVegetation = 1,
    kForTerrain = 2,
    kForOutPoints = 3,
    kForStem = 4,
    kForLiveBranches = 5,   // foliage and the branches carrying it
    kForWoodyBranches = 6,  // woody branches
};

// The three-class semantics ForestFormer3D reads (`semantic_seg`): 1 ground, 2 wood, 3 leaf
// (0: none of those, e.g. nothing hit).
enum SemanticClass : uint8_t {
    kSemNone = 0,
    kSemGround = 1,
    kSemWood = 2,
    kSemLeaf = 3,
};

// The part of the scene a triangle belongs to (the plot's PlotPart codes, pipeline/render/
// plot_render.h, so a plot's scene PLY `part`, label images and scan points agree).
enum ScanPart : uint8_t {
    kScanTerrain = 0,
    kScanStem = 1,
    kScanBranch = 2,
    kScanLeaf = 3,
    kScanRoot = 4,
    kScanLowVegetation = 5,
};

// What every triangle of a scan scene says about itself (one per triangle).
struct ScanLabel {
    int32_t treeId = 0;    // 1 … N (the tree table's id; a single tree is 1); 0 = no tree
    int32_t nodeId = -1;   // the skeleton node whose wood this is (−1: leaf, terrain, cover)
    int32_t objectId = 0;  // the scene object (Embree geometry) this triangle belongs to
    uint16_t species = 0;  // species index (the plot's species list; a single tree: 0)
    uint8_t part = kScanTerrain;  // ScanPart
    uint8_t branchOrder = 0;      // 0 = stem; leaves carry their branch's order
};

// One return of one pulse.
struct ScanPoint {
    double x = 0, y = 0, z = 0;   // metres, scene frame (+y up)
    double gpsTime = 0;           // seconds since the survey started (pulse emission time)
    uint16_t intensity = 0;       // 0 … 65535, from incidence angle and part reflectance
    uint8_t returnNumber = 1;     // 1 … numberOfReturns
    uint8_t numberOfReturns = 1;  // returns of this pulse, ≤ the scanner's maximum (≤ 15)
    uint8_t channel = 0;          // scanner channel: the TLS station or ALS/ULS strip index mod 4
    uint16_t sourceId = 0;  // LAS point source ID: the station or strip index + 1 (1 … 65535)
    bool scanDirection = false;  // LAS scan direction flag (mirror moving +)
    bool edgeOfFlightLine = false;
    // LAS 1.4: from the downward vertical, + counter-clockwise seen from behind the sensor facing
    // along its travel: ALS/ULS from nadir, + to the right of the flight; TLS −(90° + elevation),
    // the beam lying to the left of the head's clockwise turn.
    float scanAngleDeg = 0;
    float elevationDeg = 0;  // the beam above the horizon (−90 … 90)
    // The share of the return's echo energy from the surfaces of its label (tree and semantic
    // class, which the point carries): 1 when every sub-ray of the return hit one class.
    float labelPurity = 1;
    uint64_t pulse = 0;                         // the pulse's index in the survey
    ScanLabel label;                            // of the triangle hit
    uint8_t classification = kForUnclassified;  // ForInstanceClass
    uint8_t semantic = kSemNone;                // SemanticClass
};

// Where the scanner was: one record per pulse batch (ALS/ULS trajectory) or per station (TLS).
struct ScanPose {
    double gpsTime = 0;
    double x = 0, y = 0, z = 0;  // scene frame, metres
    double headingDeg = 0;       // direction of travel (ALS/ULS) or 0 (TLS)
    uint8_t channel = 0;
    uint16_t sourceId = 0;  // the station or strip index + 1 (ScanPoint::sourceId)
};

struct ScanResult {
    std::vector<ScanPoint> points;  // in pulse order, then return number
    std::vector<ScanPose> trajectory;
    uint64_t pulses = 0;  // pulses emitted (including those that hit nothing)
};

}  // namespace sylva
