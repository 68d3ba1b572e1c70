// `sylva report DATASET_DIR`: one self-contained HTML page (inline CSS, inline SVG plots, no
// scripts, no network) at DATASET_DIR/report/index.html with the dataset's facts, the species
// contact sheets (linked relatively: ../contact/<species>.png), per-species box plots of every
// numeric metric in the manifest's `stats` in a responsive grid, grouped by theme (size,
// branching, crown, leaves, views, method counters, timing; a species without a value of a
// metric gets no row in its plot), a per-species summary table, the species comparison
// (two-sample Kolmogorov–Smirnov D and Wasserstein-1 distance per metric, the strongest
// separating metrics highlighted; the KS p-value only when both species have at least
// kMinInstancesForP values, "too few instances" otherwise) and, when the dataset has sweeps,
// sweep curves (mean with a ±1 sd band against the swept value). Everything is computed from
// dataset.json and the manifest (manifest.jsonl, or the shard manifests when it is missing),
// so the report does not depend on `sylva stats`.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace sylva {

struct ReportResult {
    std::filesystem::path index;  // DATASET_DIR/report/index.html
    size_t instances = 0;         // manifest records read
    size_t species = 0;
    size_t metrics = 0;  // metrics plotted
    size_t plots = 0;    // <svg> elements written
    size_t sweepPlots = 0;
};

// Writes the report atomically. Throws std::runtime_error when DATASET_DIR has no dataset.json
// or no manifest record, and (a self-check) when a relative src/href in the page does not
// resolve to an existing file.
ReportResult writeReport(const std::filesystem::path& datasetDir);

// A KS p-value is shown only when both samples have at least this many values: below it the
// asymptotic p is not to be trusted and even the exact one can barely reach 0.05 (two samples
// of 4 that do not overlap give p ≈ 0.03), so the page says "too few instances" instead.
constexpr size_t kMinInstancesForP = 8;

// --- helpers, exposed for the tests ---------------------------------------------------------

// The theme a metric is plotted under: "size", "branching", "crown", "leaves", "views",
// "method" (the growth methods' counters and any key the report does not know) or "timing"
// (keys "timing.<stage>"). `perView`: a metric with one value per view goes under "views".
std::string metricTheme(const std::string& metric, bool perView = false);

// About `target` round tick values covering [lo, hi] (1, 2, 5 × 10^k steps).
std::vector<double> niceTicks(double lo, double hi, int target = 5);
// Unit of a metric from its name's suffix: "_m" → "m", "_m2" → "m²", "_m3" → "m³",
// "_ms" → "ms", "_deg" → "°"; otherwise "" (a count or a ratio).
std::string metricUnit(const std::string& metric);
// Every src="…" and href="…" value in `html` that is not an absolute URL or a #fragment.
std::vector<std::string> relativeLinks(const std::string& html);

}  // namespace sylva
