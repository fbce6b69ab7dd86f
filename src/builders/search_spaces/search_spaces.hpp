// SPDX-License-Identifier: MIT
// The one place that turns a set of search spaces (SearchSpace bits) into split finders, for every
// preset, the --search option and the optimum report.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "builders/preset_table.hpp"
#include "builders/driver/split.hpp"
#include "spacebvh/build.hpp"

namespace spacebvh::builders {

// Object spaces come first (the spatial gate looks at the best object split), then spatial, then grid;
// on equal cost the earlier finder's split is kept. `allow_unsplitting` and `spatial_gate_alpha` are
// the preset's rules for the spatial search space.
std::vector<std::unique_ptr<SplitFinder>> make_search_spaces(uint32_t search_spaces,
                                                             std::span<const Triangle> triangles,
                                                             const BuildConfig& config, bool allow_unsplitting,
                                                             float spatial_gate_alpha);

// The preset's search spaces, or config.search_spaces when set; the exact sweep replaces binned
// spatial search when config.spatial.exact_sweep is on.
uint32_t effective_search_spaces(const BuilderPreset& preset, const BuildConfig& config);

// True when the search spaces may clip references into both children (so the reference budget applies).
bool splits_references(uint32_t search_spaces, const BuildConfig& config);

}  // namespace spacebvh::builders
