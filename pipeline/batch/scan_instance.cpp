#include "pipeline/batch/scan_instance.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/clock.h"
#include "core/rng.h"
#include "pipeline/formats/qsm_writer.h"
#include "pipeline/formats/scan_writers.h"
#include "pipeline/render/plot_render.h"
#include "pipeline/scan/scan_scene.h"
#include "pipeline/scan/scan_stats.h"
#include "pipeline/scan/scanner.h"

namespace fs = std::filesystem;

namespace sylva {

namespace {

int tlsStations(const ScanOptions& o) {
    return o.platform == ScanPlatform::kTls ? static_cast<int>(o.stations.size()) : 0;
}

const char* systemIdentifier(ScanPlatform p) {
    switch (p) {
        case ScanPlatform::kTls:
            return "sylva TLS simulation";
        case ScanPlatform::kAls:
            return "sylva ALS simulation";
        case ScanPlatform::kUls:
            return "sylva ULS simulation";
    }
    return "sylva simulation";
}

uint64_t fileSize(const fs::path& p) {
    std::error_code ec;
    const auto size = fs::file_size(p, ec);
    return ec ? 0 : static_cast<uint64_t>(size);
}

// The survey into `spool` and `stats`, a block of pulses at a time in pulse order: memory stays
// a few blocks per thread and the spool's buffer, whatever the survey's size.
ScanResult spoolScan(const ScanScene& scene, const ScanOptions& options, uint64_t seed,
                     ScanPointSpool& spool, ScanStats& stats, const ScanProgress& progress) {
    return scanInto(
        scene, options, seed,
        [&](std::vector<ScanPoint>& points) {
            spool.append(points);
            stats.addPoints(points);
        },
        {}, progress);
}

}  // namespace

double treeGroundHalfSize(const Tree& tree, const ScanOptions& options) {
    double reach = 0;
    for (const SkeletonNode& n : tree.nodes) {
        reach = std::max({reach, std::abs(n.position.x), std::abs(n.position.z)});
    }
    for (const Leaf& l : tree.leaves) {
        reach = std::max({reach, std::abs(l.position.x), std::abs(l.position.z)});
    }
    if (options.platform == ScanPlatform::kTls) {
        for (const TlsStation& s : options.stations) {
            reach = std::max({reach, std::abs(s.x), std::abs(s.z)});
        }
    }
    return reach + kTreeGroundMargin;
}

InstanceScan scanTree(const Tree& tree, const TreeMesh& mesh, const std::vector<int32_t>& woodNodes,
                      const ScanOutputs& scan, bool leafOutlines, uint64_t seed,
                      const fs::path& spoolDir) {
    const auto t0 = std::chrono::steady_clock::now();
    const double half = treeGroundHalfSize(tree, scan.options);
    const ScanScene scene = makeScanScene(tree, mesh, woodNodes, half, leafOutlines);
    InstanceScan s;
    s.sceneMs = msSince(t0);
    s.points = std::make_unique<ScanPointSpool>(spoolDir);
    ScanStats stats(tlsStations(scan.options), 4 * half * half, scan.options.maxReturns);
    stats.addTree(1, tree);
    s.result = spoolScan(scene, scan.options, seed, *s.points, stats, {});
    s.stats = stats.json(s.result.pulses);
    s.stats["platform"] = scanPlatformName(scan.options.platform);
    s.stats["ground_m2"] = 4 * half * half;
    s.totalMs = msSince(t0);
    return s;
}

InstanceScan scanPlot(const GrownPlot& plot, const PlotScene& scene, const ScanOutputs& scan,
                      uint64_t seed, const fs::path& spoolDir, const ScanProgress& progress) {
    const auto t0 = std::chrono::steady_clock::now();
    const ScanScene s3 = makeScanScene(plot, scene);
    InstanceScan s;
    s.sceneMs = msSince(t0);
    s.points = std::make_unique<ScanPointSpool>(spoolDir);
    const double area = plot.spec->area.area();
    ScanStats stats(tlsStations(scan.options), area, scan.options.maxReturns);
    // The density is over the plot area: the margin's terrain and trees are scanned too.
    const PlotArea& outline = plot.spec->area;
    stats.setArea([&outline](double x, double z) { return outline.contains(x, z); });
    for (const PlotTree& t : plot.trees) stats.addTree(t.stem.id, t.grown.tree);
    s.result = spoolScan(s3, scan.options, seed, *s.points, stats, progress);
    s.stats = stats.json(s.result.pulses);
    s.stats["platform"] = scanPlatformName(scan.options.platform);
    s.stats["ground_m2"] = area;
    s.totalMs = msSince(t0);
    return s;
}

void writeScanFiles(const InstanceScan& scan, const ScanOutputs& options, const fs::path& out,
                    const fs::path& rel, nlohmann::json& files, uint64_t& bytes) {
    auto note = [&](const std::string& key, const std::string& name) {
        files[key] = (rel / name).generic_string();
        bytes += fileSize(out / rel / name);
    };
    fs::create_directories(out / rel);
    LasOptions lo;
    lo.colour = options.colour;
    lo.classes = options.classes;
    lo.systemIdentifier = systemIdentifier(options.options.platform);
    if (options.las) {
        writeLas(out / rel / "scan.las", *scan.points, lo);
        note("scan_las", "scan.las");
    }
    if (options.laz) {
        writeLaz(out / rel / "scan.laz", *scan.points, lo);
        note("scan_laz", "scan.laz");
    }
    if (options.forestFormer) {
        writeForestFormerPly(out / rel / "scan_forestformer.ply", *scan.points);
        note("scan_forestformer_ply", "scan_forestformer.ply");
    }
    if (options.treeLearn) {
        writeTreeLearnNpy(out / rel / "scan_treelearn.npy", *scan.points);
        note("scan_treelearn_npy", "scan_treelearn.npy");
    }
    writeTrajectory(out / rel / "scan_trajectory.csv", scan.result);
    note("scan_trajectory", "scan_trajectory.csv");
    if (options.options.platform == ScanPlatform::kTls) {
        writeStations(out / rel / "scan_stations.json", scan.result);
        note("scan_stations", "scan_stations.json");
    }
}

void writeQsmFiles(const Tree& tree, const fs::path& out, const fs::path& rel,
                   const std::string& prefix, nlohmann::json& files, uint64_t& bytes) {
    const std::string csv = prefix + "qsm.csv", txt = prefix + "qsm_treeqsm.txt";
    fs::create_directories((out / rel / csv).parent_path());
    writeQsmCylinders(out / rel / csv, tree, out / rel / txt);
    if (prefix.empty()) {
        files["qsm_csv"] = (rel / csv).generic_string();
        files["qsm_txt"] = (rel / txt).generic_string();
    }
    bytes += fileSize(out / rel / csv) + fileSize(out / rel / txt);
}

}  // namespace sylva
