// The `sylva` command line: parse the arguments and dispatch to the libraries (build, grow,
// validate, volume, species list, stats, report, merge, fit). Exit codes: 0 success, 1 a runtime
// failure (some trees failed, I/O, a broken invariant), 2 bad input (InputError, core/errors.h).
#include <tbb/global_control.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <set>

#include "core/atomic_file.h"
#include "core/budget.h"
#include "core/params.h"
#include "pipeline/analysis/dataset_stats.h"
#include "pipeline/analysis/fit.h"
#include "pipeline/analysis/merge.h"
#include "pipeline/analysis/realism_gates.h"
#include "pipeline/analysis/report.h"
#include "pipeline/analysis/species_list.h"
#include "pipeline/analysis/volume_output.h"
#include "pipeline/batch/build.h"
#include "pipeline/batch/dataset.h"
#include "pipeline/batch/estimate.h"
#include "pipeline/batch/grow_one.h"
#include "pipeline/batch/output_lock.h"
#include "species/spec/species.h"

namespace fs = std::filesystem;
using namespace sylva;

namespace {

// --shard I/N (already checked by shardValidator) as index and count; {0, 1} when not given.
std::pair<int, int> parseShard(const std::string& shard) {
    int si = 0, sn = 1;
    if (!shard.empty()) {
        int used = 0;
        if (std::sscanf(shard.c_str(), "%d/%d%n", &si, &sn, &used) != 2 ||
            used != static_cast<int>(shard.size()) || sn < 1 || si < 0 || si >= sn) {
            throw InputError("--shard " + shard + ": expected I/N with 0 ≤ I < N");
        }
    }
    return {si, sn};
}

// build --estimate: grows a few instances of every species and plot into a scratch directory
// and prints what the whole build (and the shard) would take; --out is never written.
int runEstimate(const std::string& specPath, const std::string& out, bool outGiven, int threads,
                const std::string& shard, int samples, bool jsonGiven,
                const std::string& jsonPath) {
    const auto [si, sn] = parseShard(shard);
    if (outGiven && out.empty()) throw InputError("--out: expected a directory, got \"\"");
    if (jsonGiven && jsonPath.empty()) {
        throw InputError("--estimate-json: expected a file, got \"\"");
    }
    DatasetSpec spec = loadDataset(specPath);
    EstimateOptions o;
    o.samples = samples;
    o.threads = threads;
    o.shardIndex = si;
    o.shardCount = sn;
    o.out = out.empty() ? fs::path("out") / spec.name : fs::path(out);
    const EstimateResult r = estimateDataset(spec, o);
    if (jsonGiven) writeFileAtomic(jsonPath, estimateJson(r).dump(2) + "\n");
    std::fputs(estimateTable(r).c_str(), stdout);
    return 0;
}

int runBuild(const std::string& specPath, std::string out, bool outGiven, int threads,
             const std::string& shard) {
    const auto [si, sn] = parseShard(shard);
    DatasetSpec spec = loadDataset(specPath);  // validates everything before any write
    BuildOptions o;
    if (outGiven && out.empty()) throw InputError("--out: expected a directory, got \"\"");
    o.out = out.empty() ? fs::path("out") / spec.name : fs::path(out);
    o.threads = threads;
    o.shardIndex = si;
    o.shardCount = sn;
    BuildSummary s = buildDataset(spec, o);
    if (!s.stopped.empty()) {  // a full disk (or quota, file size limit, memory): one line
        std::fprintf(stderr, "%ssylva: build: %s\n", isatty(2) ? "\r\033[K" : "",
                     s.stopped.c_str());
        return 1;
    }
    std::fprintf(stderr,
                 "sylva: %s: %lld built, %lld already there, %lld failed of %lld in %.2f s -> %s\n",
                 spec.name.c_str(), static_cast<long long>(s.built),
                 static_cast<long long>(s.skipped), static_cast<long long>(s.failed),
                 static_cast<long long>(s.total), s.wallSeconds, o.out.string().c_str());
    if (s.failed) {
        // Which ones (their reasons are on the lines above): left out of the manifest, a rerun
        // tries them again.
        std::string ids;
        for (const std::string& id : s.failedIds) ids += (ids.empty() ? "" : ", ") + id;
        const int64_t more = s.failed - static_cast<int64_t>(s.failedIds.size());
        if (more > 0) ids += " and " + std::to_string(more) + " more";
        std::fprintf(stderr, "sylva: %s: failed: %s\n", spec.name.c_str(), ids.c_str());
    }
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
        int64_t plotInstances = 0;
        for (const PlotSpec& plot : spec.plots) plotInstances += plot.count;
        const std::string plots = spec.plots.empty()
                                      ? ""
                                      : ", " + std::to_string(spec.plots.size()) + " plots (" +
                                            std::to_string(plotInstances) + " plot instances)";
        std::printf("%s: ok — dataset \"%s\", %zu species, %lld instances%s\n", path.c_str(),
                    spec.name.c_str(), spec.species.size(), static_cast<long long>(instances),
                    plots.c_str());
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
    checkOutputDir(dir, "--out");  // one clear line before anything is written
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

// Calibrates a species' [fit] parameters against its reference (pipeline/analysis/fit.h).
// Exit 2 on a bad [fit] table, reference or option, before anything is written.
int runFitCommand(const std::string& speciesPath, const FitOptions& o, int threads) {
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0) {
        limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                      threads);
    }
    const FitResult r = runFit(speciesPath, o);
    std::printf(
        "%s: objective %.4f -> %.4f in %lld evaluations (%lld from the log), %.1f s -> %s\n",
        speciesPath.c_str(), r.before.objective, r.after.objective,
        static_cast<long long>(r.evaluations), static_cast<long long>(r.reused), r.seconds,
        r.out.string().c_str());
    return 0;
}

// --- command-line values ----------------------------------------------------------------------
// Every value is checked as text before CLI11 converts it, so a bad one is one line naming the
// option and what it expects (CLI11's own messages print a 300-digit range bound, "Could not
// convert", or wrap a negative seed around to 2⁶⁴ − 1), exit 2, and nothing is written.

// The most worker threads --threads takes: more than any machine sylva runs on has cores, and
// few enough that TBB's per-thread state stays small (10⁸ ended in std::bad_alloc).
constexpr uint64_t kMaxThreads = 1024;

// Decimal digits only (no sign, no spaces), at most `max`.
std::optional<uint64_t> parseUnsigned(const std::string& s, uint64_t max) {
    if (s.empty() || s.size() > 20) return std::nullopt;
    uint64_t v = 0;
    for (char c : s) {
        if (c < '0' || c > '9') return std::nullopt;
        const uint64_t digit = static_cast<uint64_t>(c - '0');
        if (v > (max - digit) / 10) return std::nullopt;
        v = v * 10 + digit;
    }
    return v;
}

CLI::Validator unsignedValidator(uint64_t max, const std::string& note) {
    const std::string expected = "an integer in [0, " + std::to_string(max) + "]" + note;
    return CLI::Validator(
        [max, expected](std::string& s) -> std::string {
            if (parseUnsigned(s, max)) return "";
            return "expected " + expected + ", got \"" + s + "\"";
        },
        "INT in [0, " + std::to_string(max) + "]");
}

// An integer in [min, max] (a count that must be at least `min`).
CLI::Validator countValidator(uint64_t min, uint64_t max) {
    const std::string range = "[" + std::to_string(min) + ", " + std::to_string(max) + "]";
    return CLI::Validator(
        [min, max, range](std::string& s) -> std::string {
            const std::optional<uint64_t> v = parseUnsigned(s, max);
            if (v && *v >= min) return "";
            return "expected an integer in " + range + ", got \"" + s + "\"";
        },
        "INT in " + range);
}

// A finite number > 0 (metres), at most 10⁹ like any number in a spec.
CLI::Validator positiveMetres() {
    return CLI::Validator(
        [](std::string& s) -> std::string {
            char* end = nullptr;
            errno = 0;
            const double v = s.empty() ? 0.0 : std::strtod(s.c_str(), &end);
            if (!s.empty() && end == s.c_str() + s.size() && errno == 0 && std::isfinite(v) &&
                v > 0 && v <= kMaxSpecMagnitude) {
                return "";
            }
            return "expected a number of metres > 0 (at most 1e9), got \"" + s + "\"";
        },
        "METRES > 0");
}

// I/N: decimal shard index and count, 0 ≤ I < N ≤ 2³¹ − 1.
CLI::Validator shardValidator() {
    return CLI::Validator(
        [](std::string& s) -> std::string {
            const size_t slash = s.find('/');
            const uint64_t maxCount = 2147483647;
            if (slash != std::string::npos) {
                const auto i = parseUnsigned(s.substr(0, slash), maxCount);
                const auto n = parseUnsigned(s.substr(slash + 1), maxCount);
                if (i && n && *i < *n) return "";
            }
            return "expected I/N, shard I of N with 0 ≤ I < N (e.g. 0/4), got \"" + s + "\"";
        },
        "I/N");
}

// A spec or directory argument: not an empty string.
CLI::Validator nonEmptyPath() {
    return CLI::Validator(
        [](std::string& s) -> std::string {
            return s.empty() ? "expected a path, got an empty string" : "";
        },
        "");
}

// The command whose arguments argv holds ("build", "species list"; "" before one), as error
// messages name it.
std::string commandOf(const CLI::App& app, int argc, char** argv) {
    if (argc < 2) return "";
    const std::string first = argv[1];
    for (const CLI::App* sub : app.get_subcommands({})) {
        if (sub->get_name() != first) continue;
        if (first == "species" && argc > 2 && std::string(argv[2]) == "list") return "species list";
        return first;
    }
    return "";
}

// The options `command` takes, as written on the command line ("--threads").
std::set<std::string> optionNames(const CLI::App& app, const std::string& command) {
    const CLI::App* sub = &app;
    std::string rest = command;
    while (!rest.empty()) {
        const size_t space = rest.find(' ');
        const std::string name = rest.substr(0, space);
        rest = space == std::string::npos ? "" : rest.substr(space + 1);
        sub = sub->get_subcommand(name);
    }
    std::set<std::string> names;
    for (const CLI::Option* o : sub->get_options()) {
        for (const std::string& l : o->get_lnames()) names.insert("--" + l);
        for (const std::string& n : o->get_snames()) names.insert("-" + n);
    }
    return names;
}

// One line for a command-line error CLI11 reports: the option and what it expects.
std::string parseErrorLine(const CLI::App& app, const CLI::ParseError& e, int argc, char** argv) {
    const std::string command = commandOf(app, argc, argv);
    const std::string who = command.empty() ? "sylva" : "sylva " + command;
    std::string message = e.what();
    if (command.empty()) {
        std::string commands;
        for (const CLI::App* sub : app.get_subcommands({})) {
            commands += (commands.empty() ? "" : ", ") + sub->get_name();
        }
        if (argc < 2) return who + ": expected a command (" + commands + "); see sylva --help";
        const std::string first = argv[1];
        if (!first.empty() && first[0] == '-' && first != "--help" && first != "-h") {
            return who + ": unknown option " + first + "; expected a command first (" + commands +
                   ")";
        }
        if (first.empty() || first[0] != '-') {
            std::set<std::string> names;
            for (const CLI::App* sub : app.get_subcommands({})) names.insert(sub->get_name());
            std::string hint;
            if (auto w = closestWord(first, names)) hint = "; did you mean \"" + *w + "\"?";
            return who + ": unknown command \"" + first + "\"" + hint + " (commands: " + commands +
                   ")";
        }
    }
    if (dynamic_cast<const CLI::ExtrasError*>(&e)) {
        // The first argument that is no option of the command, with the closest one.
        const std::set<std::string> names = optionNames(app, command);
        for (int i = 1 + (command.find(' ') != std::string::npos ? 2 : 1); i < argc; ++i) {
            std::string a = argv[i];
            if (a.size() < 2 || a[0] != '-') continue;
            a = a.substr(0, a.find('='));
            if (names.count(a)) continue;
            std::string hint;
            if (auto w = closestWord(a, names)) hint = "; did you mean " + *w + "?";
            return who + ": unknown option " + a + hint + " (see " + who + " --help)";
        }
        message = message.substr(message.find(':') + 1);
        while (!message.empty() && message[0] == ' ') message.erase(0, 1);
        return who + ": unexpected argument " + message + " (see " + who + " --help)";
    }
    if (dynamic_cast<const CLI::RequiredError*>(&e) && command == "species") {
        if (argc > 2) return who + ": unknown subcommand \"" + argv[2] + "\"; expected \"list\"";
        return who + ": expected a subcommand (list)";
    }
    std::replace(message.begin(), message.end(), '\n', ' ');
    if (dynamic_cast<const CLI::ConversionError*>(&e) &&
        message.rfind("Could not convert: ", 0) == 0) {
        // "Could not convert: --no-timing = x": a flag given a value.
        const std::string rest = message.substr(19);
        const size_t eq = rest.find(" = ");
        if (eq != std::string::npos) {
            return who + ": " + rest.substr(0, eq) + ": cannot take the value \"" +
                   rest.substr(eq + 3) + "\"";
        }
    }
    if (dynamic_cast<const CLI::ArgumentMismatch*>(&e)) {
        // "--threads: 1 required INT missing", "--threads: At Most 1 required but received 2"
        const std::string option = message.substr(0, message.find(':'));
        if (message.find("missing") != std::string::npos) {
            return who + ": " + option + ": expected a value (see " + who + " --help)";
        }
        if (message.find("At Most") != std::string::npos) {
            return who + ": " + option + ": given more than once";
        }
    }
    return who + ": " + message;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"sylva — batch builder of labelled procedural-tree datasets"};
    app.require_subcommand(1);

    std::string spec, out, shard;
    int threads = 0;
    auto* build = app.add_subcommand("build", "Build a dataset (every instance of every species)");
    build->add_option("SPEC", spec, "Dataset spec (.toml)")->required()->check(nonEmptyPath());
    auto* buildOut =
        build->add_option("--out", out, "Output directory (default: out/<dataset name>)");
    build->add_option("--threads", threads, "Worker threads, at most 1024 (default 0: all cores)")
        ->check(unsignedValidator(kMaxThreads, " (0: all cores)"));
    build
        ->add_option("--shard", shard,
                     "Build shard I of N (I/N, 0-based): a contiguous block of instances whose "
                     "manifests concatenate, in shard order, to the whole dataset's")
        ->check(shardValidator());
    bool estimate = false;
    uint64_t estimateSamples = 2;
    std::string estimateJsonPath;
    build->add_flag("--estimate", estimate,
                    "Build nothing: grow the first instances of each species and plot into a "
                    "scratch directory (removed) and print the time, bytes and files the build "
                    "would take");
    auto* estimateSamplesOption =
        build
            ->add_option("--estimate-samples", estimateSamples,
                         "With --estimate: instances measured per species and plot (default 2)")
            ->check(countValidator(1, 1000));
    auto* estimateJsonOption = build->add_option(
        "--estimate-json", estimateJsonPath, "With --estimate: the same numbers as JSON -> FILE");

    std::string speciesPath, growOut;
    uint64_t seed = 1;
    int growThreads = 0;
    auto* grow = app.add_subcommand("grow", "Grow one tree for a quick look (with preview.png)");
    grow->add_option("SPECIES", speciesPath, "Species file (.toml)")
        ->required()
        ->check(nonEmptyPath());
    grow->add_option("--seed", seed, "Instance seed (default 1)")
        ->check(unsignedValidator(UINT64_MAX, ""));
    grow->add_option("--out", growOut, "Output directory (default: out/grow/<species>)");
    grow->add_option("--threads", growThreads,
                     "Worker threads, at most 1024 (default 0: all cores)")
        ->check(unsignedValidator(kMaxThreads, " (0: all cores)"));

    std::string validatePath;
    auto* validate =
        app.add_subcommand("validate", "Check a species or dataset file without building");
    validate->add_option("SPEC", validatePath, "Species or dataset spec (.toml)")
        ->required()
        ->check(nonEmptyPath());

    std::string volumePath, volumeOut;
    VolumeOutputOptions volumeOptions;
    auto* volume = app.add_subcommand(
        "volume", "Write a species' crown volumes (.vdb, .ply) and preview.png, to check them");
    volume->add_option("SPECIES", volumePath, "Species file (.toml)")
        ->required()
        ->check(nonEmptyPath());
    volume->add_option("--out", volumeOut, "Output directory (default: out/volume/<species>)");
    volume
        ->add_option("--seed", volumeOptions.seed,
                     "Instance seed, for volumes drawn per tree (default 1)")
        ->check(unsignedValidator(UINT64_MAX, ""));
    volume
        ->add_option("--voxel", volumeOptions.voxel,
                     "Voxel size, metres (default: each volume's largest extent / 128)")
        ->check(positiveMetres());

    std::string statsDir;
    bool statsNoTiming = false;
    auto* stats = app.add_subcommand(
        "stats",
        "Per-species metric summaries, species comparison (KS, Wasserstein) and sweep table of a "
        "dataset -> DIR/stats/");
    stats->add_option("DIR", statsDir, "Dataset directory (finished, partial or sharded)")
        ->required()
        ->check(nonEmptyPath());
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
    gates->add_option("DIR", gatesDir, "Dataset directory")->required()->check(nonEmptyPath());

    std::string speciesDir;
    auto* species = app.add_subcommand("species", "The species library");
    species->require_subcommand(1);
    auto* speciesList = species->add_subcommand(
        "list",
        "List every species file under DIR (name, method, description, path), each validated; "
        "exit 2 if any fails to load");
    speciesList
        ->add_option(
            "DIR", speciesDir,
            "Directory searched recursively for *.toml (default: the species/ directory above "
            "the executable or the current directory)")
        ->check(nonEmptyPath());

    std::string reportDir;
    auto* report = app.add_subcommand(
        "report", "Self-contained HTML report (plots, tables, contact sheets) -> DIR/report/");
    report->add_option("DIR", reportDir, "Dataset directory")->required()->check(nonEmptyPath());

    std::string fitPath, fitOut, fitReference;
    uint64_t fitSeed = 0, fitEvaluations = 0;
    int fitThreads = 0;
    bool fitFresh = false;
    auto* fit = app.add_subcommand(
        "fit",
        "Fit a species' [fit] parameters to reference distributions of measured trees (CMA-ES) "
        "-> the fitted species file, <out>.fit.jsonl, .fit.md, .fit.svg");
    fit->add_option("SPECIES", fitPath, "Species file (.toml) with a [fit] table")
        ->required()
        ->check(nonEmptyPath());
    auto* fitOutOption =
        fit->add_option("--out", fitOut, "Fitted species file (default: out/fit/<species>.toml)");
    auto* fitSeedOption = fit->add_option("--seed", fitSeed, "Fit seed (default: [fit] seed)")
                              ->check(unsignedValidator(INT64_MAX, ""));
    auto* fitEvaluationsOption =
        fit->add_option("--evaluations", fitEvaluations,
                        "Budget of objective evaluations (default: [fit] evaluations)")
            ->check(unsignedValidator(100000000, ""));
    auto* fitReferenceOption =
        fit->add_option("--reference", fitReference, "Reference file (default: [fit] reference)");
    fitReferenceOption->check(nonEmptyPath());
    fit->add_option("--threads", fitThreads,
                    "Worker threads, at most 1024 (default 0: all cores); the result is the same")
        ->check(unsignedValidator(kMaxThreads, " (0: all cores)"));
    fit->add_flag("--fresh", fitFresh,
                  "Ignore an existing <out>.fit.jsonl (default: reuse its evaluations)");

    MergeOptions mergeOptions;
    auto* merge = app.add_subcommand(
        "merge", "Merge the --out directories of a sharded build into OUT, as one unsharded build");
    merge->add_option("OUT", mergeOptions.out, "Output directory (new, or empty)")->required();
    merge
        ->add_option("SHARD_DIRS", mergeOptions.shards,
                     "Directories holding dataset.shard-I-of-N.json and its manifest and trees")
        ->required()
        ->check(nonEmptyPath());
    merge->add_flag("--move", mergeOptions.move,
                    "Move the instance directories out of the shards instead of copying them");

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {  // one line: the option and what it expects
        std::fprintf(stderr, "%s\n", parseErrorLine(app, e, argc, argv).c_str());
        return 2;
    }
    // Past the file size limit (ulimit -f) a write fails with EFBIG, which a build stops on
    // like a full disk, instead of the default SIGXFSZ killing the process mid-write.
    std::signal(SIGXFSZ, SIG_IGN);
    // The subcommand, as error messages name it.
    std::string command;
    for (const CLI::App* c : app.get_subcommands()) command = c->get_name();
    if (*speciesList) command = "species list";
    try {
        if (*build && !estimate) {
            for (const CLI::Option* e : {estimateSamplesOption, estimateJsonOption}) {
                if (e->count() > 0) throw InputError(e->get_name() + ": needs --estimate");
            }
            return runBuild(spec, out, buildOut->count() > 0, threads, shard);
        }
        if (*build) {
            return runEstimate(spec, out, buildOut->count() > 0, threads, shard,
                               static_cast<int>(estimateSamples), estimateJsonOption->count() > 0,
                               estimateJsonPath);
        }
        if (*grow) return runGrow(speciesPath, seed, growOut, growThreads);
        if (*validate) return runValidate(validatePath);
        if (*merge) return runMerge(mergeOptions);
        if (*volume) return runVolume(volumePath, volumeOptions, volumeOut);
        if (*speciesList) return runSpeciesList(speciesDir);
        if (*report) return runReport(reportDir);
        if (*stats) return runStats(statsDir, statsNoTiming, statsReference);
        if (*fit) {
            if (fitOutOption->count() > 0 && fitOut.empty()) {
                throw InputError("--out: expected a file, got \"\"");
            }
            FitOptions o;
            o.out = fitOut;
            if (fitSeedOption->count() > 0) o.seed = fitSeed;
            if (fitEvaluationsOption->count() > 0) {
                o.evaluations = static_cast<int64_t>(fitEvaluations);
            }
            if (fitReferenceOption->count() > 0) o.reference = fs::path(fitReference);
            o.resume = !fitFresh;
            return runFitCommand(fitPath, o, fitThreads);
        }
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
    } catch (const BudgetExceeded& e) {  // a tree over a budget of its spec while it grew
        std::fprintf(stderr, "sylva: %s: %s\n", command.c_str(), e.what());
        return 1;
    } catch (const std::exception& e) {  // a runtime failure or a broken invariant
        std::fprintf(stderr, "sylva: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
