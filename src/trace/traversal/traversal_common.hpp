// SPDX-License-Identifier: MIT
// What every traversal kernel shares: the conservative box-test constants, the floating-point mode the
// kernels run in, and the parallel loop over a batch of rays.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <immintrin.h>

#include <atomic>
#include <cmath>
#include <cstddef>
#include <limits>

#include "spacebvh/trace.hpp"

namespace spacebvh::trace {

// Conservative box test (Ize 2013; pbrt-v4 gamma(3)): widen the far distance by the worst rounding of
// the slab computation so rounding never culls a box the ray really touches.
inline constexpr float kFarScale = 1.0f + 2.0f * (3.0f * 0x1p-24f) / (1.0f - 3.0f * 0x1p-24f);

// The per-ray, per-axis constants of the fused slab test of the BVH4/BVH8 single-ray kernels
// (Embree's form) and of the binary kernel's two-box test: a slab distance is one fused
// multiply-subtract, plane * scale - offset, instead of (plane - o) * (1/d) in two dependent steps,
// and exit distances need no widening after. The binary kernel gains from it too, because it picks
// the next node by a branch: a kernel that chose the next node by selects would wait on the whole
// test and lose more than the fused test saves.
//
// Why no box a ray enters within [tmin, tmax] is culled (u = 2^-24; t = (p - o) / d exact; t >= 0, as
// the spec's rays have tmin >= 0).
// Entry: r = (1/d)(1 + e_r), q = o r (1 + e_q), so p r - q = t (1 + e_r) - o r e_q: an error relative to
// t plus an absolute one up to |q| u (1 + 2u), which can dwarf t (a box near a ray's origin far from the
// world's origin). The entry offset is q raised past that (slack |q| 2^-21, ample for the rounding of
// the sum), so the fused result is at most t (1 + u)^2.
// Exit: scale R = fl(r s) with s = 1 + 2^-21, so p R = K (t + o/d) and o R = K o/d with one constant
// K in [s (1 - u)^2, s (1 + u)^2]; the exit offset is fl(o R) lowered past its rounding, so
// p R - offset >= K t and the fused result is at least s (1 - u)^3 t >= (1 + u)^2 t, no less than any
// entry distance of the same box: the widening of Ize ("Robust BVH Ray Traversal", JCGT 2013) folded
// into the constants. Both slacks add 2^-126, the smallest normal float, for values in the subnormal
// range: an origin coordinate of exactly 0 then gives offsets of +-2^-126, not a subnormal that every
// fused test of the ray would take as an operand (x86 handles subnormal operands in microcode, several
// times slower, and cameras and ray origins at 0 are common).
// Answers cannot change (the exact triangle test decides them); at most a few more boxes are entered.
// An axis along which the ray does not move (d = 0, or a scale or offset not finite) gets scale 0 and
// offsets +-inf, i.e. NaN or -+inf distances that leave the running bounds unchanged when min/max
// keep the running bound as their second operand: it never culls (the other axes still do), so a
// ray along a coordinate axis would enter nearly every box its one moving axis allows. The wide
// kernels therefore give such rays (finite_axes != 7) the subtract-multiply test instead
// (wide_kernel.inl, RayBoxes), which culls on every axis.
// When no axis is left (an origin so far out that o / d overflows on every axis), nothing would keep
// the ray out of a wide node's unused slots, whose empty boxes only a culling axis rejects: lane 0
// then gets scale 2^-149 and offsets +-FLT_MAX, so every finite plane gives -FLT_MAX (entry) and
// FLT_MAX (exit), culling no real box, while an empty box's infinite planes give +inf and -inf.
// Tests: Tracer.OrganicMeshFarFromTheOriginIsWatertight fails without the slack;
// Kernels.SceneBeyondTheFloatRangeBuildsAndAnswersExactly without the lane-0 constants.
struct FusedSlabs {  // lane k: axis k (lane 3 unused)
    __m128 entry_scale, entry_offset, exit_scale, exit_offset;
    unsigned negative;     // bit k: the direction is negative along axis k (the ray enters through the upper plane)
    unsigned finite_axes;  // bit k: axis k has finite constants (it culls)

    // Made in a few vector instructions for the three axes at once: every ray pays for them, and many
    // of the binary kernel's primary and occlusion rays visit only a dozen nodes, where constants made
    // one axis at a time would cost more than the fused test saves.
    explicit FusedSlabs(const Ray& ray) {
        const __m128 org = _mm_setr_ps(ray.org[0], ray.org[1], ray.org[2], 0.0f);
        const __m128 dir = _mm_setr_ps(ray.dir[0], ray.dir[1], ray.dir[2], 1.0f);
        const __m128 inv = _mm_div_ps(_mm_set1_ps(1.0f), dir);  // +-inf for axis-parallel rays
        const __m128 exit_inv = _mm_mul_ps(inv, _mm_set1_ps(1.0f + 0x1p-21f));
        const __m128 scaled_org = _mm_mul_ps(org, inv), exit_scaled_org = _mm_mul_ps(org, exit_inv);
        const __m128 magnitude = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
        const __m128 infinity = _mm_set1_ps(std::numeric_limits<float>::infinity());
        const __m128 scaled_slack = slack(scaled_org), exit_slack = slack(exit_scaled_org);
        // Finite lanes (|x| < inf is false for NaN) take the fused constants, the others scale 0 and
        // offsets +-inf.
        const __m128 finite = _mm_and_ps(_mm_cmplt_ps(_mm_and_ps(exit_inv, magnitude), infinity),
                                         _mm_cmplt_ps(_mm_and_ps(exit_scaled_org, magnitude), infinity));
        entry_scale = _mm_and_ps(finite, inv);
        exit_scale = _mm_and_ps(finite, exit_inv);
        entry_offset =
            _mm_or_ps(_mm_and_ps(finite, _mm_add_ps(scaled_org, scaled_slack)), _mm_andnot_ps(finite, infinity));
        const __m128 minus_infinity = _mm_sub_ps(_mm_setzero_ps(), infinity);
        exit_offset = _mm_or_ps(_mm_and_ps(finite, _mm_sub_ps(exit_scaled_org, exit_slack)),
                                _mm_andnot_ps(finite, minus_infinity));
        negative = unsigned(_mm_movemask_ps(inv)) & 7u;
        finite_axes = unsigned(_mm_movemask_ps(finite)) & 7u;
        if (finite_axes == 0) [[unlikely]] {
            const float largest = std::numeric_limits<float>::max();
            entry_scale = _mm_move_ss(entry_scale, _mm_set_ss(0x1p-149f));
            exit_scale = _mm_move_ss(exit_scale, _mm_set_ss(0x1p-149f));
            entry_offset = _mm_move_ss(entry_offset, _mm_set_ss(largest));
            exit_offset = _mm_move_ss(exit_offset, _mm_set_ss(-largest));
            negative &= ~1u;  // lane 0 enters through the lower plane
        }
    }

    // |x| 2^-21 + 2^-126: the slack of an offset x.
    static __m128 slack(__m128 x) {
        const __m128 magnitude = _mm_and_ps(x, _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff)));
        return _mm_add_ps(_mm_mul_ps(magnitude, _mm_set1_ps(0x1p-21f)), _mm_set1_ps(0x1p-126f));
    }

    static float lane(__m128 values, int axis) {
        alignas(16) float lanes[4];
        _mm_store_ps(lanes, values);
        return lanes[axis];
    }
};

// a * b - c on four lanes, rounded once (the fused slab test relies on the single rounding): one
// instruction where the build targets FMA (the default native build on any x86 CPU of the last
// decade), else std::fma per lane (exact, slow: portable builds only).
[[gnu::always_inline]] inline __m128 fused_multiply_subtract(__m128 a, __m128 b, __m128 c) {
#ifdef __FMA__
    return _mm_fmsub_ps(a, b, c);
#else
    alignas(16) float x[4], y[4], z[4];
    _mm_store_ps(x, a);
    _mm_store_ps(y, b);
    _mm_store_ps(z, c);
    for (int i = 0; i < 4; ++i) x[i] = std::fma(x[i], y[i], -z[i]);
    return _mm_load_ps(x);
#endif
}

// The kernels' error bounds assume IEEE arithmetic with denormals: a caller that set flush-to-zero or
// denormals-are-zero (common in renderers, for speed) would otherwise change float edge functions
// without the bound knowing. The guard clears both for the kernel's duration and restores the
// caller's mode after.
class StandardFloatingPointMode {
public:
    StandardFloatingPointMode() : saved_(_mm_getcsr()) {
        constexpr unsigned kFlushToZero = 0x8000, kDenormalsAreZero = 0x0040;
        if (saved_ & (kFlushToZero | kDenormalsAreZero)) _mm_setcsr(saved_ & ~(kFlushToZero | kDenormalsAreZero));
    }
    ~StandardFloatingPointMode() {
        if (_mm_getcsr() != saved_) _mm_setcsr(saved_);
    }
    StandardFloatingPointMode(const StandardFloatingPointMode&) = delete;
    StandardFloatingPointMode& operator=(const StandardFloatingPointMode&) = delete;

private:
    unsigned saved_;
};

// Runs `trace(begin, end, stats)` over [0, count) in ranges of about `grain` across the calling
// thread's oneTBB arena, in the standard floating-point mode; stats are summed exactly (integers).
template <typename Trace>
void for_each_range(size_t count, size_t grain, TraversalStats* stats, Trace&& trace) {
    std::atomic<uint64_t> nodes{0}, triangles{0}, exact{0}, plane{0};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, grain), [&](const tbb::blocked_range<size_t>& range) {
        const StandardFloatingPointMode mode;
        TraversalStats local;
        trace(range.begin(), range.end(), local);
        if (stats) {
            nodes += local.nodes_visited;
            triangles += local.triangles_tested;
            exact += local.exact_tests;
            plane += local.plane_distances;
        }
    });
    if (stats) *stats = {nodes.load(), triangles.load(), exact.load(), plane.load()};
}

// Runs `trace(i, stats)` for every ray, in chunks of 1024 rays.
template <typename Trace>
void for_each_ray(size_t count, TraversalStats* stats, Trace&& trace) {
    for_each_range(count, 1024, stats, [&](size_t begin, size_t end, TraversalStats& local) {
        for (size_t i = begin; i != end; ++i) trace(i, local);
    });
}

// The batch entry points of a kernel whose `traverse(ray, hit, stats)` (stats may be null) returns
// whether it found a hit: closest hits into `hits`, or occlusion answers into `occluded`.
template <typename Traverse>
void intersect_batch(std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats, Traverse&& traverse) {
    for_each_ray(rays.size(), stats, [&](size_t i, TraversalStats& local) {
        hits[i] = Hit{};
        traverse(rays[i], hits[i], stats ? &local : nullptr);
    });
}

template <typename Traverse>
void occluded_batch(std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats,
                    Traverse&& traverse) {
    for_each_ray(rays.size(), stats, [&](size_t i, TraversalStats& local) {
        Hit unused;
        occluded[i] = traverse(rays[i], unused, stats ? &local : nullptr);
    });
}

}  // namespace spacebvh::trace
