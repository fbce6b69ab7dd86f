// SPDX-License-Identifier: MIT
// The closest point of one triangle to a point, in double, with a bound on the error of its squared
// distance and, where the double arithmetic can certify it, the vertex or edge it lies on
// (docs/distance.md derives the bound). The exact decision between candidates is exact_distance.hpp's.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "spacebvh/distance.hpp"

namespace spacebvh::trace::distance {

struct D3 {
    double x, y, z;
};
[[gnu::always_inline]] inline D3 sub(D3 a, D3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
[[gnu::always_inline]] inline double dot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
[[gnu::always_inline]] inline double dot_magnitude(D3 a, D3 b) {
    return std::fabs(a.x * b.x) + std::fabs(a.y * b.y) + std::fabs(a.z * b.z);
}
[[gnu::always_inline]] inline D3 cross(D3 a, D3 b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
[[gnu::always_inline]] inline D3 axpy(D3 a, double s, D3 b) { return {a.x + s * b.x, a.y + s * b.y, a.z + s * b.z}; }

// The relative slack of the certifying predicates: each is a dot product (or a difference of products
// of two, cross_term) of differences of inputs, each difference rounded once, each dot product
// rounding three times; 2^-48 (32 units of 2^-53) of the sum of its terms' magnitudes covers a dot
// product.
inline constexpr double kDotSlack = 0x1p-48;
// The error bound of a squared distance: kDistanceSlack * kappa * (|p - v0|^2 + (|v1 - v0| + |v2 - v0|)^2),
// kappa = |e1||e2| / |e1 x e2| >= 1 (docs/distance.md). Past kMaxKappa the bound is the trivial one.
inline constexpr double kDistanceSlack = 0x1p-39, kMaxKappa = 0x1p20;

// What the error bound needs of a triangle, computed once: kappa (0 past kMaxKappa) and |e1| + |e2|.
struct TriangleConditioning {
    double kappa, edges;
};
inline TriangleConditioning conditioning(D3 a, D3 b, D3 c) {
    const D3 ab = sub(b, a), ac = sub(c, a), n = cross(ab, ac);
    const double lab = std::sqrt(dot(ab, ab)), lac = std::sqrt(dot(ac, ac)), ln = std::sqrt(dot(n, n));
    return {ln > lab * lac / kMaxKappa ? std::max(1.0, lab * lac / ln) : 0.0, lab + lac};
}

// A certified feature: what the closest point lies on, or kNone where the double arithmetic cannot
// tell. Two triangles certified on the same vertex (or the same edge, by its two end points) are at
// exactly the same distance.
enum class Certified : uint8_t { none, vertex, edge };

struct PointTriangle {
    double d2 = 0.0;     // squared distance, in double
    double error = 0.0;  // |d2 - exact squared distance| <= error
    double u = 0.0, v = 0.0;
    D3 point{};
    uint8_t feature = 0;  // ClosestPoint::feature
    Certified certified = Certified::none;
};

// The features of ClosestPoint: 0 face, 1 2 3 edges v0v1 v1v2 v2v0, 4 5 6 vertices v0 v1 v2.
inline constexpr uint8_t kFace = 0, kEdge01 = 1, kEdge12 = 2, kEdge20 = 3, kVertex0 = 4, kVertex1 = 5, kVertex2 = 6;

// A dot product of rounded differences and the bound of its error.
struct Dot {
    double value, slack;
};
[[gnu::always_inline]] inline Dot dot_with_slack(D3 a, D3 b) { return {dot(a, b), dot_magnitude(a, b) * kDotSlack}; }
// x * y - z * w and the bound of its error: each factor errs by its slack (x' y' - x y is within
// x.slack |y'| + y.slack |x'| + x.slack y.slack), and the two products and the difference round
// once each (relative 2^-53; 2^-50 taken).
[[gnu::always_inline]] inline Dot cross_term(Dot x, Dot y, Dot z, Dot w) {
    const auto product_slack = [](Dot a, Dot b) {
        return a.slack * std::fabs(b.value) + b.slack * std::fabs(a.value) + a.slack * b.slack +
               0x1p-50 * std::fabs(a.value * b.value);
    };
    return {x.value * y.value - z.value * w.value, 2.0 * (product_slack(x, y) + product_slack(z, w))};
}
[[gnu::always_inline]] inline bool certainly_positive(Dot x) { return x.value > x.slack; }
[[gnu::always_inline]] inline bool certainly_negative(Dot x) { return x.value < -x.slack; }
// x - y, both dot products of the same point.
[[gnu::always_inline]] inline Dot difference(Dot x, Dot y) { return {x.value - y.value, 2.0 * (x.slack + y.slack)}; }

// The result at a vertex, or on an edge at `from + t * along`.
[[gnu::always_inline]] inline void at_point(PointTriangle& r, D3 p, D3 q, uint8_t feature, bool certified) {
    const D3 qp = sub(p, q);
    r.d2 = dot(qp, qp), r.point = q, r.feature = feature;
    if (certified) r.certified = feature >= kVertex0 ? Certified::vertex : Certified::edge;
}

// Ericson's region walk (Real-Time Collision Detection, 5.1.5) in double, with the regions' dot
// products certified against their error bounds. The triangle is not degenerate.
[[gnu::always_inline]] inline PointTriangle closest_on_triangle(D3 p, D3 a, D3 b, D3 c, TriangleConditioning k) {
    PointTriangle r;
    const D3 ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
    const double scale2 = dot(ap, ap) + k.edges * k.edges;
    r.error = k.kappa > 0.0 ? kDistanceSlack * k.kappa * scale2 : 4.0 * scale2;
    const Dot d1 = dot_with_slack(ab, ap), d2 = dot_with_slack(ac, ap);
    if (d1.value <= 0.0 && d2.value <= 0.0) {
        at_point(r, p, a, kVertex0, certainly_negative(d1) && certainly_negative(d2));
        return r;
    }
    const D3 bp = sub(p, b);
    const Dot d3 = dot_with_slack(ab, bp), d4 = dot_with_slack(ac, bp);
    if (d3.value >= 0.0 && d4.value <= d3.value) {
        r.u = 1.0;
        at_point(r, p, b, kVertex1, certainly_positive(d3) && certainly_negative(difference(d4, d3)));
        return r;
    }
    const Dot vc = cross_term(d1, d4, d3, d2);
    if (vc.value <= 0.0 && d1.value >= 0.0 && d3.value <= 0.0) {
        r.u = d1.value / (d1.value - d3.value);
        at_point(r, p, axpy(a, r.u, ab), kEdge01,
                 certainly_negative(vc) && certainly_positive(d1) && certainly_negative(d3));
        return r;
    }
    const D3 cp = sub(p, c);
    const Dot d5 = dot_with_slack(ab, cp), d6 = dot_with_slack(ac, cp);
    if (d6.value >= 0.0 && d5.value <= d6.value) {
        r.v = 1.0;
        at_point(r, p, c, kVertex2, certainly_positive(d6) && certainly_negative(difference(d5, d6)));
        return r;
    }
    const Dot vb = cross_term(d5, d2, d1, d6);
    if (vb.value <= 0.0 && d2.value >= 0.0 && d6.value <= 0.0) {
        r.v = d2.value / (d2.value - d6.value);
        at_point(r, p, axpy(a, r.v, ac), kEdge20,
                 certainly_negative(vb) && certainly_positive(d2) && certainly_negative(d6));
        return r;
    }
    const Dot va = cross_term(d3, d6, d5, d4), d43 = difference(d4, d3), d56 = difference(d5, d6);
    if (va.value <= 0.0 && d43.value >= 0.0 && d56.value >= 0.0) {
        const double t = d43.value / (d43.value + d56.value);
        r.u = 1.0 - t, r.v = t;
        at_point(r, p, axpy(b, t, sub(c, b)), kEdge12,
                 certainly_negative(va) && certainly_positive(d43) && certainly_positive(d56));
        return r;
    }
    // Inside the face: the distance to its plane, and the point by barycentrics.
    const double denom = 1.0 / (va.value + vb.value + vc.value);
    r.u = vb.value * denom;  // the weights of b and c
    r.v = vc.value * denom;
    r.point = axpy(axpy(a, r.u, ab), r.v, ac);
    const D3 n = cross(ab, ac);
    const double h = dot(ap, n), nn = dot(n, n);
    r.d2 = nn > 0.0 ? h * h / nn : dot(ap, ap);
    r.feature = kFace;
    return r;
}

}  // namespace spacebvh::trace::distance
