// SPDX-License-Identifier: MIT
#include "builders/driver/reference.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <immintrin.h>

namespace spacebvh::builders {

std::vector<Reference> make_references(std::span<const Triangle> triangles) {
    std::vector<Reference> references(triangles.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, references.size(), 4096), [&](const auto& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) references[i] = {triangles[i].bounds(), uint32_t(i)};
    });
    return references;
}

// Four-wide min/max with the operand order of std::min/std::max in AABB::extend, so the result is the
// same bits as extending box by box (signed zeros included).
static ReferenceSummary summarize_serial(std::span<const Reference> references) {
    __m128 lo = _mm_set1_ps(kInfinity), hi = _mm_set1_ps(-kInfinity);
    __m128 centroid_lo = lo, centroid_hi = hi;
    for (const Reference& reference : references) {
        // Reference is {lo.xyz, hi.xyz, primitive}: both loads stay inside it; lane 3 is ignored.
        const __m128 box_lo = _mm_loadu_ps(&reference.bounds.lo.x);
        const __m128 box_hi = _mm_loadu_ps(&reference.bounds.hi.x);
        const __m128 center = _mm_mul_ps(_mm_add_ps(box_lo, box_hi), _mm_set1_ps(0.5f));  // AABB::center
        lo = _mm_min_ps(box_lo, lo);
        hi = _mm_max_ps(box_hi, hi);
        centroid_lo = _mm_min_ps(center, centroid_lo);
        centroid_hi = _mm_max_ps(center, centroid_hi);
    }
    auto to_vec = [](__m128 v) {
        alignas(16) float lanes[4];
        _mm_store_ps(lanes, v);
        return Vec3{lanes[0], lanes[1], lanes[2]};
    };
    ReferenceSummary summary;
    summary.bounds = {to_vec(lo), to_vec(hi)};
    summary.centroid_bounds = {to_vec(centroid_lo), to_vec(centroid_hi)};
    return summary;
}

ReferenceSummary summarize(std::span<const Reference> references) {
    constexpr size_t kParallelThreshold = 32 * 1024;
    if (references.size() < kParallelThreshold) return summarize_serial(references);
    return tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, references.size(), 8192), ReferenceSummary{},
        [&](const tbb::blocked_range<size_t>& range, ReferenceSummary summary) {
            ReferenceSummary part = summarize_serial(references.subspan(range.begin(), range.size()));
            summary.bounds.extend(part.bounds);
            summary.centroid_bounds.extend(part.centroid_bounds);
            return summary;
        },
        [](ReferenceSummary a, const ReferenceSummary& b) {
            a.bounds.extend(b.bounds);
            a.centroid_bounds.extend(b.centroid_bounds);
            return a;
        });
}

}  // namespace spacebvh::builders
