// The scene a laser scan casts its pulses through: Embree triangle geometries (one per object:
// a tree's wood, its leaves, the terrain, the ground cover) in one BVH built once, with a label
// for every triangle (scan_point.h ScanLabel: tree id, skeleton node, part, branch order,
// species, object id) and the FOR-instance class it maps to. Repeated trees can be instanced
// (one prototype BVH, any number of placed copies, each with its own tree id).
//
// Frame: the scene's metres, +y up; the terrain's height y = ground(x, z).
//
//   ScanScene s = makeScanScene(tree, mesh, woodNodes, 10.0);   // a tree on a 20 m ground square
//   ScanScene p = makeScanScene(plot, plotScene);               // a plot: trees, terrain, cover
//   ScanResult r = scan(s, options, seed);                      // scanner.h
//
// Every Embree object (device, scenes, geometries) belongs to the ScanScene and is released with
// it, so repeated scans in one process do not grow its memory.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "core/math.h"
#include "pipeline/scan/scan_point.h"
#include "species/geometry/mesh.h"
#include "species/model/tree.h"

namespace sylva {

struct GrownPlot;
struct PlotScene;

// A tree's meshes as a scan sees them: its skeleton (for the nodes' parts, orders and whether
// their branches carry leaves), its wood tubes with the skeleton node of every wood triangle
// (tubeMesh's triangleNodes), and its leaves as leafMesh makes them from `tree.leaves` (or from
// cards of the same leaves, `leafOutlines` false). Leaf meshes are double-sided; the scene keeps
// one face per leaf (Embree hits triangles from both sides).
struct ScanTreeInput {
    const Tree* tree = nullptr;
    const TreeMesh* mesh = nullptr;
    const std::vector<int32_t>* woodNodes = nullptr;
    bool leafOutlines = true;
    int32_t treeId = 1;
    uint16_t species = 0;
};

class ScanScene {
  public:
    ScanScene();  // empty, with its own Embree device
    ~ScanScene();
    ScanScene(ScanScene&&) noexcept;
    ScanScene& operator=(ScanScene&&) noexcept;
    ScanScene(const ScanScene&) = delete;
    ScanScene& operator=(const ScanScene&) = delete;

    // Objects placed as they are (scene metres). Each call adds one object per non-empty mesh.
    void addTree(const ScanTreeInput& tree);
    void addMesh(const Mesh& mesh, ScanPart part);  // terrain or ground cover
    // A tree to be placed many times (its meshes in its own frame, base at the origin) …
    int addPrototype(const ScanTreeInput& tree);
    // … and one placed copy: rotated by `rotationY` (radians, about +y), then moved to `base`;
    // its points carry `treeId`.
    void addInstance(int prototype, const Vec3& base, double rotationY, int32_t treeId);

    // The terrain height under (x, z) (stations and flight altitude stand on it; default 0) and
    // the ground area ALS/ULS strips cover (x and z of `area`; default: the scene's bounds).
    void setGround(std::function<double(double x, double z)> height);
    void setArea(const Aabb& area);

    // Builds the BVH (once; adding objects afterwards is an error).
    void commit();

    double groundHeight(double x, double z) const;
    Aabb area() const;
    Aabb bounds() const;              // of every triangle (committed scene)
    int64_t triangles() const;        // triangles in the scene, counting every instance's copy
    int64_t storedTriangles() const;  // triangles held in memory (a prototype once)
    int64_t embreeBytes() const;      // bytes Embree holds now (geometry buffers and BVHs)

    struct Impl;
    const Impl& impl() const { return *impl_; }

  private:
    std::unique_ptr<Impl> impl_;
};

// One tree; with `groundHalfSize` > 0 also a ground square of that half size (metres) at y = 0
// under the tree's base (the terrain part).
ScanScene makeScanScene(const Tree& tree, const TreeMesh& mesh,
                        const std::vector<int32_t>& woodNodes, double groundHalfSize = 0,
                        bool leafOutlines = true);
// A plot: every tree of `scene` (ids, species as the plot's), the terrain and the ground cover;
// the ground is the plot's terrain, the strips' area the plot's (its margin excluded).
ScanScene makeScanScene(const GrownPlot& plot, const PlotScene& scene);

// The FOR-instance class and ForestFormer3D semantic of a part (scan_point.h). Wood of order ≥ 1
// is "live branches" (5) when it or a branch it carries bears leaves, else "woody branches" (6);
// stems and roots are 4; leaves 5; terrain 2; ground cover 1.
uint8_t forInstanceClass(uint8_t part, bool carriesLeaves);
uint8_t semanticClass(uint8_t part);

}  // namespace sylva
