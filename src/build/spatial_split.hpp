// The one implementation of reference clipping behind every spatial search space: cutting a
// reference (a triangle restricted to its current bounds) at an axis-aligned plane.
#pragma once

#include <utility>

#include "build/reference.hpp"
#include "build/split.hpp"
#include "core/clip_polygon.hpp"
#include "spacebvh/clip.hpp"

namespace spacebvh::build {

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

// The gate of Stich et al. (as NVIDIA's reference builder): spatial splits are tried only when the
// best split found so far has children overlapping by at least alpha * SA(root). 0 = always.
inline bool spatial_search_gated_off(const NodeContext& context, float alpha) {
    if (!(alpha > 0.0f) || !context.best_so_far.is_valid()) return false;
    const AABB overlap = intersect(context.best_so_far.left_bounds, context.best_so_far.right_bounds);
    return overlap.is_empty() || overlap.area() < alpha * context.root_area;
}

}  // namespace spacebvh::build
