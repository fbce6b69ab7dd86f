// SPDX-License-Identifier: MIT
// The exact ray-triangle test: signs of the edge functions decided exactly in double precision.
#include "core/exact_triangle.hpp"

#include <cmath>

namespace spacebvh {

namespace {

struct DVec3 {
    double x, y, z;
};
DVec3 dsub(Vec3 a, Vec3 b) { return {double(a.x) - double(b.x), double(a.y) - double(b.y), double(a.z) - double(b.z)}; }
DVec3 dcross(const DVec3& a, const DVec3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double ddot(const DVec3& a, const DVec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// Zero area as the scene conventions count it: the float32 cross product of the edges is exactly
// zero. Written as comparisons of the products (not differences) so that the answer cannot change
// when the compiler fuses a multiply and a subtraction into an FMA (-march=native does that to
// Triangle::is_degenerate()); this keeps the arbiter the same whatever the build flags.
bool zero_area_float32(const Triangle& tri) {
    const Vec3 e1 = tri.v1 - tri.v0;
    const Vec3 e2 = tri.v2 - tri.v0;
    return e1.y * e2.z == e1.z * e2.y && e1.z * e2.x == e1.x * e2.z && e1.x * e2.y == e1.y * e2.x;
}

// Which side of the directed edge p -> q the ray passes (Plücker side test in double precision,
// with p_rel = p - org, q_rel = q - org): dot(dir, cross(p_rel, q_rel)). Evaluated with the two
// endpoints in a canonical order and negated when swapped, so two triangles sharing the edge get
// exactly opposite values whatever rounding or FMA does: a ray can never slip between them
// (watertight), and a ray exactly on the edge gets 0 and hits both (closed triangles). Not inlined,
// so every call site runs the very same instructions (the same FMA choices).
//
// Exactness: the double value carries rounding noise, so a ray exactly through a shared vertex would
// get small random signs on the edges meeting there, and if they all agree around the vertex no
// triangle of the fan is hit. So when the double value is within its forward error bound of zero, the
// edge function is recomputed in quad precision (__float128, 113-bit significand) from the float
// inputs: the differences of floats and the triple products of such differences are then exact for
// any realistic coordinate range, so exact zeros come out as zeros.
double edge_side_exact(const Ray& ray, Vec3 p, Vec3 q) {
    using Quad = __float128;
    const Quad px = Quad(p.x) - Quad(ray.org.x), py = Quad(p.y) - Quad(ray.org.y), pz = Quad(p.z) - Quad(ray.org.z);
    const Quad qx = Quad(q.x) - Quad(ray.org.x), qy = Quad(q.y) - Quad(ray.org.y), qz = Quad(q.z) - Quad(ray.org.z);
    const Quad value = Quad(ray.dir.x) * (py * qz - pz * qy) + Quad(ray.dir.y) * (pz * qx - px * qz) +
                       Quad(ray.dir.z) * (px * qy - py * qx);
    return value > 0 ? 1.0 : (value < 0 ? -1.0 : 0.0);
}

[[gnu::noinline]] double edge_side(const Ray& ray, const DVec3& dir, Vec3 p, const DVec3& p_rel, Vec3 q,
                                   const DVec3& q_rel) {
    const bool q_first = q.x < p.x || (q.x == p.x && (q.y < p.y || (q.y == p.y && q.z < p.z)));
    const Vec3& first = q_first ? q : p;
    const Vec3& second = q_first ? p : q;
    const DVec3& first_rel = q_first ? q_rel : p_rel;
    const DVec3& second_rel = q_first ? p_rel : q_rel;
    const double value = ddot(dir, dcross(first_rel, second_rel));
    // |error| <= 8 ulp of the sum of the magnitudes of the six products (the differences p - org
    // add at most one more rounding each).
    const double magnitude =
        std::fabs(dir.x) * (std::fabs(first_rel.y * second_rel.z) + std::fabs(first_rel.z * second_rel.y)) +
        std::fabs(dir.y) * (std::fabs(first_rel.z * second_rel.x) + std::fabs(first_rel.x * second_rel.z)) +
        std::fabs(dir.z) * (std::fabs(first_rel.x * second_rel.y) + std::fabs(first_rel.y * second_rel.x));
    const double signed_value =
        std::fabs(value) > 8.0 * 0x1p-52 * magnitude ? value : edge_side_exact(ray, first, second);
    return q_first ? -signed_value : signed_value;
}

}  // namespace

std::optional<double> intersect_triangle_exact(const Ray& ray, const Triangle& tri) {
    if (zero_area_float32(tri)) return std::nullopt;  // degenerate: never hit (spec, scene conventions)

    const DVec3 dir{ray.dir.x, ray.dir.y, ray.dir.z};
    const DVec3 a = dsub(tri.v0, ray.org);
    const DVec3 b = dsub(tri.v1, ray.org);
    const DVec3 c = dsub(tri.v2, ray.org);

    // Edge functions of the edges opposite v0, v1, v2 (Plücker). Inside, including the boundary,
    // when none has a sign different from the others. Signs are exact (see edge_side), and the same
    // for both triangles of a shared edge: closed and watertight at edges and vertices.
    const double u = edge_side(ray, dir, tri.v1, b, tri.v2, c);
    const double v = edge_side(ray, dir, tri.v2, c, tri.v0, a);
    if ((u < 0.0 && v > 0.0) || (u > 0.0 && v < 0.0)) return std::nullopt;  // early out: most misses
    const double w = edge_side(ray, dir, tri.v0, a, tri.v1, b);
    const bool any_negative = u < 0.0 || v < 0.0 || w < 0.0;
    const bool any_positive = u > 0.0 || v > 0.0 || w > 0.0;
    if (any_negative && any_positive) return std::nullopt;
    if (!any_negative && !any_positive) return std::nullopt;  // ray in the triangle's plane: no hit

    // Distance along the ray to the plane, in units of |dir|: t = dot(n, v0 - org) / dot(n, dir).
    const DVec3 n = dcross(dsub(tri.v1, tri.v0), dsub(tri.v2, tri.v0));
    const double denominator = ddot(n, dir);
    if (denominator == 0.0) return std::nullopt;
    const double t = ddot(n, a) / denominator;
    if (!(t >= double(ray.tmin) && t <= double(ray.tmax))) return std::nullopt;
    return t;
}

}  // namespace spacebvh
