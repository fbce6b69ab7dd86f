// SPDX-License-Identifier: MIT
#include "trace/distance/exact_distance.hpp"

namespace spacebvh::trace::distance {

namespace {

struct E3 {
    Dyadic x, y, z;
};
E3 exact(D3 p) { return {Dyadic(p.x), Dyadic(p.y), Dyadic(p.z)}; }
E3 exact(const Vec3& p) { return {Dyadic(double(p.x)), Dyadic(double(p.y)), Dyadic(double(p.z))}; }
E3 operator-(const E3& a, const E3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Dyadic dot(const E3& a, const E3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
E3 cross(const E3& a, const E3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
ExactSquaredDistance to_point(const E3& d) { return {dot(d, d), Dyadic(1.0)}; }
// The squared distance from the end of d (measured from a point of the line) to the line along e:
// (|d|^2 |e|^2 - (d.e)^2) / |e|^2.
ExactSquaredDistance to_line(const E3& d, const E3& e) {
    const Dyadic de = dot(d, e), ee = dot(e, e);
    return {dot(d, d) * ee - de * de, ee};
}

}  // namespace

ExactSquaredDistance exact_squared_distance(D3 point, const Vec3& va, const Vec3& vb, const Vec3& vc) {
    const E3 p = exact(point), a = exact(va), b = exact(vb), c = exact(vc);
    const E3 ab = b - a, ac = c - a, ap = p - a;
    const Dyadic d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1.sign() <= 0 && d2.sign() <= 0) return to_point(ap);
    const E3 bp = p - b;
    const Dyadic d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3.sign() >= 0 && compare(d4, d3) <= 0) return to_point(bp);
    const Dyadic vcc = d1 * d4 - d3 * d2;
    if (vcc.sign() <= 0 && d1.sign() >= 0 && d3.sign() <= 0) return to_line(ap, ab);
    const E3 cp = p - c;
    const Dyadic d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6.sign() >= 0 && compare(d5, d6) <= 0) return to_point(cp);
    const Dyadic vbb = d5 * d2 - d1 * d6;
    if (vbb.sign() <= 0 && d2.sign() >= 0 && d6.sign() <= 0) return to_line(ap, ac);
    const Dyadic vaa = d3 * d6 - d5 * d4;
    if (vaa.sign() <= 0 && compare(d4, d3) >= 0 && compare(d5, d6) >= 0) return to_line(bp, c - b);
    const E3 n = cross(ab, ac);
    const Dyadic h = dot(ap, n);
    return {h * h, dot(n, n)};
}

int compare(const ExactSquaredDistance& x, const ExactSquaredDistance& y) {
    return compare(x.num * y.den, y.num * x.den);
}

int compare(const ExactSquaredDistance& x, double bound) {
    const Dyadic b(bound);
    return compare(x.num, b * b * x.den);
}

}  // namespace spacebvh::trace::distance
