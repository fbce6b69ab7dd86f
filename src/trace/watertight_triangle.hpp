// Watertight ray-triangle intersection (Woop, Benthin, Wald, "Watertight Ray/Triangle
// Intersection", JCGT 2013), in float, with a forward error bound: when an edge function is too close
// to zero for its sign to be trusted, the exact double-precision test of verify.hpp decides. The
// answers therefore equal the exact arbiter of ../shared/spec/rays.md, not merely watertight ones.
#pragma once

#include <cmath>
#include <cstdint>
#include <utility>

#include "spacebvh/geometry.hpp"
#include "spacebvh/verify.hpp"

namespace spacebvh::trace {

// Per-ray constants of the shear that maps the ray direction onto +z.
struct WatertightRay {
    Vec3 org;
    int kx = 0, ky = 1, kz = 2;
    float shear_x = 0, shear_y = 0, shear_z = 1;

    explicit WatertightRay(const Ray& ray) : org(ray.org) {
        const Vec3 a{std::fabs(ray.dir.x), std::fabs(ray.dir.y), std::fabs(ray.dir.z)};
        kz = (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
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

// Tests the closed triangle (v0, v1, v2) for a hit with t in [tmin, tmax]. Returns true and fills
// `hit` on a hit. Degenerate triangles never hit.
inline bool intersect_watertight(const Ray& ray, const WatertightRay& w, const Vec3& v0, const Vec3& v1,
                                 const Vec3& v2, float tmax, TriangleHit& hit) {
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
        return max(std::fabs(p[w.kx]) + std::fabs(w.shear_x * p[w.kz]), std::fabs(p[w.ky]) + std::fabs(w.shear_y * p[w.kz]));
    };
    const float magnitude = max(max(magnitude_of(a), magnitude_of(b)), magnitude_of(c));
    const float size = max(max(max(std::fabs(ax), std::fabs(ay)), max(std::fabs(bx), std::fabs(by))),
                           max(std::fabs(cx), std::fabs(cy)));
    const float error_bound = 32.0f * 0x1p-24f * magnitude * size;

    const bool clearly_outside = (u < -error_bound || v < -error_bound || wgt < -error_bound) &&
                                 (u > error_bound || v > error_bound || wgt > error_bound);
    if (clearly_outside) return false;
    const bool clearly_inside = (u > error_bound && v > error_bound && wgt > error_bound) ||
                                (u < -error_bound && v < -error_bound && wgt < -error_bound);
    if (!clearly_inside) {
        // Near an edge or vertex (or a degenerate triangle): the exact test decides.
        Ray bounded = ray;
        bounded.tmax = tmax;
        const auto t = intersect_triangle_exact(bounded, Triangle{v0, v1, v2});
        if (!t) return false;
        const float det = u + v + wgt;
        hit.t = float(*t);
        hit.u = det != 0.0f ? v / det : 0.0f;
        hit.v = det != 0.0f ? wgt / det : 0.0f;
        return true;
    }

    const float det = u + v + wgt;
    const float az = w.shear_z * a[w.kz], bz = w.shear_z * b[w.kz], cz = w.shear_z * c[w.kz];
    const float t_scaled = u * az + v * bz + wgt * cz;
    const float t = t_scaled / det;
    if (!(t >= ray.tmin && t <= tmax)) return false;
    hit.t = t;
    hit.u = v / det;
    hit.v = wgt / det;
    return true;
}

}  // namespace spacebvh::trace
