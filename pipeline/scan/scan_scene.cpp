// The scan scene: Embree geometries with per-triangle labels (scan_scene.h).
#include "pipeline/scan/scan_scene.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "pipeline/render/embree_scene.h"
#include "pipeline/render/plot_render.h"
#include "pipeline/scan/scan_scene_impl.h"
#include "species/model/leaf_shape.h"
#include "species/plot/plot.h"
#include "species/plot/terrain.h"

namespace sylva {

uint8_t forInstanceClass(uint8_t part, bool carriesLeaves) {
    switch (part) {
        case kScanTerrain:
            return kForTerrain;
        case kScanLowVegetation:
            return kForLowVegetation;
        case kScanStem:
        case kScanRoot:
            return kForStem;
        case kScanBranch:
            return carriesLeaves ? kForLiveBranches : kForWoodyBranches;
        case kScanLeaf:
            return kForLiveBranches;
        default:
            return kForUnclassified;
    }
}

uint8_t semanticClass(uint8_t part) {
    switch (part) {
        case kScanTerrain:
        case kScanLowVegetation:
            return kSemGround;
        case kScanStem:
        case kScanBranch:
        case kScanRoot:
            return kSemWood;
        case kScanLeaf:
            return kSemLeaf;
        default:
            return kSemNone;
    }
}

ResolvedHit ScanScene::Impl::resolve(unsigned geomID, unsigned primID, unsigned instID) const {
    const ScanGeometry& g = geometry(geomID, instID);
    ResolvedHit r;
    r.label = g.base;
    r.classification = g.classification;
    r.semantic = g.semantic;
    if (instID != RTC_INVALID_GEOMETRY_ID) {
        const ScanInstance& inst = instances[instanceOf[instID]];
        r.label.treeId = inst.treeId;
        r.label.objectId = inst.firstObjectId + static_cast<int32_t>(geomID);
    }
    if (!g.triangleNode.empty()) {
        const int32_t n = g.triangleNode[primID];
        if (n >= 0) {
            const ScanNodeInfo& info = (*g.nodes)[n];
            r.label.branchOrder = info.order;
            if (g.kind == SurfaceKind::kWood) {
                r.label.nodeId = n;
                r.label.part = info.part;
                r.classification = forInstanceClass(info.part, info.carriesLeaves);
                r.semantic = semanticClass(info.part);
            }
        }
    }
    return r;
}

ScanScene::Impl::~Impl() {
    for (ScanPrototype& p : prototypes) {
        if (p.scene) rtcReleaseScene(p.scene);
    }
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
}

namespace {

bool monitorMemory(void* user, ssize_t bytes, bool /*post*/) {
    static_cast<std::atomic<int64_t>*>(user)->fetch_add(bytes, std::memory_order_relaxed);
    return true;
}

// The triangles (indices into mesh) as a new Embree geometry of `scene`.
unsigned attachTriangles(RTCDevice device, RTCScene scene, const Mesh& mesh,
                         const std::vector<uint32_t>& indices) {
    return sylva::attachTriangles(device, scene, mesh.positions.data(), mesh.vertexCount(),
                                  indices.data(), indices.size() / 3);
}

// Per skeleton node: its wood part, order and whether it or a node above it bears a leaf.
std::shared_ptr<const std::vector<ScanNodeInfo>> nodeInfo(const Tree& tree) {
    auto info = std::make_shared<std::vector<ScanNodeInfo>>(tree.nodes.size());
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
        const SkeletonNode& n = tree.nodes[i];
        (*info)[i].part = n.part == kRootPart ? kScanRoot : n.order == 0 ? kScanStem : kScanBranch;
        (*info)[i].order = static_cast<uint8_t>(std::clamp(n.order, 0, 255));
    }
    for (const Leaf& l : tree.leaves) {
        if (l.node >= 0 && static_cast<size_t>(l.node) < info->size()) {
            (*info)[l.node].carriesLeaves = true;
        }
    }
    // Parents have smaller indices: one pass from the tips down.
    for (size_t i = tree.nodes.size(); i-- > 1;) {
        const int32_t p = tree.nodes[i].parent;
        if (p >= 0 && (*info)[i].carriesLeaves) (*info)[p].carriesLeaves = true;
    }
    return info;
}

struct MeshPiece {
    ScanGeometry geometry;
    const Mesh* mesh = nullptr;
    std::vector<uint32_t> indices;
};

// The wood and leaf geometries of a tree (without object ids).
std::vector<MeshPiece> treePieces(const ScanTreeInput& in) {
    if (!in.tree || !in.mesh) throw std::invalid_argument("ScanTreeInput: tree and mesh needed");
    const Tree& tree = *in.tree;
    const TreeMesh& m = *in.mesh;
    auto nodes = nodeInfo(tree);
    std::vector<MeshPiece> out;
    if (!m.wood.empty()) {
        if (!in.woodNodes || in.woodNodes->size() != m.wood.triangleCount()) {
            throw std::invalid_argument(
                "ScanTreeInput: one skeleton node per wood triangle needed");
        }
        MeshPiece w;
        w.geometry.kind = SurfaceKind::kWood;
        w.geometry.base.treeId = in.treeId;
        w.geometry.base.species = in.species;
        w.geometry.base.part = kScanBranch;
        w.geometry.triangleNode = *in.woodNodes;
        for (int32_t& n : w.geometry.triangleNode) {
            if (n >= static_cast<int32_t>(nodes->size())) n = -1;
        }
        w.geometry.nodes = nodes;
        w.geometry.classification = kForWoodyBranches;
        w.geometry.semantic = kSemWood;
        w.mesh = &m.wood;
        w.indices = m.wood.indices;
        out.push_back(std::move(w));
    }
    if (!m.leaves.empty()) {
        MeshPiece l;
        l.geometry.kind = SurfaceKind::kLeaf;
        l.geometry.base.treeId = in.treeId;
        l.geometry.base.species = in.species;
        l.geometry.base.part = kScanLeaf;
        l.geometry.nodes = nodes;
        l.geometry.classification = kForLiveBranches;
        l.geometry.semantic = kSemLeaf;
        l.mesh = &m.leaves;
        // leafMesh: per leaf its outline's triangles twice (front, then back reversed); keep the
        // front ones. When the count does not match the tree's leaves, keep every triangle.
        size_t expected = 0;
        for (const Leaf& leaf : tree.leaves) {
            expected +=
                2 * leafOutline(in.leafOutlines ? leaf.shape : LeafShape::kCard).triangles.size();
        }
        if (expected == m.leaves.indices.size()) {
            size_t at = 0;
            for (const Leaf& leaf : tree.leaves) {
                const size_t t =
                    leafOutline(in.leafOutlines ? leaf.shape : LeafShape::kCard).triangles.size();
                l.indices.insert(l.indices.end(), m.leaves.indices.begin() + at,
                                 m.leaves.indices.begin() + at + t);
                for (size_t k = 0; k < t / 3; ++k) {
                    l.geometry.triangleNode.push_back(
                        leaf.node < static_cast<int32_t>(nodes->size()) ? leaf.node : -1);
                }
                at += 2 * t;
            }
        } else {
            l.indices = m.leaves.indices;
        }
        out.push_back(std::move(l));
    }
    return out;
}

}  // namespace

ScanScene::ScanScene() : impl_(std::make_unique<Impl>()) {
    impl_->device = newEmbreeDevice();
    rtcSetDeviceMemoryMonitorFunction(impl_->device, monitorMemory, &impl_->bytes);
    impl_->scene = newRobustScene(impl_->device);
}

ScanScene::~ScanScene() = default;
ScanScene::ScanScene(ScanScene&&) noexcept = default;
ScanScene& ScanScene::operator=(ScanScene&&) noexcept = default;

void ScanScene::addTree(const ScanTreeInput& tree) {
    Impl& s = *impl_;
    if (s.committed) throw std::logic_error("ScanScene: objects added after commit");
    for (MeshPiece& p : treePieces(tree)) {
        if (p.indices.empty()) continue;
        const unsigned id = attachTriangles(s.device, s.scene, *p.mesh, p.indices);
        p.geometry.base.objectId = s.nextObjectId++;
        if (s.geometries.size() <= id) s.geometries.resize(id + 1), s.instanceOf.resize(id + 1, -1);
        s.triangles += static_cast<int64_t>(p.indices.size() / 3);
        s.storedTriangles += static_cast<int64_t>(p.indices.size() / 3);
        s.geometries[id] = std::move(p.geometry);
    }
}

void ScanScene::addMesh(const Mesh& mesh, ScanPart part) {
    Impl& s = *impl_;
    if (s.committed) throw std::logic_error("ScanScene: objects added after commit");
    if (mesh.empty()) return;
    std::vector<uint32_t> indices = mesh.indices;
    ScanGeometry g;
    g.kind = part == kScanTerrain         ? SurfaceKind::kGround
             : part == kScanLeaf          ? SurfaceKind::kLeaf
             : part == kScanLowVegetation ? SurfaceKind::kLowVegetation
                                          : SurfaceKind::kWood;
    g.base.part = part;
    g.classification = forInstanceClass(part, false);
    g.semantic = semanticClass(part);
    const unsigned id = attachTriangles(s.device, s.scene, mesh, indices);
    g.base.objectId = s.nextObjectId++;
    if (s.geometries.size() <= id) s.geometries.resize(id + 1), s.instanceOf.resize(id + 1, -1);
    s.geometries[id] = std::move(g);
    s.triangles += static_cast<int64_t>(mesh.triangleCount());
    s.storedTriangles += static_cast<int64_t>(mesh.triangleCount());
}

int ScanScene::addPrototype(const ScanTreeInput& tree) {
    Impl& s = *impl_;
    if (s.committed) throw std::logic_error("ScanScene: objects added after commit");
    ScanPrototype p;
    p.scene = newRobustScene(s.device);
    for (MeshPiece& piece : treePieces(tree)) {
        if (piece.indices.empty()) continue;
        const unsigned id = attachTriangles(s.device, p.scene, *piece.mesh, piece.indices);
        if (p.geometries.size() <= id) p.geometries.resize(id + 1);
        p.triangles += static_cast<int64_t>(piece.indices.size() / 3);
        p.geometries[id] = std::move(piece.geometry);
    }
    rtcCommitScene(p.scene);
    checkEmbree(s.device, "rtcCommitScene (prototype)");
    s.storedTriangles += p.triangles;
    s.prototypes.push_back(std::move(p));
    return static_cast<int>(s.prototypes.size()) - 1;
}

void ScanScene::addInstance(int prototype, const Vec3& base, double rotationY, int32_t treeId) {
    Impl& s = *impl_;
    if (s.committed) throw std::logic_error("ScanScene: objects added after commit");
    if (prototype < 0 || prototype >= static_cast<int>(s.prototypes.size())) {
        throw std::invalid_argument("ScanScene::addInstance: no such prototype");
    }
    const ScanPrototype& p = s.prototypes[prototype];
    RTCGeometry g = rtcNewGeometry(s.device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(g, p.scene);
    // Column-major 3×4: rotation about +y, then the translation.
    const float c = static_cast<float>(std::cos(rotationY)),
                sn = static_cast<float>(std::sin(rotationY));
    const float xf[12] = {c,
                          0,
                          -sn,
                          0,
                          1,
                          0,
                          sn,
                          0,
                          c,
                          static_cast<float>(base.x),
                          static_cast<float>(base.y),
                          static_cast<float>(base.z)};
    rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xf);
    rtcCommitGeometry(g);
    const unsigned id = rtcAttachGeometry(s.scene, g);
    rtcReleaseGeometry(g);
    checkEmbree(s.device, "instance");
    if (s.geometries.size() <= id) s.geometries.resize(id + 1), s.instanceOf.resize(id + 1, -1);
    ScanInstance inst;
    inst.prototype = prototype;
    inst.treeId = treeId;
    inst.firstObjectId = s.nextObjectId;
    inst.cosY = c;
    inst.sinY = sn;
    s.nextObjectId += static_cast<int32_t>(p.geometries.size());
    s.instanceOf[id] = static_cast<int>(s.instances.size());
    s.instances.push_back(inst);
    s.triangles += p.triangles;
}

void ScanScene::setGround(std::function<double(double, double)> height) {
    impl_->ground = std::move(height);
}

void ScanScene::setArea(const Aabb& area) {
    impl_->area = area;
    impl_->hasArea = true;
}

void ScanScene::commit() {
    Impl& s = *impl_;
    if (s.committed) return;
    rtcCommitScene(s.scene);
    checkEmbree(s.device, "rtcCommitScene");
    s.committed = true;
}

double ScanScene::groundHeight(double x, double z) const {
    return impl_->ground ? impl_->ground(x, z) : 0.0;
}

Aabb ScanScene::bounds() const {
    RTCBounds b;
    rtcGetSceneBounds(impl_->scene, &b);
    Aabb a;
    if (b.lower_x <= b.upper_x) {
        a.extend(Vec3{b.lower_x, b.lower_y, b.lower_z});
        a.extend(Vec3{b.upper_x, b.upper_y, b.upper_z});
    }
    return a;
}

Aabb ScanScene::area() const { return impl_->hasArea ? impl_->area : bounds(); }
int64_t ScanScene::triangles() const { return impl_->triangles; }
int64_t ScanScene::storedTriangles() const { return impl_->storedTriangles; }
int64_t ScanScene::embreeBytes() const { return impl_->bytes.load(); }

ScanScene makeScanScene(const Tree& tree, const TreeMesh& mesh,
                        const std::vector<int32_t>& woodNodes, double groundHalfSize,
                        bool leafOutlines) {
    ScanScene s;
    ScanTreeInput in;
    in.tree = &tree;
    in.mesh = &mesh;
    in.woodNodes = &woodNodes;
    in.leafOutlines = leafOutlines;
    s.addTree(in);
    if (groundHalfSize > 0) {
        const Vec3 base = tree.nodes.empty() ? Vec3{} : tree.nodes[0].position;
        const float h = static_cast<float>(groundHalfSize);
        const float x = static_cast<float>(base.x), z = static_cast<float>(base.z);
        Mesh g;
        g.positions = {x - h, 0, z - h, x + h, 0, z - h, x + h, 0, z + h, x - h, 0, z + h};
        g.indices = {0, 2, 1, 0, 3, 2};  // counter-clockwise seen from +y
        s.addMesh(g, kScanTerrain);
    }
    s.commit();
    // The strips' area: the tree's crown, not the ground square.
    Aabb area;
    for (const Mesh* m : {&mesh.wood, &mesh.leaves}) {
        for (size_t i = 0; i + 2 < m->positions.size(); i += 3) {
            area.extend(Vec3{m->positions[i], m->positions[i + 1], m->positions[i + 2]});
        }
    }
    if (!area.empty()) s.setArea(area);
    return s;
}

ScanScene makeScanScene(const GrownPlot& plot, const PlotScene& scene) {
    ScanScene s;
    for (size_t k = 0; k < scene.trees.size(); ++k) {
        const PlotSceneTree& t = scene.trees[k];
        ScanTreeInput in;
        in.tree = &plot.trees[k].grown.tree;
        in.mesh = &t.mesh;
        in.woodNodes = &t.woodNodes;
        in.leafOutlines = scene.leafOutlines;
        in.treeId = t.id;
        in.species = static_cast<uint16_t>(plot.trees[k].stem.species);
        s.addTree(in);
    }
    s.addMesh(scene.terrain, kScanTerrain);
    s.addMesh(scene.groundCover, kScanLowVegetation);
    s.commit();
    const Terrain terrain = plot.layout.terrain;
    s.setGround([terrain](double x, double z) { return terrain.height(x, z); });
    if (!plot.spec) return s;  // the strips cover the scene's bounds
    Aabb area;
    const PlotArea& a = plot.spec->area;
    const double hx = a.halfX(), hz = a.halfZ();
    area.extend(Vec3{-hx, 0, -hz});
    area.extend(Vec3{hx, 0, hz});
    s.setArea(area);
    return s;
}

}  // namespace sylva
