// SPDX-License-Identifier: MIT
// Exact clipping of a triangle against an axis-aligned box (Sutherland-Hodgman), returning the tight
// bounds of the clipped piece. Spatial splits (kd planes that cut references) depend on it, and so
// does the EPO metric.
#pragma once

#include "spacebvh/geometry.hpp"

namespace spacebvh {

// Tight bounds of (triangle ∩ box). Empty when the triangle misses the box. Points of the triangle
// on the box surface count as inside (closed box), so a triangle lying in a face of the box gives a
// flat, non-empty result. The result is always contained in both box and triangle.bounds().
AABB clip_triangle_bounds(const Triangle& triangle, const AABB& box);

// Tight bounds of the part of the triangle (already restricted to `current_bounds`, as a reference
// is after earlier splits) on each side of the plane x[axis] = position. Either may be empty.
struct SplitBounds {
    AABB left;
    AABB right;
};
SplitBounds split_triangle_bounds(const Triangle& triangle, const AABB& current_bounds, int axis, float position);

// Area of the part of the triangle inside the box (exact polygon clipping; used by EPO).
double clipped_triangle_area(const Triangle& triangle, const AABB& box);

}  // namespace spacebvh
