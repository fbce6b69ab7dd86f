// SPDX-License-Identifier: MIT
// How RayQueries' batches are split across threads, and the order containment batches are walked in.
// Each answer belongs to its own ray, so neither changes an answer.
#pragma once

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "spacebvh/geometry.hpp"

namespace spacebvh::trace::queries {

// A fixed grain: the work split does not depend on the thread count (and answers are per ray anyway).
inline constexpr size_t kGrain = 256;

// Runs body(begin, end) over [0, n) in ranges of kGrain across the calling thread's oneTBB arena.
template <class Body>
void for_chunks(size_t n, Body&& body) {
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, n, kGrain),
        [&](const tbb::blocked_range<size_t>& range) { body(range.begin(), range.end()); }, tbb::simple_partitioner());
}

// The order containment rays are walked in: their points bucketed on a grid over the mesh's box
// (clamped to it), cells in Morton order, the input order within a cell (a stable counting sort).
// Containment rays share one direction, so rays from points close together walk nearly the same
// nodes and leaves, and walking them one after another finds those in cache: an incoherent batch is
// bound by memory latency, not arithmetic. The order depends on the points only (not on the thread
// count). Rays of other directions gain less than the ordering costs (measured for first, any and
// all hits), so only containment is ordered.
template <class RayAt>
std::vector<uint32_t> coherent_order(const AABB& bounds, size_t n, const RayAt& ray_at) {
    // 2^4 cells per axis: 4096 counters, which stay in the first-level cache while counting.
    constexpr int kBits = 4;
    constexpr uint32_t kCells = 1u << kBits, kKeys = 1u << (3 * kBits);
    static_assert(3 * kBits <= 16, "keys are 16 bits");
    float scale[3], low[3];
    for (int a = 0; a < 3; ++a) {
        const float extent = bounds.hi[a] - bounds.lo[a];
        low[a] = bounds.lo[a];
        scale[a] = extent > 0.0f ? float(kCells) / extent : 0.0f;
    }
    std::vector<uint16_t> key(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1 << 14), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i < range.end(); ++i) {
            const Vec3 org = ray_at(i).org;
            uint32_t code = 0;
            for (int a = 0; a < 3; ++a) {
                const float x = (org[a] - low[a]) * scale[a];  // NaN only for an empty box: cell 0
                const uint32_t cell = !(x > 0.0f) ? 0u : x >= float(kCells - 1) ? kCells - 1 : uint32_t(x);
                for (int bit = 0; bit < kBits; ++bit) code |= ((cell >> bit) & 1u) << (3 * bit + a);
            }
            key[i] = uint16_t(code);
        }
    });
    std::vector<uint32_t> start(kKeys + 1, 0), order(n);
    for (size_t i = 0; i < n; ++i) ++start[key[i] + 1u];
    for (uint32_t k = 0; k < kKeys; ++k) start[k + 1] += start[k];
    for (size_t i = 0; i < n; ++i) order[start[key[i]]++] = uint32_t(i);
    return order;
}

// Containment batches smaller than this are walked in input order (ordering would cost more than it
// saves).
inline constexpr size_t kOrderedBatch = 4096;

}  // namespace spacebvh::trace::queries
