// Scan writers (issue 17): what writing a scan costs next to making it.
//  - ScanWrite/<format>: encoding 1,000,000 scan points (random-ish labels, a 100 m plot) as
//    LAS 1.4 format 6, format 7 (RGB by class), the ForestFormer3D PLY, TreeLearn's .npy, and
//    LAZ format 6 and 7, in memory (lasBytes, …: the files are these bytes), one thread; points
//    per second, and the bytes written (counter `bytes`: LAZ's against LAS's).
//  - QsmCylinders: the cylinder table of a pedunculate oak (seed 1, ~25k segments) and its CSV.
#include <benchmark/benchmark.h>

#include <string>

#include "pipeline/formats/qsm_writer.h"
#include "pipeline/formats/scan_writers.h"
#include "species/spec/species.h"

using namespace sylva;

namespace {

ScanResult millionPoints() {
    ScanResult scan;
    constexpr int n = 1000000;
    scan.points.resize(n);
    uint64_t h = 0x9e3779b97f4a7c15ull;
    for (int i = 0; i < n; ++i) {
        h ^= h << 13, h ^= h >> 7, h ^= h << 17;
        ScanPoint& p = scan.points[i];
        p.x = -50 + 100 * double(h & 0xffff) / 65536;
        p.y = 25 * double((h >> 16) & 0xffff) / 65536;
        p.z = -50 + 100 * double((h >> 32) & 0xffff) / 65536;
        p.gpsTime = 1e-6 * i;
        p.intensity = static_cast<uint16_t>(h >> 48);
        p.numberOfReturns = static_cast<uint8_t>(1 + (h >> 20) % 4);
        p.returnNumber = static_cast<uint8_t>(1 + (h >> 24) % p.numberOfReturns);
        p.channel = static_cast<uint8_t>((h >> 28) % 4);
        p.scanAngleDeg = static_cast<float>(-30 + 60 * double((h >> 40) & 0xff) / 256);
        p.label.treeId = static_cast<int32_t>((h >> 8) % 400);
        p.label.nodeId = static_cast<int32_t>((h >> 12) % 20000) - 1;
        p.label.part = static_cast<uint8_t>((h >> 4) % 6);
        p.classification = static_cast<uint8_t>((h >> 36) % 7);
        p.semantic = static_cast<uint8_t>(1 + (h >> 44) % 3);
    }
    return scan;
}

void ScanWriteBench(benchmark::State& state) {
    static const ScanResult scan = millionPoints();
    const int format = static_cast<int>(state.range(0));
    LasOptions rgb;
    rgb.colour = LasColour::kClass;
    size_t bytes = 0;
    for (auto _ : state) {
        std::string b = format == 0   ? lasBytes(scan)
                        : format == 1 ? lasBytes(scan, rgb)
                        : format == 2 ? forestFormerPlyBytes(scan)
                        : format == 3 ? treeLearnNpyBytes(scan)
                        : format == 4 ? lazBytes(scan)
                                      : lazBytes(scan, rgb);
        bytes = b.size();
        benchmark::DoNotOptimize(b.data());
    }
    state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(scan.points.size()));
    state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(bytes));
    state.counters["bytes"] = static_cast<double>(bytes);
}
// 0 LAS format 6, 1 LAS format 7, 2 ForestFormer3D PLY, 3 TreeLearn .npy, 4 LAZ format 6,
// 5 LAZ format 7.
BENCHMARK(ScanWriteBench)
    ->Name("ScanWrite")
    ->ArgName("format")
    ->DenseRange(0, 5)
    ->Unit(benchmark::kMillisecond);

void QsmCylindersBench(benchmark::State& state) {
    static const Tree tree = growSpecies(loadSpecies(std::string(SYLVA_SOURCE_DIR) +
                                                     "/species/presets/pedunculate-oak.toml"),
                                         1, nullptr, true)
                                 .tree;
    size_t n = 0;
    for (auto _ : state) {
        const std::string csv = qsmCylinderCsv(qsmCylinders(tree));
        n = csv.size();
        benchmark::DoNotOptimize(csv.data());
    }
    state.counters["nodes"] = static_cast<double>(tree.nodes.size());
    state.counters["csv_bytes"] = static_cast<double>(n);
}
BENCHMARK(QsmCylindersBench)->Name("QsmCylinders")->Unit(benchmark::kMillisecond);

}  // namespace
