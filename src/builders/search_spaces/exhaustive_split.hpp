// SPDX-License-Identifier: MIT
// The exhaustive optimum of a small node (the slides' "Exhaustive search: O(2^N)"): every two-way
// partition of the node's references, each child with the tight box of its references, under the one
// cost model (CostModel::split_cost, overlap penalty included). A validator and research tool: no
// object-partitioning search space (object sweep, binned, grid without splitting) can find a cheaper
// split, so it measures how far each one's local choice is from the best (slides: CBVH ~700 vs ~100).
//
// Splitting options: none. A partition fixes each child's box from its references; a split reference
// would need a box to be clipped to, which only search spaces that fix the boxes first (kd planes,
// grid) define. Splitting search spaces may therefore go below this optimum, and the report says so.
#pragma once

#include <span>

#include "builders/driver/reference.hpp"
#include "spacebvh/cost_model.hpp"

namespace spacebvh::builders {

inline constexpr size_t kMaxExhaustiveReferences = 24;  // 2^23 partitions, ~0.1 s

struct ExhaustiveSplit {
    float cost = kInfinity;  // +inf when no partition is feasible (or fewer than 2 references)
    uint32_t left_mask = 0;  // bit i set: references[i] goes left (the last reference always goes right)
    AABB left_bounds, right_bounds;
    uint32_t left_count = 0, right_count = 0;
};

// Throws Error for more than kMaxExhaustiveReferences references. Ties: the lowest mask.
ExhaustiveSplit exhaustive_split(std::span<const Reference> references, const AABB& node, const CostModel& cost);

}  // namespace spacebvh::builders
