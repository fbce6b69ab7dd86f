// SPDX-License-Identifier: MIT
// Adaptive exact predicates on doubles (Shewchuk 1997, "Adaptive precision floating-point arithmetic
// and fast robust geometric predicates"): each sign is first read from the double evaluation when it
// exceeds a static forward error bound, and otherwise recomputed exactly as a sum of error-free
// products. Bounds use eps = 2^-53 and gamma_n = n eps / (1 - n eps) (Higham 2002, ch. 3); they hold
// for the input range of Ray64 (no overflow; every input a multiple of 2^-252, so every product of at
// most four inputs or input differences is a multiple of 2^-1008 and no error term is lost to underflow).
#include "core/exact_float64.hpp"

#include <cmath>
#include <initializer_list>
#include <limits>

namespace spacebvh::exact {

void two_product(double a, double b, double& p, double& e) {
    p = a * b;
    e = std::fma(a, b, -p);  // explicit FMA: exact error of the rounded product
}

namespace {

constexpr double kEps = 0x1p-53;

// An input difference a - b held exactly as hi + lo (two-sum of a and -b).
struct Pair {
    double hi, lo;
};
Pair exact_difference(double a, double b) {
    Pair d;
    two_sum(a, -b, d.hi, d.lo);
    return d;
}
Pair single(double a) { return {a, 0.0}; }

// Adds sign * f[0] * f[1] * ... exactly: every choice of one part per factor, each product expanded
// by two_product (a k-factor product of doubles is 2^(k-1) doubles).
template <size_t Capacity>
void add_product(Expansion<Capacity>& sum, double sign, std::initializer_list<Pair> factors) {
    double terms[64];
    size_t count = 1;
    terms[0] = sign;
    for (const Pair& factor : factors) {
        double next[64];
        size_t next_count = 0;
        for (size_t i = 0; i < count; ++i)
            for (double part : {factor.hi, factor.lo}) {
                if (part == 0.0) continue;
                double p, e;
                two_product(terms[i], part, p, e);
                if (p != 0.0) next[next_count++] = p;
                if (e != 0.0) next[next_count++] = e;
            }
        for (size_t i = 0; i < next_count; ++i) terms[i] = next[i];
        count = next_count;
    }
    for (size_t i = 0; i < count; ++i) sum.add(terms[i]);
}

// Exact sign of the triple product x · (y × z) of three exact vectors: six products of three factors,
// at most 6 * 32 terms.
int triple_product_sign(const Pair x[3], const Pair y[3], const Pair z[3]) {
    Expansion<6 * 32 + 1> sum;
    for (int i = 0; i < 3; ++i) {
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        add_product(sum, 1.0, {x[i], y[j], z[k]});
        add_product(sum, -1.0, {x[i], y[k], z[j]});
    }
    return sum.sign();
}

// Double estimate of x · (y × z) and the sum of the magnitudes of its six products.
struct Estimate {
    double value, magnitude;
};
Estimate triple_product(const Vec3d& x, const Vec3d& y, const Vec3d& z) {
    const double cx = y[1] * z[2] - y[2] * z[1];
    const double cy = y[2] * z[0] - y[0] * z[2];
    const double cz = y[0] * z[1] - y[1] * z[0];
    const double value = x[0] * cx + x[1] * cy + x[2] * cz;
    const double magnitude = std::fabs(x[0]) * (std::fabs(y[1] * z[2]) + std::fabs(y[2] * z[1])) +
                             std::fabs(x[1]) * (std::fabs(y[2] * z[0]) + std::fabs(y[0] * z[2])) +
                             std::fabs(x[2]) * (std::fabs(y[0] * z[1]) + std::fabs(y[1] * z[0]));
    return {value, magnitude};
}
Vec3d sub(const Vec3d& a, const Vec3d& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

// Filter constants. A product of three factors, each rounded once (input differences) or exact, is
// rounded once per multiplication, once in the 2x2 difference and twice in the sum of three:
//   edge function (d exact, p - o and q - o rounded): |error| <= gamma_7 * M,
//   orientation  (v0 - o, v1 - o, v2 - o rounded):   |error| <= gamma_8 * M,
// with M the exact magnitude sum over the exact factors; the computed M (positive terms, gamma_6) over
// rounded factors (gamma_3) is within gamma_10 of it. 2^-50 = 8 eps > gamma_7 (1 + gamma_10) covers
// the edge function (and the 2x2 determinants of is_degenerate, gamma_4). The range test adds one subtraction and tmin
// * den (|error| <= gamma_8 Mnum + |tmin| gamma_8 Mden + 2 eps (Mnum + |tmin| Mden)): 2^-48 = 32 eps covers it.
constexpr double kTripleProductBound = 0x1p-50;
constexpr double kRangeBound = 0x1p-48;
// Below this magnitude sum the relative bounds could meet subnormal rounding: decide exactly.
constexpr double kSmallestTrusted = 0x1p-900;

// Exact sign of num - tau * den (num and den as in intersect below): t >= tau and t <= tau when the
// filter cannot decide.
int range_sign_exact(const Ray64& ray, const Triangle64& tri, double tau) {
    Pair a[3], b[3], c[3], e1[3], e2[3];
    for (int i = 0; i < 3; ++i) {
        a[i] = exact_difference(tri.v0[i], ray.org[i]);
        b[i] = exact_difference(tri.v1[i], ray.org[i]);
        c[i] = exact_difference(tri.v2[i], ray.org[i]);
        e1[i] = exact_difference(tri.v1[i], tri.v0[i]);
        e2[i] = exact_difference(tri.v2[i], tri.v0[i]);
    }
    // num = a · (b × c) (at most 192 terms), tau * den = tau * d · (e1 × e2) (at most 192 terms).
    Expansion<2 * 6 * 32 + 1> sum;
    for (int i = 0; i < 3; ++i) {
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        add_product(sum, 1.0, {a[i], b[j], c[k]});
        add_product(sum, -1.0, {a[i], b[k], c[j]});
        if (tau != 0.0) {
            add_product(sum, -1.0, {single(tau), single(ray.dir[i]), e1[j], e2[k]});
            add_product(sum, 1.0, {single(tau), single(ray.dir[i]), e1[k], e2[j]});
        }
    }
    return sum.sign();
}

}  // namespace

namespace {

// The edge function with p - o and q - o already rounded (shared by the three edges of a triangle).
double edge_function_relative(const Vec3d& o, const Vec3d& d, const Vec3d& p, const Vec3d& q, const Vec3d& p_rounded,
                              const Vec3d& q_rounded) {
    const Estimate estimate = triple_product(d, p_rounded, q_rounded);
    if (std::fabs(estimate.value) > kTripleProductBound * estimate.magnitude && estimate.magnitude > kSmallestTrusted)
        return estimate.value;
    Pair dir[3], p_rel[3], q_rel[3];
    for (int i = 0; i < 3; ++i) {
        dir[i] = single(d[i]);
        p_rel[i] = exact_difference(p[i], o[i]);
        q_rel[i] = exact_difference(q[i], o[i]);
    }
    const int sign = triple_product_sign(dir, p_rel, q_rel);
    if (sign == 0) return 0.0;
    // The exact sign with the estimate's size where they agree (barycentrics), else the smallest normal.
    const double size = (estimate.value > 0.0) == (sign > 0) && estimate.value != 0.0
                            ? std::fabs(estimate.value)
                            : std::numeric_limits<double>::min();
    return sign > 0 ? size : -size;
}

}  // namespace

double edge_function(const Vec3d& o, const Vec3d& d, const Vec3d& p, const Vec3d& q) {
    return edge_function_relative(o, d, p, q, sub(p, o), sub(q, o));
}

bool is_degenerate(const Triangle64& tri) {
    const Vec3d e1 = sub(tri.v1, tri.v0), e2 = sub(tri.v2, tri.v0);
    // Filter per component: e1j e2k - e1k e2j with rounded differences (2), a product (3) and the
    // difference (4): |error| <= gamma_4 (|e1j e2k| + |e1k e2j|) (1 + gamma_4) < 2^-50 (...).
    for (int i = 0; i < 3; ++i) {
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        const double value = e1[j] * e2[k] - e1[k] * e2[j];
        const double magnitude = std::fabs(e1[j] * e2[k]) + std::fabs(e1[k] * e2[j]);
        if (std::fabs(value) > kTripleProductBound * magnitude && magnitude > kSmallestTrusted) return false;
    }
    for (int i = 0; i < 3; ++i) {
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        const Pair a = exact_difference(tri.v1[j], tri.v0[j]), b = exact_difference(tri.v2[k], tri.v0[k]);
        const Pair c = exact_difference(tri.v1[k], tri.v0[k]), d = exact_difference(tri.v2[j], tri.v0[j]);
        Expansion<2 * 8 + 1> sum;
        add_product(sum, 1.0, {a, b});
        add_product(sum, -1.0, {c, d});
        if (sum.sign() != 0) return false;
    }
    return true;
}

std::optional<ExactHit> intersect(const Ray64& ray, const Triangle64& tri, bool degenerate) {
    if (degenerate) return std::nullopt;  // never hit (scene conventions)
    // Edge functions opposite v0, v1, v2 (Plücker): exact signs, so a ray through a shared edge or
    // vertex gets the same zero or the same opposite signs in every triangle there (watertight and
    // closed); inside when no two signs differ.
    const Vec3d a = sub(tri.v0, ray.org), b = sub(tri.v1, ray.org), c = sub(tri.v2, ray.org);
    const double u = edge_function_relative(ray.org, ray.dir, tri.v1, tri.v2, b, c);
    const double v = edge_function_relative(ray.org, ray.dir, tri.v2, tri.v0, c, a);
    if ((u < 0.0 && v > 0.0) || (u > 0.0 && v < 0.0)) return std::nullopt;
    const double w = edge_function_relative(ray.org, ray.dir, tri.v0, tri.v1, a, b);
    const bool any_negative = u < 0.0 || v < 0.0 || w < 0.0;
    const bool any_positive = u > 0.0 || v > 0.0 || w > 0.0;
    if (any_negative == any_positive) return std::nullopt;  // outside, or the ray in the plane

    // u + v + w = d · n exactly (n = (v1 - v0) × (v2 - v0)), so the shared sign is that of the
    // denominator of t = num / den, num = (v0 - o) · ((v1 - o) × (v2 - o)).
    const int den_sign = any_positive ? 1 : -1;
    const Estimate num = triple_product(a, b, c);
    const Estimate den = triple_product(ray.dir, sub(tri.v1, tri.v0), sub(tri.v2, tri.v0));
    // t >= tau exactly when sign(num - tau den) * sign(den) >= 0.
    auto at_or_after = [&](double tau) {
        const double value = num.value - tau * den.value;
        const double bound = kRangeBound * (num.magnitude + std::fabs(tau) * den.magnitude);
        const int sign = std::fabs(value) > bound && bound > kSmallestTrusted ? (value > 0.0 ? 1 : -1)
                                                                              : range_sign_exact(ray, tri, tau);
        return sign * den_sign;  // > 0: t > tau, 0: t == tau, < 0: t < tau
    };
    if (ray.tmin != -std::numeric_limits<double>::infinity()) {
        if (ray.tmin == std::numeric_limits<double>::infinity() || at_or_after(ray.tmin) < 0) return std::nullopt;
    }
    if (ray.tmax != std::numeric_limits<double>::infinity()) {
        if (ray.tmax == -std::numeric_limits<double>::infinity() || at_or_after(ray.tmax) > 0) return std::nullopt;
    }
    // t rounded; kept inside the exact range the tests above established.
    // u + v + w has the exact sign of den (its terms share it) where the estimate of den does not.
    const double sum = u + v + w;
    const double den_value = den.value != 0.0 && (den.value > 0.0) == (den_sign > 0) ? den.value : sum;
    const double t = std::fmin(std::fmax(num.value / den_value, ray.tmin), ray.tmax);
    return ExactHit{t, v / sum, w / sum};
}

}  // namespace spacebvh::exact
