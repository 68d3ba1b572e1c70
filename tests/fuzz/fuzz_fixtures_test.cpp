// The fuzz targets' crashers, kept as regression fixtures (tests/data/fuzz/<target>/, written
// there by scripts/fuzz): each is read exactly as the fuzzer read it (spec_input.h) and must
// give its recorded outcome — accepted, or sylva's one-line error saying what was wrong —
// where, before its fix, it crashed, tripped a sanitizer, threw another exception or hung.
// Every fixture needs a row in kExpected, so a new crasher cannot sit there untriaged.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "tests/fuzz/spec_input.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

const fs::path kFixtures = fs::path(SYLVA_SOURCE_DIR) / "tests" / "data" / "fuzz";

// Fixture (relative to tests/data/fuzz/) → what reading it must give: "" when the readers
// accept it, else a fragment of the one-line error.
const std::map<std::string, std::string> kExpected = {
    // toml++'s description quotes the bad text, here "fals" and the newline after it.
    {"spec/toml-syntax-error-quotes-a-newline",
     ":50:13: TOML syntax error: Error while parsing boolean: expected 'false', saw 'fals\\n'"},
    // An integer sweep range beyond int64: llround gave -9.2·10¹⁸, quoted at the species key.
    // Spec numbers are now bounded at 1e9, which refuses it at the range.
    {"spec/sweep-integer-range-beyond-int64",
     ":7:18: sweep[0].range.from: expected a finite number of magnitude at most 1e9"},
    // toml++ 3.3.0 reaches __builtin_unreachable classifying these characters (upstream
    // #190/#295, fixed after Debian 12's version; sanitizer_ignorelist.txt): not sylva's to fix,
    // kept to check that Debian's build still rejects them with one line.
    {"spec/toml-unreachable-in-whitespace-check",
     ":1:1: TOML syntax error: Error while parsing root table: expected keys, tables, "
     "whitespace or comments, saw"},
    {"spec/toml-unreachable-in-whitespace-check-after-key",
     ":1:6: TOML syntax error: Error while parsing key-value pair: expected '=', saw"},
    // A level set 10¹² m from the origin: OpenVDB's int voxel index overflowed (UB). Numbers
    // are now bounded at 1e9 m, which refuses it first; a level set within that bound but over
    // 2²⁰ voxels from the origin is refused at its voxel_size / level_set_voxel / stroke.
    {"spec/level-set-far-from-origin",
     ":9:12: crown.position[0]: expected a finite number of magnitude at most 1e9"},
    {"spec/level-set-far-within-bounds",
     ":10:14: crown.voxel_size: the level set would lie over 2²⁰ voxels from the origin"},
    // Revolution strokes 3·10⁹ m up: building the level set hung.
    {"spec/revolution-far-from-origin",
     ":7:11: crown.stroke: item 0: expected finite numbers of magnitude at most 1e9"},
    {"spec/revolution-far-from-origin-level-set-voxel",
     ":7:11: crown.stroke: item 0: expected finite numbers of magnitude at most 1e9"},
    // A 320×480 grey PNG cut inside its IDAT chunk: OpenImageIO 2.4's PNG reader leaked its
    // error string when libpng longjmps (lsan_suppressions.txt); image_file.cpp's structure
    // check now refuses the cut file before OpenImageIO opens it.
    {"image/png-truncated-in-idat",
     "image.png: truncated: the file ends before the PNG's end (its IEND chunk)"},
};

std::vector<fs::path> fixtures(const std::string& target) {
    std::vector<fs::path> out;
    if (!fs::is_directory(kFixtures / target)) return out;
    for (const auto& e : fs::directory_iterator(kFixtures / target)) {
        if (e.is_regular_file() && e.path().filename().string()[0] != '.') out.push_back(e.path());
    }
    std::sort(out.begin(), out.end());
    return out;
}

void checkFixtures(const std::string& target) {
    const fuzz::Sandbox box(SYLVA_SOURCE_DIR);
    for (const fs::path& f : fixtures(target)) {
        const std::string name = target + "/" + f.filename().string();
        SCOPED_TRACE(name);
        auto it = kExpected.find(name);
        ASSERT_NE(it, kExpected.end()) << "a fixture without an expected outcome: triage it";
        const std::string bytes = test::slurp(f);
        const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
        fuzz::Outcome o;
        try {
            o = target == "spec" ? fuzz::readSpec(box, data, bytes.size())
                                 : fuzz::readImage(box, data, bytes.size());
        } catch (const std::exception& e) {
            ADD_FAILURE() << "escaped the readers: " << e.what();
            continue;
        }
        if (it->second.empty()) {
            EXPECT_TRUE(o.accepted) << o.message;
        } else {
            EXPECT_FALSE(o.accepted && target == "spec");
            EXPECT_TRUE(fuzz::isOneLine(o.message)) << o.message;
            EXPECT_NE(o.message.find(it->second), std::string::npos) << o.message;
        }
    }
}

TEST(FuzzFixtures, EverySpecCrasherIsAcceptedOrOneLineSpecError) { checkFixtures("spec"); }

TEST(FuzzFixtures, EveryImageCrasherIsAcceptedOrTheReadersError) { checkFixtures("image"); }

// Every fixture has a row, and every row a fixture.
TEST(FuzzFixtures, ExpectationsNameExistingFixtures) {
    for (const auto& [name, expected] : kExpected) {
        EXPECT_TRUE(fs::is_regular_file(kFixtures / name)) << name;
    }
}

}  // namespace
}  // namespace sylva
