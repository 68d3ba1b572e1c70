// What the fuzz targets do with their bytes, shared with the regression test of their
// crashers (fuzz_fixtures_test.cpp), so a fixture is read exactly as the fuzzer read it.
//
// The contract under test: whatever the bytes, sylva's readers either accept them or throw
// sylva's own error with a one-line message — never a crash, a sanitizer report, another
// exception, a hang or an unbounded allocation.
//
// A spec input is written to <sandbox>/in/spec.toml, where the sandbox also links the
// repository's species/, datasets/, tests/ and bench/ folders, so a fuzzed dataset can list
// the shipped species ("../species/presets/oak.toml") and a species its sketches
// ("../species/sketches/oak-mask.png"); scripts/fuzz rewrites the corpus's relative paths to
// that form. The input is then read as `sylva validate` reads it: TOML, then a dataset (every
// species file and sweep point validated, the instances expanded) or a species (validated,
// then instantiated once more with distributions drawn, as a build does per tree). Nothing is
// grown but what validation grows itself (a plot's LAI target is checked against one tree of
// each species grown alone, 0.1–0.5 s natively and seconds under the sanitizers, so a busy
// machine reports such inputs as slow or timed out): resource bombs that pass validation are
// the per-tree budgets' business.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>
#include <string>
#include <system_error>

#include "core/errors.h"
#include "core/params.h"
#include "pipeline/batch/dataset.h"
#include "species/spec/species.h"
#include "volumes/canopy_envelope.h"
#include "volumes/mask.h"
#include "volumes/revolution.h"

namespace sylva::fuzz {

// A scratch directory with links to the repository's spec folders; removed (the links, not
// what they point to) when it goes out of scope.
class Sandbox {
  public:
    explicit Sandbox(const std::filesystem::path& source) {
        namespace fs = std::filesystem;
        static int counter = 0;
        dir_ = fs::temp_directory_path() /
               ("sylva-fuzz-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
        fs::remove_all(dir_);
        fs::create_directories(dir_ / "in");
        for (const char* d : {"species", "datasets", "tests", "bench"}) {
            fs::create_directory_symlink(source / d, dir_ / d);
        }
    }
    ~Sandbox() {
        std::error_code ec;
        std::filesystem::remove_all(dir_, ec);  // does not follow the links
    }
    Sandbox(const Sandbox&) = delete;
    Sandbox& operator=(const Sandbox&) = delete;

    // Writes `bytes` to in/<name> and returns its path.
    std::string put(const std::string& name, const uint8_t* data, size_t size) const {
        const std::filesystem::path p = dir_ / "in" / name;
        std::ofstream out(p, std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
        out.close();
        if (!out) throw std::runtime_error("fuzz sandbox: cannot write " + p.string());
        return p.string();
    }
    const std::filesystem::path& dir() const { return dir_; }

  private:
    std::filesystem::path dir_;
};

// How a reader took an input: accepted, or rejected with sylva's error (`message`).
struct Outcome {
    bool accepted = false;
    std::string message;
};

// A rejection message must be one line (and say something).
inline bool isOneLine(const std::string& message) {
    return !message.empty() && message.find_first_of("\r\n") == std::string::npos;
}

// Instances expanded at most: a larger dataset is valid but its expansion is the lazy
// expansion's business, not the readers'.
constexpr int64_t kMaxExpandedInstances = 100000;

// The spec target: the bytes as a species or dataset file. Throws whatever the readers throw
// that is not a SpecError.
inline Outcome readSpec(const Sandbox& box, const uint8_t* data, size_t size) {
    const std::string path = box.put("spec.toml", data, size);
    Outcome o;
    try {
        const toml::table t = parseTomlFile(path);
        if (isDatasetFile(t)) {
            const DatasetSpec spec = loadDataset(path);
            int64_t total = 0;
            for (const SpeciesEntry& e : spec.species) {
                total += e.count * static_cast<int64_t>(e.points.size());
            }
            for (const PlotSpec& p : spec.plots) total += p.count;  // one job per plot instance
            if (total <= kMaxExpandedInstances) {
                const std::vector<InstanceJob> jobs = expandJobs(spec);
                if (static_cast<int64_t>(jobs.size()) != total) {
                    throw std::logic_error("expandJobs: " + std::to_string(jobs.size()) +
                                           " jobs, expected " + std::to_string(total));
                }
            }
        } else {
            const SpeciesFile s = loadSpecies(path);
            validateSpecies(s, nullptr);
            DrawContext draw;  // as a build does per tree: distributions drawn
            draw.seed = 0x5eed;
            instantiateSpecies(s, draw, nullptr);
        }
        o.accepted = true;
    } catch (const SpecError& e) {
        o.message = e.what();
    }
    return o;
}

// The image target: the bytes as every image or sketch file a spec can name — a silhouette
// mask (mask-revolution, visual-hull, space-colonization guides), a stroke image and an SVG
// stroke (revolution), a canopy layer image. Each reader throws its own error type, which the
// spec readers turn into a SpecError at the key that named the file.
inline Outcome readImage(const Sandbox& box, const uint8_t* data, size_t size) {
    const std::string png = box.put("image.png", data, size);
    const std::string svg = box.put("stroke.svg", data, size);
    Outcome o;
    int accepted = 0;
    auto note = [&](const std::string& m) { o.message += (o.message.empty() ? "" : " | ") + m; };
    try {
        readMask(png, false);
        ++accepted;
    } catch (const MaskError& e) {
        if (!isOneLine(e.what())) throw std::logic_error(std::string("MaskError: ") + e.what());
        note(e.what());
    }
    try {
        traceStrokeImage(png, 0.0, 1.0);
        ++accepted;
    } catch (const StrokeError& e) {
        if (!isOneLine(e.what())) throw std::logic_error(std::string("StrokeError: ") + e.what());
        note(e.what());
    } catch (const MaskError& e) {
        if (!isOneLine(e.what())) throw std::logic_error(std::string("MaskError: ") + e.what());
        note(e.what());
    }
    try {
        readCanopyImage(png);
        ++accepted;
    } catch (const std::runtime_error& e) {  // documented: one line naming the file
        if (!isOneLine(e.what())) throw std::logic_error(std::string("canopy: ") + e.what());
        note(e.what());
    }
    try {
        readSvgStroke(svg, 0.0, 1.0);
        ++accepted;
    } catch (const StrokeError& e) {
        if (!isOneLine(e.what())) throw std::logic_error(std::string("StrokeError: ") + e.what());
        note(e.what());
    }
    o.accepted = accepted > 0;
    return o;
}

}  // namespace sylva::fuzz
