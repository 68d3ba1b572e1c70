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
      perChannel_(4, 0),
      returnsHistogram_(16, 0) {}

void ScanStats::addTree(int32_t treeId, const Tree& tree) {
    TreeWood w;
    w.id = treeId;
    w.area.assign(tree.nodes.size(), 0.0);
    w.hit.assign(tree.nodes.size(), 0);
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
        const SkeletonNode& n = tree.nodes[i];
        if (n.parent < 0 || n.part != kShootPart) continue;
        const SkeletonNode& p = tree.nodes[static_cast<size_t>(n.parent)];
        const double length = distance(n.position, p.position);
        w.area[i] = 2 * kPi * 0.5 * (n.radius + p.radius) * length;
        w.total += w.area[i];
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
        ++classCount_[p.classification & 15];
        ++perChannel_[p.channel & 3];
        if (p.returnNumber == 1) ++returnsHistogram_[std::min<int>(p.numberOfReturns, 15)];
        if (p.label.treeId > 0 && p.label.nodeId >= 0) {
            if (TreeWood* w = find(p.label.treeId)) {
                const auto n = static_cast<size_t>(p.label.nodeId);
                if (n < w->hit.size()) w->hit[n] = 1;
            }
        }
    }
}

double ScanStats::woodSurfaceHit(int32_t treeId) const {
    const TreeWood* w = find(treeId);
    if (!w || !(w->total > 0)) return 0;
    double hit = 0;
    for (size_t i = 0; i < w->area.size(); ++i) hit += w->hit[i] ? w->area[i] : 0.0;
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
        for (int s = 0; s < stations_ && s < 4; ++s) per.push_back(perChannel_[s]);
        j["points_per_station"] = per;
    } else {
        j["points_per_m2"] = groundArea_ > 0 ? static_cast<double>(points_) / groundArea_ : 0.0;
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
