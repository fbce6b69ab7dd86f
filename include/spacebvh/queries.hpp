// SPDX-License-Identifier: MIT
// Exact ray queries beyond the closest hit: every crossing along a ray, crossing counts, the first
// crossing, any crossing, and point containment by parity. docs/queries.md states the rule and what
// it guarantees for closed, open, non-manifold and inconsistently oriented meshes.
//
// The rule in one sentence: the answers are the exact crossings of the ray after its origin has been
// moved sideways by an infinitesimal, fixed amount (symbolic perturbation), so a ray through a shared
// edge or vertex is decided as if it passed just beside it. Each crossing of a connected surface is
// then reported exactly once, with no epsilon and no re-query, and the same on every run and thread
// count. Along the ray the interval [tmin, tmax] is closed: a crossing at exactly tmin or tmax counts.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"

namespace spacebvh {

// One crossing of a ray with a triangle.
struct QueryHit {
    double t = 0.0;                      // distance along the ray in units of |dir|
    uint32_t primitive = kInvalidIndex;  // triangle id (the index into the span the queries were made from)
    double u = 0.0, v = 0.0;             // barycentrics of v1 and v2 (v0's weight is 1 - u - v)
    std::array<double, 3> point{};       // v0 + u (v1 - v0) + v (v2 - v0), computed in double from the triangle

    bool is_hit() const { return primitive != kInvalidIndex; }
};

// The hits of many rays: ray i's hits are hits[offsets[i] .. offsets[i + 1]), sorted by (t, primitive).
struct HitLists {
    std::vector<uint64_t> offsets;  // rays + 1 entries
    std::vector<QueryHit> hits;
};

inline constexpr size_t kNoHitLimit = std::numeric_limits<size_t>::max();

// The fixed direction of containment rays (any direction would do; fixing one makes the answer
// repeatable). Not axis-aligned, so that rays from grid points rarely run along mesh edges.
inline constexpr Vec3 kContainmentDirection{0.4395064455f, 0.6175986299f, 0.6522315667f};

// The queries over one triangle mesh. Built from the triangles and a BVH over them (any builder);
// keeps its own copy of what it needs, so both may be discarded afterwards. Degenerate (zero-area)
// triangles are never hit. Thread-safe: every query is const. Batch queries run across the calling
// thread's oneTBB arena and give the same answers for any thread count.
class RayQueries {
public:
    RayQueries(std::span<const Triangle> triangles, const Bvh& bvh);
    ~RayQueries();
    RayQueries(RayQueries&&) noexcept;
    RayQueries& operator=(RayQueries&&) noexcept;

    size_t triangle_count() const;

    // The crossing with the smallest t (ties: the smaller triangle id), or nothing.
    std::optional<QueryHit> first_hit(const Ray& ray) const;
    // Whether the ray crosses any triangle in [tmin, tmax].
    bool any_hit(const Ray& ray) const;
    // Every crossing, sorted by (t, primitive), at most max_hits of them (the nearest). Replaces `out`.
    void all_hits(const Ray& ray, std::vector<QueryHit>& out, size_t max_hits = kNoHitLimit) const;
    // The number of crossings (what all_hits would return without a cap).
    uint32_t count_hits(const Ray& ray) const;
    // Parity of the crossings of the ray from `point` along kContainmentDirection over [0, inf):
    // inside a closed mesh when odd. A point on the surface counts the crossing at t = 0, which makes
    // it the answer for the point moved infinitesimally backwards along kContainmentDirection.
    bool contains(Vec3 point) const;

    // Batches (rays.size() == out.size(); misses of first_hits have primitive == kInvalidIndex).
    void first_hits(std::span<const Ray> rays, std::span<QueryHit> out) const;
    // The triangle of each first crossing only (kInvalidIndex on a miss): first_hits without the
    // distance, barycentrics and point.
    void first_hit_ids(std::span<const Ray> rays, std::span<uint32_t> out) const;
    void any_hits(std::span<const Ray> rays, std::span<uint8_t> out) const;
    HitLists all_hits(std::span<const Ray> rays, size_t max_hits = kNoHitLimit) const;
    void count_hits(std::span<const Ray> rays, std::span<uint32_t> out) const;
    void contains(std::span<const Vec3> points, std::span<uint8_t> out) const;

    struct Layout;

private:
    std::unique_ptr<Layout> layout_;
};

// The decision for one ray and one triangle under the rule above, without a tree: the reference the
// traversal is tested against and the building block of brute-force checks. Returns the crossing or
// nothing.
std::optional<QueryHit> intersect_triangle_perturbed(const Ray& ray, const Triangle& triangle, uint32_t id);

}  // namespace spacebvh
