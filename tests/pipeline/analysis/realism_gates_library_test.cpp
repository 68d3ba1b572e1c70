// The realism gates over the library itself (pipeline/analysis/realism_gates.h): 16 trees of
// every species in species/presets/ built from datasets/realism-gates.toml, every gate passed.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>

#include "pipeline/analysis/realism_gates.h"
#include "pipeline/build/build.h"
#include "pipeline/build/dataset.h"

namespace sylva {
namespace {

namespace fs = std::filesystem;

// The library: every species in species/presets/, 16 trees each, passes every gate. The table
// is printed (and written to $SYLVA_GATES_TABLE when set, for the README).
TEST(RealismGates, EveryLibrarySpeciesPasses) {
    const fs::path source = SYLVA_SOURCE_DIR;
    const DatasetSpec spec = loadDataset((source / "datasets/realism-gates.toml").string());
    std::set<std::string> listed, presets;
    for (const SpeciesEntry& e : spec.species) {
        EXPECT_EQ(e.count, 16) << e.species.path;
        listed.insert(fs::weakly_canonical(e.species.path).string());
    }
    for (const auto& e : fs::directory_iterator(source / "species/presets")) {
        if (e.path().extension() == ".toml") presets.insert(fs::weakly_canonical(e.path()));
    }
    EXPECT_EQ(listed, presets) << "datasets/realism-gates.toml must list every preset";
    ASSERT_GE(presets.size(), 1u);

    const fs::path out = fs::temp_directory_path() / ("sylva_gates_" + std::to_string(getpid()));
    fs::remove_all(out);
    BuildOptions o;
    o.out = out;
    o.progress = false;
    const BuildSummary b = buildDataset(spec, o);
    EXPECT_EQ(b.failed, 0);
    const std::vector<SpeciesGates> gates = evaluateGates(out);
    fs::remove_all(out);
    const std::string table = gatesMarkdown(gates);
    std::cout << table;
    if (const char* path = std::getenv("SYLVA_GATES_TABLE")) std::ofstream(path) << table;
    EXPECT_EQ(gates.size(), presets.size());
    for (const SpeciesGates& s : gates) {
        EXPECT_EQ(s.instances, 16) << s.species;
        for (const GateResult& g : s.gates) {
            EXPECT_TRUE(g.pass) << s.species << ": " << g.gate << " = " << g.value;
        }
    }
}

}  // namespace
}  // namespace sylva
