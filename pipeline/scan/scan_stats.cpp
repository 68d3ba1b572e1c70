#include "pipeline/scan/scan_stats.h"

#include <algorithm>
#include <cmath>

namespace sylva {

namespace {

// FOR-instance class names (scan_point.h), as the block's keys.
const char* className(int c) {
    switch (c) {
        case kForUnclassified:
            return "unclassified";
        case kForLowVegetation:
            return "low_vegetation";
        case kForTerrain:
            return "terrain";
        case kForOutPoints:
            return "out_points";
        case kForStem:
            return "stem";
        case kForLiveBranches:
            return "live_branches";
        case kForWoodyBranches:
            return "woody_branches";
        default:
            return nullptr;
    }
}

}  // namespace

ScanStats::ScanStats(int stations, double groundArea, int maxReturns)
    : stations_(stations),
      groundArea_(groundArea),
      maxReturns_(maxReturns),
      perStation_(static_cast<size_t>(std::max(stations, 0)), 0),
      returnsHistogram_(16, 0) {}

void ScanStats::addTree(int32_t treeId, const Tree& tree) {
    TreeWood w;
    w.id = treeId;
    const size_t n = tree.nodes.size();
    w.area.assign(n, 0.0);
    w.hit.assign(n, 0);
    w.start.assign(n, Vec3{});
    w.axis.assign(n, Vec3{0, 1, 0});
    w.e1.assign(n, Vec3{1, 0, 0});
    w.e2.assign(n, Vec3{0, 0, 1});
    for (size_t i = 0; i < n; ++i) {
        const SkeletonNode& node = tree.nodes[i];
        if (node.parent < 0 || node.part != kShootPart) continue;
        const SkeletonNode& p = tree.nodes[static_cast<size_t>(node.parent)];
        const double length = distance(node.position, p.position);
        if (!(length > 0)) continue;
        w.area[i] = 2 * kPi * 0.5 * (node.radius + p.radius) * length;
        w.total += w.area[i];
        // The segment's frame: its axis and two unit vectors across it (the first from the
        // world axis least parallel to it), so a point's angle around the axis picks a sector.
        const Vec3 d = (node.position - p.position) * (1.0 / length);
        const Vec3 ref = std::abs(d.y) < 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
        const Vec3 a = normalize(cross(ref, d));
        w.start[i] = p.position;
        w.axis[i] = d;
        w.e1[i] = a;
        w.e2[i] = cross(d, a);
    }
    const auto at = std::lower_bound(trees_.begin(), trees_.end(), treeId,
                                     [](const TreeWood& a, int32_t id) { return a.id < id; });
    trees_.insert(at, std::move(w));
}

ScanStats::TreeWood* ScanStats::find(int32_t treeId) {
    const auto at = std::lower_bound(trees_.begin(), trees_.end(), treeId,
                                     [](const TreeWood& a, int32_t id) { return a.id < id; });
    return at != trees_.end() && at->id == treeId ? &*at : nullptr;
}

const ScanStats::TreeWood* ScanStats::find(int32_t treeId) const {
    return const_cast<ScanStats*>(this)->find(treeId);
}

void ScanStats::addPoints(const std::vector<ScanPoint>& points) {
    for (const ScanPoint& p : points) {
        ++points_;
        if (!inside_ || inside_(p.x, p.z)) ++areaPoints_;
        ++classCount_[p.classification & 15];
        // Point source IDs count stations from 1.
        if (p.sourceId >= 1 && p.sourceId <= perStation_.size()) ++perStation_[p.sourceId - 1];
        if (p.returnNumber == 1) ++returnsHistogram_[std::min<int>(p.numberOfReturns, 15)];
        if (p.label.treeId > 0 && p.label.nodeId >= 0) {
            if (TreeWood* w = find(p.label.treeId)) {
                const auto n = static_cast<size_t>(p.label.nodeId);
                if (n < w->hit.size() && w->area[n] > 0) {
                    const Vec3 v = Vec3{p.x, p.y, p.z} - w->start[n];
                    const double angle = std::atan2(dot(v, w->e2[n]), dot(v, w->e1[n]));
                    int sector =
                        static_cast<int>(std::floor((angle + kPi) / (2 * kPi) * kWoodSectors));
                    sector = std::clamp(sector, 0, kWoodSectors - 1);
                    w->hit[n] |= static_cast<uint8_t>(1u << sector);
                }
            }
        }
    }
}

double ScanStats::woodSurfaceHit(int32_t treeId) const {
    const TreeWood* w = find(treeId);
    if (!w || !(w->total > 0)) return 0;
    double hit = 0;
    for (size_t i = 0; i < w->area.size(); ++i) {
        hit += w->area[i] * __builtin_popcount(w->hit[i]) / kWoodSectors;
    }
    return hit / w->total;
}

nlohmann::json ScanStats::json(uint64_t pulses) const {
    nlohmann::json j;
    j["pulses"] = pulses;
    j["points"] = points_;
    uint64_t echoing = 0, multiple = 0;
    for (size_t n = 1; n < returnsHistogram_.size(); ++n) {
        echoing += returnsHistogram_[n];
        if (n >= 2) multiple += returnsHistogram_[n];
    }
    // Pulses that returned anything, and the share of those with two or more returns.
    j["pulses_with_returns"] = echoing;
    j["multiple_return_share"] =
        echoing ? static_cast<double>(multiple) / static_cast<double>(echoing) : 0.0;
    if (stations_ > 0) {
        nlohmann::json per = nlohmann::json::array();
        for (uint64_t n : perStation_) per.push_back(n);
        j["points_per_station"] = per;
    } else {
        j["points_per_m2"] = groundArea_ > 0 ? static_cast<double>(areaPoints_) / groundArea_ : 0.0;
    }
    nlohmann::json cls = nlohmann::json::object();
    for (int c = 0; c < 16; ++c) {
        const char* name = className(c);
        if (!name) continue;
        cls[name] =
            points_ ? static_cast<double>(classCount_[c]) / static_cast<double>(points_) : 0.0;
    }
    j["class_fraction"] = cls;
    nlohmann::json trees = nlohmann::json::array();
    double sum = 0, lo = 1;
    int counted = 0;
    for (const TreeWood& w : trees_) {
        if (!(w.total > 0)) continue;
        const double f = woodSurfaceHit(w.id);
        trees.push_back({{"tree", w.id}, {"wood_surface_hit", f}});
        sum += f;
        lo = std::min(lo, f);
        ++counted;
    }
    j["wood_surface_hit_mean"] = counted ? sum / counted : 0.0;
    j["wood_surface_hit_min"] = counted ? lo : 0.0;
    j["trees"] = trees;
    return j;
}

}  // namespace sylva
