#include "build/binned_spatial_split_finder.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <vector>

#include "build/spatial_split.hpp"
#include "spacebvh/clip.hpp"

namespace spacebvh::build {
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

// Clipped boxes and enter/exit counts per bin. Merging is exact (min/max, integer sums), so a
// parallel reduction gives the same bins whatever the thread count.
struct SpatialBins {
    std::vector<AABB> bounds;
    std::vector<uint32_t> enter, exit;
    std::vector<float> planes;  // scratch for chopping
    std::vector<AABB> pieces;

    explicit SpatialBins(uint32_t bins) : bounds(bins), enter(bins, 0), exit(bins, 0) {}

    void add(std::span<const Reference> references, std::span<const Triangle> triangles, const SpatialBinning& binning) {
        const int axis = binning.axis;
        for (const Reference& reference : references) {
            // Bins from the plane positions themselves, so a bin's box never crosses its planes
            // (bin_of's rounding alone could leave a box a hair past a plane, which would make the
            // children look overlapping and, with C_o = inf, every plane infeasible).
            const float lo = reference.bounds.lo[axis], hi = reference.bounds.hi[axis];
            uint32_t first = binning.bin_of(lo);
            while (first > 0 && binning.plane(first) > lo) --first;
            uint32_t last = std::max(first, binning.bin_of(hi));
            while (last + 1 < binning.bins && binning.plane(last + 1) < hi) ++last;
            enter[first]++;
            exit[last]++;
            if (first == last) {
                bounds[first].extend(reference.bounds);
                continue;
            }
            // Chop the reference into the bins it spans (one exact clip, one slab per plane).
            const uint32_t spanned = last - first + 1;
            planes.resize(spanned - 1);
            pieces.resize(spanned);
            for (uint32_t i = 0; i + 1 < spanned; ++i) planes[i] = binning.plane(first + i + 1);
            chop_triangle_bounds(triangles[reference.primitive], reference.bounds, axis, planes, pieces);
            for (uint32_t i = 0; i < spanned; ++i) bounds[first + i].extend(pieces[i]);
        }
    }
    void merge(const SpatialBins& other) {
        for (size_t i = 0; i < bounds.size(); ++i) {
            bounds[i].extend(other.bounds[i]);
            enter[i] += other.enter[i];
            exit[i] += other.exit[i];
        }
    }
};

// Bins the node along each axis and offers every plane that beats the sink's threshold
// (CheapestSplit or SplitCandidates).
template <typename Sink>
void bin_and_sweep(const NodeContext& context, const CostModel& cost, std::span<const Triangle> triangles,
                   const SpatialSearchOptions& options, Sink& sink) {
    const std::span<Reference> references = context.references;
    if (references.size() < 2) return;
    if (spatial_search_gated_off(context, options.gate_alpha)) return;
    const AABB& node = context.summary.bounds;
    const uint32_t bins = options.bins;
    for (int axis = 0; axis < 3; ++axis) {
        const float extent = node.hi[axis] - node.lo[axis];
        if (!(extent > 0.0f)) continue;
        SpatialBinning binning{axis, node.lo[axis], extent / float(bins), float(bins) / extent, bins};

        SpatialBins grid(bins);
        constexpr size_t kParallelThreshold = 8 * 1024;
        if (references.size() < kParallelThreshold) {
            grid.add(references, triangles, binning);
        } else {
            grid = tbb::parallel_reduce(
                tbb::blocked_range<size_t>(0, references.size(), 2048), SpatialBins(bins),
                [&](const tbb::blocked_range<size_t>& range, SpatialBins partial) {
                    partial.add(references.subspan(range.begin(), range.size()), triangles, binning);
                    return partial;
                },
                [](SpatialBins a, const SpatialBins& b) {
                    a.merge(b);
                    return a;
                });
        }

        std::vector<AABB> suffix_bounds(bins);
        std::vector<uint32_t> suffix_counts(bins);
        AABB right;
        uint32_t right_count = 0;
        for (uint32_t i = bins; i-- > 1;) {
            right.extend(grid.bounds[i]);
            right_count += grid.exit[i];
            suffix_bounds[i] = right;
            suffix_counts[i] = right_count;
        }
        AABB left;
        uint32_t left_count = 0;
        for (uint32_t i = 1; i < bins; ++i) {
            left.extend(grid.bounds[i - 1]);
            left_count += grid.enter[i - 1];
            const uint32_t count_right = suffix_counts[i];
            if (left_count == 0 || count_right == 0) continue;
            // Over this subtree's budget the plane is still a candidate: apply_split then sends the
            // straddlers it cannot duplicate whole to their cheaper side (the budget always holds).
            const float split_cost = cost.split_cost(node, left, left_count, suffix_bounds[i], count_right);
            if (split_cost < sink.threshold(axis))
                sink.offer(spatial_split(split_cost, axis, binning.plane(i), left, left_count, suffix_bounds[i], count_right,
                                         options.unsplit));
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

}  // namespace spacebvh::build
