// What every traversal kernel shares: the conservative box-test constant, the floating-point mode the
// kernels run in, and the parallel loop over a batch of rays.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <xmmintrin.h>

#include <atomic>
#include <cstddef>

#include "spacebvh/tracer.hpp"

namespace spacebvh::trace {

// Conservative box test (Ize 2013; pbrt-v4 gamma(3)): widen the far distance by the worst rounding of
// the slab computation so rounding never culls a box the ray really touches.
inline constexpr float kFarScale = 1.0f + 2.0f * (3.0f * 0x1p-24f) / (1.0f - 3.0f * 0x1p-24f);

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
    std::atomic<uint64_t> nodes{0}, triangles{0};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, grain), [&](const tbb::blocked_range<size_t>& range) {
        const StandardFloatingPointMode mode;
        TraversalStats local;
        trace(range.begin(), range.end(), local);
        if (stats) {
            nodes += local.nodes_visited;
            triangles += local.triangles_tested;
        }
    });
    if (stats) *stats = {nodes.load(), triangles.load()};
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
void occluded_batch(std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats, Traverse&& traverse) {
    for_each_ray(rays.size(), stats, [&](size_t i, TraversalStats& local) {
        Hit unused;
        occluded[i] = traverse(rays[i], unused, stats ? &local : nullptr);
    });
}

}  // namespace spacebvh::trace
