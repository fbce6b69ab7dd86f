// SPDX-License-Identifier: MIT
// The exact squared distance from a double point to a float triangle, as a fraction of dyadic
// rationals, for the decisions the double arithmetic cannot make (docs/distance.md): which of two
// candidates is nearer, and whether the nearest lies within the search distance.
#pragma once

#include "spacebvh/geometry.hpp"
#include "trace/distance/exact_dyadic.hpp"
#include "trace/distance/point_triangle.hpp"

namespace spacebvh::trace::distance {

// num / den, den > 0.
struct ExactSquaredDistance {
    Dyadic num, den;
};

// Ericson's region walk with every sign decided exactly; the triangle is not degenerate.
ExactSquaredDistance exact_squared_distance(D3 p, const Vec3& a, const Vec3& b, const Vec3& c);

// The sign of x - y.
int compare(const ExactSquaredDistance& x, const ExactSquaredDistance& y);
// The sign of x - bound^2.
int compare(const ExactSquaredDistance& x, double bound);

}  // namespace spacebvh::trace::distance
