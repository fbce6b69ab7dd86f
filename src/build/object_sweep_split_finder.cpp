#include "build/object_sweep_split_finder.hpp"

#include <tbb/parallel_sort.h>

#include <algorithm>
#include <vector>

namespace spacebvh::build {

Split ObjectSweepSplitFinder::find(const NodeContext& context, const CostModel& cost) const {
    const std::span<Reference> references = context.references;
    const ReferenceSummary& node = context.summary;
    Split best;
    const size_t count = references.size();
    if (count < 2) return best;
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
            if (split_cost < best.cost) {
                best.kind = SplitKind::object_sorted;
                best.cost = split_cost;
                best.axis = axis;
                best.tie = references[i];
                best.left_bounds = left;
                best.right_bounds = suffix_bounds[i];
                best.left_count = uint32_t(i);
                best.right_count = uint32_t(count - i);
            }
        }
    }
    return best;
}

}  // namespace spacebvh::build
