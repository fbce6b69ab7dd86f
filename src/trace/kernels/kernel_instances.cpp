// SPDX-License-Identifier: MIT
// Every kernel, compiled once per instruction set: wide_kernel.inl (single rays), packet_rays.inl and
// packet_kernel.inl (packets: their lane tests, their traversal) are included into one namespace per
// node-test policy, under `#pragma GCC target` for AVX2 and AVX-512, so a portable build still runs
// the widest instructions the CPU reports (chosen at run time). Functions outside the pragma regions
// (the scalar triangle test and the exact fallback) keep the default target; inlining them into a
// wider target is allowed.
#include <immintrin.h>

#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "trace/kernels/kernels.hpp"
#include "trace/target_region.hpp"
#include "trace/leaf_tests/moller_filter.hpp"
#include "trace/layout/quantized_layout.hpp"
#include "trace/traversal/traversal_common.hpp"
#include "trace/traversal/visit_order.hpp"
#include "trace/leaf_tests/watertight_triangle.hpp"
#include "trace/layout/wide_layout.hpp"

namespace spacebvh::trace {

// Writes the entry distances and slots of the children in `mask`, in slot order.
[[gnu::always_inline]] inline int collect_bits(unsigned mask, const float* near, float* entry, uint32_t* slot) {
    int count = 0;
    while (mask) {
        const int lane = __builtin_ctz(mask);
        mask &= mask - 1;
        entry[count] = near[lane];
        slot[count++] = uint32_t(lane);
    }
    return count;
}

// The reference: plain loops with the operand order of the SIMD min/max (NaN keeps the bound).
namespace scalar_kernels {
template <int W>
struct Policy {
    static constexpr int kLanes = W;
    static constexpr bool kScalarTriangles = true;
    struct F {
        float lane[W];
    };
    template <typename Op>
    static F apply(const F& a, const F& b, Op op) {
        F r;
        for (int i = 0; i < W; ++i) r.lane[i] = op(a.lane[i], b.lane[i]);
        return r;
    }
    static F load(const float* p) {
        F r;
        for (int i = 0; i < W; ++i) r.lane[i] = p[i];
        return r;
    }
    static void store(float* p, const F& a) {
        for (int i = 0; i < W; ++i) p[i] = a.lane[i];
    }
    static F set1(float x) {
        F r;
        for (int i = 0; i < W; ++i) r.lane[i] = x;
        return r;
    }
    static F sub(const F& a, const F& b) {
        return apply(a, b, [](float x, float y) { return x - y; });
    }
    static F mul(const F& a, const F& b) {
        return apply(a, b, [](float x, float y) { return x * y; });
    }
    static F max(const F& a, const F& b) {
        return apply(a, b, [](float x, float y) { return x > y ? x : y; });
    }
    static F min(const F& a, const F& b) {
        return apply(a, b, [](float x, float y) { return x < y ? x : y; });
    }
    static F add(const F& a, const F& b) {
        return apply(a, b, [](float x, float y) { return x + y; });
    }
    static F div(const F& a, const F& b) {
        return apply(a, b, [](float x, float y) { return x / y; });
    }
    static F abs(const F& a) {
        return apply(a, a, [](float x, float) { return std::fabs(x); });
    }
    static F fmsub(const F& a, const F& b, const F& c) {
        F r;
        for (int i = 0; i < W; ++i) r.lane[i] = std::fma(a.lane[i], b.lane[i], -c.lane[i]);
        return r;
    }
    static F fmadd(const F& a, const F& b, const F& c) {
        F r;
        for (int i = 0; i < W; ++i) r.lane[i] = std::fma(a.lane[i], b.lane[i], c.lane[i]);
        return r;
    }
    static F load_u8(const uint8_t* p) {
        F r;
        for (int i = 0; i < W; ++i) r.lane[i] = float(p[i]);
        return r;
    }
    static unsigned less_mask(const F& a, const F& b) {
        unsigned mask = 0;
        for (int i = 0; i < W; ++i) mask |= unsigned(a.lane[i] < b.lane[i]) << i;
        return mask;
    }
    static unsigned hit_mask(const F& near, const F& limit) {
        unsigned mask = 0;
        for (int i = 0; i < W; ++i) mask |= unsigned(near.lane[i] <= limit.lane[i]) << i;
        return mask;
    }
    static int collect(unsigned mask, const F& near, float* entry, uint32_t* slot) {
        return collect_bits(mask, near.lane, entry, slot);
    }
};
#include "trace/kernels/wide_kernel.inl"
#include "trace/kernels/packet_rays.inl"
#include "trace/kernels/packet_kernel.inl"
#include "trace/kernels/kernel_entry_points.inl"
}  // namespace scalar_kernels

// The operations of the SSE and AVX2 policies live outside the kernel namespaces, so that the AVX-512
// policies can reuse them without argument-dependent lookup seeing two copies of every kernel.
struct SseOperations {
    static constexpr int kLanes = 4;
    static constexpr bool kScalarTriangles = false;
    using F = __m128;
    static F load(const float* p) { return _mm_load_ps(p); }
    static void store(float* p, F a) { _mm_store_ps(p, a); }
    static F set1(float x) { return _mm_set1_ps(x); }
    static F sub(F a, F b) { return _mm_sub_ps(a, b); }
    static F mul(F a, F b) { return _mm_mul_ps(a, b); }
    static F max(F a, F b) { return _mm_max_ps(a, b); }
    static F min(F a, F b) { return _mm_min_ps(a, b); }
    static F add(F a, F b) { return _mm_add_ps(a, b); }
    static F div(F a, F b) { return _mm_div_ps(a, b); }
    static F abs(F a) { return _mm_andnot_ps(_mm_set1_ps(-0.0f), a); }
    static F fmsub(F a, F b, F c) { return fused_multiply_subtract(a, b, c); }
    static unsigned less_mask(F a, F b) { return unsigned(_mm_movemask_ps(_mm_cmplt_ps(a, b))); }
    static unsigned hit_mask(F near, F limit) { return unsigned(_mm_movemask_ps(_mm_cmple_ps(near, limit))); }
    static int collect(unsigned mask, F near, float* entry, uint32_t* slot) {
        alignas(16) float lanes[4];
        _mm_store_ps(lanes, near);
        return collect_bits(mask, lanes, entry, slot);
    }
};

// SSE: 4 lanes, the x86-64 baseline.
namespace sse_kernels {
struct Policy : SseOperations {};
#include "trace/kernels/wide_kernel.inl"
#include "trace/kernels/packet_rays.inl"
#include "trace/kernels/packet_kernel.inl"
#include "trace/kernels/kernel_entry_points.inl"
}  // namespace sse_kernels

SPACEBVH_TARGET_BEGIN("avx2,fma")
struct Avx2Operations {
    static constexpr int kLanes = 8;
    static constexpr bool kScalarTriangles = false;
    using F = __m256;
    static F load(const float* p) { return _mm256_load_ps(p); }
    static void store(float* p, F a) { _mm256_store_ps(p, a); }
    static F set1(float x) { return _mm256_set1_ps(x); }
    static F sub(F a, F b) { return _mm256_sub_ps(a, b); }
    static F mul(F a, F b) { return _mm256_mul_ps(a, b); }
    static F max(F a, F b) { return _mm256_max_ps(a, b); }
    static F min(F a, F b) { return _mm256_min_ps(a, b); }
    static F add(F a, F b) { return _mm256_add_ps(a, b); }
    static F div(F a, F b) { return _mm256_div_ps(a, b); }
    static F abs(F a) { return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), a); }
    static F fmsub(F a, F b, F c) { return _mm256_fmsub_ps(a, b, c); }
    static F fmadd(F a, F b, F c) { return _mm256_fmadd_ps(a, b, c); }
    // Eight codes (quantized nodes) to floats: a zero-extending load and a convert.
    static F load_u8(const uint8_t* p) {
        return _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
    }
    static unsigned less_mask(F a, F b) { return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LT_OQ))); }
    static unsigned hit_mask(F near, F limit) {
        return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(near, limit, _CMP_LE_OQ)));
    }
    static int collect(unsigned mask, F near, float* entry, uint32_t* slot) {
        alignas(32) float lanes[8];
        _mm256_store_ps(lanes, near);
        return collect_bits(mask, lanes, entry, slot);
    }
};

// AVX2: 8 lanes.
namespace avx2_kernels {
struct Policy : Avx2Operations {};
#include "trace/kernels/wide_kernel.inl"
#include "trace/kernels/packet_rays.inl"
#include "trace/kernels/packet_kernel.inl"
#include "trace/kernels/kernel_entry_points.inl"
}  // namespace avx2_kernels
SPACEBVH_TARGET_END()

SPACEBVH_TARGET_BEGIN("avx2,fma,avx512f,avx512vl")
// AVX-512VL: compares straight into mask registers, and the hit children compressed into slot order
// in registers (a compress to memory is microcoded and slow on some CPUs).
namespace avx512_kernels {
template <int W>
struct Policy;

template <>
struct Policy<4> : SseOperations {
    static unsigned hit_mask(__m128 near, __m128 limit) { return _mm_cmp_ps_mask(near, limit, _CMP_LE_OQ); }
    // Its own: SseOperations::fmsub is compiled outside this target region and, in a portable build
    // (no -mfma), falls back to std::fma per lane.
    static __m128 fmsub(__m128 a, __m128 b, __m128 c) { return _mm_fmsub_ps(a, b, c); }
    static int collect(unsigned mask, __m128 near, float* entry, uint32_t* slot) {
        _mm_storeu_ps(entry, _mm_maskz_compress_ps(__mmask8(mask), near));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(slot),
                         _mm_maskz_compress_epi32(__mmask8(mask), _mm_setr_epi32(0, 1, 2, 3)));
        return __builtin_popcount(mask);
    }
};

template <>
struct Policy<8> : Avx2Operations {
    static unsigned hit_mask(__m256 near, __m256 limit) { return _mm256_cmp_ps_mask(near, limit, _CMP_LE_OQ); }
    static int collect(unsigned mask, __m256 near, float* entry, uint32_t* slot) {
        _mm256_storeu_ps(entry, _mm256_maskz_compress_ps(__mmask8(mask), near));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(slot),
                            _mm256_maskz_compress_epi32(__mmask8(mask), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)));
        return __builtin_popcount(mask);
    }
};
#include "trace/kernels/wide_kernel.inl"
#include "trace/kernels/packet_rays.inl"
#include "trace/kernels/packet_kernel.inl"
#include "trace/kernels/kernel_entry_points.inl"
}  // namespace avx512_kernels
SPACEBVH_TARGET_END()

bool cpu_has(NodeTest test) {
    switch (test) {
        case NodeTest::scalar:
        case NodeTest::sse:
            return true;
        case NodeTest::avx2:
            return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
        case NodeTest::avx512:
            return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
                   __builtin_cpu_supports("fma");
        case NodeTest::best:
            return true;
    }
    return false;
}

bool width_has(int width, NodeTest test) {
    switch (test) {
        case NodeTest::scalar:
        case NodeTest::avx512:
            return true;
        case NodeTest::sse:
            return width == 4;
        case NodeTest::avx2:
            return width == 8;
        case NodeTest::best:
            return true;
    }
    return false;
}

namespace {
template <class K>
constexpr SingleRayKernels table_of(LeafTest leaf_test) {
    if (leaf_test == LeafTest::moller)
        return {&K::closest_moller, &K::closest_moller_stats, &K::occluded_moller, &K::occluded_moller_stats};
    return {&K::closest, &K::closest_stats, &K::occluded, &K::occluded_stats};
}
template <class K>
constexpr SingleRayKernels quantized_table_of(LeafTest leaf_test) {
    if (leaf_test == LeafTest::moller)
        return {&K::template quantized_closest<true>, &K::template quantized_closest_stats<true>,
                &K::template quantized_occluded<true>, &K::template quantized_occluded_stats<true>};
    return {&K::template quantized_closest<false>, &K::template quantized_closest_stats<false>,
            &K::template quantized_occluded<false>, &K::template quantized_occluded_stats<false>};
}
template <class K>
constexpr PacketKernels packet_table_of() {
    return {&K::packet_closest, &K::packet_occluded};
}
}  // namespace

SingleRayKernels single_ray_kernels(int width, NodeTest test, LeafTest leaf_test, NodeFormat format) {
    if (format == NodeFormat::quantized) {
        switch (test) {
            case NodeTest::avx2:
                return quantized_table_of<avx2_kernels::Kernels<avx2_kernels::Policy>>(leaf_test);
            case NodeTest::avx512:
                return quantized_table_of<avx512_kernels::Kernels<avx512_kernels::Policy<8>>>(leaf_test);
            default:
                return quantized_table_of<scalar_kernels::Kernels<scalar_kernels::Policy<8>>>(leaf_test);
        }
    }
    if (width == 4) {
        switch (test) {
            case NodeTest::sse:
                return table_of<sse_kernels::Kernels<sse_kernels::Policy>>(leaf_test);
            case NodeTest::avx512:
                return table_of<avx512_kernels::Kernels<avx512_kernels::Policy<4>>>(leaf_test);
            default:
                return table_of<scalar_kernels::Kernels<scalar_kernels::Policy<4>>>(leaf_test);
        }
    }
    switch (test) {
        case NodeTest::avx2:
            return table_of<avx2_kernels::Kernels<avx2_kernels::Policy>>(leaf_test);
        case NodeTest::avx512:
            return table_of<avx512_kernels::Kernels<avx512_kernels::Policy<8>>>(leaf_test);
        default:
            return table_of<scalar_kernels::Kernels<scalar_kernels::Policy<8>>>(leaf_test);
    }
}

PacketKernels packet_kernels(NodeTest test) {
    switch (test) {
        case NodeTest::avx2:
            return packet_table_of<avx2_kernels::Kernels<avx2_kernels::Policy>>();
        case NodeTest::avx512:
            return packet_table_of<avx512_kernels::Kernels<avx512_kernels::Policy<8>>>();
        default:
            return packet_table_of<scalar_kernels::Kernels<scalar_kernels::Policy<8>>>();
    }
}

}  // namespace spacebvh::trace
