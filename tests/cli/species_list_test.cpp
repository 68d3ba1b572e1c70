// `sylva species list`: every species file under a directory, one line each (name, method,
// description, path), sorted by name; dataset files skipped; a file that fails to load listed
// with its error and exit code 2; by default the repository's species/ directory. Runs the real
// binary (SYLVA_EXE) on species files written into a temp directory.
#include "pipeline/analysis/species_list.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli/cli_support.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::test::slurp;

const fs::path kSource = SYLVA_SOURCE_DIR;

// A tiny iterated-graph species (as tests/data/tiny.toml) with the given name, description
// and an optional extra top-level line (to break it).
std::string species(const std::string& name, const std::string& description,
                    const std::string& extra = "") {
    return "name = \"" + name + "\"\nmethod = \"iterated-graph\"\ndescription = \"" + description +
           "\"\n" + extra +
           "[crown]\ntype = \"sphere\"\nradius = 2.0\nposition = [0, 3, 0]\n"
           "[[levels]]\nnodes = 60\nendpoints = 4\n";
}

class SpeciesListTest : public ::testing::Test {
  protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("sylva_species_list_" + std::to_string(::getpid()) + "_" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_ / "lib" / "nested");
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    void write(const fs::path& rel, const std::string& text) {
        std::ofstream(dir_ / rel, std::ios::binary) << text;
    }
    struct Result {
        int code = -1;
        std::vector<std::string> lines;  // stdout
        std::string err;
    };
    // `sylva species list [args]` in working directory `cwd`.
    Result list(const std::string& args, const fs::path& cwd) {
        std::vector<std::string> argv = {"species", "list"};
        if (!args.empty()) argv.push_back(args);
        sylva::test::CliOptions o;
        o.logDir = dir_;
        const sylva::test::CliResult run = sylva::test::runSylva(argv, cwd, o);
        Result r;
        r.code = run.code;
        std::istringstream in(run.out);
        for (std::string line; std::getline(in, line);) r.lines.push_back(line);
        r.err = run.err;
        return r;
    }
    fs::path dir_;
};

TEST_F(SpeciesListTest, OneLinePerSpeciesSortedByNameDatasetsSkipped) {
    write("lib/nested/zeta.toml", species("zeta", "Last by name, first found"));
    write("lib/alpha.toml", species("alpha", "First by name"));
    write("lib/notes.txt", "not a species");
    write("lib/set.toml",
          "name = \"set\"\nseed = 1\n[[species]]\nfile = \"alpha.toml\"\ncount = 1\n");
    Result r = list("lib", dir_);
    ASSERT_EQ(r.code, 0) << r.err;
    ASSERT_EQ(r.lines.size(), 2u) << r.err;
    // name, method, description, path; padded so the columns line up.
    std::regex row(R"(^(\S+) +(\S+) +(.+?) +(\S+)$)");
    std::smatch a, z;
    ASSERT_TRUE(std::regex_match(r.lines[0], a, row)) << r.lines[0];
    ASSERT_TRUE(std::regex_match(r.lines[1], z, row)) << r.lines[1];
    EXPECT_EQ(a[1], "alpha");
    EXPECT_EQ(a[2], "iterated-graph");
    EXPECT_EQ(a[3], "First by name");
    EXPECT_EQ(a[4], "lib/alpha.toml");
    EXPECT_EQ(z[1], "zeta");
    EXPECT_EQ(z[3], "Last by name, first found");
    EXPECT_EQ(z[4], "lib/nested/zeta.toml");
    EXPECT_EQ(a.position(2), z.position(2));
    EXPECT_EQ(a.position(3), z.position(3));
    EXPECT_EQ(a.position(4), z.position(4));
}

TEST_F(SpeciesListTest, FailedFileIsListedWithItsErrorAndExitIs2) {
    write("lib/good.toml", species("good", "Loads"));
    write("lib/broken.toml", species("broken", "Misspelt key", "brnch = 3\n"));
    Result r = list("lib", dir_);
    EXPECT_EQ(r.code, 2);
    ASSERT_EQ(r.lines.size(), 2u) << r.err;
    EXPECT_EQ(r.lines[0].rfind("broken ", 0), 0u) << r.lines[0];
    // The validation error, one line with file:line:col and the key, then the path.
    EXPECT_NE(r.lines[0].find(" -  "), std::string::npos) << r.lines[0];
    EXPECT_NE(r.lines[0].find("error: lib/broken.toml:4:9: brnch: unknown key"), std::string::npos)
        << r.lines[0];
    EXPECT_EQ(r.lines[1].rfind("good ", 0), 0u) << r.lines[1];
    EXPECT_NE(r.err.find("1 of 2 species files failed"), std::string::npos) << r.err;
}

TEST_F(SpeciesListTest, NotADirectoryIsBadInput) {
    Result r = list("no_such_dir", dir_);
    EXPECT_EQ(r.code, 2);
    EXPECT_TRUE(r.lines.empty());
    EXPECT_NE(r.err.find("no_such_dir: not a directory"), std::string::npos) << r.err;
    EXPECT_THROW(sylva::listSpecies(dir_ / "no_such_dir"), std::runtime_error);
}

// Without DIR, from a directory outside the repository: the species/ above build/sylva. Every
// preset of the library loads and is listed, one line per file.
TEST_F(SpeciesListTest, DefaultIsTheRepositorySpeciesDirectory) {
    size_t files = 0;
    for (const auto& e : fs::recursive_directory_iterator(kSource / "species")) {
        files += e.path().extension() == ".toml";
    }
    ASSERT_GE(files, 48u);  // the library and the papers' reproductions, at least
    Result r = list("", dir_);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.lines.size(), files);
    bool sawXmA = false;
    const std::string xmA =
        (fs::weakly_canonical(kSource) / "species/papers/xu-mould-2012/xm-a.toml").string();
    for (const std::string& line : r.lines) {
        if (line.rfind("xm-a ", 0) == 0) {
            sawXmA = true;
            EXPECT_NE(line.find(" iterated-graph "), std::string::npos) << line;
            EXPECT_EQ(line.substr(line.size() - xmA.size()), xmA) << line;
        }
    }
    EXPECT_TRUE(sawXmA);
    // The library (species/presets/) first, then the papers' reproductions.
    size_t lastLibrary = 0, firstPaper = r.lines.size();
    for (size_t i = 0; i < r.lines.size(); ++i) {
        if (r.lines[i].find("/species/papers/") != std::string::npos) {
            firstPaper = std::min(firstPaper, i);
        } else {
            lastLibrary = i;
        }
    }
    EXPECT_LT(lastLibrary, firstPaper);
    EXPECT_LT(firstPaper, r.lines.size());
}

}  // namespace
