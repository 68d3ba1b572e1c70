#include "pipeline/batch/instance.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "core/atomic_file.h"
#include "core/clock.h"
#include "pipeline/batch/pack.h"
#include "pipeline/batch/plot_instance.h"
#include "pipeline/formats/glb_meshopt.h"
#include "pipeline/formats/mesh_writers.h"
#include "pipeline/formats/skeleton_writers.h"
#include "pipeline/formats/stats_json.h"
#include "pipeline/formats/view_writers.h"
#include "species/geometry/leaf_mesh.h"
#include "species/geometry/tube_mesh.h"
#include "species/geometry/watertight.h"
#include "species/model/tree_stats.h"
#include "species/plot/layout.h"
#include "species/plot/plot_growth.h"

namespace sylva {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

std::string hex64(uint64_t v) {
    char buf[20];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
    return buf;
}

// The mesh's triangles (tubes and both faces of every leaf), counted before it is made and
// held to the tree's max_triangles (BudgetExceeded): the views draw the same tubes.
void checkMeshTriangles(const GrownTree& g, const TubeOptions& tubes) {
    const auto leaves = static_cast<int64_t>(leafMeshSize(g.tree.leaves).triangles);
    GrowthGuard(g.budget).triangles(tubeTriangleCount(g.tree, tubes) + leaves,
                                    " in the mesh (tubes and leaves)");
}

// The watertight mesh before its level set is made: its surface is at least about the
// capsules' lateral area (twigs thickened to the voxel's covering radius, as watertight.cpp
// does), and a surface voxel gives about two triangles. Only a surface four times the budget
// fails here (the union's overlaps make it smaller); the mesh made is checked exactly after.
void checkWatertightEstimate(const GrownTree& g, const WatertightOptions& o) {
    const double voxel = o.voxelSize;
    double area = 0.0;
    for (const SkeletonNode& n : g.tree.nodes) {
        if (n.parent < 0) continue;
        const SkeletonNode& p = g.tree.nodes[n.parent];
        const double r = std::max(0.5 * (n.radius + p.radius), 0.8660254037844386 * voxel);
        area += 2.0 * kPi * r * distance(n.position, p.position);
    }
    const double triangles = 2.0 * area / (voxel * voxel);
    if (triangles > 4.0 * static_cast<double>(g.budget.maxTriangles)) {
        throw BudgetExceeded("budget max_triangles = " + std::to_string(g.budget.maxTriangles) +
                             " exceeded: the watertight mesh at voxel_size " +
                             formatNumber(voxel, 3) + " m would have ≈ " + formatSize(triangles) +
                             " triangles; raise [budget] max_triangles or the voxel size");
    }
}

}  // namespace

std::string meshBytes(const TreeMesh& m, const std::string& format, const MeshLook* look,
                      const std::string& compression, const std::vector<Leaf>* instances) {
    if (format == "glb") {
        if (compression == "meshopt") return compressGlbMeshopt(meshGlbParts(m, look, instances));
        if (compression == "draco") return compressGlbDraco(meshGlbParts(m, look, instances));
        return meshGlb(m, look, instances);
    }
    return meshPly(m);
}

fs::path instanceDir(const InstanceJob& job) {
    if (job.plot) return fs::path("plots") / job.plot->name / job.id;
    return fs::path("trees") / job.entry->species.name / job.id;
}

void growStage(InstanceWork& w) {
    auto t0 = Clock::now();
    const InstanceJob& job = w.job;
    if (job.plot) {  // a plot: its layout, then its trees grown together
        PlotProgress report;
        if (w.progress) {
            report = [p = *w.progress](const char* phase, int64_t done, int64_t total) {
                p(phase, done, total, "trees");
            };
        }
        w.plot = std::make_shared<GrownPlot>(
            growPlot(*job.plot, layoutPlot(*job.plot, job.seed), job.datasetBudget, true, report));
        w.growMs = msSince(t0);
        return;
    }
    w.grown = growSpecies(job.entry->species, job.seed, job.point->overrides.get(), true,
                          &job.entry->budget);
    w.growMs = msSince(t0);
}

// [outputs] leaf_outlines = false: every leaf meshed and drawn as its card.
static void leavesAsCards(Tree& tree) {
    for (Leaf& leaf : tree.leaves) leaf.shape = LeafShape::kCard;
}

void meshStage(InstanceWork& w, const OutputOptions& o, const fs::path& out) {
    if (w.job.plot) return;  // writePlot meshes a plot as it writes it
    auto t0 = Clock::now();
    if (!o.leafOutlines) leavesAsCards(w.grown.tree);
    if (!o.meshFormats.empty() || o.scan.enabled) {  // the scan sees the mesh
        checkMeshTriangles(w.grown, o.tubes);
        w.mesh.wood = tubeMesh(w.grown.tree, o.tubes, &w.woodNodes);
        // The leaves' triangles, unless only an instanced GLB would take them (it draws the
        // tree's leaves themselves).
        const bool onlyInstanced = o.leafInstances && !o.scan.enabled && !o.colour.enabled &&
                                   std::all_of(o.meshFormats.begin(), o.meshFormats.end(),
                                               [](const std::string& f) { return f == "glb"; });
        if (!onlyInstanced) w.mesh.leaves = leafMesh(w.grown.tree);
    }
    if (o.watertight) {
        std::string vdb = o.vdb ? (out / instanceDir(w.job) / "watertight.vdb").string() : "";
        checkWatertightEstimate(w.grown, o.watertightOptions);
        if (o.vdb) fs::create_directories(out / instanceDir(w.job));
        w.watertight = watertightMesh(w.grown.tree, o.watertightOptions, vdb);
        GrowthGuard(w.grown.budget)
            .triangles(static_cast<int64_t>(w.watertight.triangleCount()),
                       " in the watertight mesh");
    }
    w.meshMs = msSince(t0);
}

void renderStage(InstanceWork& w, const OutputOptions& o) {
    if (o.views.count <= 0 || w.job.plot) return;  // writePlot renders a plot's views
    auto t0 = Clock::now();
    Rng camRng = Rng(w.job.seed).derive("cameras");
    w.sphere = treeBoundingSphere(w.grown.tree);
    w.cameras = makeCameras(w.sphere, o.views, camRng);
    // The views show the tubes as meshed: the mesh stage's, or made here when no mesh is written.
    Mesh ownWood;
    std::vector<int32_t> ownNodes;
    const bool meshed = !o.meshFormats.empty();
    if (!meshed) {
        checkMeshTriangles(w.grown, o.tubes);
        ownWood = tubeMesh(w.grown.tree, o.tubes, &ownNodes);
    }
    const Mesh& wood = meshed ? w.mesh.wood : ownWood;
    const std::vector<int32_t>& nodes = meshed ? w.woodNodes : ownNodes;
    w.views = renderViews(w.grown.tree, wood, nodes, w.cameras,
                          o.views.depth || o.views.depthPng || o.views.pointCloud,
                          o.views.labels || o.views.pointCloud, o.render);
    if (o.colour.enabled) {  // the same triangles through Embree, one BVH for every view
        Mesh ownLeaves;
        if (!meshed) ownLeaves = leafMesh(w.grown.tree);
        const ColourScene scene(w.grown.tree, wood, meshed ? w.mesh.leaves : ownLeaves,
                                *w.job.entry->species.look, w.job.seed);
        const Rng colourRng = Rng(w.job.seed).derive("colour");
        w.colours.reserve(w.cameras.size());
        for (size_t k = 0; k < w.cameras.size(); ++k) {
            w.colours.push_back(
                scene.render(w.cameras[k], w.views[k], o.colour, colourRng.derive(k)));
        }
    }
    w.renderMs = msSince(t0);
}

void scanStage(InstanceWork& w, const OutputOptions& o, const fs::path& out) {
    if (!o.scan.enabled || w.job.plot) return;
    auto t0 = Clock::now();
    w.scan = std::make_shared<InstanceScan>(
        scanTree(w.grown.tree, w.mesh, w.woodNodes, o.scan, o.leafOutlines,
                 Rng(w.job.seed).derive("scan").seed(), out / instanceDir(w.job)));
    w.scanMs = msSince(t0);
}

// An instance to be packed (w.packTar set): its record names the members it will be, and the
// instance's staged archive (kPackStageFile) holds `staged` and record.json (the record without
// `timing`, which is added after; "<id>.json" in the shard).
static void stageForPacking(InstanceWork& w, const fs::path& out,
                            std::vector<std::pair<std::string, std::string>> staged) {
    if (w.packTar.empty()) return;
    const std::string rel = instanceDir(w.job).generic_string();
    packRecordFiles(w.record, w.job.id, rel, w.packTar);
    staged.emplace_back(kPackRecordFile, w.record.dump());
    writePackStage(out / rel, staged);
}

void writeStage(InstanceWork& w, const OutputOptions& o, const fs::path& out) {
    auto t0 = Clock::now();
    const InstanceJob& job = w.job;
    if (job.plot) {
        ScanProgress scanned;
        if (w.progress) {
            scanned = [p = *w.progress](uint64_t done, uint64_t total) {
                p("scanning", static_cast<int64_t>(done), static_cast<int64_t>(total), "pulses");
            };
        }
        w.record = writePlot(*w.plot, o, out, job.id, scanned);
        w.record["id"] = job.id;
        w.record["kind"] = "plot";
        w.record["plot"] = job.plot->name;
        if (!job.plot->sweptFrom.empty()) w.record["sweep"] = job.plot->sweep;
        w.record["index"] = job.index;
        w.record["seed"] = hex64(job.seed);
        stageForPacking(w, out, {});
        w.writeMs = msSince(t0);
        // writePlot's timing (the scan's, within write_ms) first, then the stages'.
        w.record["timing"]["grow_ms"] = w.growMs;
        w.record["timing"]["write_ms"] = w.writeMs;
        return;
    }
    const SpeciesFile& species = job.entry->species;
    const fs::path rel = instanceDir(job);
    nlohmann::json files = nlohmann::json::object();
    uint64_t bytes = 0;
    // A file of the instance: written, or kept for its staged archive when it is to be packed.
    std::vector<std::pair<std::string, std::string>> staged;
    auto emit = [&](const std::string& name, std::string data) {
        bytes += data.size();
        if (w.packTar.empty()) {
            writeFileAtomic(out / rel / name, data);
        } else {
            staged.emplace_back(name, std::move(data));
        }
    };
    auto put = [&](const std::string& key, const std::string& name, std::string data) {
        emit(name, std::move(data));
        files[key] = (rel / name).generic_string();
    };
    auto count = [&](const fs::path& relPath) {  // files written by OIIO / OpenVDB
        std::error_code ec;
        auto size = fs::file_size(out / relPath, ec);
        if (!ec) bytes += size;
    };
    auto noteFile = [&](const std::string& key, const fs::path& relPath) {
        files[key] = relPath.generic_string();
        count(relPath);
    };

    if (o.ply) put("skeleton_ply", "skeleton.ply", skeletonPly(w.grown.tree));
    if (o.swc) put("skeleton_swc", "skeleton.swc", skeletonSwc(w.grown.tree));
    // A mesh in each format; an OBJ with its materials beside it (<stem>_mtl, <stem>.mtl) and,
    // textured, its bark tile (<stem>_bark_png, <stem>_bark.png). [outputs] textures: the
    // species' look on mesh.* (not on the watertight mesh, which has no UVs).
    const MeshLook look{species.look.get(), job.seed};
    auto putMesh = [&](const std::string& stem, const TreeMesh& m, const std::string& f,
                       const MeshLook* ml, const std::vector<Leaf>* instances) {
        if (f == "obj") {
            const bool bark = ml && !m.wood.empty();
            if (bark) put(stem + "_bark_png", stem + "_bark.png", objBarkPng(*ml));
            put(stem + "_mtl", stem + ".mtl", meshMtl(m, ml, bark ? stem + "_bark.png" : ""));
            put(stem + "_obj", stem + ".obj", meshObj(m, stem + ".mtl", ml));
        } else {
            put(stem + "_" + f, stem + "." + f, meshBytes(m, f, ml, o.meshCompression, instances));
        }
    };
    for (const std::string& f : o.meshFormats) {
        putMesh("mesh", w.mesh, f, o.textures && species.look ? &look : nullptr,
                o.leafInstances ? &w.grown.tree.leaves : nullptr);
    }
    if (o.watertight) {
        TreeMesh wt;
        wt.wood = w.watertight;
        for (const std::string& f : o.meshFormats) putMesh("watertight", wt, f, nullptr, nullptr);
        if (o.vdb) noteFile("watertight_vdb", rel / "watertight.vdb");
    }
    if (w.scan) writeScanFiles(*w.scan, o.scan, out, rel, files, bytes);
    if (o.qsm) writeQsmFiles(w.grown.tree, out, rel, "", files, bytes);
    if (o.preview) {
        writePreviewPng(w.grown.tree, out / rel / "preview.png", o.previewSize);
        noteFile("preview_png", rel / "preview.png");
    }

    nlohmann::json coverage = nlohmann::json::array(), fractal = nlohmann::json::array();
    if (!w.views.empty()) {
        ViewFiles vf;
        if (o.views.depthPng) vf.integerDepthScale = integerDepthScale(w.views);
        for (size_t k = 0; k < w.views.size(); ++k) {
            const ViewImage& v = w.views[k];
            char stem[32];
            std::snprintf(stem, sizeof stem, "views/%03zu", k);
            vf.images.push_back(std::string(stem) + ".png");
            emit(vf.images.back(), greyPngBytes(v.width, v.height, v.silhouette));
            if (o.views.depth) {
                vf.depthExr.push_back(std::string(stem) + "_depth.exr");
                emit(vf.depthExr.back(), depthExrBytes(v.width, v.height, v.depth,
                                                       o.views.depthHalf, o.views.depthZip));
            }
            if (o.views.depthPng) {
                vf.depthPng.push_back(std::string(stem) + "_depth.png");
                emit(vf.depthPng.back(),
                     depthPngBytes(v.width, v.height, v.depth, vf.integerDepthScale));
            }
            if (!w.colours.empty()) {
                vf.colour.push_back(std::string(stem) + (o.colour.jpeg ? "_rgb.jpg" : "_rgb.png"));
                vf.lights.push_back(w.colours[k].light);
                emit(vf.colour.back(),
                     encodeColourImage(w.colours[k], o.colour.jpeg, o.colour.jpegQuality));
            }
            if (o.views.labels) {
                vf.labels.push_back(std::string(stem) + "_label.png");
                emit(vf.labels.back(), greyPngBytes(v.width, v.height, v.labels));
            }
            coverage.push_back(silhouetteCoverage(v));
            fractal.push_back(boxCountingDimension(v));
        }
        files["views"] = (rel / "views").generic_string();
        put("transforms", "transforms.json",
            transformsJson(w.cameras, vf, ngpPlacement(w.sphere)).dump(2) + "\n");
        if (o.views.pointCloud) put("points_ply", "points.ply", pointCloudPly(w.cameras, w.views));
        if (o.views.contactSheet) {
            int cols = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(w.views.size()))));
            if (w.colours.empty()) {
                writeContactSheet(out / rel / "contact.png", w.views, cols);
            } else {
                writeColourContactSheet(out / rel / "contact.png", w.colours, cols);
            }
            noteFile("contact_png", rel / "contact.png");
        }
    }

    TreeStats stats = computeStats(w.grown.tree);
    nlohmann::json st = toJson(stats);
    for (const auto& [k, v] : w.grown.methodStats) st[k] = v;
    st["leaves"] = w.grown.tree.leaves.size();
    if (!o.meshFormats.empty()) {  // the leaves' as leafMesh makes them, made or not
        const LeafMeshSize leaves = leafMeshSize(w.grown.tree.leaves);
        st["mesh_vertices"] = w.mesh.wood.vertexCount() + leaves.vertices;
        st["mesh_triangles"] = w.mesh.wood.triangleCount() + leaves.triangles;
        st["wood_triangles"] = w.mesh.wood.triangleCount();
        st["leaf_triangles"] = leaves.triangles;
    }
    if (o.watertight) {
        st["watertight_vertices"] = w.watertight.vertexCount();
        st["watertight_triangles"] = w.watertight.triangleCount();
    }
    if (!w.views.empty()) {
        st["silhouette_coverage"] = coverage;
        st["fractal_dimension"] = fractal;
        // Leaves' share of the tree's pixels, from the label images (null without them).
        const double leafFraction = leafPixelFraction(w.views);
        st["leaf_pixel_fraction"] =
            std::isfinite(leafFraction) ? nlohmann::json(leafFraction) : nlohmann::json(nullptr);
    }

    nlohmann::json& rec = w.record;
    rec["id"] = job.id;
    rec["species"] = species.name;
    rec["method"] = species.method;
    if (!species.habit.empty()) rec["habit"] = species.habit;
    rec["index"] = job.index;
    rec["seed"] = hex64(job.seed);
    rec["sweep"] = job.point->values;
    rec["params"] = w.grown.sampled;
    rec["files"] = files;
    rec["bytes_written"] = bytes;
    if (w.scan) {
        st["scan_points"] = w.scan->stats["points"];
        st["scan_wood_surface_hit"] = w.scan->stats["wood_surface_hit_mean"];
        st["scan_multiple_return_share"] = w.scan->stats["multiple_return_share"];
        if (w.scan->stats.contains("points_per_m2")) {
            st["scan_points_per_m2"] = w.scan->stats["points_per_m2"];
        }
    }
    rec["stats"] = st;
    if (w.scan) rec["scan"] = w.scan->stats;
    stageForPacking(w, out, std::move(staged));
    w.writeMs = msSince(t0);
    // The only fields that differ between identical builds.
    rec["timing"] = {{"grow_ms", w.growMs},
                     {"mesh_ms", w.meshMs},
                     {"render_ms", w.renderMs},
                     {"write_ms", w.writeMs}};
    if (w.scan) {
        rec["timing"]["scan_ms"] = w.scanMs;
        rec["timing"]["scan_scene_ms"] = w.scan->sceneMs;
    }
}

}  // namespace sylva
