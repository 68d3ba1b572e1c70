// A species file's own keys: the habit (recorded with every instance; every species of the
// library states one).
#include <gtest/gtest.h>

#include <fstream>

#include "species/spec/species.h"
#include "tests/test_support.h"

namespace sylva {
namespace {

TEST(SpeciesFile, HabitIsReadAndCheckedAgainstTheKnownHabits) {
    test::TempDir t;
    auto write = [&](const std::string& name, const std::string& habitLine) {
        const auto p = t.path() / (name + ".toml");
        std::ofstream(p) << "name = \"" << name << "\"\nmethod = \"grammar\"\n" << habitLine;
        return p.string();
    };
    EXPECT_EQ(loadSpecies(write("a", "habit = \"conifer\"\n")).habit, "conifer");
    EXPECT_EQ(loadSpecies(write("b", "")).habit, "");  // optional: none stated
    try {
        loadSpecies(write("c", "habit = \"bush\"\n"));
        FAIL() << "expected a SpecError";
    } catch (const SpecError& e) {
        EXPECT_NE(std::string(e.what()).find(
                      "c.toml:3:9: habit: expected one of \"tree\", \"conifer\", \"shrub\", "
                      "\"clump\", \"palm\", got \"bush\""),
                  std::string::npos)
            << e.what();
    }
}

TEST(SpeciesFile, EverySpeciesOfTheLibraryStatesItsHabit) {
    const auto presets = std::filesystem::path(SYLVA_SOURCE_DIR) / "species" / "presets";
    int checked = 0;
    for (const auto& e : std::filesystem::directory_iterator(presets)) {
        if (e.path().extension() != ".toml") continue;
        SCOPED_TRACE(e.path().filename().string());
        const SpeciesFile s = loadSpecies(e.path().string());
        EXPECT_FALSE(s.habit.empty());
        ++checked;
    }
    EXPECT_GE(checked, 16);
}

}  // namespace
}  // namespace sylva
