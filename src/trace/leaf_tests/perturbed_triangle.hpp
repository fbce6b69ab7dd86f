// SPDX-License-Identifier: MIT
// The exact ray-triangle decisions of the multi-hit queries (queries/query_walks.cpp,
// docs/queries.md), for a triangle the float edge functions of the watertight test could not settle:
//  - the sign of each edge function, exactly (filtered double, then an exact expansion); an edge
//    function that is exactly zero gets the sign it takes when the ray's origin moves by
//    e*x + e^2*y + e^3*z for an infinitesimal e (simulation of simplicity): the sign of the first
//    nonzero component of dir x (q - p). One perturbation for the whole query, so the answers are
//    those of one real ray passing beside every edge and vertex;
//  - the distance: t in [tmin, tmax] decided exactly (closed interval), t itself in double.
// Inline: the all-hits walks call them once per crossing.
#pragma once

#include <cmath>
#include <cstdint>

#include "spacebvh/geometry.hpp"
#include "spacebvh/queries.hpp"

namespace spacebvh::trace::perturbed {

// ---------------------------------------------------------------------------------------------
// Exact signs of polynomials in float inputs. A product of two floats is exact in double; a third
// factor makes a two-term expansion (fma); the sum is kept as a nonoverlapping expansion (Shewchuk,
// "Adaptive Precision Floating-Point Arithmetic", 1997), whose sign is that of its largest term.
// Exact over the whole float range (no overflow or harmful underflow for products of up to four
// floats). The build disables FMA contraction, which the two-sum below relies on.

class Expansion {
public:
    void add(double x) {
        if (x == 0.0) return;
        double q = x;
        int m = 0;
        for (int i = 0; i < size_; ++i) {
            const double s = q + terms_[i];
            const double bv = s - q;
            const double av = s - bv;
            const double e = (q - av) + (terms_[i] - bv);
            if (e != 0.0) terms_[m++] = e;
            q = s;
        }
        if (q != 0.0) terms_[m++] = q;
        size_ = m;
    }
    void add_product(double a, double b) {  // a * b exactly
        const double p = a * b;
        add(std::fma(a, b, -p));
        add(p);
    }
    int sign() const { return size_ == 0 ? 0 : (terms_[size_ - 1] > 0.0 ? 1 : -1); }

private:
    // Every add() grows the expansion by at most one term; the longest sum below has 84 terms.
    double terms_[96];
    int size_ = 0;
};

// s * tau * a.(b x c), added exactly (products of four floats: two exact doubles, then a two-product).
inline void add_scaled_determinant(Expansion& e, double s, float tau, Vec3 a, Vec3 b, Vec3 c) {
    auto term = [&](float x, float y, float z, double sign) {
        e.add_product(sign * s * double(tau) * double(x), double(y) * double(z));
    };
    term(a.x, b.y, c.z, 1.0);
    term(a.x, b.z, c.y, -1.0);
    term(a.y, b.z, c.x, 1.0);
    term(a.y, b.x, c.z, -1.0);
    term(a.z, b.x, c.y, 1.0);
    term(a.z, b.y, c.x, -1.0);
}

// s * a.(b x c), added exactly (tau = 1 multiplies exactly).
inline void add_determinant(Expansion& e, double s, Vec3 a, Vec3 b, Vec3 c) {
    add_scaled_determinant(e, s, 1.0f, a, b, c);
}

// Edge function of the directed edge p -> q: dir . ((p - o) x (q - o)) = det(d, p, q) + det(d, q, o)
// + det(d, o, p), exactly.
inline int edge_sign_exact(const Ray& ray, Vec3 p, Vec3 q) {
    Expansion e;
    add_determinant(e, 1.0, ray.dir, p, q);
    add_determinant(e, 1.0, ray.dir, q, ray.org);
    add_determinant(e, 1.0, ray.dir, ray.org, p);
    return e.sign();
}

// The sign the edge function takes under the perturbation: first nonzero component of d x (q - p).
inline int perturbation_sign(const Vec3& d, Vec3 p, Vec3 q) {
    for (int axis = 0; axis < 3; ++axis) {
        const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
        // (d x (q - p))[axis] = d[a1] (q[a2] - p[a2]) - d[a2] (q[a1] - p[a1])
        Expansion e;
        e.add(double(d[a1]) * double(q[a2]));
        e.add(-double(d[a1]) * double(p[a2]));
        e.add(-double(d[a2]) * double(q[a1]));
        e.add(double(d[a2]) * double(p[a1]));
        if (const int s = e.sign()) return s;
    }
    return 0;  // the edge is parallel to the ray: its triangle is seen edge-on and never hit
}

struct DVec {
    double x, y, z;
};
inline DVec dsub(Vec3 a, Vec3 b) { return {double(a.x) - b.x, double(a.y) - b.y, double(a.z) - b.z}; }

// Sign of the edge function p -> q under the perturbation; never 0 unless the edge is parallel to dir.
inline int perturbed_edge_sign(const Ray& ray, Vec3 p, Vec3 q) {
    const DVec a = dsub(p, ray.org), b = dsub(q, ray.org);
    const double dx = ray.dir.x, dy = ray.dir.y, dz = ray.dir.z;
    const double value = dx * (a.y * b.z - a.z * b.y) + dy * (a.z * b.x - a.x * b.z) + dz * (a.x * b.y - a.y * b.x);
    const double magnitude = std::fabs(dx) * (std::fabs(a.y * b.z) + std::fabs(a.z * b.y)) +
                             std::fabs(dy) * (std::fabs(a.z * b.x) + std::fabs(a.x * b.z)) +
                             std::fabs(dz) * (std::fabs(a.x * b.y) + std::fabs(a.y * b.x));
    // Rounding of the differences (one each), products (two levels) and sums (three): far below 16 ulp.
    if (std::fabs(value) > 16.0 * 0x1p-53 * magnitude + 0x1p-1000) return value > 0 ? 1 : -1;
    if (const int s = edge_sign_exact(ray, p, q)) return s;
    return perturbation_sign(ray.dir, p, q);
}

// Whether the perturbed ray passes through the triangle's interior (stage 2).
inline bool crosses_perturbed(const Ray& ray, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
    const int su = perturbed_edge_sign(ray, v1, v2);
    if (su == 0) return false;
    const int sv = perturbed_edge_sign(ray, v2, v0);
    if (sv != su) return false;
    return perturbed_edge_sign(ray, v0, v1) == su;
}

// Exact sign of N - tau * D, where t = N / D is the plane crossing: N = det(v0 - o, v1 - o, v2 - o),
// D = (v1 - v0) x (v2 - v0) . dir.
inline int crossing_minus_sign_exact(const Ray& ray, const Vec3& v0, const Vec3& v1, const Vec3& v2, float tau) {
    const Vec3 o = ray.org, d = ray.dir;
    Expansion e;
    add_determinant(e, 1.0, v0, v1, v2);
    add_determinant(e, -1.0, o, v1, v2);
    add_determinant(e, -1.0, v0, o, v2);
    add_determinant(e, -1.0, v0, v1, o);
    if (tau != 0.0f) {
        add_scaled_determinant(e, -1.0, tau, v1, v2, d);
        add_scaled_determinant(e, -1.0, tau, v0, v1, d);
        add_scaled_determinant(e, -1.0, tau, v2, v0, d);
    }
    return e.sign();
}

inline int denominator_sign_exact(const Ray& ray, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
    Expansion e;
    add_determinant(e, 1.0, v1, v2, ray.dir);
    add_determinant(e, 1.0, v0, v1, ray.dir);
    add_determinant(e, 1.0, v2, v0, ray.dir);
    return e.sign();
}

// Stage 3: the plane crossing t = N / D in double, and whether tmin <= t <= tmax, exactly. The triangle
// is known to be crossed transversally, so D != 0 in exact arithmetic.
inline bool crossing_in_range(const Ray& ray, const Vec3& v0, const Vec3& v1, const Vec3& v2, double tmax, double& t) {
    const DVec e1 = dsub(v1, v0), e2 = dsub(v2, v0), p = dsub(v0, ray.org);
    const double dx = ray.dir.x, dy = ray.dir.y, dz = ray.dir.z;
    const double nx = e1.y * e2.z - e1.z * e2.y, ny = e1.z * e2.x - e1.x * e2.z, nz = e1.x * e2.y - e1.y * e2.x;
    const double mx = std::fabs(e1.y * e2.z) + std::fabs(e1.z * e2.y),
                 my = std::fabs(e1.z * e2.x) + std::fabs(e1.x * e2.z),
                 mz = std::fabs(e1.x * e2.y) + std::fabs(e1.y * e2.x);
    const double numerator = nx * p.x + ny * p.y + nz * p.z;
    const double denominator = nx * dx + ny * dy + nz * dz;
    // Error bounds: a few roundings per level, each relative to the magnitudes involved.
    constexpr double kRelative = 32.0 * 0x1p-53;
    const double numerator_error =
        kRelative * (mx * std::fabs(p.x) + my * std::fabs(p.y) + mz * std::fabs(p.z)) + 0x1p-1000;
    const double denominator_error =
        kRelative * (mx * std::fabs(dx) + my * std::fabs(dy) + mz * std::fabs(dz)) + 0x1p-1000;

    int denominator_sign;
    if (std::fabs(denominator) > denominator_error)
        denominator_sign = denominator > 0 ? 1 : -1;
    else
        denominator_sign = denominator_sign_exact(ray, v0, v1, v2);
    if (denominator_sign == 0) return false;

    // sign(t - tau) = sign(N - tau D) * sign(D)
    auto at_or_beyond = [&](double tau) {  // sign of t - tau
        const double value = numerator - tau * denominator;
        const double error = numerator_error + std::fabs(tau) * denominator_error +
                             4.0 * 0x1p-53 * (std::fabs(numerator) + std::fabs(tau * denominator));
        const int s =
            std::fabs(value) > error ? (value > 0 ? 1 : -1) : crossing_minus_sign_exact(ray, v0, v1, v2, float(tau));
        return s * denominator_sign;
    };
    if (std::isfinite(ray.tmin) && at_or_beyond(ray.tmin) < 0) return false;
    if (std::isfinite(tmax)) {
        if (tmax == double(ray.tmax)) {
            if (at_or_beyond(ray.tmax) > 0) return false;
        } else {
            // A shrunk bound (first hit): the double t of an earlier crossing; compare in double.
            if (!(numerator / denominator <= tmax)) return false;
        }
    }
    t = numerator / denominator;
    return true;
}

// Barycentrics and point of a crossing, from the double edge functions.
inline QueryHit make_hit(const Ray& ray, const Vec3& v0, const Vec3& v1, const Vec3& v2, uint32_t id, double t) {
    const DVec a = dsub(v0, ray.org), b = dsub(v1, ray.org), c = dsub(v2, ray.org);
    const double dx = ray.dir.x, dy = ray.dir.y, dz = ray.dir.z;
    auto edge = [&](const DVec& p, const DVec& q) {
        return dx * (p.y * q.z - p.z * q.y) + dy * (p.z * q.x - p.x * q.z) + dz * (p.x * q.y - p.y * q.x);
    };
    const double fu = edge(b, c), fv = edge(c, a), fw = edge(a, b);
    const double sum = fu + fv + fw;
    QueryHit hit;
    hit.t = t;
    hit.primitive = id;
    hit.u = sum != 0.0 ? fv / sum : 0.0;
    hit.v = sum != 0.0 ? fw / sum : 0.0;
    const double w0 = 1.0 - hit.u - hit.v;
    for (int axis = 0; axis < 3; ++axis)
        hit.point[size_t(axis)] = w0 * double(v0[axis]) + hit.u * double(v1[axis]) + hit.v * double(v2[axis]);
    return hit;
}

}  // namespace spacebvh::trace::perturbed
