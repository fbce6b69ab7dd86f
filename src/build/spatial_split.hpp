// The one implementation of reference clipping behind every spatial search space: cutting a
// reference (a triangle restricted to its current bounds) at an axis-aligned plane.
#pragma once

#include <utility>

#include "build/reference.hpp"
#include "spacebvh/clip.hpp"

namespace spacebvh::build {

// The two pieces of `reference` on either side of x[axis] = position, with the tight bounds of the
// triangle part inside each (exact clipping, src/core/clip.cpp). A piece that is empty has an empty
// box. A reference lying in the plane goes to both sides.
inline std::pair<Reference, Reference> split_reference(const Reference& reference, const Triangle& triangle, int axis,
                                                       float position) {
    const SplitBounds pieces = split_triangle_bounds(triangle, reference.bounds, axis, position);
    return {Reference{pieces.left, reference.primitive}, Reference{pieces.right, reference.primitive}};
}

}  // namespace spacebvh::build
