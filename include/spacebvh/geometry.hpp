// SPDX-License-Identifier: MIT
// Basic geometry: vectors, axis-aligned boxes, rays and triangles (float32, as the ray files of
// docs/rays.md). Kept header-only and small: every module includes it.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

namespace spacebvh {

inline constexpr float kInfinity = std::numeric_limits<float>::infinity();
inline constexpr uint32_t kInvalidIndex = 0xFFFFFFFFu;

struct Vec3 {
    float x = 0, y = 0, z = 0;

    constexpr Vec3() = default;
    constexpr Vec3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
    constexpr explicit Vec3(float s) : x(s), y(s), z(s) {}

    constexpr float operator[](int axis) const { return axis == 0 ? x : (axis == 1 ? y : z); }
    constexpr float& operator[](int axis) { return axis == 0 ? x : (axis == 1 ? y : z); }

    friend constexpr Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
    friend constexpr Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
    friend constexpr Vec3 operator*(Vec3 a, Vec3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
    friend constexpr Vec3 operator*(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
    friend constexpr Vec3 operator*(float s, Vec3 a) { return a * s; }
    friend constexpr Vec3 operator/(Vec3 a, float s) { return {a.x / s, a.y / s, a.z / s}; }
    friend constexpr Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
    friend constexpr bool operator==(Vec3 a, Vec3 b) = default;
};

constexpr float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline float length(Vec3 a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalize(Vec3 a) { return a / length(a); }
constexpr Vec3 min(Vec3 a, Vec3 b) { return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)}; }
constexpr Vec3 max(Vec3 a, Vec3 b) { return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}; }
inline bool is_finite(Vec3 a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }

// Axis-aligned box. The default box is empty (lo = +inf, hi = -inf) so that extend() works from it.
struct AABB {
    Vec3 lo{kInfinity};
    Vec3 hi{-kInfinity};

    static constexpr AABB empty() { return {}; }
    static constexpr AABB of_point(Vec3 p) { return {p, p}; }

    constexpr bool is_empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    constexpr void extend(Vec3 p) {
        lo = min(lo, p);
        hi = max(hi, p);
    }
    constexpr void extend(const AABB& b) {
        lo = min(lo, b.lo);
        hi = max(hi, b.hi);
    }
    constexpr Vec3 extent() const { return hi - lo; }
    constexpr Vec3 center() const { return (lo + hi) * 0.5f; }
    constexpr float centroid(int axis) const { return 0.5f * (lo[axis] + hi[axis]); }

    // Surface area and volume of an empty box are 0, so empty children cost nothing.
    constexpr float area() const {
        if (is_empty()) return 0.0f;
        Vec3 e = extent();
        return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
    }
    constexpr float volume() const {
        if (is_empty()) return 0.0f;
        Vec3 e = extent();
        return e.x * e.y * e.z;
    }
    constexpr int largest_axis() const {
        Vec3 e = extent();
        return (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
    }
    constexpr bool contains(Vec3 p) const {
        return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
    }
    constexpr bool contains(const AABB& b) const { return b.is_empty() || (contains(b.lo) && contains(b.hi)); }
    friend constexpr bool operator==(const AABB& a, const AABB& b) = default;
};

constexpr AABB merge(const AABB& a, const AABB& b) { return {min(a.lo, b.lo), max(a.hi, b.hi)}; }
// Surface area in double precision from the float box: how the tree SAH (and the reinsertion
// optimiser pricing it) measures areas, so that sums over many nodes keep their precision.
constexpr double area_in_double(const AABB& box) {
    if (box.is_empty()) return 0.0;
    const double ex = double(box.hi.x) - double(box.lo.x);
    const double ey = double(box.hi.y) - double(box.lo.y);
    const double ez = double(box.hi.z) - double(box.lo.z);
    return 2.0 * (ex * ey + ey * ez + ez * ex);
}
// Intersection of two boxes; empty (lo > hi on some axis) when they are disjoint.
constexpr AABB intersect(const AABB& a, const AABB& b) { return {max(a.lo, b.lo), min(a.hi, b.hi)}; }

// A ray as in the ray files: t is measured in units of |dir|, hits count for t in [tmin, tmax].
struct Ray {
    Vec3 org;
    Vec3 dir;
    float tmin = 0.0f;
    float tmax = kInfinity;
};

struct Triangle {
    Vec3 v0, v1, v2;

    constexpr AABB bounds() const {
        AABB b = AABB::of_point(v0);
        b.extend(v1);
        b.extend(v2);
        return b;
    }
    constexpr Vec3 geometric_normal() const { return cross(v1 - v0, v2 - v0); }
    // Zero-area triangles are legal input, kept in numbering, and never hit. Written as comparisons
    // of products (no subtraction) so that FMA contraction cannot change the answer between builds:
    // the float32 cross product of the edges is exactly zero.
    constexpr bool is_degenerate() const {
        const Vec3 e1 = v1 - v0, e2 = v2 - v0;
        return e1.y * e2.z == e1.z * e2.y && e1.z * e2.x == e1.x * e2.z && e1.x * e2.y == e1.y * e2.x;
    }
    constexpr Vec3 vertex(int i) const { return i == 0 ? v0 : (i == 1 ? v1 : v2); }
};

// The box of a triangle list (empty for none).
inline AABB bounds_of(std::span<const Triangle> triangles) {
    AABB box;
    for (const Triangle& triangle : triangles) box.extend(triangle.bounds());
    return box;
}

}  // namespace spacebvh
