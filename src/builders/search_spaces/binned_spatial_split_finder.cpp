// SPDX-License-Identifier: MIT
#include "builders/search_spaces/binned_spatial_split_finder.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <immintrin.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "builders/driver/simd_box.hpp"
#include "builders/search_spaces/spatial_split.hpp"

namespace spacebvh::builders {
namespace {

// Bins along one axis of the node box: plane i (between bins i-1 and i) is at origin + i * width.
struct SpatialBinning {
    int axis;
    float origin, width, inverse_width;
    uint32_t bins;

    uint32_t bin_of(float x) const {
        const float position = (x - origin) * inverse_width;
        return uint32_t(std::min(std::max(position, 0.0f), float(bins - 1)));
    }
    float plane(uint32_t i) const { return i == bins ? origin + width * float(bins) : origin + width * float(i); }
};

// Boxes and enter/exit counts per bin, for the three axes at once (one pass over the references).
// Merging is exact (min/max, integer sums), so a parallel reduction gives the same bins whatever
// the thread count.
struct SpatialBins {
    std::array<std::vector<SimdBox>, 3> bounds;
    std::array<std::vector<uint32_t>, 3> enter, exit;

    explicit SpatialBins(uint32_t bins) {
        for (int axis = 0; axis < 3; ++axis) {
            bounds[axis].resize(bins);
            enter[axis].assign(bins, 0);
            exit[axis].assign(bins, 0);
        }
    }

    void add(std::span<const Reference> references, std::span<const Triangle> triangles,
             std::span<const SpatialBinning> binnings) {
        for (const Reference& reference : references) {
            const SimdBox box = simd(reference.bounds);
            for (const SpatialBinning& binning : binnings) {
                const int axis = binning.axis;
                // Bins from the plane positions themselves, so a bin's box never crosses its planes
                // (bin_of's rounding alone could leave a box a hair past a plane, which would make the
                // children look overlapping and, with C_o = inf, every plane infeasible).
                const float lo = reference.bounds.lo[axis], hi = reference.bounds.hi[axis];
                uint32_t first = binning.bin_of(lo);
                while (first > 0 && binning.plane(first) > lo) --first;
                uint32_t last = std::max(first, binning.bin_of(hi));
                while (last + 1 < binning.bins && binning.plane(last + 1) < hi) ++last;
                enter[axis][first]++;
                exit[axis][last]++;
                if (first == last) {
                    bounds[axis][first].extend(box);
                } else {
                    add_straddler(triangles[reference.primitive], box, reference.bounds, first, last, binning);
                }
            }
        }
    }

    // A reference spanning bins first..last. Each bin gets the box of the triangle's points between
    // its planes (the vertices there and the edges' crossings with the planes), clamped into the
    // reference's bounds and the bin's slab, as Embree's spatial binning does. Clamping is monotone,
    // so that is the clamped box of the triangle's part in the slab: it holds the exact piece (up to
    // the rounding of the crossings) but may be looser where the reference was clipped before. The
    // bins only price the planes: the chosen split clips exactly (apply_split) and each child gets
    // the tight box of what it receives. An exact double-precision chop of the triangle into
    // every bin would dominate the time of a `spatial` build.
    void add_straddler(const Triangle& triangle, const SimdBox& limit, const AABB& limit_box, uint32_t first,
                       uint32_t last, const SpatialBinning& binning) {
        const int axis = binning.axis;
        std::vector<SimdBox>& boxes = bounds[axis];
        const __m128 on_axis =
            _mm_castsi128_ps(_mm_setr_epi32(axis == 0 ? -1 : 0, axis == 1 ? -1 : 0, axis == 2 ? -1 : 0, 0));
        const float axis_lo = limit_box.lo[axis], axis_hi = limit_box.hi[axis];
        // The box of points lo..hi clamped into the reference's bounds, at position x on the axis.
        auto clamped = [&](__m128 lo, __m128 hi, float x) {
            const __m128 position = _mm_and_ps(on_axis, _mm_set1_ps(x));
            return SimdBox{_mm_or_ps(position, _mm_andnot_ps(on_axis, _mm_max_ps(_mm_min_ps(lo, limit.hi), limit.lo))),
                           _mm_or_ps(position, _mm_andnot_ps(on_axis, _mm_max_ps(_mm_min_ps(hi, limit.hi), limit.lo)))};
        };
        // Whether x lies in the bin's slab: a reference may end a hair short of an end bin (bin_of's
        // rounding), and then that bin gets nothing.
        auto in_slab = [&](float x, uint32_t bin) { return x >= binning.plane(bin) && x <= binning.plane(bin + 1); };
        // The vertices by ascending position on the axis: low, middle, high.
        Vec3 low = triangle.v0, middle = triangle.v1, high = triangle.v2;
        if (middle[axis] < low[axis]) std::swap(low, middle);
        if (high[axis] < middle[axis]) std::swap(middle, high);
        if (middle[axis] < low[axis]) std::swap(low, middle);
        // Each vertex in its bin among first..last (the end bin for those beyond the reference). The
        // low vertex lies below plane first + 1 and the high one above plane last (they bound the
        // reference), so only the middle one normally needs the search; the tests give the bin the
        // search would give.
        const float inner_lo = binning.plane(first + 1), inner_hi = binning.plane(last);
        for (const Vec3& vertex : {low, middle, high}) {
            const float x = vertex[axis];
            uint32_t bin;
            if (x < inner_lo) {
                bin = first;
            } else if (x > inner_hi) {
                bin = last;
            } else {
                bin = std::clamp(binning.bin_of(x), first, last);
                while (bin > first && binning.plane(bin) > x) --bin;
                while (bin < last && binning.plane(bin + 1) < x) ++bin;
            }
            // Clamped into the slab, so always in it.
            const float clamped_x =
                std::clamp(std::clamp(x, axis_lo, axis_hi), binning.plane(bin), binning.plane(bin + 1));
            const __m128 point = simd(vertex);
            boxes[bin].extend(clamped(point, point, clamped_x));
        }
        // Each inner plane cuts the triangle in a segment: from the long edge (low to high) to one of
        // the short ones. The segment belongs to both bins beside the plane.
        const float x_low = low[axis], x_middle = middle[axis], x_high = high[axis];
        if (!(x_low < x_high)) return;  // flat on the axis: no plane cuts it
        const float inverse_long = 1.0f / (x_high - x_low);
        const float inverse_lower = x_middle > x_low ? 1.0f / (x_middle - x_low) : 0.0f;
        const float inverse_upper = x_high > x_middle ? 1.0f / (x_high - x_middle) : 0.0f;
        const __m128 low_point = simd(low), middle_point = simd(middle);
        const __m128 long_edge = simd(high - low), lower_edge = simd(middle - low), upper_edge = simd(high - middle);
        // The segment on a plane between the long edge and the short edge starting at `short_start`
        // (t_short: the plane's parameter on it), unclamped.
        auto segment_at = [&](float plane, __m128 short_start, __m128 short_edge, float t_short) {
            const float t_long = std::clamp((plane - x_low) * inverse_long, 0.0f, 1.0f);
            const __m128 on_long = _mm_add_ps(low_point, _mm_mul_ps(long_edge, _mm_set1_ps(t_long)));
            const __m128 on_short =
                _mm_add_ps(short_start, _mm_mul_ps(short_edge, _mm_set1_ps(std::clamp(t_short, 0.0f, 1.0f))));
            return SimdBox{_mm_min_ps(on_long, on_short), _mm_max_ps(on_long, on_short)};
        };
        auto lower_segment = [&](float plane) {
            return segment_at(plane, low_point, lower_edge, (plane - x_low) * inverse_lower);
        };
        auto upper_segment = [&](float plane) {
            return segment_at(plane, middle_point, upper_edge, (plane - x_middle) * inverse_upper);
        };
        // The segment on plane k goes to bins k - 1 and k; `carry` holds the one on plane k - 1 until
        // bin k - 1 is extended by both, so each bin is read and written once.
        SimdBox carry;
        auto add_segments = [&](uint32_t k, const SimdBox& below, const SimdBox& above) {
            carry.extend(below);
            boxes[k - 1].extend(carry);
            carry = above;
        };
        if (inner_lo > axis_lo && inner_hi < axis_hi && inner_lo >= x_low && inner_hi <= x_high) {
            // The common case: every inner plane cuts the triangle inside the reference, so each
            // segment goes to both bins whole. The general loop below, with its tests hoisted: the
            // planes up to the middle vertex end on the lower short edge, the rest on the upper one.
            uint32_t k = first + 1;
            if (x_middle > x_low)
                for (float plane; k <= last && (plane = binning.plane(k)) <= x_middle; ++k) {
                    const SimdBox segment = lower_segment(plane);
                    const SimdBox whole = clamped(segment.lo, segment.hi, plane);
                    add_segments(k, whole, whole);
                }
            for (; k <= last; ++k) {
                const float plane = binning.plane(k);
                const SimdBox segment = upper_segment(plane);
                const SimdBox whole = clamped(segment.lo, segment.hi, plane);
                add_segments(k, whole, whole);
            }
            boxes[last].extend(carry);
            return;
        }
        for (uint32_t k = first + 1; k <= last; ++k) {
            const float plane = binning.plane(k);
            SimdBox below, above;  // empty: plane k does not cut the triangle
            if (plane >= x_low && plane <= x_high) {
                const SimdBox segment =
                    plane <= x_middle && x_middle > x_low ? lower_segment(plane) : upper_segment(plane);
                if (plane > axis_lo && plane < axis_hi) {  // in both slabs
                    below = above = clamped(segment.lo, segment.hi, plane);
                } else {
                    const float x = std::clamp(plane, axis_lo, axis_hi);
                    const SimdBox clamped_segment = clamped(segment.lo, segment.hi, x);
                    if (in_slab(x, k - 1)) below = clamped_segment;
                    if (in_slab(x, k)) above = clamped_segment;
                }
            }
            add_segments(k, below, above);
        }
        boxes[last].extend(carry);
    }

    void merge(const SpatialBins& other) {
        for (int axis = 0; axis < 3; ++axis)
            for (size_t i = 0; i < bounds[axis].size(); ++i) {
                bounds[axis][i].extend(other.bounds[axis][i]);
                enter[axis][i] += other.enter[axis][i];
                exit[axis][i] += other.exit[axis][i];
            }
    }
};

// Bins the node along each axis and offers every plane that beats the sink's threshold
// (CheapestSplit or SplitCandidates).
template <typename Sink>
void bin_and_sweep(const NodeContext& context, const CostModel& cost, std::span<const Triangle> triangles,
                   const SpatialSearchOptions& options, Sink& sink) {
    const std::span<const Reference> references = context.references;
    if (references.size() < 2) return;
    if (spatial_search_gated_off(context, cost, options.gate_alpha)) return;
    const AABB& node = context.summary.bounds;
    const uint32_t bins = options.bins;
    std::vector<SpatialBinning> binnings;
    for (int axis = 0; axis < 3; ++axis) {
        // An extent beyond the float range (a node spanning more than FLT_MAX) has no bins: its width
        // and planes would be infinite, and a bin index from inf * 0 undefined.
        const float extent = node.hi[axis] - node.lo[axis];
        if (extent > 0.0f && std::isfinite(node.lo[axis] + extent))
            binnings.push_back({axis, node.lo[axis], extent / float(bins), float(bins) / extent, bins});
    }
    if (binnings.empty()) return;

    SpatialBins grid(bins);
    constexpr size_t kParallelThreshold = 4 * 1024;
    if (references.size() < kParallelThreshold) {
        grid.add(references, triangles, binnings);
    } else {
        grid = tbb::parallel_reduce(
            tbb::blocked_range<size_t>(0, references.size(), 1024), SpatialBins(bins),
            [&](const tbb::blocked_range<size_t>& range, SpatialBins partial) {
                partial.add(references.subspan(range.begin(), range.size()), triangles, binnings);
                return partial;
            },
            [](SpatialBins a, const SpatialBins& b) {
                a.merge(b);
                return a;
            });
    }

    std::vector<AABB> suffix_bounds(bins);
    std::vector<uint32_t> suffix_counts(bins);
    for (const SpatialBinning& binning : binnings) {
        const int axis = binning.axis;
        AABB right;
        uint32_t right_count = 0;
        for (uint32_t i = bins; i-- > 1;) {
            right.extend(grid.bounds[axis][i].aabb());
            right_count += grid.exit[axis][i];
            suffix_bounds[i] = right;
            suffix_counts[i] = right_count;
        }
        AABB left;
        uint32_t left_count = 0;
        for (uint32_t i = 1; i < bins; ++i) {
            left.extend(grid.bounds[axis][i - 1].aabb());
            left_count += grid.enter[axis][i - 1];
            const uint32_t count_right = suffix_counts[i];
            if (left_count == 0 || count_right == 0) continue;
            // Without spare capacity (searched then only where no other space offered a split, as in
            // kdbvh, or the node must split and no offered split beats a leaf: spatial_search_gated_off)
            // the plane is still a candidate: apply_split sends the straddlers it cannot duplicate
            // whole to their cheaper side (the budget always holds).
            const float split_cost = cost.split_cost(node, left, left_count, suffix_bounds[i], count_right);
            if (split_cost < sink.threshold(axis))
                sink.offer(spatial_split(split_cost, axis, binning.plane(i), left, left_count, suffix_bounds[i],
                                         count_right, options.unsplit));
        }
    }
}

}  // namespace

Split BinnedSpatialSplitFinder::find(const NodeContext& context, const CostModel& cost) const {
    CheapestSplit cheapest;
    bin_and_sweep(context, cost, triangles_, options_, cheapest);
    return cheapest.best;
}

std::vector<Split> BinnedSpatialSplitFinder::find_candidates(const NodeContext& context, const CostModel& cost,
                                                             uint32_t per_axis) const {
    SplitCandidates candidates(per_axis);
    bin_and_sweep(context, cost, triangles_, options_, candidates);
    return candidates.all();
}

}  // namespace spacebvh::builders
