// SPDX-License-Identifier: MIT
#include "builders/search_spaces/exhaustive_split.hpp"

#include <bit>
#include <string>
#include <vector>

#include "spacebvh/error.hpp"

namespace spacebvh::builders {

ExhaustiveSplit exhaustive_split(std::span<const Reference> references, const AABB& node, const CostModel& cost) {
    const size_t count = references.size();
    if (count > kMaxExhaustiveReferences)
        throw Error("exhaustive split: at most " + std::to_string(kMaxExhaustiveReferences) + " references, got " +
                    std::to_string(count));
    ExhaustiveSplit best;
    if (count < 2) return best;
    // Boxes of every subset of the low and of the high half of the references, so that the box of
    // any subset is one merge of two table entries.
    const uint32_t low_bits = uint32_t(count / 2), high_bits = uint32_t(count) - low_bits;
    auto subset_boxes = [&](uint32_t first, uint32_t bits) {
        std::vector<AABB> boxes(size_t(1) << bits);
        for (uint32_t mask = 1; mask < boxes.size(); ++mask) {
            const uint32_t lowest = uint32_t(std::countr_zero(mask));
            boxes[mask] = merge(boxes[mask & (mask - 1)], references[first + lowest].bounds);
        }
        return boxes;
    };
    const std::vector<AABB> low = subset_boxes(0, low_bits), high = subset_boxes(low_bits, high_bits);
    const uint32_t low_mask = (1u << low_bits) - 1, all = uint32_t((uint64_t(1) << count) - 1);
    auto box_of = [&](uint32_t mask) { return merge(low[mask & low_mask], high[mask >> low_bits]); };
    // The last reference always goes right, so each unordered partition is seen once.
    const uint32_t partitions = 1u << (count - 1);
    for (uint32_t left_mask = 1; left_mask < partitions; ++left_mask) {
        const uint32_t right_mask = all & ~left_mask;
        const AABB left = box_of(left_mask), right = box_of(right_mask);
        const uint32_t left_count = uint32_t(std::popcount(left_mask));
        const float split_cost = cost.split_cost(node, left, left_count, right, uint32_t(count) - left_count);
        if (split_cost < best.cost) {
            best.cost = split_cost;
            best.left_mask = left_mask;
            best.left_bounds = left;
            best.right_bounds = right;
            best.left_count = left_count;
            best.right_count = uint32_t(count) - left_count;
        }
    }
    return best;
}

}  // namespace spacebvh::builders
