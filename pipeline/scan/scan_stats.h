// The scan-statistics block of a manifest record (docs/scanning.md, "Statistics"): pulses and
// points, density (points per m² of ground for ALS/ULS, points per station for TLS), the share of
// each FOR-instance class, the share of pulses with several returns, and occlusion — the
// fraction of each tree's wood surface the scan hit.
//
// Occlusion is measured on the skeleton's tubes: a tree's wood surface is the lateral area of its
// shoot's segments (2π · mean radius · length, the tube sylva meshes around each), each cut into
// kWoodSectors equal sectors around its axis; a sector counts as hit when a point carrying the
// segment's node id (ScanLabel::nodeId, the node the segment ends at) lies in it. One TLS
// station sees about half of an isolated stem's sectors. Roots are left out (below ground no
// scanner sees them).
#pragma once

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

#include "pipeline/scan/scan_point.h"
#include "species/model/tree.h"

namespace sylva {

constexpr int kWoodSectors = 8;

class ScanStats {
  public:
    // `stations`: TLS stations (0 for ALS/ULS); `groundArea`: m² the survey covers (the plot's
    // area, or the tree's ground square); `maxReturns`: the scanner's.
    ScanStats(int stations, double groundArea, int maxReturns);

    // A tree of the scene and its skeleton (node ids of its points index it).
    void addTree(int32_t treeId, const Tree& tree);
    // The ground the density counts (x, z in the scene frame): only points above it make
    // points_per_m2 (a plot's area without its margin); without it every point counts.
    void setArea(std::function<bool(double x, double z)> inside) { inside_ = std::move(inside); }
    // Points in any order and any number of batches (the scanner's sink).
    void addPoints(const std::vector<ScanPoint>& points);

    // The block; `pulses` is the survey's pulse count (ScanResult::pulses).
    nlohmann::json json(uint64_t pulses) const;

    // Fraction of tree `treeId`'s wood surface hit (0 without wood).
    double woodSurfaceHit(int32_t treeId) const;

  private:
    struct TreeWood {
        int32_t id = 0;
        std::vector<double> area;  // per node: lateral area of the segment ending at it (m²)
        std::vector<uint8_t> hit;  // per node: a bit per sector hit
        std::vector<Vec3> start, axis, e1, e2;  // per node: the segment's frame
        double total = 0;
    };
    TreeWood* find(int32_t treeId);
    const TreeWood* find(int32_t treeId) const;

    int stations_;
    double groundArea_;
    int maxReturns_;
    std::vector<TreeWood> trees_;  // sorted by id
    std::function<bool(double, double)> inside_;
    uint64_t points_ = 0;
    uint64_t areaPoints_ = 0;  // points above the area (all without setArea)
    uint64_t classCount_[16] = {};
    std::vector<uint64_t> perStation_;        // TLS: points per station (ScanPoint::sourceId)
    std::vector<uint64_t> returnsHistogram_;  // first returns by number of returns (1 … 15)
};

}  // namespace sylva
