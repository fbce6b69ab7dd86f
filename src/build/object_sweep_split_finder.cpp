#include "build/object_sweep_split_finder.hpp"

#include <tbb/parallel_sort.h>

#include <algorithm>
#include <vector>

namespace spacebvh::build {
namespace {

// Offers every cut that beats the sink's threshold (CheapestSplit or SplitCandidates).
template <typename Sink>
void sweep(const NodeContext& context, const CostModel& cost, Sink& sink) {
    const std::span<Reference> references = context.references;
    const ReferenceSummary& node = context.summary;
    const size_t count = references.size();
    if (count < 2) return;
    // Right-to-left suffix boxes; reused across axes.
    std::vector<AABB> suffix_bounds(count);
    for (int axis = 0; axis < 3; ++axis) {
        if (node.centroid_bounds.lo[axis] == node.centroid_bounds.hi[axis]) continue;  // no cut separates
        // The order is total, so the unstable parallel sort still gives one answer.
        if (count > 64 * 1024)
            tbb::parallel_sort(references.begin(), references.end(), CentroidOrder{axis});
        else
            std::sort(references.begin(), references.end(), CentroidOrder{axis});

        AABB right;
        for (size_t i = count; i-- > 1;) {
            right.extend(references[i].bounds);
            suffix_bounds[i] = right;
        }
        AABB left;
        for (size_t i = 1; i < count; ++i) {
            left.extend(references[i - 1].bounds);
            const float split_cost = cost.split_cost(node.bounds, left, i, suffix_bounds[i], count - i);
            if (split_cost < sink.threshold(axis)) {
                Split split = make_split(SplitKind::object_sorted, split_cost, axis, left, uint32_t(i), suffix_bounds[i],
                                         uint32_t(count - i));
                split.tie = references[i];
                sink.offer(split);
            }
        }
    }
}

}  // namespace

Split ObjectSweepSplitFinder::find(const NodeContext& context, const CostModel& cost) const {
    CheapestSplit cheapest;
    sweep(context, cost, cheapest);
    return cheapest.best;
}

std::vector<Split> ObjectSweepSplitFinder::find_candidates(const NodeContext& context, const CostModel& cost,
                                                           uint32_t per_axis) const {
    SplitCandidates candidates(per_axis);
    sweep(context, cost, candidates);
    return candidates.all();
}

}  // namespace spacebvh::build
