// SPDX-License-Identifier: MIT
// Applying a chosen split: moving each reference of a node to its child (and, for spatial splits,
// clipping straddling references into both).
#pragma once

#include <span>

#include "builders/driver/split.hpp"

namespace spacebvh::builders {

// A node's references occupy storage[0, count); its subtree may use all of storage (its capacity).
// After the split, the left child's references are storage[0, left_count) and the right child's
// storage[left_capacity, left_capacity + right_count); each child may use its capacity. The spare
// capacity (storage.size() - left_count - right_count) is shared in proportion to the counts.
struct ChildRanges {
    uint32_t left_count = 0, left_capacity = 0;
    uint32_t right_count = 0, right_capacity = 0;
    // Spatial splits: the last this many references of each child came from references that
    // straddled the plane (clipped pieces, or whole ones placed on one side); the others are the
    // node's references that lay on that side, in the node's order.
    uint32_t left_from_straddlers = 0, right_from_straddlers = 0;
};

// Where a reference lies against the plane x[axis] = position, as a spatial split sends it: wholly
// left (a reference flat in the plane included), wholly right, or straddling (clipped into both, or
// placed on one side by unsplitting or the reference budget).
enum class PlaneSide { left, right, straddles };
inline PlaneSide plane_side(const Reference& reference, int axis, float position) {
    const float lo = reference.bounds.lo[axis], hi = reference.bounds.hi[axis];
    if (hi <= position && lo < position) return PlaneSide::left;
    if (lo >= position && hi > position) return PlaneSide::right;
    if (lo == hi) return PlaneSide::left;  // flat in the plane itself: one side is enough
    return PlaneSide::straddles;
}

// Deterministic: the same input order gives the same output order. Object splits keep the order
// (each child's references in the node's order).
ChildRanges apply_split(std::span<Reference> storage, uint32_t count, const Split& split,
                        std::span<const Triangle> triangles);

bool goes_left(const Reference& reference, const Split& split);  // object splits only

// The fallback when a node must be split (too many references) but no search space offers a
// feasible split: halve the node at the median of the centroid order on the widest axis.
Split median_split(std::span<const Reference> references, const ReferenceSummary& node);

}  // namespace spacebvh::builders
