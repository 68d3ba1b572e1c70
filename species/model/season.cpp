#include "species/model/season.h"

#include <algorithm>

namespace sylva {

const std::vector<std::string>& seasonNames() {
    static const std::vector<std::string> names = {"spring", "summer", "autumn", "winter"};
    return names;
}

int seasonIndex(const std::string& name) {
    const std::vector<std::string>& names = seasonNames();
    const auto it = std::find(names.begin(), names.end(), name);
    return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

std::array<SeasonPalette, 4> grammarSeasons() {
    std::array<SeasonPalette, 4> s;
    s[static_cast<int>(Season::kSpring)] = {{1, 2, 3}, 0.6};
    s[static_cast<int>(Season::kSummer)] = {{0, 1, 2, 3}, 1.0};
    s[static_cast<int>(Season::kAutumn)] = {{4, 5, 6, 7}, 0.8};
    s[static_cast<int>(Season::kWinter)] = {{}, 0.0};
    return s;
}

std::array<SeasonPalette, 4> grownSeasons() {
    std::array<SeasonPalette, 4> s = grammarSeasons();
    s[static_cast<int>(Season::kSummer)] = {{}, 1.0, true};
    return s;
}

}  // namespace sylva
