// SPDX-License-Identifier: MIT
// The one implementation of reference clipping behind every spatial search space: cutting a
// reference (a triangle restricted to its current bounds) at an axis-aligned plane.
#pragma once

#include <utility>

#include "builders/driver/reference.hpp"
#include "builders/driver/split.hpp"
#include "core/clip_polygon.hpp"
#include "spacebvh/clip.hpp"

namespace spacebvh::builders {

// The two pieces of `reference` on either side of x[axis] = position, with the tight bounds of the
// triangle part inside each (exact clipping, src/core/clip.cpp). A piece that is empty has an empty
// box. A reference lying in the plane goes to both sides. Finders that cut one reference at many
// planes keep its clipping::TrianglePiece instead (the same clipper, the same bits).
inline std::pair<Reference, Reference> split_reference(const Reference& reference, const Triangle& triangle, int axis,
                                                       float position) {
    const SplitBounds pieces = split_triangle_bounds(triangle, reference.bounds, axis, position);
    return {Reference{pieces.left, reference.primitive}, Reference{pieces.right, reference.primitive}};
}

// A spatial split (SplitKind::spatial) at x[axis] = position, as both spatial search spaces report it.
inline Split spatial_split(float cost, int axis, float position, const AABB& left_bounds, uint32_t left_count,
                           const AABB& right_bounds, uint32_t right_count, bool unsplit) {
    Split split = make_split(SplitKind::spatial, cost, axis, left_bounds, left_count, right_bounds, right_count);
    split.position = position;
    split.unsplit = unsplit;
    return split;
}

// When a node's spatial search is skipped. Only where another search space has offered a split
// (with spatial planes alone, as in kdbvh, they are the node's only splits), and not where that
// split loses to a leaf while the node is too big for one: such a node needs every option (a soup
// of large overlapping triangles under C_o > 0 otherwise gets object splits that peel one reference
// at a time, down to the depth limit).
//  * The subtree has no spare reference capacity. A plane can then duplicate nothing, so its binned
//    price, which assumes every straddler goes to both sides, is wrong: apply_split sends them to
//    one side. Skipping it builds faster, and the trees have a lower SAH, since the wrongly
//    priced planes no longer win over object splits.
//  * The gate of Stich et al. (as NVIDIA's reference builder; Embree has one too): the best split
//    found so far has children overlapping by less than alpha * SA(root). alpha = 0: no gate.
inline bool spatial_search_gated_off(const NodeContext& context, const CostModel& cost, float alpha) {
    const Split& best = context.best_so_far;
    if (!best.is_valid()) return false;
    if (context.must_split && !(best.cost < cost.leaf_cost(context.references.size()))) return false;
    if (context.capacity <= context.references.size()) return true;
    if (!(alpha > 0.0f)) return false;
    const AABB overlap = intersect(best.left_bounds, best.right_bounds);
    return overlap.is_empty() || overlap.area() < alpha * context.root_area;
}

}  // namespace spacebvh::builders
