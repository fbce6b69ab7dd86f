// SPDX-License-Identifier: MIT
#include "builders/search_spaces/binned_object_split_finder.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <immintrin.h>

#include <algorithm>
#include <array>

namespace spacebvh::builders {
namespace {

// Bins live on the stack (no allocation per node) and only the first `bins` are initialised, so a
// small node pays for its bins, not for kMaxObjectBins. Bin boxes are kept as 4-wide registers
// (lane 3 unused) so that one min and one max update a bin.
struct Bin {
    __m128 lo, hi;
};

// Bins of all three axes. Merging takes min/max of boxes and sums of counts, both exact, so a
// parallel reduction gives the same bins whatever the thread count.
struct BinGrid {
    std::array<ObjectBinning, 3> binning;
    uint32_t bin_count;
    Bin bins[3][kMaxObjectBins];  // only [axis][0, bin_count) are live
    uint32_t counts[3][kMaxObjectBins];

    explicit BinGrid(const std::array<ObjectBinning, 3>& b) : binning(b), bin_count(b[0].bins) {
        const __m128 empty_lo = _mm_set1_ps(kInfinity), empty_hi = _mm_set1_ps(-kInfinity);
        for (int axis = 0; axis < 3; ++axis)
            for (uint32_t i = 0; i < bin_count; ++i) {
                bins[axis][i] = {empty_lo, empty_hi};
                counts[axis][i] = 0;
            }
    }
    BinGrid(const BinGrid& other) : binning(other.binning), bin_count(other.bin_count) { copy_from(other); }
    BinGrid& operator=(const BinGrid& other) {
        binning = other.binning;
        bin_count = other.bin_count;
        copy_from(other);
        return *this;
    }
    void copy_from(const BinGrid& other) {
        for (int axis = 0; axis < 3; ++axis) {
            std::copy_n(other.bins[axis], bin_count, bins[axis]);
            std::copy_n(other.counts[axis], bin_count, counts[axis]);
        }
    }

    // The same float operations as ObjectBinning::bin_of, so partitioning reproduces these bins.
    struct Binner {
        __m128 origin, scale, last_bin;
        explicit Binner(const std::array<ObjectBinning, 3>& binning, uint32_t bin_count)
            : origin(_mm_setr_ps(binning[0].origin, binning[1].origin, binning[2].origin, 0.0f)),
              scale(_mm_setr_ps(binning[0].scale, binning[1].scale, binning[2].scale, 0.0f)),
              last_bin(_mm_set1_ps(float(bin_count - 1))) {}
    };
    [[gnu::always_inline]] void add_one(const Binner& binner, const Reference& reference) {
        // Reference is {lo.xyz, hi.xyz, primitive}: both loads stay inside it; lane 3 is ignored.
        const __m128 lo = _mm_loadu_ps(&reference.bounds.lo.x);
        const __m128 hi = _mm_loadu_ps(&reference.bounds.hi.x);
        const __m128 centroid = _mm_mul_ps(_mm_set1_ps(0.5f), _mm_add_ps(lo, hi));
        const __m128 position = _mm_mul_ps(_mm_sub_ps(centroid, binner.origin), binner.scale);
        const __m128 clamped = _mm_min_ps(_mm_max_ps(position, _mm_setzero_ps()), binner.last_bin);
        alignas(16) int32_t index[4];
        _mm_store_si128(reinterpret_cast<__m128i*>(index), _mm_cvttps_epi32(clamped));
        for (int axis = 0; axis < 3; ++axis) {
            Bin& bin = bins[axis][index[axis]];
            bin.lo = _mm_min_ps(bin.lo, lo);
            bin.hi = _mm_max_ps(bin.hi, hi);
            counts[axis][index[axis]]++;
        }
    }
    void add(std::span<const Reference> references) {
        const Binner binner(binning, bin_count);
        // Neighbouring references tend to fall in the same bins; alternating between two sets of bins
        // keeps one update from waiting on the previous one. Merging is exact (min, max, sums).
        if (references.size() < 32) {
            for (const Reference& reference : references) add_one(binner, reference);
            return;
        }
        BinGrid odd(binning);
        size_t i = 0;
        for (; i + 1 < references.size(); i += 2) {
            add_one(binner, references[i]);
            odd.add_one(binner, references[i + 1]);
        }
        if (i < references.size()) add_one(binner, references[i]);
        merge(odd);
    }
    void merge(const BinGrid& other) {
        for (int axis = 0; axis < 3; ++axis)
            for (uint32_t i = 0; i < bin_count; ++i) {
                bins[axis][i].lo = _mm_min_ps(bins[axis][i].lo, other.bins[axis][i].lo);
                bins[axis][i].hi = _mm_max_ps(bins[axis][i].hi, other.bins[axis][i].hi);
                counts[axis][i] += other.counts[axis][i];
            }
    }
};

// Bins the node's centroids and offers every cut between bins that beats the sink's threshold
// (CheapestSplit or SplitCandidates).
template <typename Sink>
void bin_and_sweep(const NodeContext& context, const CostModel& cost, uint32_t max_bins, Sink& sink) {
    const std::span<const Reference> references = context.references;
    const ReferenceSummary& node = context.summary;
    if (references.size() < 2) return;

    // Small nodes get fewer bins, as in Embree (heuristic_binning.h: min(B, 4 + 0.05 N)): a node of N
    // references fills at most N bins, and initialising and sweeping unused bins dominates otherwise.
    const uint32_t bins = std::min<uint32_t>(max_bins, 4 + uint32_t(references.size() / 20));
    std::array<ObjectBinning, 3> binning;
    for (int axis = 0; axis < 3; ++axis) {
        const float extent = node.centroid_bounds.hi[axis] - node.centroid_bounds.lo[axis];
        binning[axis].axis = axis;
        binning[axis].origin = node.centroid_bounds.lo[axis];
        binning[axis].bins = bins;
        // Slightly below B / extent so the largest centroid lands in the last bin, not past it.
        binning[axis].scale = extent > 0.0f ? float(bins) * (1.0f - 1e-6f) / extent : 0.0f;
    }

    BinGrid grid(binning);
    constexpr size_t kParallelThreshold = 16 * 1024;
    if (references.size() < kParallelThreshold) {
        grid.add(references);
    } else {
        grid = tbb::parallel_reduce(
            tbb::blocked_range<size_t>(0, references.size(), 4096), BinGrid(binning),
            [&](const tbb::blocked_range<size_t>& range, BinGrid partial) {
                partial.add(references.subspan(range.begin(), range.size()));
                return partial;
            },
            [](BinGrid a, const BinGrid& b) {
                a.merge(b);
                return a;
            });
    }

    // Raw registers, not AABBs: nothing to construct for the bins a node does not use.
    Bin suffix[kMaxObjectBins];
    uint32_t suffix_counts[kMaxObjectBins];
    auto to_box = [](const Bin& bin) {
        alignas(16) float lo[4], hi[4];
        _mm_store_ps(lo, bin.lo);
        _mm_store_ps(hi, bin.hi);
        return AABB{{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}};
    };
    for (int axis = 0; axis < 3; ++axis) {
        if (binning[axis].scale == 0.0f) continue;  // all centroids on one plane: nothing to cut
        const Bin* axis_bins = grid.bins[axis];
        const uint32_t* counts = grid.counts[axis];
        Bin right{_mm_set1_ps(kInfinity), _mm_set1_ps(-kInfinity)};
        uint32_t right_count = 0;
        for (uint32_t i = bins; i-- > 1;) {
            right.lo = _mm_min_ps(right.lo, axis_bins[i].lo);
            right.hi = _mm_max_ps(right.hi, axis_bins[i].hi);
            right_count += counts[i];
            suffix[i] = right;
            suffix_counts[i] = right_count;
        }
        Bin left{_mm_set1_ps(kInfinity), _mm_set1_ps(-kInfinity)};
        uint32_t left_count = 0;
        for (uint32_t i = 1; i < bins; ++i) {
            // An empty bin repeats the previous cut: nothing new to evaluate.
            if (counts[i - 1] == 0) continue;
            left.lo = _mm_min_ps(left.lo, axis_bins[i - 1].lo);
            left.hi = _mm_max_ps(left.hi, axis_bins[i - 1].hi);
            left_count += counts[i - 1];
            if (suffix_counts[i] == 0) break;
            const AABB left_box = to_box(left), right_box = to_box(suffix[i]);
            const float split_cost = cost.split_cost(node.bounds, left_box, left_count, right_box, suffix_counts[i]);
            if (split_cost < sink.threshold(axis)) {
                Split split = make_split(SplitKind::object_binned, split_cost, axis, left_box, left_count, right_box,
                                         suffix_counts[i]);
                split.binning = binning[axis];
                split.bin = i;
                sink.offer(split);
            }
        }
    }
}

}  // namespace

Split BinnedObjectSplitFinder::find(const NodeContext& context, const CostModel& cost) const {
    CheapestSplit cheapest;
    bin_and_sweep(context, cost, bins_, cheapest);
    return cheapest.best;
}

std::vector<Split> BinnedObjectSplitFinder::find_candidates(const NodeContext& context, const CostModel& cost,
                                                            uint32_t per_axis) const {
    SplitCandidates candidates(per_axis);
    bin_and_sweep(context, cost, bins_, candidates);
    return candidates.all();
}

}  // namespace spacebvh::builders
