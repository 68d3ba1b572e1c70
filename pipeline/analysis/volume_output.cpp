// `sylva volume`: level sets, meshes and a preview of a species' named volumes.
//
// Conventions of the written files (also in the README, "Checking a crown"):
//  - <name>.vdb: one FloatGrid named <name>, class GRID_LEVEL_SET, linear transform with the
//    voxel size (index (i, j, k) is the point (i, j, k)·voxel, metres), narrow band of 3
//    voxels each side (background 3·voxel), interior tiles at −3·voxel; metadata
//    "description" = the volume's describe(). Sampled by levelSetGrid() exactly as a
//    `voxel_size` in the species would realise the volume.
//  - <name>.ply: the zero level set meshed by openvdb::tools::volumeToMesh (adaptivity 0),
//    in metres, +y up, triangles counter-clockwise seen from outside (outward normals),
//    area-weighted vertex normals; written by meshPly (so order, part, colour, u, v are 0).
//  - preview.png: renderVolumePreview, one row per volume.
//  - volumes.json: the summaries, bounds and extents in metres, and the preview layout.
#include "pipeline/analysis/volume_output.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/atomic_file.h"
#include "core/clock.h"
#include "pipeline/formats/mesh_writers.h"
#include "pipeline/formats/view_writers.h"
#include "species/geometry/level_set_mesh.h"
#include "species/spec/species.h"
#include "volumes/level_set_grid.h"

namespace fs = std::filesystem;

namespace sylva {

namespace {

constexpr double kHalfWidth = 3.0;         // narrow band, voxels each side
constexpr double kDefaultDivisions = 128;  // default voxel = largest bounds dimension / 128
constexpr double kMaxVoxels = 2e9;         // as for `voxel_size` in species files
// Values closer to zero than this many voxels are pushed off it before meshing: a surface
// through a voxel centre makes volumeToMesh emit coincident vertices and degenerate
// triangles (see species/geometry/watertight.cpp). Moves the mesh by at most 0.001 voxel.
constexpr float kZeroNudgeVoxels = 1e-3f;

// The zero level set as a closed triangle mesh, counter-clockwise seen from outside, with
// area-weighted vertex normals.
Mesh meshLevelSet(const VdbGrid& grid, double voxel) {
    // ≤ 0 is inside (Volume::inside), so a value of exactly 0 goes inwards.
    const VdbGridPtr g = vdbModule().nudgedCopy(grid, kZeroNudgeVoxels * static_cast<float>(voxel));
    return levelSetMesh(*g);
}

Vec3 vertex(const Mesh& m, uint32_t i) {
    return {m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]};
}

// Volume enclosed by a closed, outward mesh: Σ p0 · (p1 × p2) / 6 (divergence theorem).
double enclosedVolume(const Mesh& m) {
    double v = 0;
    for (size_t t = 0; t < m.indices.size(); t += 3)
        v += dot(vertex(m, m.indices[t]),
                 cross(vertex(m, m.indices[t + 1]), vertex(m, m.indices[t + 2])));
    return v / 6.0;
}

double interiorMeasure(const VdbGrid& grid, double voxel) {
    return interiorVoxelCount(grid) * voxel * voxel * voxel;
}

// The bytes openvdb::io::File::write would write, serialised by the module into memory and
// written atomically with every error checked.
void writeVdb(const VdbGrid& grid, const fs::path& path) {
    writeFileAtomic(path, vdbModule().fileBytes(grid));
}

// --- preview ---------------------------------------------------------------------------------

constexpr int kSuper = 2;       // supersampling per axis
constexpr double kFill = 0.92;  // the largest extent spans this much of a tile
constexpr float kEmpty = -std::numeric_limits<float>::infinity();
constexpr double kDepthStepPx = 4.0;  // outline where depth's 2nd difference exceeds this
constexpr double kAmbient = 0.32, kDiffuse = 0.58;  // grey = 255·(ambient + diffuse·max(0, n·l))
constexpr uint8_t kOutline = 40, kGround = 170, kOrigin = 90, kSeparator = 215;

// An orthographic view: screen right, screen up, and towards the viewer (right × up).
struct ViewAxes {
    Vec3 right, up, toward;
};
const std::array<ViewAxes, 3> kViews = {{
    {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}},   // front, from +z
    {{0, 0, -1}, {0, 1, 0}, {1, 0, 0}},  // side, from +x
    {{1, 0, 0}, {0, 0, -1}, {0, 1, 0}},  // top, from +y
}};

// One view of one mesh into a tile of the sheet (s × s supersampled pixels at `out`, row
// stride `stride`), centred on `centre`.
void renderTile(const Mesh& mesh, const ViewAxes& view, const Vec3& centre, double pxPerMetre,
                int s, bool top, double* out, size_t stride) {
    const size_t n = static_cast<size_t>(s) * s;
    std::vector<float> depth(n, kEmpty);
    std::vector<float> shade(n, 1.0f);
    const Vec3 light = normalize(view.right * -0.4 + view.up * 0.5 + view.toward * 0.77);
    const double cx = dot(centre, view.right), cy = dot(centre, view.up);
    auto toX = [&](const Vec3& p) { return (dot(p, view.right) - cx) * pxPerMetre + 0.5 * s; };
    auto toY = [&](const Vec3& p) { return 0.5 * s - (dot(p, view.up) - cy) * pxPerMetre; };

    const size_t nv = mesh.vertexCount();
    std::vector<double> sx(nv), sy(nv), sz(nv);
    for (size_t v = 0; v < nv; ++v) {
        const Vec3 p = vertex(mesh, static_cast<uint32_t>(v));
        sx[v] = toX(p);
        sy[v] = toY(p);
        sz[v] = dot(p, view.toward);
    }
    // Triangles in mesh order with a strict depth test: deterministic.
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        const uint32_t i0 = mesh.indices[t], i1 = mesh.indices[t + 1], i2 = mesh.indices[t + 2];
        const double area =
            (sx[i1] - sx[i0]) * (sy[i2] - sy[i0]) - (sx[i2] - sx[i0]) * (sy[i1] - sy[i0]);
        if (!(std::abs(area) > 1e-12)) continue;
        const int x0 =
            std::max(0, static_cast<int>(std::ceil(std::min({sx[i0], sx[i1], sx[i2]}) - 0.5)));
        const int x1 =
            std::min(s - 1, static_cast<int>(std::floor(std::max({sx[i0], sx[i1], sx[i2]}) - 0.5)));
        const int y0 =
            std::max(0, static_cast<int>(std::ceil(std::min({sy[i0], sy[i1], sy[i2]}) - 0.5)));
        const int y1 =
            std::min(s - 1, static_cast<int>(std::floor(std::max({sy[i0], sy[i1], sy[i2]}) - 0.5)));
        for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x) {
                const double px = x + 0.5, py = y + 0.5;
                const double b0 =
                    ((sx[i1] - px) * (sy[i2] - py) - (sx[i2] - px) * (sy[i1] - py)) / area;
                const double b1 =
                    ((sx[i2] - px) * (sy[i0] - py) - (sx[i0] - px) * (sy[i2] - py)) / area;
                const double b2 = 1.0 - b0 - b1;
                // A small tolerance so that pixel centres on a shared edge are never dropped by
                // both.
                if (b0 < -1e-9 || b1 < -1e-9 || b2 < -1e-9) continue;
                const float z = static_cast<float>(b0 * sz[i0] + b1 * sz[i1] + b2 * sz[i2]);
                const size_t k = static_cast<size_t>(y) * s + x;
                if (!(z > depth[k])) continue;
                depth[k] = z;
                Vec3 nrm{0, 0, 0};
                if (!mesh.normals.empty()) {
                    for (int a = 0; a < 3; ++a)
                        nrm[a] = b0 * mesh.normals[3 * i0 + a] + b1 * mesh.normals[3 * i1 + a] +
                                 b2 * mesh.normals[3 * i2 + a];
                    nrm = normalize(nrm);
                }
                shade[k] = static_cast<float>(kAmbient + kDiffuse * std::max(0.0, dot(nrm, light)));
            }
    }

    // Outline: covered pixels within kSuper pixels of an uncovered one, or where the depth
    // bends sharply (an occluding contour inside the silhouette; a smooth surface's second
    // difference stays small except in the last pixel before its silhouette).
    const double step = kDepthStepPx / pxPerMetre;
    auto covered = [&](int x, int y) {
        return x >= 0 && y >= 0 && x < s && y < s &&
               depth[static_cast<size_t>(y) * s + x] != kEmpty;
    };
    auto z = [&](int x, int y) { return double(depth[static_cast<size_t>(y) * s + x]); };
    for (int y = 0; y < s; ++y)
        for (int x = 0; x < s; ++x) {
            const size_t k = static_cast<size_t>(y) * s + x;
            double v = 255.0;
            if (covered(x, y)) {
                bool edge = false;
                for (int d = 1; d <= kSuper && !edge; ++d)
                    edge = !covered(x - d, y) || !covered(x + d, y) || !covered(x, y - d) ||
                           !covered(x, y + d);
                if (!edge)
                    edge = std::abs(z(x - 1, y) - 2 * z(x, y) + z(x + 1, y)) > step ||
                           std::abs(z(x, y - 1) - 2 * z(x, y) + z(x, y + 1)) > step;
                v = edge ? kOutline : 255.0 * shade[k];
            }
            out[static_cast<size_t>(y) * stride + x] = v;
        }

    // The ground line (y = 0) behind the volume in the front and side views; the root point
    // on top of it in the top view.
    const Vec3 origin{0, 0, 0};
    const double gx = toX(origin), gy = toY(origin);
    const int arm = 6 * kSuper;
    if (!top) {
        for (int y = static_cast<int>(std::floor(gy - 1)); y <= static_cast<int>(gy); ++y)
            for (int x = 0; x < s && y >= 0 && y < s; ++x)
                if (!covered(x, y)) out[static_cast<size_t>(y) * stride + x] = kGround;
    } else {
        const int ox = static_cast<int>(std::floor(gx)), oy = static_cast<int>(std::floor(gy));
        for (int d = -arm; d <= arm; ++d)
            for (int w = -1; w <= 0; ++w) {
                if (ox + d >= 0 && ox + d < s && oy + w >= 0 && oy + w < s)
                    out[static_cast<size_t>(oy + w) * stride + ox + d] = kOrigin;
                if (ox + w >= 0 && ox + w < s && oy + d >= 0 && oy + d < s)
                    out[static_cast<size_t>(oy + d) * stride + ox + w] = kOrigin;
            }
    }
}

}  // namespace

VolumePreview renderVolumePreview(const std::vector<const Mesh*>& meshes, int tile) {
    if (tile < 8) throw std::invalid_argument("renderVolumePreview: tile must be ≥ 8 pixels");
    const int rows = std::max<int>(1, static_cast<int>(meshes.size()));
    VolumePreview p;
    p.width = 3 * tile;
    p.height = rows * tile;
    std::vector<Aabb> bounds(meshes.size());
    double extent = 0;
    for (size_t r = 0; r < meshes.size(); ++r) {
        for (size_t v = 0; v < meshes[r]->vertexCount(); ++v)
            bounds[r].extend(vertex(*meshes[r], static_cast<uint32_t>(v)));
        if (!bounds[r].empty()) {
            bounds[r].extend(Vec3{0, 0, 0});  // the root point is always in frame
            const Vec3 e = bounds[r].size();
            extent = std::max({extent, e.x, e.y, e.z});
        }
    }
    if (!(extent > 0)) extent = 1.0;
    p.metresPerPixel = extent / (kFill * tile);
    const double pxPerMetre = kSuper / p.metresPerPixel;  // supersampled pixels

    const int s = kSuper * tile;
    const size_t stride = static_cast<size_t>(3) * s;
    std::vector<double> big(stride * static_cast<size_t>(rows) * s, 255.0);
    // Tiles write disjoint parts of the sheet: the same raster for any thread count.
    tbb::parallel_for(tbb::blocked_range<int>(0, 3 * static_cast<int>(meshes.size())),
                      [&](const tbb::blocked_range<int>& range) {
                          for (int t = range.begin(); t != range.end(); ++t) {
                              const int r = t / 3, c = t % 3;
                              if (bounds[r].empty()) continue;
                              double* out = big.data() + static_cast<size_t>(r) * s * stride +
                                            static_cast<size_t>(c) * s;
                              renderTile(*meshes[r], kViews[c], bounds[r].center(), pxPerMetre, s,
                                         c == 2, out, stride);
                          }
                      });
    p.pixels.resize(static_cast<size_t>(p.width) * p.height);
    for (int y = 0; y < p.height; ++y)
        for (int x = 0; x < p.width; ++x) {
            double sum = 0;
            for (int j = 0; j < kSuper; ++j)
                for (int i = 0; i < kSuper; ++i)
                    sum += big[static_cast<size_t>(kSuper * y + j) * stride + kSuper * x + i];
            uint8_t v = static_cast<uint8_t>(std::lround(sum / (kSuper * kSuper)));
            // Thin separators between the tiles.
            if ((x > 0 && x % tile == 0) || (y > 0 && y % tile == 0)) v = std::min(v, kSeparator);
            p.pixels[static_cast<size_t>(y) * p.width + x] = v;
        }
    return p;
}

std::string summaryLine(const VolumeSummary& s) {
    const Vec3 e = s.bounds.size();
    char buf[640];
    std::snprintf(buf, sizeof buf,
                  "%s: %s; bounds [%.3g, %.3g, %.3g] to [%.3g, %.3g, %.3g] m (extent %.3g × "
                  "%.3g × %.3g m); %.4g m³ (level set %.4g, mesh %.4g); voxel %.4g m; grid "
                  "%.1f ms, mesh %.1f ms; %zu triangles",
                  s.name.c_str(), s.kind.c_str(), s.bounds.lo.x, s.bounds.lo.y, s.bounds.lo.z,
                  s.bounds.hi.x, s.bounds.hi.y, s.bounds.hi.z, e.x, e.y, e.z, s.measure,
                  s.levelSetMeasure, s.meshVolume, s.voxel, s.gridMs, s.meshMs, s.triangles);
    return buf;
}

VolumeOutputResult writeSpeciesVolumes(const std::string& speciesPath, const fs::path& dir,
                                       const VolumeOutputOptions& options) {
    VolumeOutputResult result;
    auto t0 = std::chrono::steady_clock::now();
    SpeciesFile species = loadSpecies(speciesPath);
    DrawContext draw;
    draw.seed = hashCombine(options.seed, 0x9a7a);  // as growSpecies draws the parameters
    BudgetTable budget;
    std::unique_ptr<GrowthMethod> method =
        instantiateSpecies(species, draw, nullptr, nullptr, nullptr, &budget);
    checkSizeBounds(*method, effectiveBudget(budget), false);  // a bad species, as validate says
    result.species = species.name;
    result.parseMs = msSince(t0);
    const auto named = method->volumes();
    if (named.empty())
        throw InputError(species.path + ": method \"" + species.method +
                         "\" has no named volumes to write");

    // Voxel sizes first, so a bad --voxel fails before any work.
    std::vector<double> voxels;
    for (const auto& [name, v] : named) {
        const Vec3 e = v->bounds().size();
        const double largest = std::max({e.x, e.y, e.z});
        const double voxel = options.voxel > 0 ? options.voxel : largest / kDefaultDivisions;
        if (!(voxel > 0) || !std::isfinite(voxel))
            throw InputError("the " + name + " volume has no extent to voxelise");
        const double pad = 2 * (kHalfWidth + 1);
        const double cells = (e.x / voxel + pad) * (e.y / voxel + pad) * (e.z / voxel + pad);
        if (!(cells <= kMaxVoxels)) {
            char buf[200];
            std::snprintf(buf, sizeof buf,
                          "%svoxel %g m is too fine for the %s volume (%.3g voxels, over 2·10⁹)",
                          options.voxel > 0 ? "--" : "", voxel, name.c_str(), cells);
            throw InputError(buf);  // a --voxel too fine
        }
        voxels.push_back(voxel);
    }

    // Everything is computed before the first write.
    const VdbModule& vdb = vdbModule();
    std::vector<VdbGridPtr> grids;
    std::vector<Mesh> meshes;
    for (size_t i = 0; i < named.size(); ++i) {
        const auto& [name, v] = named[i];
        VolumeSummary s;
        s.name = name;
        s.kind = v->describe();
        s.bounds = v->bounds();
        s.measure = v->measure();
        s.voxel = voxels[i];
        auto t = std::chrono::steady_clock::now();
        VdbGridPtr grid = levelSetGrid(*v, s.voxel, kHalfWidth);
        s.gridMs = msSince(t);
        vdb.setName(*grid, name);
        vdb.setStringMeta(*grid, "description", s.kind);
        s.activeVoxels = vdb.activeVoxelCount(*grid);
        s.levelSetMeasure = interiorMeasure(*grid, s.voxel);
        t = std::chrono::steady_clock::now();
        meshes.push_back(meshLevelSet(*grid, s.voxel));
        s.meshMs = msSince(t);
        s.triangles = meshes.back().triangleCount();
        s.meshVolume = enclosedVolume(meshes.back());
        grids.push_back(grid);
        result.volumes.push_back(s);
    }
    std::vector<const Mesh*> rows;
    for (const Mesh& m : meshes) rows.push_back(&m);
    const VolumePreview preview = renderVolumePreview(rows, options.tile);
    result.previewWidth = preview.width;
    result.previewHeight = preview.height;
    result.metresPerPixel = preview.metresPerPixel;

    fs::create_directories(dir);
    nlohmann::json vols = nlohmann::json::array();
    for (size_t i = 0; i < named.size(); ++i) {
        const VolumeSummary& s = result.volumes[i];
        writeVdb(*grids[i], dir / (s.name + ".vdb"));
        writeFileAtomic(dir / (s.name + ".ply"), meshPly(TreeMesh{meshes[i], Mesh{}}));
        const Vec3 e = s.bounds.size();
        vols.push_back({{"name", s.name},
                        {"kind", s.kind},
                        {"bounds_min_m", {s.bounds.lo.x, s.bounds.lo.y, s.bounds.lo.z}},
                        {"bounds_max_m", {s.bounds.hi.x, s.bounds.hi.y, s.bounds.hi.z}},
                        {"extent_m", {e.x, e.y, e.z}},
                        {"measure_m3", s.measure},
                        {"level_set_m3", s.levelSetMeasure},
                        {"mesh_m3", s.meshVolume},
                        {"voxel_m", s.voxel},
                        {"half_width_voxels", kHalfWidth},
                        {"active_voxels", s.activeVoxels},
                        {"triangles", s.triangles},
                        {"grid_ms", s.gridMs},
                        {"mesh_ms", s.meshMs},
                        {"vdb", s.name + ".vdb"},
                        {"ply", s.name + ".ply"}});
    }
    writeGreyPng(dir / "preview.png", preview.width, preview.height, preview.pixels);
    std::vector<std::string> rowNames;
    for (const auto& s : result.volumes) rowNames.push_back(s.name);
    nlohmann::json manifest = {{"species", species.name},
                               {"file", species.path},
                               {"method", species.method},
                               {"seed", options.seed},
                               {"parse_ms", result.parseMs},
                               {"volumes", vols},
                               {"preview",
                                {{"file", "preview.png"},
                                 {"width", preview.width},
                                 {"height", preview.height},
                                 {"tile", options.tile},
                                 {"metres_per_pixel", preview.metresPerPixel},
                                 {"rows", rowNames},
                                 {"columns",
                                  {"front: from +z, x right, y up", "side: from +x, -z right, y up",
                                   "top: from +y, x right, -z up"}}}}};
    writeFileAtomic(dir / "volumes.json", manifest.dump(2) + "\n");
    return result;
}

}  // namespace sylva
