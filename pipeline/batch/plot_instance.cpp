#include "pipeline/batch/plot_instance.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <set>

#include "core/atomic_file.h"
#include "core/rng.h"
#include "pipeline/batch/instance.h"
#include "pipeline/batch/scan_instance.h"
#include "pipeline/formats/image_codecs.h"
#include "pipeline/formats/mesh_writers.h"
#include "pipeline/formats/plot_tables.h"
#include "pipeline/formats/skeleton_writers.h"
#include "pipeline/formats/stats_json.h"
#include "pipeline/formats/view_writers.h"
#include "pipeline/render/plot_render.h"
#include "species/model/tree_stats.h"
#include "species/plot/inventory.h"
#include "species/plot/plot_growth.h"

namespace sylva {

namespace fs = std::filesystem;

namespace {

std::string hex64(uint64_t v) {
    char buf[20];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
    return buf;
}

// The tree moved so its base is at the origin: the single-instance statistics assume the
// ground at y = 0 and the trunk on the y axis.
Tree atOrigin(const Tree& tree, const Vec3& base) {
    Tree t = tree;
    for (SkeletonNode& n : t.nodes) n.position = n.position - base;
    for (Leaf& l : t.leaves) l.position = l.position - base;
    return t;
}

}  // namespace

fs::path plotInstanceDir(const GrownPlot& plot, const std::string& id) {
    return fs::path("plots") / (plot.spec ? plot.spec->name : std::string("plot")) / id;
}

nlohmann::json writePlot(const GrownPlot& plot, const OutputOptions& o, const fs::path& out,
                         const std::string& id, const ScanProgress& scanProgress) {
    const fs::path rel = plotInstanceDir(plot, id);
    nlohmann::json files = nlohmann::json::object();
    uint64_t bytes = 0;
    auto put = [&](const std::string& key, const fs::path& name, const std::string& data) {
        writeFileAtomic(out / rel / name, data);
        if (!key.empty()) files[key] = (rel / name).generic_string();
        bytes += data.size();
    };

    const bool meshes = !o.meshFormats.empty();
    const bool views = o.views.count > 0;
    // The scene (every tree's tubes and leaves) only for meshes; its files are streamed from
    // it, and the views draw from the trees one by one (with the scene's tubes, or making each
    // tree's tubes in turn): no other copy of the plot's geometry is held.
    PlotScene scene;
    const bool scanned = o.scan.enabled;
    const bool colour = views && o.colour.enabled;
    if (meshes || scanned || colour) {  // [scan] and the colour pictures see the scene's meshes
        scene = makePlotScene(plot, o.tubes, /*leafMeshes=*/true, o.leafOutlines);
    }
    // Each tree in its species' look, keyed by the seed its colour pictures use (below), so
    // the textured meshes show the colours the pictures show; [outputs] textures.
    const Look plainLook;
    SceneLooks looks;
    for (const PlotTree& t : plot.trees) {
        const size_t si = static_cast<size_t>(std::max(0, t.stem.species));
        const bool known = plot.spec && si < plot.spec->species.size();
        looks.trees.push_back({known ? plot.spec->species[si].species.look.get() : &plainLook,
                               hashCombine(plot.seed, static_cast<uint64_t>(t.stem.id))});
        looks.names.push_back(known ? plot.spec->species[si].species.name : "tree");
    }
    const SceneLooks* textured = o.textures ? &looks : nullptr;
    if (meshes) {
        const fs::path glb = rel / "scene.glb", ply = rel / "scene.ply";
        bytes += writeSceneGlb(scene, out / glb, textured);
        files["scene_glb"] = glb.generic_string();
        bytes += writeScenePly(scene, out / ply);
        files["scene_ply"] = ply.generic_string();
    }

    // Per tree: what a single instance writes, in plot-local metres.
    for (size_t k = 0; k < plot.trees.size(); ++k) {
        const PlotTree& t = plot.trees[k];
        const fs::path dir = fs::path("trees") / treeName(t.stem.id);
        if (o.ply) put("", dir / "skeleton.ply", skeletonPly(t.grown.tree));
        if (o.swc) put("", dir / "skeleton.swc", skeletonSwc(t.grown.tree));
        // [outputs] leaf_instances: the leaves the scene meshed (copied as cards when
        // leaf_outlines is false).
        std::vector<Leaf> cards;
        if (o.leafInstances && !o.leafOutlines) {
            cards = t.grown.tree.leaves;
            for (Leaf& l : cards) l.shape = LeafShape::kCard;
        }
        const std::vector<Leaf>* instanced = !o.leafInstances ? nullptr
                                             : o.leafOutlines ? &t.grown.tree.leaves
                                                              : &cards;
        for (const std::string& f : o.meshFormats) {
            const TreeMesh& m = scene.trees[k].mesh;
            const MeshLook* ml = textured ? &looks.trees[k] : nullptr;
            if (f == "obj") {
                const bool bark = ml && !m.wood.empty();
                if (bark) put("", dir / "mesh_bark.png", objBarkPng(*ml));
                put("", dir / "mesh.mtl", meshMtl(m, ml, bark ? "mesh_bark.png" : ""));
                put("", dir / "mesh.obj", meshObj(m, "mesh.mtl", ml));
            } else {
                put("", dir / ("mesh." + f), meshBytes(m, f, ml, o.meshCompression, instanced));
            }
        }
        nlohmann::json st = toJson(computeStats(atOrigin(t.grown.tree, t.stem.base)));
        for (const auto& [key, v] : t.grown.methodStats) st[key] = v;
        st["leaves"] = t.grown.tree.leaves.size();
        st["leaves_grown"] = t.leavesGrown;  // before the LAI thinning
        st["tree_id"] = t.stem.id;
        st["species"] = plotSpeciesName(plot, t.stem.species);
        st["base"] = {t.stem.base.x, t.stem.base.y, t.stem.base.z};
        st["leaf_scale"] = t.leafScale;
        if (o.qsm) writeQsmFiles(t.grown.tree, out, rel, (dir / "").generic_string(), files, bytes);
        if (meshes) {
            const TreeMesh& m = scene.trees[k].mesh;
            st["mesh_vertices"] = m.wood.vertexCount() + m.leaves.vertexCount();
            st["mesh_triangles"] = m.wood.triangleCount() + m.leaves.triangleCount();
        }
        put("", dir / "stats.json", st.dump(2) + "\n");
    }
    if (!plot.trees.empty()) files["trees"] = (rel / "trees").generic_string();

    // The scan of the whole plot (terrain, trees, ground cover), its random streams keyed by
    // the plot's seed.
    std::optional<InstanceScan> scan;
    if (scanned) {
        scan = scanPlot(plot, scene, o.scan, Rng(plot.seed).derive("scan").seed(), out / rel,
                        scanProgress);
        writeScanFiles(*scan, o.scan, out, rel, files, bytes);
        scan->points.reset();  // the points are written; the statistics stay
    }

    if (views) {
        const std::vector<Camera> cameras = makePlotCameras(plot, o.views);
        const std::vector<ViewImage> images = renderPlotViews(
            plot, meshes || scanned || colour ? &scene : nullptr, o.tubes, o.leafOutlines, cameras,
            o.views.depth || o.views.depthPng || colour, o.views.labels, o.render);
        // Colour pictures: every tree in its species' look, the terrain and the ground cover,
        // the centre samples covered where the views drew any surface (depth > 0).
        std::vector<ColourImage> colours;
        if (colour) {
            ColourScene cs;
            for (size_t k = 0; k < plot.trees.size(); ++k) {
                const PlotTree& t = plot.trees[k];
                cs.addTree(t.grown.tree, scene.trees[k].mesh.wood, scene.trees[k].mesh.leaves,
                           *looks.trees[k].look, looks.trees[k].treeSeed, !o.leafOutlines);
            }
            cs.addGround(scene.terrain, scene.groundCover);
            cs.commit();
            const Rng colourRng = Rng(plot.seed).derive("colour");
            for (size_t k = 0; k < images.size(); ++k) {
                std::vector<uint8_t> drawn(images[k].depth.size());
                for (size_t i = 0; i < drawn.size(); ++i) drawn[i] = images[k].depth[i] > 0;
                colours.push_back(
                    cs.render(cameras[k], images[k], o.colour, colourRng.derive(k), &drawn));
            }
        }
        scene = PlotScene{};  // (last use)
        ViewFiles vf;
        if (o.views.depthPng) vf.integerDepthScale = integerDepthScale(images);
        for (size_t k = 0; k < images.size(); ++k) {
            const ViewImage& v = images[k];
            const std::string stem = std::string("views/") + kPlotViewNames[k];
            vf.images.push_back(stem + ".png");
            put("", vf.images.back(), encodeGreyPng(v.width, v.height, v.silhouette.data()));
            if (o.views.depth) {
                vf.depthExr.push_back(stem + "_depth.exr");
                put("", vf.depthExr.back(),
                    depthExrBytes(v.width, v.height, v.depth, o.views.depthHalf, o.views.depthZip));
            }
            if (o.views.depthPng) {
                vf.depthPng.push_back(stem + "_depth.png");
                const std::vector<uint16_t> units = depthToUnits(v.depth, vf.integerDepthScale);
                put("", vf.depthPng.back(), encodeGrey16Png(v.width, v.height, units.data()));
            }
            if (o.views.labels) {
                vf.labels.push_back(stem + "_label.png");
                put("", vf.labels.back(), encodeGreyPng(v.width, v.height, v.labels.data()));
            }
            put("", stem + "_id.png", encodeGrey16Png(v.width, v.height, v.ids.data()));
            if (colour) {
                vf.colour.push_back(stem + (o.colour.jpeg ? "_rgb.jpg" : "_rgb.png"));
                vf.lights.push_back(colours[k].light);
                put("", vf.colour.back(),
                    encodeColourImage(colours[k], o.colour.jpeg, o.colour.jpegQuality));
            }
        }
        files["views"] = (rel / "views").generic_string();
        // transforms.json holds the perspective views alone: nerfstudio applies its top-level
        // intrinsics to every frame and instant-ngp would take the orthographic view's pixels
        // per metre for a focal length, both without a word. The orthographic top view has a
        // file of its own, transforms_top.json, in the same layout ("orthographic": true).
        auto transformsOf = [&](bool orthographic) {
            std::vector<Camera> cams;
            std::vector<size_t> index;
            ViewFiles part;
            part.integerDepthScale = vf.integerDepthScale;
            auto take = [](const std::vector<std::string>& from, size_t k,
                           std::vector<std::string>& to) {
                if (k < from.size()) to.push_back(from[k]);
            };
            for (size_t k = 0; k < cameras.size(); ++k) {
                if (cameras[k].orthographic != orthographic) continue;
                cams.push_back(cameras[k]);
                index.push_back(k);
                take(vf.images, k, part.images);
                take(vf.depthExr, k, part.depthExr);
                take(vf.depthPng, k, part.depthPng);
                take(vf.labels, k, part.labels);
                take(vf.colour, k, part.colour);
                if (k < vf.lights.size()) part.lights.push_back(vf.lights[k]);
            }
            if (cams.empty()) return nlohmann::json();
            nlohmann::json t = transformsJson(cams, part, plotNgpPlacement(plot));
            for (size_t f = 0; f < index.size() && f < t["frames"].size(); ++f) {
                t["frames"][f]["view"] = kPlotViewNames[index[f]];
                t["frames"][f]["id_file_path"] =
                    std::string("views/") + kPlotViewNames[index[f]] + "_id.png";
            }
            return t;
        };
        if (const nlohmann::json t = transformsOf(false); !t.is_null()) {
            put("transforms", "transforms.json", t.dump(2) + "\n");
        }
        if (const nlohmann::json t = transformsOf(true); !t.is_null()) {
            put("transforms_top", "transforms_top.json", t.dump(2) + "\n");
        }
    }

    const std::vector<TreeRecord> table = treeTable(plot);
    const PlotStatistics stats = plotStatistics(plot, table);
    put("trees_csv", "trees.csv", treeTableCsv(table));
    put("trees_json", "trees.json", treeTableJson(table).dump(2) + "\n");
    nlohmann::json statsJson = toJson(stats);
    // The neighbours' mark on the crowns (plot_growth.h): the mean cosine between crown-centre
    // offsets and the vectors away from close neighbours (> 0: crowns grow away from them), and
    // the largest share of a crown's projection another crown covers.
    const double cosine = crownNeighbourCosine(crownAsymmetry(plot));
    // 0.1 m cells, as canopy cover's: the default (1/50 of the smallest crown radius) made the
    // hectare of PlotBuild/1ha take 49 s instead of 43.
    // Among the canopy's crowns: an understory crown under a canopy tree overlaps it wholly,
    // as it should.
    std::vector<CrownOverlap> pairs = crownOverlaps(plot, 0.1);
    std::set<int32_t> understoryIds;
    for (const PlotTree& t : plot.trees) {
        const auto k = static_cast<size_t>(t.stem.species);  // (hand-made plots: no spec)
        if (plot.spec && k < plot.spec->species.size() && plot.spec->species[k].understory) {
            understoryIds.insert(t.stem.id);
        }
    }
    auto understory = [&](int32_t id) { return understoryIds.count(id) > 0; };
    pairs.erase(
        std::remove_if(pairs.begin(), pairs.end(),
                       [&](const CrownOverlap& o) { return understory(o.a) || understory(o.b); }),
        pairs.end());
    const double overlap = maxCrownOverlap(pairs);
    double projected = 0;  // heights ignored: a tree under another crown counts as overlapped
    int64_t overtopped = 0;
    for (const CrownOverlap& o : pairs) {
        projected = std::max(projected, o.projected);
        overtopped += o.overtopped ? 1 : 0;
    }
    statsJson["crown_neighbour_cosine"] = cosine;
    statsJson["max_crown_overlap"] =
        std::isfinite(overlap) ? nlohmann::json(overlap) : nlohmann::json(nullptr);
    statsJson["max_projected_crown_overlap"] = projected;
    statsJson["overtopped_crown_pairs"] = overtopped;
    if (scan) {
        statsJson["scan_points"] = scan->stats["points"];
        statsJson["scan_wood_surface_hit"] = scan->stats["wood_surface_hit_mean"];
        statsJson["scan_multiple_return_share"] = scan->stats["multiple_return_share"];
        if (scan->stats.contains("points_per_m2")) {
            statsJson["scan_points_per_m2"] = scan->stats["points_per_m2"];
        }
    }
    put("plot_json", "plot.json", statsJson.dump(2) + "\n");

    nlohmann::json rec;
    rec["id"] = id;
    rec["kind"] = "plot";
    rec["plot"] = plot.spec ? plot.spec->name : std::string("plot");
    rec["seed"] = hex64(plot.seed);
    rec["trees"] = plot.trees.size();
    rec["files"] = files;
    rec["bytes_written"] = bytes;
    rec["stats"] = statsJson;
    if (scan) {
        rec["scan"] = scan->stats;
        rec["timing"] = {{"scan_ms", scan->totalMs}, {"scan_scene_ms", scan->sceneMs}};
    }
    return rec;
}

}  // namespace sylva
