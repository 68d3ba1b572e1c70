// Small helpers shared by the tests: hand-built skeletons, whole-file reads and scratch
// directories.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "species/model/tree.h"

namespace sylva::test {

// Appends a skeleton node and returns its index.
inline int32_t addNode(Tree& t, int32_t parent, Vec3 p, double radius = 0.01, int32_t order = 0,
                       uint8_t part = kShootPart) {
    SkeletonNode n;
    n.position = p;
    n.radius = radius;
    n.parent = parent;
    n.order = order;
    n.part = part;
    t.nodes.push_back(n);
    return static_cast<int32_t>(t.nodes.size() - 1);
}

// Every species file shipped: the library (species/presets/) and the papers' reproductions
// (species/papers/<paper>/), sorted by file name.
inline std::vector<std::filesystem::path> shippedSpeciesFiles() {
    std::vector<std::filesystem::path> files;
    const std::filesystem::path species = std::filesystem::path(SYLVA_SOURCE_DIR) / "species";
    for (const char* dir : {"presets", "papers"}) {
        for (const auto& e : std::filesystem::recursive_directory_iterator(species / dir)) {
            if (e.is_regular_file() && e.path().extension() == ".toml") files.push_back(e.path());
        }
    }
    std::sort(files.begin(), files.end(),
              [](const auto& a, const auto& b) { return a.filename() < b.filename(); });
    return files;
}

inline std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// `name` with every character but letters and digits made '_': a GoogleTest parameter's name
// (e.g. a fixture file's stem) or a directory name.
inline std::string identifier(std::string name) {
    for (char& c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    }
    return name;
}

// What a bad-spec fixture says its error must be: its `# expect: <text>` comments (any number)
// and its `# line: <n>` (0 when absent).
struct FixtureComments {
    std::vector<std::string> expect;
    int line = 0;
};
inline FixtureComments fixtureComments(const std::filesystem::path& file) {
    FixtureComments f;
    std::ifstream in(file);
    for (std::string l; std::getline(in, l);) {
        if (l.rfind("# expect: ", 0) == 0) f.expect.push_back(l.substr(10));
        if (l.rfind("# line: ", 0) == 0) f.line = std::stoi(l.substr(8));
    }
    return f;
}

// A fresh directory under the system temp directory, named after the process and the running
// test, removed with everything in it when it goes out of scope.
class TempDir {
  public:
    TempDir() {
        static std::atomic<int> counter{0};
        std::string name = "sylva";
        if (const auto* info = ::testing::UnitTest::GetInstance()->current_test_info()) {
            name += std::string("_") + info->test_suite_name() + "_" + info->name();
        }
        dir_ =
            std::filesystem::temp_directory_path() /
            (identifier(name) + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(dir_, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    const std::filesystem::path& path() const { return dir_; }
    std::filesystem::path operator/(const std::string& s) const { return dir_ / s; }

  private:
    std::filesystem::path dir_;
};

}  // namespace sylva::test
