// SPDX-License-Identifier: MIT
// Watertight ray-triangle intersection (Woop, Benthin, Wald, "Watertight Ray/Triangle
// Intersection", JCGT 2013), in float, with a forward error bound: when an edge function is too close
// to zero for its sign to be trusted, the exact double-precision test of verify.hpp decides. The
// answers therefore equal the exact arbiter of docs/rays.md, not merely watertight ones.
#pragma once

#include <cmath>
#include <cstdint>
#include <utility>

#include "spacebvh/geometry.hpp"
#include "core/exact_triangle.hpp"

namespace spacebvh::trace {

// Absolute slack of the edge functions' error bound for results in the subnormal range (see
// intersect_watertight): far above the few 2^-150 roundings, far below any normal-range bound.
inline constexpr float kUnderflowBound = 0x1p-140f;

// The axis of the largest direction component (ties to the lower axis): the shear's kz.
inline int dominant_axis(const Vec3& dir) {
    const Vec3 a{std::fabs(dir.x), std::fabs(dir.y), std::fabs(dir.z)};
    return (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
}

// Per-ray constants of the shear that maps the ray direction onto +z.
struct WatertightRay {
    Vec3 org;
    int kx = 0, ky = 1, kz = 2;
    float shear_x = 0, shear_y = 0, shear_z = 1;

    WatertightRay() = default;
    explicit WatertightRay(const Ray& ray) : org(ray.org) {
        kz = dominant_axis(ray.dir);
        kx = (kz + 1) % 3;
        ky = (kx + 1) % 3;
        if (ray.dir[kz] < 0.0f) std::swap(kx, ky);  // keep the winding, so det's sign is meaningful
        shear_x = ray.dir[kx] / ray.dir[kz];
        shear_y = ray.dir[ky] / ray.dir[kz];
        shear_z = 1.0f / ray.dir[kz];
    }
};

struct TriangleHit {
    float t, u, v;
};

// Hit distance from the plane equation in double: t = n.(v0 - org) / n.dir. Differences and products
// of floats are (nearly) exact in double, so t keeps its digits even when, in float, the sheared depths
// of a long sliver triangle would cancel (a triangle 188 units long hit at t = 0.5 lost 3 digits).
inline double plane_hit_distance(const Ray& ray, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
    const double e1x = double(v1.x) - v0.x, e1y = double(v1.y) - v0.y, e1z = double(v1.z) - v0.z;
    const double e2x = double(v2.x) - v0.x, e2y = double(v2.y) - v0.y, e2z = double(v2.z) - v0.z;
    const double nx = e1y * e2z - e1z * e2y, ny = e1z * e2x - e1x * e2z, nz = e1x * e2y - e1y * e2x;
    const double px = double(v0.x) - ray.org.x, py = double(v0.y) - ray.org.y, pz = double(v0.z) - ray.org.z;
    return (nx * px + ny * py + nz * pz) / (nx * ray.dir.x + ny * ray.dir.y + nz * ray.dir.z);
}

// The rare case (near an edge or vertex, or a degenerate triangle): the exact test decides. Kept out
// of line so the hot float path stays small enough to inline into the traversal loop.
[[gnu::noinline, gnu::cold]] inline bool decide_exactly(const Ray& ray, const Vec3& v0, const Vec3& v1, const Vec3& v2,
                                                        float tmax, float u, float v, float w, TriangleHit& hit) {
    Ray bounded = ray;
    bounded.tmax = tmax;
    const auto t = intersect_triangle_exact(bounded, Triangle{v0, v1, v2});
    if (!t) return false;
    const float det = u + v + w;
    hit.t = float(*t);
    hit.u = det != 0.0f ? v / det : 0.0f;
    hit.v = det != 0.0f ? w / det : 0.0f;
    return true;
}

// The ray certainly crosses the triangle's interior (every edge function u, v, w clearly of one sign);
// only the distance is left. Shared by the scalar test and the four-wide test of wide_kernel.inl.
[[gnu::always_inline]] inline bool finish_crossing(const Ray& ray, const Vec3& v0, const Vec3& v1, const Vec3& v2,
                                                   float tmax, float u, float v, float w, TriangleHit& hit) {
    const float det = u + v + w;
    const double t = plane_hit_distance(ray, v0, v1, v2);
    if (!(t >= ray.tmin && t <= tmax)) return false;
    hit.t = float(t);
    hit.u = v / det;
    hit.v = w / det;
    return true;
}

// Tests the closed triangle (v0, v1, v2) for a hit with t in [tmin, tmax]. Returns true and fills
// `hit` on a hit. Degenerate triangles never hit.
[[gnu::always_inline]] inline bool intersect_watertight(const Ray& ray, const WatertightRay& w, const Vec3& v0,
                                                        const Vec3& v1, const Vec3& v2, float tmax, TriangleHit& hit) {
    const Vec3 a = v0 - w.org, b = v1 - w.org, c = v2 - w.org;
    const float ax = a[w.kx] - w.shear_x * a[w.kz], ay = a[w.ky] - w.shear_y * a[w.kz];
    const float bx = b[w.kx] - w.shear_x * b[w.kz], by = b[w.ky] - w.shear_y * b[w.kz];
    const float cx = c[w.kx] - w.shear_x * c[w.kz], cy = c[w.ky] - w.shear_y * c[w.kz];
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float wgt = bx * ay - by * ax;

    // Error bound of the edge functions: each sheared coordinate carries an error of a few ulps of
    // the magnitudes it was computed from (M), and each edge function is a difference of products of
    // those coordinates (magnitude at most S).
    // Plain comparisons (not std::fmax, which is an out-of-line libm call): inputs are finite here.
    auto max = [](float x, float y) { return x > y ? x : y; };
    auto magnitude_of = [&](const Vec3& p) {
        return max(std::fabs(p[w.kx]) + std::fabs(w.shear_x * p[w.kz]),
                   std::fabs(p[w.ky]) + std::fabs(w.shear_y * p[w.kz]));
    };
    const float magnitude = max(max(magnitude_of(a), magnitude_of(b)), magnitude_of(c));
    const float size = max(max(max(std::fabs(ax), std::fabs(ay)), max(std::fabs(bx), std::fabs(by))),
                           max(std::fabs(cx), std::fabs(cy)));
    // The absolute term covers underflow: on a tiny scene the products fall below the normal range,
    // where rounding errors are absolute (at most 2^-150 each), not relative.
    const float error_bound = 32.0f * 0x1p-24f * magnitude * size + kUnderflowBound;

    const bool clearly_outside = (u < -error_bound || v < -error_bound || wgt < -error_bound) &&
                                 (u > error_bound || v > error_bound || wgt > error_bound);
    if (clearly_outside) return false;
    const bool clearly_inside = (u > error_bound && v > error_bound && wgt > error_bound) ||
                                (u < -error_bound && v < -error_bound && wgt < -error_bound);
    if (!clearly_inside) [[unlikely]]
        return decide_exactly(ray, v0, v1, v2, tmax, u, v, wgt, hit);

    return finish_crossing(ray, v0, v1, v2, tmax, u, v, wgt, hit);
}

}  // namespace spacebvh::trace
