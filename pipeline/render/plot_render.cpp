#include "pipeline/render/plot_render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "species/geometry/leaf_mesh.h"
#include "species/plot/inventory.h"
#include "species/plot/terrain.h"

namespace sylva {

namespace {

void setColumn(Camera& c, int j, const Vec3& v) {
    c.cameraToWorld[0][j] = v.x;
    c.cameraToWorld[1][j] = v.y;
    c.cameraToWorld[2][j] = v.z;
}

// The box the views frame: the plot area at terrain height and every tree (nodes with radii,
// leaf centres ± size).
Aabb plotBox(const GrownPlot& plot) {
    Aabb box;
    const PlotArea area = plot.spec ? plot.spec->area : PlotArea{};
    const double hx = area.halfX(), hz = area.halfZ();
    const Terrain& t = plot.layout.terrain;
    for (double x : {-hx, 0.0, hx}) {
        for (double z : {-hz, 0.0, hz}) box.extend({x, t.height(x, z), z});
    }
    for (const PlotTree& tree : plot.trees) {
        for (const SkeletonNode& n : tree.grown.tree.nodes) {
            const double r = std::max(0.0, n.radius);
            box.extend(n.position - Vec3{r, r, r});
            box.extend(n.position + Vec3{r, r, r});
        }
        for (const Leaf& leaf : tree.grown.tree.leaves) {
            const double s = leaf.size;
            box.extend(leaf.position - Vec3{s, s, s});
            box.extend(leaf.position + Vec3{s, s, s});
        }
    }
    return box;
}

BoundingSphere plotSphere(const GrownPlot& plot) {
    const Aabb box = plotBox(plot);
    BoundingSphere s;
    s.centre = box.center();
    s.radius = std::max(1.0, 0.5 * length(box.hi - box.lo));
    return s;
}

}  // namespace

PlotScene makePlotScene(const GrownPlot& plot, const TubeOptions& tubes, bool leafMeshes,
                        bool leafOutlines) {
    PlotScene scene;
    scene.leafOutlines = leafOutlines;
    scene.trees.reserve(plot.trees.size());
    for (const PlotTree& t : plot.trees) {
        PlotSceneTree st;
        st.id = t.stem.id;
        st.name = treeName(t.stem.id);
        st.mesh.wood = tubeMesh(t.grown.tree, tubes, &st.woodNodes);
        if (leafMeshes && leafOutlines) st.mesh.leaves = leafMesh(t.grown.tree);
        if (leafMeshes && !leafOutlines) {
            Tree cards;
            cards.leaves = t.grown.tree.leaves;
            for (Leaf& l : cards.leaves) l.shape = LeafShape::kCard;
            st.mesh.leaves = leafMesh(cards);
        }
        st.woodParts.assign(st.mesh.wood.vertexCount(), kPartBranch);
        for (size_t f = 0; f < st.woodNodes.size(); ++f) {
            const uint8_t part = woodPart(t.grown.tree.nodes[st.woodNodes[f]]);
            for (int c = 0; c < 3; ++c) st.woodParts[st.mesh.wood.indices[3 * f + c]] = part;
        }
        scene.trees.push_back(std::move(st));
    }
    scene.terrain = terrainMesh(plot.layout.terrain);
    if (!plot.groundCover.empty()) {
        Tree cover;
        cover.leaves = plot.groundCover;
        scene.groundCover = leafMesh(cover);
    }
    return scene;
}

std::vector<Camera> makePlotCameras(const GrownPlot& plot, const ViewOptions& options) {
    if (options.width <= 0 || options.height <= 0) {
        throw std::invalid_argument("views: image size must be positive");
    }
    const Aabb box = plotBox(plot);
    const double aspect = static_cast<double>(options.width) / options.height;
    const double fovY = options.fovDeg * kPi / 180.0;
    const double fovX = 2.0 * std::atan(std::tan(0.5 * fovY) * aspect);
    const double margin = options.margin > 0 ? options.margin : 1.05;
    std::vector<Camera> cameras;
    auto perspective = [&](double azDeg, double elDeg) {
        Camera cam;
        cam.width = options.width;
        cam.height = options.height;
        cam.fovY = fovY;
        cam.azimuthDeg = azDeg;
        cam.elevationDeg = elDeg;
        const double az = azDeg * kPi / 180.0, el = elDeg * kPi / 180.0;
        const Vec3 back{std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az)};
        const Vec3 right{std::cos(az), 0.0, -std::sin(az)};
        const Vec3 up = cross(back, right);
        // The nearest distance along `back` from the box centre at which every box corner is
        // inside the frustum narrowed by `margin`.
        const Vec3 centre = box.center();
        const double tx = std::tan(0.5 * fovX) / margin, ty = std::tan(0.5 * fovY) / margin;
        double dist = 0.0;
        for (int k = 0; k < 8; ++k) {
            const Vec3 corner{(k & 1) ? box.hi.x : box.lo.x, (k & 2) ? box.hi.y : box.lo.y,
                              (k & 4) ? box.hi.z : box.lo.z};
            const Vec3 d = corner - centre;
            dist = std::max({dist, dot(d, back) + std::abs(dot(d, right)) / tx,
                             dot(d, back) + std::abs(dot(d, up)) / ty});
        }
        setColumn(cam, 0, right);
        setColumn(cam, 1, up);
        setColumn(cam, 2, back);
        setColumn(cam, 3, centre + back * dist);
        cam.cameraToWorld[3][3] = 1.0;
        cameras.push_back(cam);
    };
    perspective(45.0, 35.0);
    perspective(315.0, 12.0);
    Camera top;
    top.width = options.width;
    top.height = options.height;
    top.orthographic = true;
    top.azimuthDeg = 0.0;
    top.elevationDeg = 90.0;
    const double dx = (box.hi.x - box.lo.x) * margin, dz = (box.hi.z - box.lo.z) * margin;
    top.orthoHeight = std::max({dz, dx / aspect, 1.0});
    setColumn(top, 0, {1, 0, 0});
    setColumn(top, 1, {0, 0, -1});
    setColumn(top, 2, {0, 1, 0});
    const Vec3 c = box.center();
    setColumn(top, 3, {c.x, box.hi.y + 1.0 + 0.1 * (box.hi.y - box.lo.y), c.z});
    top.cameraToWorld[3][3] = 1.0;
    cameras.push_back(top);
    return cameras;
}

NgpPlacement plotNgpPlacement(const GrownPlot& plot) { return ngpPlacement(plotSphere(plot)); }

namespace {

void checkIds(const GrownPlot& plot) {
    for (const PlotTree& t : plot.trees) {
        if (t.stem.id < 1 || t.stem.id > 65535) {
            throw std::invalid_argument("plot views: tree id " + std::to_string(t.stem.id) +
                                        " does not fit a 16-bit id image (1 … 65535)");
        }
    }
}

// A tree's labels for renderScene: PlotPart + 1 per node and leaf, its id on every one.
SceneLabels treeLabels(const Tree& t, uint16_t id) {
    SceneLabels L;
    L.nodeLabels.reserve(t.nodes.size());
    for (const SkeletonNode& n : t.nodes) L.nodeLabels.push_back(woodPart(n) + 1);
    L.nodeIds.assign(t.nodes.size(), id);
    L.leafLabels.assign(t.leaves.size(), kPartLeaf + 1);
    L.leafIds.assign(t.leaves.size(), id);
    return L;
}

// The terrain as a tree of one node whose wood it is.
SceneLabels terrainLabels(Tree& node, std::vector<int32_t>& woodNodes, const Mesh& terrain) {
    node.nodes.assign(1, SkeletonNode{});
    node.nodes[0].parent = -1;
    woodNodes.assign(terrain.triangleCount(), 0);
    SceneLabels L;
    L.nodeLabels = {kPartTerrain + 1};
    L.nodeIds = {0};
    return L;
}

// The ground cover as the leaves of a tree without nodes.
SceneLabels groundCoverLabels(Tree& cover, const GrownPlot& plot) {
    cover.leaves = plot.groundCover;
    for (Leaf& l : cover.leaves) l.node = -1;
    SceneLabels L;
    L.leafLabels.assign(cover.leaves.size(), kPartLowVegetation + 1);
    L.leafIds.assign(cover.leaves.size(), 0);
    return L;
}

// renderScene's image as a plot view: silhouette from the ids, labels back to PlotPart.
ViewImage plotImage(ViewImage v, bool wantLabels) {
    const size_t n = v.ids.size();
    for (size_t k = 0; k < n; ++k) {
        v.silhouette[k] = v.ids[k] != 0 ? 255 : 0;
        v.labels[k] = v.labels[k] == 0 ? kPartBackground : static_cast<uint8_t>(v.labels[k] - 1);
    }
    if (!wantLabels) v.labels.clear();
    return v;
}

PlotRenderScene mergeScene(const GrownPlot& plot, const PlotScene& scene, bool withTerrain,
                           bool withGroundCover) {
    if (scene.trees.size() != plot.trees.size()) {
        throw std::invalid_argument("makePlotRenderScene: the scene is not the plot's");
    }
    checkIds(plot);
    PlotRenderScene r;
    size_t nodes = 1, leaves = 0, vertices = scene.terrain.vertexCount(),
           indices = scene.terrain.indices.size();
    for (size_t k = 0; k < plot.trees.size(); ++k) {
        nodes += plot.trees[k].grown.tree.nodes.size();
        leaves += plot.trees[k].grown.tree.leaves.size();
        vertices += scene.trees[k].mesh.wood.vertexCount();
        indices += scene.trees[k].mesh.wood.indices.size();
    }
    leaves += plot.groundCover.size();
    r.tree.nodes.reserve(nodes);
    r.tree.leaves.reserve(leaves);
    r.wood.positions.reserve(3 * vertices);
    r.wood.indices.reserve(indices);
    r.woodNodes.reserve(indices / 3);
    SceneLabels& L = r.labels;
    auto addWood = [&](const Mesh& m, const std::vector<int32_t>* nodesOf, int32_t nodeBase,
                       int32_t fixedNode) {
        const uint32_t base = static_cast<uint32_t>(r.wood.vertexCount());
        r.wood.positions.insert(r.wood.positions.end(), m.positions.begin(), m.positions.end());
        for (uint32_t v : m.indices) r.wood.indices.push_back(base + v);
        for (size_t f = 0; f < m.triangleCount(); ++f) {
            r.woodNodes.push_back(nodesOf ? nodeBase + (*nodesOf)[f] : fixedNode);
        }
    };
    for (size_t k = 0; k < plot.trees.size(); ++k) {
        const Tree& t = plot.trees[k].grown.tree;
        const uint16_t id = static_cast<uint16_t>(plot.trees[k].stem.id);
        const int32_t nodeBase = static_cast<int32_t>(r.tree.nodes.size());
        for (const SkeletonNode& n : t.nodes) {
            SkeletonNode m = n;
            if (m.parent >= 0) m.parent += nodeBase;
            r.tree.nodes.push_back(m);
            L.nodeLabels.push_back(static_cast<uint8_t>(woodPart(n) + 1));
            L.nodeIds.push_back(id);
        }
        for (const Leaf& leaf : t.leaves) {
            Leaf l = leaf;
            if (l.node >= 0) l.node += nodeBase;
            if (!scene.leafOutlines) l.shape = LeafShape::kCard;
            r.tree.leaves.push_back(l);
            L.leafLabels.push_back(kPartLeaf + 1);
            L.leafIds.push_back(id);
        }
        addWood(scene.trees[k].mesh.wood, &scene.trees[k].woodNodes, nodeBase, 0);
    }
    if (withTerrain) {
        SkeletonNode ground;
        ground.parent = -1;
        r.tree.nodes.push_back(ground);
        L.nodeLabels.push_back(kPartTerrain + 1);
        L.nodeIds.push_back(0);
        addWood(scene.terrain, nullptr, 0, static_cast<int32_t>(r.tree.nodes.size() - 1));
    }
    if (withGroundCover) {
        for (const Leaf& leaf : plot.groundCover) {
            Leaf l = leaf;
            l.node = -1;
            r.tree.leaves.push_back(l);
            L.leafLabels.push_back(kPartLowVegetation + 1);
            L.leafIds.push_back(0);
        }
    }
    return r;
}

}  // namespace

PlotRenderScene makePlotRenderScene(const GrownPlot& plot, const PlotScene& scene, bool withTerrain,
                                    bool withGroundCover) {
    return mergeScene(plot, scene, withTerrain, withGroundCover);
}

ViewImage renderPlotView(const PlotRenderScene& scene, const Camera& camera, bool wantDepth,
                         bool wantLabels, const RenderOptions& options) {
    return plotImage(renderScene(scene.tree, scene.wood, scene.woodNodes, scene.labels, camera,
                                 wantDepth, true, true, options),
                     wantLabels);
}

std::vector<ViewImage> renderPlotViews(const GrownPlot& plot, const PlotScene* scene,
                                       const TubeOptions& tubes, bool leafOutlines,
                                       const std::vector<Camera>& cameras, bool wantDepth,
                                       bool wantLabels, const RenderOptions& options) {
    if (scene && scene->trees.size() != plot.trees.size()) {
        throw std::invalid_argument("renderPlotViews: the scene is not the plot's");
    }
    checkIds(plot);
    if (scene) leafOutlines = scene->leafOutlines;
    std::vector<SceneCanvas> canvases;
    canvases.reserve(cameras.size());
    for (const Camera& c : cameras) canvases.emplace_back(c, options);
    for (size_t k = 0; k < plot.trees.size(); ++k) {
        const Tree& grown = plot.trees[k].grown.tree;
        Tree cards;  // the tree with its leaves as cards, when the plot draws them so
        if (!leafOutlines) {
            cards.nodes = grown.nodes;
            cards.leaves = grown.leaves;
            for (Leaf& l : cards.leaves) l.shape = LeafShape::kCard;
        }
        const Tree& t = leafOutlines ? grown : cards;
        Mesh madeWood;
        std::vector<int32_t> madeNodes;
        if (!scene) madeWood = tubeMesh(grown, tubes, &madeNodes);
        const Mesh& wood = scene ? scene->trees[k].mesh.wood : madeWood;
        const std::vector<int32_t>& woodNodes = scene ? scene->trees[k].woodNodes : madeNodes;
        const SceneLabels labels = treeLabels(t, static_cast<uint16_t>(plot.trees[k].stem.id));
        for (SceneCanvas& canvas : canvases) canvas.draw(t, wood, woodNodes, labels);
    }
    {
        const Mesh made = scene ? Mesh{} : terrainMesh(plot.layout.terrain);
        const Mesh& terrain = scene ? scene->terrain : made;
        Tree node;
        std::vector<int32_t> woodNodes;
        const SceneLabels labels = terrainLabels(node, woodNodes, terrain);
        for (SceneCanvas& canvas : canvases) canvas.draw(node, terrain, woodNodes, labels);
    }
    {
        Tree cover;
        const SceneLabels labels = groundCoverLabels(cover, plot);
        for (SceneCanvas& canvas : canvases) canvas.draw(cover, Mesh{}, {}, labels);
    }
    std::vector<ViewImage> images;
    images.reserve(cameras.size());
    for (SceneCanvas& canvas : canvases) {
        images.push_back(plotImage(canvas.finish(wantDepth, true, true), wantLabels));
    }
    return images;
}

std::vector<uint8_t> colourParts(const std::vector<uint8_t>& parts) {
    static constexpr uint8_t kColours[6][3] = {{196, 170, 130}, {92, 51, 23},  {214, 120, 34},
                                               {60, 170, 70},   {150, 30, 30}, {128, 140, 40}};
    std::vector<uint8_t> rgb(3 * parts.size(), 255);
    for (size_t k = 0; k < parts.size(); ++k) {
        if (parts[k] < 6) std::copy(kColours[parts[k]], kColours[parts[k]] + 3, &rgb[3 * k]);
    }
    return rgb;
}

std::vector<uint8_t> colourIds(const std::vector<uint16_t>& ids,
                               const std::vector<uint8_t>& parts) {
    std::vector<uint8_t> rgb(3 * ids.size(), 255);
    for (size_t k = 0; k < ids.size(); ++k) {
        uint8_t* p = &rgb[3 * k];
        if (ids[k] == 0) {
            const bool sky = k < parts.size() && parts[k] == kPartBackground;
            p[0] = p[1] = p[2] = sky ? 255 : 200;
            continue;
        }
        uint32_t h = ids[k] * 2654435761u;  // Knuth's multiplicative hash
        h ^= h >> 15;
        p[0] = static_cast<uint8_t>(40 + (h & 0xff) % 180);
        p[1] = static_cast<uint8_t>(40 + ((h >> 8) & 0xff) % 180);
        p[2] = static_cast<uint8_t>(40 + ((h >> 16) & 0xff) % 180);
    }
    return rgb;
}

}  // namespace sylva
