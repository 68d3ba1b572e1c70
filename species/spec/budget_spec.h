// Reader of a [budget] table (core/budget.h): in a species file, the budgets of its trees; in a
// dataset file, the budgets of every tree of the dataset (over the species' own). Keys, units,
// defaults and ranges: docs/specs.md ("Budgets").
#pragma once

#include "core/budget.h"
#include "core/params.h"

namespace sylva {

// The keys the table gives (plain numbers, no distributions). `dataset`: the dataset file's
// table, which also takes max_view_pixels. Calls finish().
BudgetTable readBudget(Params& table, bool dataset);

}  // namespace sylva
