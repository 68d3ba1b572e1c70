// `sylva report`: the statistics helpers on known answers, and the HTML of a hand-written
// dataset (dataset.json + manifest.jsonl + one contact sheet) whose comparison and sweep
// results are known: structure, plot count, highlighted separating metric, link resolution.
#include "pipeline/analysis/report.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>

#include "pipeline/analysis/dataset_stats.h"
#include "tests/test_support.h"

namespace fs = std::filesystem;
using namespace sylva;
using nlohmann::json;

namespace {

size_t countOf(const std::string& s, const std::string& what) {
    size_t n = 0;
    for (size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
    return n;
}

void writeText(const fs::path& p, const std::string& s) {
    fs::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << s;
}

// Two species of n instances (8 unless said). height_m: alpha 1..n, beta 11..10+n (fully
// separated: KS D = 1, W1 = 10 m). crown_width_m: 1..n in both (D = 0). root_depth_m: 0
// everywhere (constant). silhouette_coverage: two views. nodes: 100 + 10·x in both (x = 1, 2
// alternating). graph_nodes: alpha only (a method's counter), 50 + k. stems: alpha only, 1
// (constant for alpha). grow_rate: null in every record (no species has it). Sweep (when
// `sweep`): alpha instances alternate levels[0].x = 1, 2; beta has no sweep key.
void writeDataset(const fs::path& dir, bool sweep, int n = 8) {
    json info = {{"name", "synthetic <set>"},
                 {"seed", 11},
                 {"description", "report test"},
                 {"counts", {{"built", 2 * n}, {"failed", 0}}},
                 {"versions", {{"sylva", "0.1.0"}}},
                 {"wall_seconds", 2.5},
                 {"trees_per_second", 6.4},
                 {"species",
                  {{{"name", "alpha"}, {"method", "m"}, {"count", n}},
                   {{"name", "beta"}, {"method", "m"}, {"count", n}}}}};
    writeText(dir / "dataset.json", info.dump(2));
    std::string lines;
    for (int i = 0; i < 2 * n; ++i) {
        bool alpha = i < n;
        int k = i % n + 1;
        int x = k % 2 ? 1 : 2;
        json r = {{"id", (alpha ? "alpha-" : "beta-") + std::to_string(k)},
                  {"index", i},
                  {"species", alpha ? "alpha" : "beta"},
                  {"stats",
                   {{"height_m", alpha ? k : 10 + k},
                    {"crown_width_m", k},
                    {"root_depth_m", 0.0},
                    {"silhouette_coverage", {0.1 * k, 0.1 * k + 0.2}},
                    {"nodes", 100 + 10 * x},
                    {"grow_rate", nullptr}}},
                  {"timing", {{"grow_ms", 1.0 + k}}}};
        if (alpha) {
            r["stats"]["graph_nodes"] = 50 + k;
            r["stats"]["stems"] = 1;
        }
        if (sweep && alpha) r["sweep"] = {{"levels[0].x", std::to_string(x)}};
        lines += r.dump() + "\n";
    }
    lines += "{\"id\": \"torn";  // a torn last line, as a killed build leaves
    writeText(dir / "manifest.jsonl", lines);
    writeText(dir / "contact" / "alpha.png", "not really a png");
}

std::string slurpFile(const fs::path& p) { return sylva::test::slurp(p); }

}  // namespace

TEST(ReportHelpers, QuantilesKsWassersteinTicksUnits) {
    // The shared statistics (pipeline/analysis/dataset_stats.h) as the report uses them.
    EXPECT_DOUBLE_EQ(quantileType7({1, 2, 3, 4}, 0.25), 1.75);  // numpy's default (type 7)
    EXPECT_DOUBLE_EQ(quantileType7({1, 2, 3, 4}, 0.5), 2.5);
    EXPECT_DOUBLE_EQ(quantileType7({5}, 0.9), 5.0);
    EXPECT_DOUBLE_EQ(ksTwoSample({1, 2, 3}, {1, 2, 3}).d, 0.0);
    EXPECT_DOUBLE_EQ(ksTwoSample({1, 2}, {3, 4}).d, 1.0);
    EXPECT_DOUBLE_EQ(ksTwoSample({1, 2, 3, 4}, {3, 4, 5, 6}).d, 0.5);
    EXPECT_DOUBLE_EQ(ksTwoSample({1, 1, 2}, {1, 2, 2}).d, 1.0 / 3.0);  // ties step together
    EXPECT_NEAR(wasserstein1({1, 2, 3}, {4, 5, 6}), 3.0, 1e-12);       // a shift by 3
    EXPECT_NEAR(wasserstein1({0, 0, 1, 1}, {0, 1}), 0.0, 1e-12);
    EXPECT_NEAR(wasserstein1({0}, {0, 2}), 1.0, 1e-12);
    std::vector<double> t = niceTicks(0.13, 0.87);
    ASSERT_EQ(t.size(), 6u);
    for (size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(t[i], 0.2 * static_cast<double>(i), 1e-12);
    t = niceTicks(12, 12);  // a constant still gets an axis around it
    EXPECT_LT(t.front(), 12);
    EXPECT_GT(t.back(), 12);
    EXPECT_EQ(metricUnit("height_m"), "m");
    EXPECT_EQ(metricUnit("crown_hull_volume_m3"), "m³");
    EXPECT_EQ(metricUnit("timing.grow_ms"), "ms");
    EXPECT_EQ(metricUnit("nodes"), "");
    EXPECT_EQ(relativeLinks("<a href=\"../x.json\"><img src=\"a/b.png\"><a href=\"#top\">"
                            "<a href=\"https://e.org/\">"),
              (std::vector<std::string>{"../x.json", "a/b.png"}));
}

TEST(Report, HtmlOfAKnownDataset) {
    sylva::test::TempDir tmp;
    writeDataset(tmp.path(), true);
    ReportResult r = writeReport(tmp.path());
    EXPECT_EQ(r.index, tmp.path() / "report" / "index.html");
    EXPECT_EQ(r.instances, 16u);  // the torn line is skipped
    EXPECT_EQ(r.species, 2u);
    // height_m, crown_width_m, silhouette_coverage, nodes, graph_nodes; root_depth_m and stems
    // are constant, grow_rate has no value.
    EXPECT_EQ(r.metrics, 5u);
    std::string html = slurpFile(r.index);
    ASSERT_FALSE(html.empty());
    EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
    EXPECT_NE(html.find("</html>"), std::string::npos);
    EXPECT_NE(html.find("synthetic &lt;set&gt;"), std::string::npos);  // escaped
    EXPECT_EQ(html.find("<script"), std::string::npos);                // no scripts
    EXPECT_EQ(countOf(html, "<svg"), r.plots);
    EXPECT_EQ(countOf(html, "</svg>"), r.plots);
    // 5 metric plots + 1 timing plot + sweep plots (alpha over levels[0].x: only nodes varies
    // between the sweep points... and the metrics that differ by chance between 1 and 2).
    EXPECT_GE(r.sweepPlots, 1u);
    EXPECT_LE(r.sweepPlots, 4u);
    EXPECT_EQ(r.plots, 6u + r.sweepPlots);
    EXPECT_NE(html.find("id=\"sweeps\""), std::string::npos);
    EXPECT_NE(html.find("alpha · levels[0].x"), std::string::npos);
    EXPECT_NE(html.find("alpha: nodes"), std::string::npos);  // nodes = 100 + 10 x: all variance
    EXPECT_NE(html.find("height_m [m]"), std::string::npos);  // axis title with unit
    EXPECT_NE(html.find("silhouette_coverage (mean over views)"), std::string::npos);
    EXPECT_NE(html.find("root_depth_m = 0,"), std::string::npos);
    EXPECT_NE(html.find("stems = 1 (alpha only)"), std::string::npos);
    EXPECT_NE(html.find("6.4 trees/s"), std::string::npos);
    EXPECT_NE(html.find("2.5 s"), std::string::npos);
    // The strongest separating metric of alpha–beta is height_m (D = 1, W1 = 10 m).
    EXPECT_NE(html.find("<tr class=\"top\"><td class=\"l\">alpha</td><td class=\"l\">beta</td>"
                        "<td class=\"l\">height_m</td><td>8 / 8</td><td>4.5</td><td>14.5</td><td "
                        "class=\"strong\">1</td>"),
              std::string::npos);
    EXPECT_NE(html.find("<td>10 m</td>"), std::string::npos);
    // Contact sheets: alpha's linked, beta's (missing) not.
    EXPECT_NE(html.find("src=\"../contact/alpha.png\""), std::string::npos);
    EXPECT_EQ(html.find("beta.png"), std::string::npos);
    // Every relative link resolves from report/.
    std::vector<std::string> links = relativeLinks(html);
    EXPECT_GE(links.size(), 3u);  // dataset.json, manifest.jsonl, the contact sheet
    for (const auto& l : links) EXPECT_TRUE(fs::exists(r.index.parent_path() / l)) << l;
    // The stats in the SVG titles: alpha height_m median 4.5, q25 2.75.
    EXPECT_NE(html.find("alpha: n 8, mean 4.5, sd 2.449, q05 1.35, q25 2.75, median 4.5"),
              std::string::npos);
}

// How the dataset was built comes from the run log runs.jsonl (dataset.json describes the
// dataset only): the runs by status, their summed build time, the most threads.
TEST(Report, RunsFromTheRunLog) {
    sylva::test::TempDir tmp;
    writeDataset(tmp.path(), false);
    writeText(tmp.path() / "runs.jsonl",
              "{\"command\":\"build\",\"status\":\"interrupted\",\"threads\":2,"
              "\"built\":5}\n"
              "{\"command\":\"build\",\"status\":\"complete\",\"threads\":8,"
              "\"wall_seconds\":1.25,\"built\":11}\n");
    const std::string html = slurpFile(writeReport(tmp.path()).index);
    EXPECT_NE(html.find("<td>runs</td><td class=\"l\">2 (1 complete, 1 interrupted)</td>"),
              std::string::npos);
    EXPECT_NE(html.find("<td>build time</td><td class=\"l\">1.25 s (sum of the build runs)</td>"),
              std::string::npos);
    EXPECT_NE(html.find("<td>threads</td><td class=\"l\">8 (most in a run)</td>"),
              std::string::npos);
    EXPECT_FALSE(fs::exists(tmp.path() / ".sylva.lock"));  // report's lock, gone again
}

TEST(Report, NoSweepSectionWithoutSweepsAndErrors) {
    sylva::test::TempDir tmp;
    writeDataset(tmp.path(), false);
    ReportResult r = writeReport(tmp.path());
    EXPECT_EQ(r.sweepPlots, 0u);
    EXPECT_EQ(r.plots, 6u);
    std::string html = slurpFile(r.index);
    EXPECT_EQ(html.find("id=\"sweeps\""), std::string::npos);
    fs::remove(tmp.path() / "manifest.jsonl");
    EXPECT_THROW(writeReport(tmp.path()), InputError);  // no record: bad input, exit 2
    EXPECT_THROW(writeReport(tmp.path() / "nowhere"), InputError);
}

namespace {

// The HTML of the plot figure of `metric` (from its <figure to its </figure>), "" if none.
std::string figureOf(const std::string& html, const std::string& metric) {
    const size_t at = html.find("<figure class=\"plot\" data-metric=\"" + metric + "\"");
    if (at == std::string::npos) return "";
    return html.substr(at, html.find("</figure>", at) - at);
}

}  // namespace

TEST(ReportHelpers, MetricThemes) {
    EXPECT_EQ(metricTheme("height_m"), "size");
    EXPECT_EQ(metricTheme("mesh_triangles"), "size");
    EXPECT_EQ(metricTheme("fork_angle_mean_deg"), "branching");
    EXPECT_EQ(metricTheme("radius_exponent_median"), "branching");
    EXPECT_EQ(metricTheme("crown_hull_volume_m3"), "crown");
    EXPECT_EQ(metricTheme("leaves"), "leaves");
    EXPECT_EQ(metricTheme("leaf_pixel_fraction"), "leaves");
    EXPECT_EQ(metricTheme("silhouette_coverage"), "views");
    EXPECT_EQ(metricTheme("anything_per_view", true), "views");
    EXPECT_EQ(metricTheme("graph_nodes"), "method");  // a growth method's counter
    EXPECT_EQ(metricTheme("timing.grow_ms"), "timing");
}

// Plots sit in one grid per theme, each under its heading, themes in page order; a species
// without a value of a metric has no row in its plot; a metric no species has is not plotted.
TEST(Report, PlotsGroupedByThemeWithoutAbsentSpecies) {
    sylva::test::TempDir tmp;
    writeDataset(tmp.path(), false);
    ReportResult r = writeReport(tmp.path());
    const std::string html = slurpFile(r.index);
    size_t last = 0;
    for (const char* theme : {"size", "crown", "views", "method", "timing"}) {
        const size_t at = html.find("<h3 id=\"theme-" + std::string(theme) + "\">");
        ASSERT_NE(at, std::string::npos) << theme;
        EXPECT_GT(at, last) << theme << " out of order";
        last = at;
        EXPECT_EQ(html.compare(html.find('\n', at) + 1, 20, "<div class=\"plots\">\n"), 0) << theme;
    }
    EXPECT_EQ(html.find("id=\"theme-branching\""), std::string::npos);  // no such metric here
    EXPECT_EQ(html.find("id=\"theme-leaves\""), std::string::npos);
    // Each plot under its theme: height_m after the size heading, before the crown heading.
    const size_t height = html.find("data-metric=\"height_m\"");
    EXPECT_GT(height, html.find("id=\"theme-size\""));
    EXPECT_LT(height, html.find("id=\"theme-crown\""));
    EXPECT_GT(html.find("data-metric=\"graph_nodes\""), html.find("id=\"theme-method\""));

    const std::string both = figureOf(html, "height_m");
    EXPECT_NE(both.find("data-species=\"alpha\""), std::string::npos);
    EXPECT_NE(both.find("data-species=\"beta\""), std::string::npos);
    EXPECT_EQ(both.find("no value"), std::string::npos);
    const std::string alphaOnly = figureOf(html, "graph_nodes");
    ASSERT_FALSE(alphaOnly.empty());
    EXPECT_NE(alphaOnly.find("data-species=\"alpha\""), std::string::npos);
    EXPECT_EQ(alphaOnly.find("data-species=\"beta\""), std::string::npos);  // no empty row
    EXPECT_EQ(alphaOnly.find(">beta<"), std::string::npos);                 // nor its label
    EXPECT_NE(alphaOnly.find("no value for beta"), std::string::npos);
    EXPECT_EQ(countOf(alphaOnly, "<rect"), 1u);  // one box: alpha's
    // grow_rate is null everywhere: no plot, no row, no mention.
    EXPECT_EQ(html.find("grow_rate"), std::string::npos);
    // The summary table: graph_nodes has – for beta.
    EXPECT_NE(
        html.find("<tr><td class=\"l\">graph_nodes</td><td>54.5 ± 2.45 (54.5)</td><td>–</td>"),
        std::string::npos);
}

// With 8 instances per species the KS p-value is shown; with 3, "too few instances" instead
// (and the n of each side), in every comparison row; fewer than 5 values draw no box.
TEST(Report, TooFewInstancesForAPValue) {
    sylva::test::TempDir tmp;
    writeDataset(tmp.path(), false, 8);
    std::string html = slurpFile(writeReport(tmp.path()).index);
    EXPECT_EQ(html.find("too few instances</td>"), std::string::npos);
    const double p8 = ksTwoSample({1, 2, 3, 4, 5, 6, 7, 8}, {11, 12, 13, 14, 15, 16, 17, 18}).p;
    char p8Text[32];
    std::snprintf(p8Text, sizeof p8Text, "<td>%.2g</td>", p8);
    EXPECT_NE(html.find(std::string("</td>") + p8Text + "<td>10 m</td>"), std::string::npos)
        << p8Text;

    sylva::test::TempDir few;
    writeDataset(few.path(), false, 3);
    html = slurpFile(writeReport(few.path()).index);
    const size_t table = html.find("id=\"compare\"");
    ASSERT_NE(table, std::string::npos);
    const std::string compare = html.substr(table, html.find("</table>", table) - table);
    const size_t rows = countOf(compare, "<tr") - 1;  // less the header
    EXPECT_GE(rows, 3u);
    EXPECT_EQ(countOf(compare, "<td class=\"few\">too few instances</td>"), rows);
    EXPECT_NE(compare.find("<td>3 / 3</td>"), std::string::npos);
    EXPECT_EQ(countOf(figureOf(html, "height_m"), "<rect"), 0u);  // instances and median only
}
