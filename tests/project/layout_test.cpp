// The source layout: every folder of code has a README.md whose "May include:" line names the
// folders its files may include, and every #include "…" of sylva's own headers obeys it. The
// layers themselves (core → volumes → species → pipeline) are enforced by the build's include
// roots; this checks the direction between the folders inside a layer too.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "tests/test_support.h"

namespace fs = std::filesystem;

namespace {

const std::set<std::string> kLayers = {"core", "volumes", "species", "pipeline"};

struct LayoutReport {
    int filesChecked = 0;
    int includesChecked = 0;
    std::vector<std::string> problems;
};

// The folders named in backticks on the README's "May include:" line; nullopt without one.
std::optional<std::vector<std::string>> mayInclude(const fs::path& readme) {
    std::ifstream in(readme);
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind("May include:", 0) != 0) continue;
        std::vector<std::string> out;
        static const std::regex kTick("`([^`]+)`");
        for (std::sregex_iterator it(line.begin(), line.end(), kTick), end; it != end; ++it) {
            out.push_back((*it)[1]);
        }
        return out;
    }
    return std::nullopt;
}

bool isSource(const fs::path& p) { return p.extension() == ".h" || p.extension() == ".cpp"; }

// Checks every folder under the layers of `root` that holds source files.
LayoutReport checkLayout(const fs::path& root) {
    LayoutReport r;
    std::map<std::string, std::vector<fs::path>> folders;  // folder (relative) -> its sources
    for (const std::string& layer : kLayers) {
        if (!fs::is_directory(root / layer)) {
            r.problems.push_back(layer + "/: missing");
            continue;
        }
        for (const auto& e : fs::recursive_directory_iterator(root / layer)) {
            if (e.is_regular_file() && isSource(e.path())) {
                folders[fs::relative(e.path().parent_path(), root).generic_string()].push_back(
                    e.path());
            }
        }
    }
    static const std::regex kInclude(R"re(^\s*#\s*include\s*"([^"]+)")re");
    for (const auto& [folder, files] : folders) {
        const auto allowed = mayInclude(root / folder / "README.md");
        if (!allowed) {
            r.problems.push_back(folder +
                                 "/README.md: missing, or without a \"May include:\" line");
            continue;
        }
        for (const std::string& a : *allowed) {
            if (!fs::is_directory(root / a)) {
                r.problems.push_back(folder + "/README.md: names `" + a + "`, not a folder");
            }
        }
        auto permitted = [&](const std::string& target) {
            if (target == folder) return true;
            for (const std::string& a : *allowed) {
                if (target == a || target.rfind(a + "/", 0) == 0) return true;
            }
            return false;
        };
        for (const fs::path& file : files) {
            ++r.filesChecked;
            std::ifstream in(file);
            std::string line;
            int lineNo = 0;
            while (std::getline(in, line)) {
                ++lineNo;
                std::smatch m;
                if (!std::regex_search(line, m, kInclude)) continue;
                const std::string inc = m[1];
                const std::string top = inc.substr(0, inc.find('/'));
                if (!kLayers.count(top)) continue;  // a library's header
                ++r.includesChecked;
                const std::string target = fs::path(inc).parent_path().generic_string();
                if (!permitted(target)) {
                    r.problems.push_back(fs::relative(file, root).generic_string() + ":" +
                                         std::to_string(lineNo) + ": includes \"" + inc +
                                         "\", but " + folder + "/README.md does not allow `" +
                                         target + "`");
                }
            }
        }
    }
    return r;
}

void write(const fs::path& p, const std::string& text) {
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
}

}  // namespace

TEST(Layout, EveryIncludeFollowsItsFoldersReadme) {
    const LayoutReport r = checkLayout(SYLVA_SOURCE_DIR);
    for (const std::string& p : r.problems) ADD_FAILURE() << p;
    // Not vacuous: the whole tree was read.
    EXPECT_GT(r.filesChecked, 100);
    EXPECT_GT(r.includesChecked, 200);
}

TEST(Layout, CheckerFindsAnUpwardIncludeAndAMissingReadme) {
    sylva::test::TempDir dir;
    const fs::path root = dir.path();
    for (const std::string& layer : kLayers) fs::create_directories(root / layer);
    write(root / "core/README.md", "# core\n\nMay include: nothing else of sylva.\n");
    write(root / "core/a.h", "#pragma once\n#include <vector>\n");
    write(root / "species/model/README.md", "May include: `core`.\n");
    write(root / "species/model/tree.h", "#include \"core/a.h\"\n");
    write(root / "species/spec/README.md", "May include: `core`, `species/model`.\n");
    write(root / "species/spec/s.cpp",
          "#include \"species/spec/s.h\"\n#include \"species/model/tree.h\"\n");
    // The violations: model including spec (upward), and a folder without a README.
    write(root / "species/model/tree.cpp", "#include \"species/spec/s.h\"\n");
    write(root / "pipeline/batch/b.cpp", "#include \"species/model/tree.h\"\n");

    const LayoutReport r = checkLayout(root);
    ASSERT_EQ(r.problems.size(), 2u);
    EXPECT_NE(r.problems[0].find("pipeline/batch/README.md: missing"), std::string::npos)
        << r.problems[0];
    EXPECT_NE(r.problems[1].find("species/model/tree.cpp:1: includes \"species/spec/s.h\""),
              std::string::npos)
        << r.problems[1];
    EXPECT_EQ(r.filesChecked, 4);  // pipeline/batch/b.cpp is not checked without its README
}
