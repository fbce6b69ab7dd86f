// Applying a chosen split: moving each reference of a node to its child (and, for spatial splits,
// clipping straddling references into both).
#pragma once

#include <span>

#include "build/split.hpp"

namespace spacebvh::build {

// A node's references occupy storage[0, count); its subtree may use all of storage (its capacity).
// After the split, the left child's references are storage[0, left_count) and the right child's
// storage[left_capacity, left_capacity + right_count); each child may use its capacity. The spare
// capacity (storage.size() - left_count - right_count) is shared in proportion to the counts.
struct ChildRanges {
    uint32_t left_count = 0, left_capacity = 0;
    uint32_t right_count = 0, right_capacity = 0;
};

// Deterministic: the same input order gives the same output order.
ChildRanges apply_split(std::span<Reference> storage, uint32_t count, const Split& split,
                        std::span<const Triangle> triangles);

bool goes_left(const Reference& reference, const Split& split);  // object splits only

// The fallback when a node must be split (too many references) but no search space offers a
// feasible split: halve the node at the median of the centroid order on the widest axis.
Split median_split(std::span<Reference> references, const ReferenceSummary& node);

}  // namespace spacebvh::build
