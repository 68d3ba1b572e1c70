// Readers of [leaves] tables: the leaf cards' own keys, shared by every such table, and the
// species' [leaves] table of the methods that do not place their own leaves. Keys, units,
// defaults and ranges: docs/specs.md ("Leaves") and docs/methods/canopy.md.
#pragma once

#include "core/params.h"
#include "species/geometry/leaves.h"
#include "species/model/season.h"

namespace sylva {

// size, aspect, shape, orientation, sun_direction and sun_weight of a [leaves] table, defaults
// from `cards`.
void readLeafCards(Params& leaves, LeafCardOptions& cards);

// The `shape` key of any table of leaves ("card", "simple", "lobed", "palmate", "compound",
// "needles", "frond"; species/model/leaf_shape.h), `fallback` when absent.
LeafShape readLeafShape(Params& leaves, LeafShape fallback);

// The species' [leaves] table (disabled options when it has none).
LeafOptions readLeaves(Params& species);

// An array of leaf colour classes (integers 0–255) under `key`; empty when absent.
std::vector<uint8_t> readColourClasses(Params& table, std::string_view key);

// The season under `key` ("spring", "summer", "autumn", "winter"), `fallback` when absent.
Season readSeason(Params& table, std::string_view key, Season fallback);

// The species' [seasons.<season>] tables (`classes`, `density`): overrides of `palettes`.
// With `asGrownAllowed` (the methods that colour their own leaves) a season's `classes` may
// also be "as-grown": the leaves keep their method's colours.
void readSeasonPalettes(Params& species, std::array<SeasonPalette, 4>& palettes,
                        bool asGrownAllowed);

}  // namespace sylva
