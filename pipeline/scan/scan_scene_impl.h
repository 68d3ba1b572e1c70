// Inside a ScanScene (scan_scene.cpp builds it, scanner.cpp reads it): the Embree handles and
// the per-geometry tables that turn a hit (geometry, primitive, instance) into a label.
#pragma once

#include <embree3/rtcore.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "pipeline/scan/scan_scene.h"

namespace sylva {

// What a surface is to the laser: which reflectance applies and whether rays may go through.
enum class SurfaceKind : uint8_t { kWood, kLeaf, kGround, kLowVegetation };

struct ScanNodeInfo {
    uint8_t part = kScanBranch;  // ScanPart of the wood ending at the node
    uint8_t order = 0;           // branch order (clamped to 255)
    bool carriesLeaves = false;  // the node or a node above it bears a leaf
};

// One Embree geometry of a scene (the top scene or a prototype's).
struct ScanGeometry {
    ScanLabel base;  // treeId, species, objectId, part (leaf, terrain, cover), order
    SurfaceKind kind = SurfaceKind::kWood;
    std::vector<int32_t> triangleNode;                       // per triangle; empty: none
    std::shared_ptr<const std::vector<ScanNodeInfo>> nodes;  // of the tree
    uint8_t classification = kForUnclassified;               // when no node decides it
    uint8_t semantic = kSemNone;
};

struct ScanPrototype {
    RTCScene scene = nullptr;
    std::vector<ScanGeometry> geometries;  // by geomID within the prototype
    int64_t triangles = 0;
};

struct ScanInstance {
    int prototype = 0;
    int32_t treeId = 0;
    int32_t firstObjectId = 0;  // objectId of the prototype's geometry 0 for this copy
    float cosY = 1, sinY = 0;   // its rotation about +y (Embree reports normals unrotated)
};

struct ResolvedHit {
    ScanLabel label;
    uint8_t classification = kForUnclassified;
    uint8_t semantic = kSemNone;
};

struct ScanScene::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::vector<ScanGeometry> geometries;  // top-level geomID → mesh object …
    std::vector<int> instanceOf;           // … or instance (index into instances; −1: a mesh)
    std::vector<ScanInstance> instances;
    std::vector<ScanPrototype> prototypes;
    std::function<double(double, double)> ground;
    Aabb area;
    bool hasArea = false;
    bool committed = false;
    int32_t nextObjectId = 0;
    int64_t triangles = 0, storedTriangles = 0;
    std::atomic<int64_t> bytes{0};  // Embree's memory monitor

    ~Impl();

    // The geometry a hit landed on (instID: RTC_INVALID_GEOMETRY_ID when not instanced).
    const ScanGeometry& geometry(unsigned geomID, unsigned instID) const {
        if (instID == RTC_INVALID_GEOMETRY_ID) return geometries[geomID];
        return prototypes[instances[instanceOf[instID]].prototype].geometries[geomID];
    }
    ResolvedHit resolve(unsigned geomID, unsigned primID, unsigned instID) const;
};

}  // namespace sylva
