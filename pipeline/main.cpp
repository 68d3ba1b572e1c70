// The `sylva` command line: parse the arguments and dispatch to the libraries (build, grow,
// validate, volume, species list, stats, report, merge). Exit codes: 0 success, 1 a runtime
// failure (some trees failed, I/O, a broken invariant), 2 bad input (InputError, core/errors.h).
#include <tbb/global_control.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "pipeline/analysis/dataset_stats.h"
#include "pipeline/analysis/merge.h"
#include "pipeline/analysis/realism_gates.h"
#include "pipeline/analysis/report.h"
#include "pipeline/analysis/species_list.h"
#include "pipeline/analysis/volume_output.h"
#include "pipeline/build/build.h"
#include "pipeline/build/dataset.h"
#include "pipeline/build/grow_one.h"
#include "species/spec/species.h"

namespace fs = std::filesystem;
using namespace sylva;

namespace {

int runBuild(const std::string& specPath, std::string out, int threads, const std::string& shard) {
    int si = 0, sn = 1;
    if (!shard.empty()) {
        int used = 0;
        if (std::sscanf(shard.c_str(), "%d/%d%n", &si, &sn, &used) != 2 ||
            used != static_cast<int>(shard.size()) || sn < 1 || si < 0 || si >= sn) {
            std::fprintf(stderr, "sylva: --shard %s: expected I/N with 0 ≤ I < N\n", shard.c_str());
            return 2;
        }
    }
    DatasetSpec spec = loadDataset(specPath);  // validates everything before any write
    BuildOptions o;
    o.out = out.empty() ? fs::path("out") / spec.name : fs::path(out);
    o.threads = threads;
    o.shardIndex = si;
    o.shardCount = sn;
    BuildSummary s = buildDataset(spec, o);
    std::fprintf(stderr,
                 "sylva: %s: %lld built, %lld already there, %lld failed of %lld in %.2f s -> %s\n",
                 spec.name.c_str(), static_cast<long long>(s.built),
                 static_cast<long long>(s.skipped), static_cast<long long>(s.failed),
                 static_cast<long long>(s.total), s.wallSeconds, o.out.string().c_str());
    return s.failed ? 1 : 0;
}

int runMerge(const MergeOptions& o) {
    const MergeSummary s = mergeShards(o);
    std::fprintf(stderr,
                 "sylva: merged %d shards, %lld instances, %lld species sheets in %.2f s -> %s\n",
                 s.shardCount, static_cast<long long>(s.instances),
                 static_cast<long long>(s.sheets), s.wallSeconds, o.out.string().c_str());
    return 0;
}

int runGrow(const std::string& speciesPath, uint64_t seed, const std::string& out, int threads) {
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0) {
        limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                      threads);
    }
    const GrowOneResult r = growOne(speciesPath, seed, out);
    std::printf(
        "%s seed %llu: %lld nodes, %lld endpoints, height %.2f m, crown width %.2f m, "
        "%.1f ms -> %s\n",
        r.species.c_str(), static_cast<unsigned long long>(seed),
        static_cast<long long>(r.stats.nodes), static_cast<long long>(r.stats.endpoints),
        r.stats.height, r.stats.crownWidth, r.growMs, r.dir.string().c_str());
    return 0;
}

int runValidate(const std::string& path) {
    toml::table t = parseTomlFile(path);
    if (isDatasetFile(t)) {
        DatasetSpec spec = loadDataset(path);
        const int64_t instances = DatasetInstances(spec).size();  // computed, not listed
        std::printf("%s: ok — dataset \"%s\", %zu species, %lld instances\n", path.c_str(),
                    spec.name.c_str(), spec.species.size(), static_cast<long long>(instances));
    } else {
        SpeciesFile s = loadSpecies(path);
        validateSpecies(s, nullptr);
        std::printf("%s: ok — species \"%s\", method \"%s\"\n", path.c_str(), s.name.c_str(),
                    s.method.c_str());
    }
    return 0;
}

int runVolume(const std::string& speciesPath, const VolumeOutputOptions& options, std::string out) {
    fs::path dir = out;
    if (dir.empty()) dir = fs::path("out") / "volume" / loadSpecies(speciesPath).name;
    const VolumeOutputResult r = writeSpeciesVolumes(speciesPath, dir, options);
    std::printf("%s seed %llu: %zu volume(s), species parsed in %.1f ms -> %s\n", r.species.c_str(),
                static_cast<unsigned long long>(options.seed), r.volumes.size(), r.parseMs,
                dir.string().c_str());
    for (const VolumeSummary& s : r.volumes) std::printf("  %s\n", summaryLine(s).c_str());
    std::printf("  preview.png: %d × %d px, front | side | top, %.4g m per pixel\n", r.previewWidth,
                r.previewHeight, r.metresPerPixel);
    return 0;
}

// Lists the species under `dir` (default: the repository's species/). Exit 2 when a file
// fails to load (it is still listed, with its error), so scripts can check a library.
int runSpeciesList(std::string dir) {
    fs::path d = dir;
    if (d.empty()) {
        std::error_code ec;
        fs::path exe = fs::read_symlink("/proc/self/exe", ec);
        std::optional<fs::path> found = defaultSpeciesDir(exe);
        if (!found) {
            std::fprintf(stderr,
                         "sylva: species list: no species/ directory with presets/ above the "
                         "executable or the current directory; give DIR\n");
            return 2;
        }
        // Relative to the current directory when below it, so the paths are short.
        fs::path rel = found->lexically_relative(fs::current_path(ec));
        d = !ec && !rel.empty() && *rel.begin() != ".." ? rel : *found;
    }
    const std::vector<SpeciesListEntry> entries = listSpecies(d);
    std::fputs(formatSpeciesList(entries).c_str(), stdout);
    size_t failed = std::count_if(entries.begin(), entries.end(),
                                  [](const SpeciesListEntry& e) { return !e.error.empty(); });
    if (failed) {
        std::fprintf(stderr, "sylva: species list: %zu of %zu species files failed to load\n",
                     failed, entries.size());
        return 2;
    }
    return 0;
}

// Summaries, species comparison and sweep table of a dataset directory (finished, partial or
// sharded), and with a reference file the KS distances to it. Exit 2 when DIR is not a dataset
// directory or holds no complete record, or the reference file or a skeleton is bad.
int runStats(const std::string& dir, bool noTiming, const std::string& reference) {
    DatasetStatsOptions o;
    o.timing = !noTiming;
    o.reference = reference;
    const DatasetStatsResult r = computeDatasetStats(dir, o);
    std::printf("%s", r.summary.c_str());
    return 0;
}

// Self-contained HTML report of a dataset directory -> DIR/report/index.html. Exit 2 when DIR
// is not a dataset directory or its manifest holds no record.
int runReport(const std::string& dir) {
    ReportResult r = writeReport(dir);
    std::printf("%s: %zu instances, %zu species, %zu metrics, %zu plots (%zu sweep) -> %s\n",
                dir.c_str(), r.instances, r.species, r.metrics, r.plots, r.sweepPlots,
                r.index.string().c_str());
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"sylva — batch builder of labelled procedural-tree datasets"};
    app.require_subcommand(1);

    std::string spec, out, shard;
    int threads = 0;
    auto* build = app.add_subcommand("build", "Build a dataset (every instance of every species)");
    build->add_option("SPEC", spec, "Dataset spec (.toml)")->required();
    build->add_option("--out", out, "Output directory (default: out/<dataset name>)");
    build->add_option("--threads", threads, "Worker threads (default: all cores)")
        ->check(CLI::NonNegativeNumber);
    build->add_option("--shard", shard,
                      "Build shard I of N (I/N, 0-based): a contiguous block of instances whose "
                      "manifests concatenate, in shard order, to the whole dataset's");

    std::string speciesPath, growOut;
    uint64_t seed = 1;
    int growThreads = 0;
    auto* grow = app.add_subcommand("grow", "Grow one tree for a quick look (with preview.png)");
    grow->add_option("SPECIES", speciesPath, "Species file (.toml)")->required();
    grow->add_option("--seed", seed, "Instance seed (default 1)");
    grow->add_option("--out", growOut, "Output directory (default: out/grow/<species>)");
    grow->add_option("--threads", growThreads, "Worker threads (default: all cores)")
        ->check(CLI::NonNegativeNumber);

    std::string validatePath;
    auto* validate =
        app.add_subcommand("validate", "Check a species or dataset file without building");
    validate->add_option("SPEC", validatePath, "Species or dataset spec (.toml)")->required();

    std::string volumePath, volumeOut;
    VolumeOutputOptions volumeOptions;
    auto* volume = app.add_subcommand(
        "volume", "Write a species' crown volumes (.vdb, .ply) and preview.png, to check them");
    volume->add_option("SPECIES", volumePath, "Species file (.toml)")->required();
    volume->add_option("--out", volumeOut, "Output directory (default: out/volume/<species>)");
    volume->add_option("--seed", volumeOptions.seed,
                       "Instance seed, for volumes drawn per tree (default 1)");
    volume
        ->add_option("--voxel", volumeOptions.voxel,
                     "Voxel size, metres (default: each volume's largest extent / 128)")
        ->check(CLI::PositiveNumber);

    std::string statsDir;
    bool statsNoTiming = false;
    auto* stats = app.add_subcommand(
        "stats",
        "Per-species metric summaries, species comparison (KS, Wasserstein) and sweep table of a "
        "dataset -> DIR/stats/");
    stats->add_option("DIR", statsDir, "Dataset directory (finished, partial or sharded)")
        ->required();
    stats->add_flag("--no-timing", statsNoTiming,
                    "Leave out the timing.* metrics (machine-dependent), for reproducible files");
    std::string statsReference;
    stats->add_option("--reference", statsReference,
                      "Reference distributions of measured trees (e.g. "
                      "species/reference/treeqsm-broadleaf.json): KS distance of every species' "
                      "architecture to them -> DIR/stats/reference.{csv,json}");

    std::string gatesDir;
    auto* gates = app.add_subcommand(
        "gates", "The realism gates of every species of a built dataset, as a Markdown table");
    gates->add_option("DIR", gatesDir, "Dataset directory")->required();

    std::string speciesDir;
    auto* species = app.add_subcommand("species", "The species library");
    species->require_subcommand(1);
    auto* speciesList = species->add_subcommand(
        "list",
        "List every species file under DIR (name, method, description, path), each validated; "
        "exit 2 if any fails to load");
    speciesList->add_option(
        "DIR", speciesDir,
        "Directory searched recursively for *.toml (default: the species/ directory above the "
        "executable or the current directory)");

    std::string reportDir;
    auto* report = app.add_subcommand(
        "report", "Self-contained HTML report (plots, tables, contact sheets) -> DIR/report/");
    report->add_option("DIR", reportDir, "Dataset directory")->required();

    MergeOptions mergeOptions;
    auto* merge = app.add_subcommand(
        "merge", "Merge the --out directories of a sharded build into OUT, as one unsharded build");
    merge->add_option("OUT", mergeOptions.out, "Output directory (new, or empty)")->required();
    merge
        ->add_option("SHARD_DIRS", mergeOptions.shards,
                     "Directories holding dataset.shard-I-of-N.json and its manifest and trees")
        ->required();
    merge->add_flag("--move", mergeOptions.move,
                    "Move the instance directories out of the shards instead of copying them");

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        return 2;
    }
    // The subcommand, as error messages name it.
    std::string command;
    for (const CLI::App* c : app.get_subcommands()) command = c->get_name();
    if (*speciesList) command = "species list";
    try {
        if (*build) return runBuild(spec, out, threads, shard);
        if (*grow) return runGrow(speciesPath, seed, growOut, growThreads);
        if (*validate) return runValidate(validatePath);
        if (*merge) return runMerge(mergeOptions);
        if (*volume) return runVolume(volumePath, volumeOptions, volumeOut);
        if (*speciesList) return runSpeciesList(speciesDir);
        if (*report) return runReport(reportDir);
        if (*stats) return runStats(statsDir, statsNoTiming, statsReference);
        if (*gates) {
            std::fputs(gatesMarkdown(evaluateGates(fs::path(gatesDir))).c_str(), stdout);
            return 0;
        }
    } catch (const SpecError& e) {  // file:line:col: key: what was expected
        std::fprintf(stderr, "%s\n", e.what());
        return 2;
    } catch (const InputError& e) {  // other bad input: a directory, a command-line value
        std::fprintf(stderr, "sylva: %s: %s\n", command.c_str(), e.what());
        return 2;
    } catch (const std::exception& e) {  // a runtime failure or a broken invariant
        std::fprintf(stderr, "sylva: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
