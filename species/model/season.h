// Seasons of a tree's leaves: which colour classes its leaves take and what share of them it
// carries in each season. The grammar method draws them per stem as it places its particles
// (Jain et al. 2021 §3.2); the other methods place their leaves as grown and the season is
// applied to the finished tree (applySeason, species/geometry/leaves.h), with the same rule.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace sylva {

enum class Season { kSpring = 0, kSummer = 1, kAutumn = 2, kWinter = 3 };

// "spring", "summer", "autumn", "winter", indexed by Season.
const std::vector<std::string>& seasonNames();
// The index (as Season) of a season's name, −1 for another word.
int seasonIndex(const std::string& name);

// One season's leaves: colour classes darkest (lowest on the tree) first, and the fraction of
// the leaves kept. `asGrown`: the leaves keep the colours their method gave them (`classes`
// unused) — the methods other than the grammar in summer, and evergreens all year.
struct SeasonPalette {
    std::vector<uint8_t> classes;
    double density = 1.0;
    bool asGrown = false;
};

// The grammar's built-in palettes (Jain §3.2): spring {1, 2, 3} × 0.6, summer {0, 1, 2, 3} × 1,
// autumn {4, 5, 6, 7} × 0.8, winter bare. Classes 0–3 are greens dark → light, 4 dark red,
// 5 red, 6 orange, 7 yellow.
std::array<SeasonPalette, 4> grammarSeasons();

// The same for the methods that colour their own leaves, except that summer is as grown.
std::array<SeasonPalette, 4> grownSeasons();

}  // namespace sylva
