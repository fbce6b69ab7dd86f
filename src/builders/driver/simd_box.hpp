// SPDX-License-Identifier: MIT
// A box in SSE registers (lanes x, y, z; the fourth lane unused), for the split finders' hot loops,
// which extend boxes millions of times per build.
#pragma once

#include <immintrin.h>

#include "spacebvh/geometry.hpp"

namespace spacebvh::builders {

struct alignas(16) SimdBox {
    __m128 lo = _mm_set1_ps(kInfinity), hi = _mm_set1_ps(-kInfinity);

    void extend(const SimdBox& box) {
        lo = _mm_min_ps(lo, box.lo);
        hi = _mm_max_ps(hi, box.hi);
    }
    // AABB::extend exactly, operand order included (std::min keeps the running bound on ties, so the
    // sign of a zero comes out the same): a sweep over SimdBoxes builds the same bytes as over AABBs.
    // Reads 16 bytes from each corner of `box`: lo.xyz + hi.x and hi.xyz + the 4 bytes after it,
    // which must be readable (a Reference's primitive id follows its bounds).
    void extend_as_aabb(const AABB& box) {
        lo = _mm_min_ps(_mm_loadu_ps(&box.lo.x), lo);
        hi = _mm_max_ps(_mm_loadu_ps(&box.hi.x), hi);
    }
    // AABB::area() to the bit: the same products and sums in the same order (the build uses
    // -ffp-contract=off, so no fused multiply-add on either side). 0 for an empty box.
    float area() const {
        if (_mm_movemask_ps(_mm_cmpgt_ps(lo, hi)) & 7) return 0.0f;
        const __m128 extent = _mm_sub_ps(hi, lo);
        // Lanes: x*y, y*z, z*x.
        const __m128 products = _mm_mul_ps(extent, _mm_shuffle_ps(extent, extent, _MM_SHUFFLE(3, 0, 2, 1)));
        const float xy = _mm_cvtss_f32(products);
        const float yz = _mm_cvtss_f32(_mm_shuffle_ps(products, products, _MM_SHUFFLE(1, 1, 1, 1)));
        const float zx = _mm_cvtss_f32(_mm_movehl_ps(products, products));
        return 2.0f * (xy + yz + zx);
    }
    AABB aabb() const {
        alignas(16) float l[4], h[4];
        _mm_store_ps(l, lo);
        _mm_store_ps(h, hi);
        return AABB{{l[0], l[1], l[2]}, {h[0], h[1], h[2]}};
    }
};

// overlap_fraction (cost_model.hpp) on SimdBoxes, to the bit: the per-axis ratios are the same IEEE
// divisions, and an axis on which the node is flat multiplies by exactly 1. `node_extent` is the
// node's hi - lo.
inline float overlap_fraction(__m128 node_extent, const SimdBox& left, const SimdBox& right) {
    const int empty = _mm_movemask_ps(_mm_or_ps(_mm_cmpgt_ps(left.lo, left.hi), _mm_cmpgt_ps(right.lo, right.hi))) & 7;
    if (empty) return 0.0f;
    const __m128 overlap_extent = _mm_sub_ps(_mm_min_ps(left.hi, right.hi), _mm_max_ps(left.lo, right.lo));
    if (_mm_movemask_ps(_mm_cmplt_ps(overlap_extent, _mm_setzero_ps())) & 7) return 0.0f;  // disjoint
    const __m128 counted = _mm_cmpgt_ps(node_extent, _mm_setzero_ps());
    const __m128 ratio = _mm_or_ps(_mm_and_ps(counted, _mm_div_ps(overlap_extent, node_extent)),
                                   _mm_andnot_ps(counted, _mm_set1_ps(1.0f)));
    alignas(16) float r[4];
    _mm_store_ps(r, ratio);
    return 1.0f * r[0] * r[1] * r[2];
}

inline __m128 simd(Vec3 v) { return _mm_setr_ps(v.x, v.y, v.z, 0.0f); }
inline SimdBox simd(const AABB& box) { return {simd(box.lo), simd(box.hi)}; }

}  // namespace spacebvh::builders
