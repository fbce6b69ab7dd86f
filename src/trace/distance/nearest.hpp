// SPDX-License-Identifier: MIT
// The nearest triangle to a point: a query of the walk skeleton (walk.hpp) over the eight-wide layout
// (node test: a lower bound of the squared distance to each child's box, children nearest first), a
// leaf visitor that keeps every triangle that may still be the nearest, and the exact decision between
// those (docs/distance.md).
#pragma once

#include <cstdint>
#include <vector>

#include "spacebvh/distance.hpp"
#include "trace/distance/point_triangle.hpp"
#include "trace/layout/wide_layout.hpp"

namespace spacebvh::trace::distance {

// A triangle that may be the nearest: its double squared distance lies within its error bound of the
// best upper bound found so far.
struct Candidate {
    uint32_t primitive;
    PointTriangle at;
};

// The conditioning of each lane of each pack of the layout (packs[i] lane l: conditioning[4 i + l]),
// computed once: what each triangle's error bound needs.
std::vector<TriangleConditioning> pack_conditioning(const WideLayout<8>& wide);

// Points of larger magnitude are refused (Error): their squared distances could overflow.
inline constexpr double kMaxCoordinate = 0x1p400;

// The nearest triangle of `wide` to p within max_distance (inclusive; infinity: no limit), decided
// exactly, ties to the smaller id. `triangles` are the mesh's (the exact decision reads them);
// `scratch` is reused between calls.
ClosestPoint nearest_triangle(const WideLayout<8>& wide, std::span<const TriangleConditioning> conditioning,
                              std::span<const Triangle> triangles, const Vec3d& p, double max_distance,
                              std::vector<Candidate>& scratch);

}  // namespace spacebvh::trace::distance
