// SPDX-License-Identifier: MIT
// Leaf triangles in SoA packs of four, and the four-wide watertight test on them: the leaf layout and
// leaf test of every kernel (binary, BVH4, BVH8, packets), so one copy of the exact test exists.
//
// Everything here is SSE, the x86-64 baseline, and always inlined: inlined into the AVX2 and AVX-512
// kernels of kernel_instances.cpp it is compiled for their instructions.
#pragma once

#include <immintrin.h>

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include <span>

#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/trace.hpp"
#include "trace/layout/huge_page_allocator.hpp"
#include "trace/leaf_tests/watertight_triangle.hpp"

namespace spacebvh::trace {

// Four triangles in SoA: vertex[k][axis][lane]. Lanes past the last filled one are unused (zero).
struct alignas(16) TrianglePack {
    float vertex[3][3][4];
    uint32_t primitive[4];
};
static_assert(sizeof(TrianglePack) == 160);

using TrianglePacks = std::vector<TrianglePack, HugePageAllocator<TrianglePack>>;

// Appends the non-degenerate triangles of binary leaf `leaf` (degenerate ones are never hit, so no
// layout stores them).
inline void append_live_triangles(std::span<const Triangle> triangles, const Bvh& bvh, const BvhNode& leaf,
                                  std::vector<uint32_t>& out) {
    for (uint32_t i = leaf.first; i < leaf.first + leaf.reference_count; ++i)
        if (!triangles[bvh.primitives[i]].is_degenerate()) out.push_back(bvh.primitives[i]);
}

// Lays out the triangles of leaves, in the order the layout visits them, into shared packs. A kernel
// tests a leaf as {first pack, lane count}: lanes 0 .. count-1 of packs first, first + 1, ...
//
// Most leaves of an SAH tree hold one to three triangles, so a pack per leaf would leave half the
// lanes (and of the memory a ray fetches) empty. Instead a leaf whose new triangles fit in the lanes
// left in the last pack goes there, and its count covers the triangles of the earlier leaves in that
// pack too. Testing those costs nothing (the four lanes are tested together) and cannot change an
// answer: each is a real triangle of the scene, and a hit on it is a real hit within [tmin, tmax],
// which only narrows tmax sooner. A triangle already in that pack (a neighbour's clipped reference)
// is not stored twice. Degenerate triangles are dropped: they are never hit.
class LeafPacker {
public:
    LeafPacker(std::span<const Triangle> triangles, const Bvh& bvh, TrianglePacks& packs)
        : triangles_(triangles), bvh_(bvh), packs_(packs) {}

    // Returns {first pack, lane count}; {0, 0} when every triangle of the leaf is degenerate.
    std::pair<uint32_t, uint32_t> add(const BvhNode& leaf);
    // The same for a leaf of these triangles (distinct; a merged subtree, wide_collapse.hpp).
    std::pair<uint32_t, uint32_t> add(std::span<const uint32_t> triangles);

private:
    void put(uint32_t primitive);

    std::span<const Triangle> triangles_;
    const Bvh& bvh_;
    TrianglePacks& packs_;
    uint32_t open_lanes_ = 4;        // lanes filled in packs_.back(); 4 = no room left
    std::vector<uint32_t> scratch_;  // scratch of add()
};

// Per-ray constants of the four-wide watertight triangle test (the shear of WatertightRay, broadcast).
// The origin is stored already permuted into the shear's axes (kx, ky, kz) and the axes as float
// offsets into a vertex's planes, so the test reads them at fixed places: indexing by kx at every leaf
// made the compiler recompute and spill the addresses per leaf visit.
struct PackRay {
    __m128 org_x, org_y, org_z;
    __m128 shear_x, shear_y;
    uint32_t plane_x = 0, plane_y = 4, plane_z = 8;

    PackRay() = default;
    explicit PackRay(const WatertightRay& w)
        : org_x(_mm_set1_ps(w.org[w.kx])),
          org_y(_mm_set1_ps(w.org[w.ky])),
          org_z(_mm_set1_ps(w.org[w.kz])),
          shear_x(_mm_set1_ps(w.shear_x)),
          shear_y(_mm_set1_ps(w.shear_y)),
          plane_x(uint32_t(4 * w.kx)),
          plane_y(uint32_t(4 * w.ky)),
          plane_z(uint32_t(4 * w.kz)) {}
};

struct PackEdges {
    alignas(16) float u[4], v[4], w[4];
    int outside, inside;  // lane masks: clearly outside, clearly inside (see intersect_watertight)
};

[[gnu::always_inline]] inline __m128 abs4(__m128 x) { return _mm_andnot_ps(_mm_set1_ps(-0.0f), x); }

// The edge functions and their error bound for four triangles: exactly the float operations of
// intersect_watertight, lane by lane, so each lane decides exactly as the scalar test would.
[[gnu::always_inline]] inline void pack_edges(const TrianglePack& pack, const PackRay& ray, PackEdges& edges) {
    __m128 sheared_x[3], sheared_y[3], magnitude = _mm_setzero_ps(), size = _mm_setzero_ps();
    for (int k = 0; k < 3; ++k) {
        const float* planes = pack.vertex[k][0];  // vertex k's three planes, contiguous (float[3][4])
        const __m128 px = _mm_sub_ps(_mm_load_ps(planes + ray.plane_x), ray.org_x);
        const __m128 py = _mm_sub_ps(_mm_load_ps(planes + ray.plane_y), ray.org_y);
        const __m128 pz = _mm_sub_ps(_mm_load_ps(planes + ray.plane_z), ray.org_z);
        const __m128 shift_x = _mm_mul_ps(ray.shear_x, pz), shift_y = _mm_mul_ps(ray.shear_y, pz);
        sheared_x[k] = _mm_sub_ps(px, shift_x);
        sheared_y[k] = _mm_sub_ps(py, shift_y);
        const __m128 vertex_magnitude =
            _mm_max_ps(_mm_add_ps(abs4(px), abs4(shift_x)), _mm_add_ps(abs4(py), abs4(shift_y)));
        magnitude = _mm_max_ps(magnitude, vertex_magnitude);
        size = _mm_max_ps(size, _mm_max_ps(abs4(sheared_x[k]), abs4(sheared_y[k])));
    }
    const __m128 ax = sheared_x[0], ay = sheared_y[0], bx = sheared_x[1], by = sheared_y[1];
    const __m128 cx = sheared_x[2], cy = sheared_y[2];
    const __m128 u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
    const __m128 v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
    const __m128 w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
    const __m128 bound = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(_mm_set1_ps(32.0f * 0x1p-24f), magnitude), size),
                                    _mm_set1_ps(kUnderflowBound));
    const __m128 negative_bound = _mm_sub_ps(_mm_setzero_ps(), bound);
    const __m128 any_below = _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(u, negative_bound), _mm_cmplt_ps(v, negative_bound)),
                                       _mm_cmplt_ps(w, negative_bound));
    const __m128 any_above =
        _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(u, bound), _mm_cmpgt_ps(v, bound)), _mm_cmpgt_ps(w, bound));
    const __m128 all_above =
        _mm_and_ps(_mm_and_ps(_mm_cmpgt_ps(u, bound), _mm_cmpgt_ps(v, bound)), _mm_cmpgt_ps(w, bound));
    const __m128 all_below = _mm_and_ps(_mm_and_ps(_mm_cmplt_ps(u, negative_bound), _mm_cmplt_ps(v, negative_bound)),
                                        _mm_cmplt_ps(w, negative_bound));
    edges.outside = _mm_movemask_ps(_mm_and_ps(any_below, any_above));
    edges.inside = _mm_movemask_ps(_mm_or_ps(all_above, all_below));
    _mm_store_ps(edges.u, u);
    _mm_store_ps(edges.v, v);
    _mm_store_ps(edges.w, w);
}

[[gnu::always_inline]] inline void pack_triangle(const TrianglePack& pack, int lane, Vec3 vertex[3]) {
    for (int k = 0; k < 3; ++k) vertex[k] = {pack.vertex[k][0][lane], pack.vertex[k][1][lane], pack.vertex[k][2][lane]};
}

// The per-lane path of both leaf tests (this one and moller_filter.hpp): the exact test for a lane
// whose edges the float test could not decide, the double-precision distance for one certainly
// inside. u, v, w: the lane's edge functions, weights of v0, v1, v2 times det (for the barycentrics).
// Narrows `tmax` and fills `hit` on a closer hit; returns true when the ray is done (any hit).
template <bool kAnyHit, bool kStats>
[[gnu::always_inline]] inline bool settle_lane(const TrianglePack& pack, int lane, bool inside, float u, float v,
                                               float w, const Ray& ray, float& tmax, Hit& hit, bool& found,
                                               TraversalStats* stats) {
    Vec3 vertex[3];
    pack_triangle(pack, lane, vertex);
    if constexpr (kStats) {
        if (inside)
            ++stats->plane_distances;
        else
            ++stats->exact_tests;
    }
    TriangleHit candidate;
    const bool crossed = inside ? finish_crossing(ray, vertex[0], vertex[1], vertex[2], tmax, u, v, w, candidate)
                                : decide_exactly(ray, vertex[0], vertex[1], vertex[2], tmax, u, v, w, candidate);
    if (!crossed) return false;
    found = true;
    if constexpr (kAnyHit) return true;
    tmax = candidate.t;
    hit = {candidate.t, pack.primitive[lane], candidate.u, candidate.v};
    return false;
}

// Tests a leaf's `count` lanes (from pack `first`) in lane order, so a hit at equal distance resolves
// the same way in every kernel that shares the packing. kScalarTriangles tests them one at a time with the scalar
// test (the reference kernels). Narrows `tmax` and fills `hit` on each closer hit; returns true on a
// hit when kAnyHit.
template <bool kScalarTriangles, bool kAnyHit, bool kStats>
[[gnu::always_inline]] inline bool test_leaf_packs(const TrianglePack* packs, uint32_t first, uint32_t count,
                                                   const Ray& ray, const WatertightRay& shear, const PackRay& pack_ray,
                                                   float& tmax, Hit& hit, bool& found, TraversalStats* stats) {
    for (uint32_t p = 0; p * 4 < count; ++p) {
        const TrianglePack& pack = packs[first + p];
        const uint32_t lanes = count - p * 4 < 4 ? count - p * 4 : 4;
        if constexpr (kStats) stats->triangles_tested += lanes;
        TriangleHit candidate;
        if constexpr (kScalarTriangles) {
            for (uint32_t lane = 0; lane < lanes; ++lane) {
                Vec3 vertex[3];
                pack_triangle(pack, int(lane), vertex);
                if (!intersect_watertight(ray, shear, vertex[0], vertex[1], vertex[2], tmax, candidate)) continue;
                found = true;
                if constexpr (kAnyHit) return true;
                tmax = candidate.t;
                hit = {candidate.t, pack.primitive[lane], candidate.u, candidate.v};
            }
        } else {
            PackEdges edges;
            pack_edges(pack, pack_ray, edges);
            unsigned candidates = unsigned(~edges.outside) & ((1u << lanes) - 1);
            while (candidates) {
                const int lane = __builtin_ctz(candidates);
                candidates &= candidates - 1;
                if (settle_lane<kAnyHit, kStats>(pack, lane, (edges.inside >> lane) & 1, edges.u[lane], edges.v[lane],
                                                 edges.w[lane], ray, tmax, hit, found, stats))
                    return true;
            }
        }
    }
    return false;
}

// Starts fetching a leaf's first pack (three cache lines).
[[gnu::always_inline]] inline void prefetch_pack(const TrianglePack& pack) {
    const char* bytes = reinterpret_cast<const char*>(&pack);
    for (size_t line = 0; line < sizeof(TrianglePack); line += 64) _mm_prefetch(bytes + line, _MM_HINT_T0);
}

}  // namespace spacebvh::trace
