// SPDX-License-Identifier: MIT
// The exact ray-triangle test every answer rests on: the tracers' near-edge fallback and the arbiter.
#pragma once

#include <optional>

#include "spacebvh/geometry.hpp"

namespace spacebvh {

// Exact test in double precision of a ray against one closed triangle (edges and vertices count as
// inside; degenerate triangles are never hit). Returns t in [ray.tmin, ray.tmax] or nothing.
std::optional<double> intersect_triangle_exact(const Ray& ray, const Triangle& triangle);

}  // namespace spacebvh
