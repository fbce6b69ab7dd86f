// SPDX-License-Identifier: MIT
// How far a search space's best local split is from the exhaustive optimum of a small node: every
// two-way partition of its triangles (the slides' "Exhaustive search: O(2^N)"), each child with the
// tight box of its triangles, priced by the one cost model (overlap penalty included). No
// object-partitioning search space can find a cheaper split; splitting ones (kd planes, grid with
// splitting) may, since a partition cannot clip. `spacebvh optimum` reports it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "spacebvh/build.hpp"
#include "spacebvh/cost_model.hpp"
#include "spacebvh/geometry.hpp"

namespace spacebvh {

// The largest node exhaustive_split_cost takes (2^23 partitions, about 0.1 s).
inline constexpr size_t kMaxExhaustiveTriangles = 24;

// The cost of the cheapest two-way partition of the triangles as one node; +inf when no partition is
// feasible (or fewer than two triangles). Throws Error for more than kMaxExhaustiveTriangles.
float exhaustive_split_cost(std::span<const Triangle> triangles, const CostModel& cost);

// The cheapest split that the search spaces (SearchSpace bits) find for the triangles as one node,
// with room for every triangle to be clipped once; +inf when none is feasible. `config` gives the
// cost model and the search spaces' settings (bins, grid). Throws Error for unknown search-space bits.
float best_local_split_cost(std::span<const Triangle> triangles, uint32_t search_spaces, const BuildConfig& config);

}  // namespace spacebvh
