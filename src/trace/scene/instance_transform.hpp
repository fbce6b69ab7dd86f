// SPDX-License-Identifier: MIT
// An instance's transform as tracing uses it: the float inverse that takes rays into the instance's
// space (one fixed evaluation, docs/scenes.md), and the instance's box in the parent's space with
// the padding that keeps the parent's box tests conservative for the ray that will be transformed.
#pragma once

#include <array>

#include "spacebvh/geometry.hpp"
#include "spacebvh/scene.hpp"

namespace spacebvh::scene {

// The largest condition number ||A|| * ||A^-1|| (infinity norms) an instance transform may have: the
// padding bound below assumes the ray transform's rounding stays far below the box sizes.
inline constexpr double kMaxConditionNumber = 65536.0;

// A box-test allowance that grows with the ray origin: a reported hit at t on a ray r lies within
// pad0 + pad1 * |r.org|_inf of the box it belongs to (docs/scenes.md, "Boxes of instances").
struct Padding {
    double pad0 = 0.0, pad1 = 0.0;
};

struct InstanceTransform {
    std::array<float, 9> inverse{};        // A^-1 rounded to float, row-major
    std::array<float, 3> inverse_shift{};  // -(A^-1 b) rounded to float
    AABB box;                              // the child's box in the parent's space, rounded outward
    Padding padding;                       // of box, for rays in the parent's space
};

// Validates `transform` and derives the above for a child whose root box is `child_box` with root
// padding `child`. Throws Error starting with `what` for a non-finite, singular or too badly
// conditioned transform.
InstanceTransform make_instance_transform(const Affine& transform, const AABB& child_box, Padding child,
                                          const std::string& what);

// The box of `child_box` (in the child's space) seen from the parent with this transform (the exact
// inverse of the float inverse, in double, rounded outward); used again by refit.
void place_box(InstanceTransform& xf, const AABB& child_box, Padding child);

// The ray in the instance's space: each coordinate of the origin and direction is the sum, left to
// right in double, of the float products (exact in double) and the float shift, rounded once to
// float. tmin and tmax are kept: t measures the same point on both rays.
inline Ray to_instance(const InstanceTransform& xf, const Ray& ray) {
    const auto& a = xf.inverse;
    Ray out = ray;
    for (int i = 0; i < 3; ++i) {
        const double ox = double(a[3 * i]) * ray.org.x + double(a[3 * i + 1]) * ray.org.y +
                          double(a[3 * i + 2]) * ray.org.z + double(xf.inverse_shift[i]);
        const double dx =
            double(a[3 * i]) * ray.dir.x + double(a[3 * i + 1]) * ray.dir.y + double(a[3 * i + 2]) * ray.dir.z;
        out.org[i] = float(ox);
        out.dir[i] = float(dx);
    }
    return out;
}

// to_instance with the matrix held as double columns, four lanes wide (GCC vector extensions: AVX
// where the build has it, SSE halves otherwise): lane i computes coordinate i with the operations of
// to_instance in the same order (exact float products, summed left to right, one rounding to float),
// so the two agree bit for bit; a scene keeps one per instance it enters often (scene::TopRecord).
struct RayTransform {
    using D4 = double __attribute__((vector_size(32)));
    D4 column[3]{};  // column j: A^-1's entries (i, j) for i = 0, 1, 2, then 0
    D4 shift{};      // the float shift, then 0

    RayTransform() = default;
    RayTransform(const float* inverse, const float* shift_) {
        for (int j = 0; j < 3; ++j)
            column[j] = D4{double(inverse[j]), double(inverse[3 + j]), double(inverse[6 + j]), 0.0};
        shift = D4{double(shift_[0]), double(shift_[1]), double(shift_[2]), 0.0};
    }
    explicit RayTransform(const InstanceTransform& xf) : RayTransform(xf.inverse.data(), xf.inverse_shift.data()) {}

    Ray apply(const Ray& ray) const {
        Ray out;
        apply_finite(ray, out);
        return out;
    }

    // apply, and whether the ray in the instance's space is finite (is_finite_ray): rounded to
    // float four lanes at once, a coordinate that overflowed is +-inf there, and x - x is 0 for
    // every finite x and NaN for an infinite one, so one compare of the sum checks all six.
    bool apply_finite(const Ray& ray, Ray& out) const {
        using F4 = float __attribute__((vector_size(16)));
        const D4 org =
            (column[0] * double(ray.org.x) + column[1] * double(ray.org.y)) + column[2] * double(ray.org.z) + shift;
        const D4 dir = (column[0] * double(ray.dir.x) + column[1] * double(ray.dir.y)) + column[2] * double(ray.dir.z);
        const F4 o = __builtin_convertvector(org, F4), d = __builtin_convertvector(dir, F4);
        out = ray;
        for (int i = 0; i < 3; ++i) {
            out.org[i] = o[i];
            out.dir[i] = d[i];
        }
        const F4 zero = (o - o) + (d - d);
        return zero[0] == 0.0f && zero[1] == 0.0f && zero[2] == 0.0f;
    }
};

// A ray whose image in an instance's space overflows float (a world ray near FLT_MAX taken through
// a scaling transform) cannot meet the instance's float triangles: the walks skip the instance. The
// kernels need finite origins and directions (an infinite origin makes every slab distance NaN).
inline bool is_finite_ray(const Ray& ray) { return is_finite(ray.org) && is_finite(ray.dir); }

}  // namespace spacebvh::scene
