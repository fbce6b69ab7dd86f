// SPDX-License-Identifier: MIT
// Exact ray-triangle decisions on float64 input: an adaptive predicate (a double filter with a static
// forward error bound, then floating-point expansion arithmetic where the filter cannot decide;
// Shewchuk 1997). docs/float64.md derives the bounds and states the input range they hold for.
#pragma once

#include <cstddef>
#include <optional>

#include "spacebvh/float64.hpp"

namespace spacebvh::exact {

// Error-free transformations: a + b = s + e and a * b = p + e exactly (Knuth's two-sum; the product's
// error by one fused multiply-add, exact while a * b does not underflow below 2^-1074's grid).
inline void two_sum(double a, double b, double& s, double& e) {
    s = a + b;
    const double b_virtual = s - a;
    const double a_virtual = s - b_virtual;
    e = (a - a_virtual) + (b - b_virtual);
}
void two_product(double a, double b, double& p, double& e);

// A sum of doubles held exactly as a nonoverlapping expansion: components in increasing magnitude,
// zeros eliminated (Shewchuk's GROW-EXPANSION). Each add() grows it by at most one component, so
// Capacity adds always fit.
template <size_t Capacity>
class Expansion {
public:
    void add(double b) {
        if (b == 0.0) return;
        size_t out = 0;
        double q = b;
        for (size_t i = 0; i < size_; ++i) {
            double sum, error;
            two_sum(q, components_[i], sum, error);
            if (error != 0.0) components_[out++] = error;
            q = sum;
        }
        if (q != 0.0) components_[out++] = q;
        size_ = out;
    }
    // The sign of the exact sum: that of the largest component (it outweighs all the others together).
    int sign() const { return size_ == 0 ? 0 : (components_[size_ - 1] > 0.0 ? 1 : -1); }

private:
    double components_[Capacity];
    size_t size_ = 0;
};

// d · ((p - o) × (q - o)): the Plücker side of the ray (o, d) to the directed edge p -> q. The sign of
// the result is exact; its magnitude is the double estimate (or the smallest normal double when only
// the exact arithmetic could tell the sign).
double edge_function(const Vec3d& o, const Vec3d& d, const Vec3d& p, const Vec3d& q);

// Zero area, exactly: the cross product of the edges (v1 - v0) × (v2 - v0) is exactly zero.
bool is_degenerate(const Triangle64& triangle);

// The exact test of a ray against one closed triangle (edges and vertices count, degenerate triangles
// are never hit, a ray in the triangle's plane does not hit): t in [ray.tmin, ray.tmax], decided
// exactly, t itself rounded (double). u, v: barycentrics of v1 and v2. `degenerate` is
// is_degenerate(triangle), computed once by the caller.
struct ExactHit {
    double t, u, v;
};
std::optional<ExactHit> intersect(const Ray64& ray, const Triangle64& triangle, bool degenerate);

}  // namespace spacebvh::exact
