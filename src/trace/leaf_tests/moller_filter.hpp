// SPDX-License-Identifier: MIT
// The "moller" leaf test: Möller-Trumbore (JGT 1997) on four triangles at once, with each triangle's
// normal precomputed as Embree's Triangle4 stores it, used as a float filter with a static forward
// error bound on every decision it makes (the three edge signs, and t against [tmin, tmax]). A lane
// whose decision lies within its bound goes to the same exact path as the watertight test
// (decide_exactly, finish_crossing), so the answers are the exact arbiter's (docs/rays.md). The
// bound's derivation is docs/leaf-test.md.
//
// Layout: the watertight test's TrianglePack (exact vertices and primitive ids) plus, at the same
// index, a PackPlanes of one cache line: the four normals and edge scales. The exact paths need the
// exact vertices (edges rounded to float cannot give them back), so the vertices stay and the edges
// are formed on the fly.
#pragma once

#include <immintrin.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

#include "spacebvh/geometry.hpp"
#include "spacebvh/trace.hpp"
#include "trace/layout/huge_page_allocator.hpp"
#include "trace/leaf_tests/triangle_pack.hpp"
#include "trace/leaf_tests/watertight_triangle.hpp"

namespace spacebvh::trace {

// Per lane: N = (v1 - v0) x (v2 - v0) rounded to float from double, and m >= the largest |component|
// of the exact edges v1 - v0 and v2 - v0 (rounded up), the one scale the error bounds need.
struct alignas(64) PackPlanes {
    float normal[3][4];
    float edge_scale[4];
};
static_assert(sizeof(PackPlanes) == 64);

using PackPlanesList = std::vector<PackPlanes, HugePageAllocator<PackPlanes>>;

// The planes of every pack (unused lanes: zero).
PackPlanesList make_pack_planes(std::span<const TrianglePack> packs);

// Per-ray constants of the filter.
struct MollerRay {
    __m128 org[3], dir[3];
    __m128 edge_coefficient;  // 8 u |dir|_1, rounded up: Be = edge_coefficient * m * (3 |C|_1 + 2 m)
    __m128 tmin;              // tmin, or NaN when tmin < 0 or NaN (no distance decision then)
    float distance_gate;      // 1, or NaN when tmin < 0 or NaN (multiplies the running tmax)

    explicit MollerRay(const Ray& ray) {
        for (int axis = 0; axis < 3; ++axis) {
            org[axis] = _mm_set1_ps(ray.org[axis]);
            dir[axis] = _mm_set1_ps(ray.dir[axis]);
        }
        const double dir_norm = double(std::fabs(ray.dir.x)) + std::fabs(ray.dir.y) + std::fabs(ray.dir.z);
        edge_coefficient = _mm_set1_ps(float(8.0 * 0x1p-24 * dir_norm * (1.0 + 0x1p-20)));
        // The distance decisions assume 0 <= tmin <= tmax (the running tmax never drops below tmin).
        const bool gated = ray.tmin >= 0.0f;
        const float nan = std::numeric_limits<float>::quiet_NaN();
        tmin = _mm_set1_ps(gated ? ray.tmin : nan);
        distance_gate = gated ? 1.0f : nan;
    }
};

// What the filter decided about a pack's lanes (bit = lane).
struct MollerDecision {
    alignas(16) float w[4], a[4], b[4];  // edge functions: weights of v0, v1, v2 times det (any sign)
    int rejected;                        // certainly no hit in [tmin, tmax]: outside an edge, or t certainly outside
    int inside;  // certainly inside all three edges (the others not rejected: the exact test decides)
    int within;  // inside, and t certainly in [tmin, tmax]
};

[[gnu::always_inline]] inline __m128 moller_abs(__m128 x) { return _mm_andnot_ps(_mm_set1_ps(-0.0f), x); }

// The filter on one pack; `tmax` is the running tmax. Error bounds: docs/leaf-test.md.
[[gnu::always_inline]] inline void moller_pack(const TrianglePack& pack, const PackPlanes& planes, const MollerRay& ray,
                                               float tmax, MollerDecision& out) {
    __m128 c[3], e1[3], e2[3];
    for (int axis = 0; axis < 3; ++axis) {
        const __m128 v0 = _mm_load_ps(pack.vertex[0][axis]);
        c[axis] = _mm_sub_ps(v0, ray.org[axis]);
        e1[axis] = _mm_sub_ps(_mm_load_ps(pack.vertex[1][axis]), v0);
        e2[axis] = _mm_sub_ps(_mm_load_ps(pack.vertex[2][axis]), v0);
    }
    // R = C x d; A = R.E2 (weight of v1 times det), B = -R.E1 (v2), W = det - A - B (v0), det = N.d.
    const __m128 rx = _mm_sub_ps(_mm_mul_ps(c[1], ray.dir[2]), _mm_mul_ps(c[2], ray.dir[1]));
    const __m128 ry = _mm_sub_ps(_mm_mul_ps(c[2], ray.dir[0]), _mm_mul_ps(c[0], ray.dir[2]));
    const __m128 rz = _mm_sub_ps(_mm_mul_ps(c[0], ray.dir[1]), _mm_mul_ps(c[1], ray.dir[0]));
    const __m128 nx = _mm_load_ps(planes.normal[0]), ny = _mm_load_ps(planes.normal[1]),
                 nz = _mm_load_ps(planes.normal[2]);
    const __m128 det =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(nx, ray.dir[0]), _mm_mul_ps(ny, ray.dir[1])), _mm_mul_ps(nz, ray.dir[2]));
    const __m128 a = _mm_add_ps(_mm_add_ps(_mm_mul_ps(rx, e2[0]), _mm_mul_ps(ry, e2[1])), _mm_mul_ps(rz, e2[2]));
    const __m128 minus_b = _mm_add_ps(_mm_add_ps(_mm_mul_ps(rx, e1[0]), _mm_mul_ps(ry, e1[1])), _mm_mul_ps(rz, e1[2]));
    const __m128 w = _mm_add_ps(_mm_sub_ps(det, a), minus_b);
    const __m128 t_scaled = _mm_add_ps(_mm_add_ps(_mm_mul_ps(nx, c[0]), _mm_mul_ps(ny, c[1])), _mm_mul_ps(nz, c[2]));

    // The bounds: Be on A, B, W and det; Bt on T (docs/leaf-test.md), with G = m (3 |C|_1 + 2 m).
    const __m128 m = _mm_load_ps(planes.edge_scale);
    const __m128 c_norm = _mm_add_ps(_mm_add_ps(moller_abs(c[0]), moller_abs(c[1])), moller_abs(c[2]));
    const __m128 g = _mm_mul_ps(m, _mm_add_ps(_mm_mul_ps(_mm_set1_ps(3.0f), c_norm), _mm_add_ps(m, m)));
    const __m128 tiny = _mm_set1_ps(kUnderflowBound);
    const __m128 edge_bound = _mm_add_ps(_mm_mul_ps(ray.edge_coefficient, g), tiny);
    const __m128 distance_bound = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(_mm_set1_ps(8.0f * 0x1p-24f), m), g), tiny);

    // Edges: inside when A, B, W are all clearly of one sign; outside when two are clearly of
    // opposite signs (B's sign is minus_b's, flipped).
    const __m128 negative_edge_bound = _mm_sub_ps(_mm_setzero_ps(), edge_bound);
    const __m128 a_pos = _mm_cmpgt_ps(a, edge_bound), a_neg = _mm_cmplt_ps(a, negative_edge_bound);
    const __m128 b_pos = _mm_cmplt_ps(minus_b, negative_edge_bound), b_neg = _mm_cmpgt_ps(minus_b, edge_bound);
    const __m128 w_pos = _mm_cmpgt_ps(w, edge_bound), w_neg = _mm_cmplt_ps(w, negative_edge_bound);
    const __m128 any_pos = _mm_or_ps(_mm_or_ps(a_pos, b_pos), w_pos),
                 any_neg = _mm_or_ps(_mm_or_ps(a_neg, b_neg), w_neg);
    const __m128 inside =
        _mm_or_ps(_mm_and_ps(_mm_and_ps(a_pos, b_pos), w_pos), _mm_and_ps(_mm_and_ps(a_neg, b_neg), w_neg));
    const __m128 outside = _mm_and_ps(any_pos, any_neg);

    // Distance (on inside lanes det = A + B + W is clearly of their sign): t = T / det in [tmin, tmax]
    // iff s T in [tmin |det|, tmax |det|], s the sign of det; |det| is within Be of |det_f|.
    const __m128 sign = _mm_and_ps(det, _mm_set1_ps(-0.0f));
    const __m128 signed_t = _mm_xor_ps(t_scaled, sign);
    const __m128 det_abs = moller_abs(det);
    const __m128 det_low = _mm_sub_ps(det_abs, edge_bound), det_high = _mm_add_ps(det_abs, edge_bound);
    const __m128 t_low = _mm_sub_ps(signed_t, distance_bound), t_high = _mm_add_ps(signed_t, distance_bound);
    const __m128 limit = _mm_set1_ps(tmax * ray.distance_gate);
    const __m128 after_tmin = _mm_cmpgt_ps(t_low, _mm_mul_ps(ray.tmin, det_high));
    const __m128 before_tmax = _mm_cmplt_ps(t_high, _mm_mul_ps(limit, det_low));
    const __m128 before_tmin = _mm_cmplt_ps(t_high, _mm_mul_ps(ray.tmin, det_low));
    const __m128 after_tmax = _mm_cmpgt_ps(t_low, _mm_mul_ps(limit, det_high));

    out.inside = _mm_movemask_ps(inside);
    out.rejected = _mm_movemask_ps(_mm_or_ps(outside, _mm_and_ps(inside, _mm_or_ps(before_tmin, after_tmax))));
    out.within = _mm_movemask_ps(_mm_and_ps(inside, _mm_and_ps(after_tmin, before_tmax)));
    _mm_store_ps(out.w, w);
    _mm_store_ps(out.a, a);
    _mm_store_ps(out.b, _mm_sub_ps(_mm_setzero_ps(), minus_b));
}

// The moller form of test_leaf_packs (triangle_pack.hpp): the same lane order and the same exact
// paths, so the answers are the watertight test's. Certain hits end an any-hit ray at once; a closest
// hit still takes its distance from the plane equation in double (finish_crossing), as the arbiter.
template <bool kAnyHit, bool kStats>
[[gnu::always_inline]] inline bool test_leaf_moller(const TrianglePack* packs, const PackPlanes* planes, uint32_t first,
                                                    uint32_t count, const Ray& ray, const MollerRay& moller,
                                                    float& tmax, Hit& hit, bool& found, TraversalStats* stats) {
    for (uint32_t p = 0; p * 4 < count; ++p) {
        const TrianglePack& pack = packs[first + p];
        const uint32_t lanes = count - p * 4 < 4 ? count - p * 4 : 4;
        const unsigned live = (1u << lanes) - 1;
        if constexpr (kStats) stats->triangles_tested += lanes;
        MollerDecision decision;
        moller_pack(pack, planes[first + p], moller, tmax, decision);
        if constexpr (kAnyHit) {
            if (unsigned(decision.within) & live) {
                found = true;
                return true;
            }
        }
        unsigned candidates = unsigned(~decision.rejected) & live;
        while (candidates) {
            const int lane = __builtin_ctz(candidates);
            candidates &= candidates - 1;
            if (settle_lane<kAnyHit, kStats>(pack, lane, (decision.inside >> lane) & 1, decision.w[lane],
                                             decision.a[lane], decision.b[lane], ray, tmax, hit, found, stats))
                return true;
        }
    }
    return false;
}

// Starts fetching a leaf's first pack and its planes.
[[gnu::always_inline]] inline void prefetch_pack_planes(const PackPlanes& planes) {
    _mm_prefetch(reinterpret_cast<const char*>(&planes), _MM_HINT_T0);
}

}  // namespace spacebvh::trace
