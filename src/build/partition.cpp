#include "build/partition.hpp"

#include <algorithm>

#include "build/object_sweep_split_finder.hpp"

namespace spacebvh::build {

bool goes_left(const Reference& reference, const Split& split) {
    switch (split.kind) {
        case SplitKind::object_sorted: {
            const float c = reference.centroid(split.axis);
            return c < split.position || (c == split.position && reference.primitive < split.tie_primitive);
        }
        case SplitKind::object_binned:
            return split.binning.bin_of(reference.centroid(split.axis)) < split.bin;
        case SplitKind::none:
            break;
    }
    return false;
}

size_t partition_references(std::span<Reference> references, const Split& split) {
    auto middle = std::partition(references.begin(), references.end(),
                                 [&](const Reference& reference) { return goes_left(reference, split); });
    return size_t(middle - references.begin());
}

Split median_split(std::span<Reference> references, const ReferenceSummary& node) {
    Split split;
    split.kind = SplitKind::object_sorted;
    split.axis = node.centroid_bounds.largest_axis();
    const size_t half = references.size() / 2;
    std::nth_element(references.begin(), references.begin() + half, references.end(), CentroidOrder{split.axis});
    split.position = references[half].centroid(split.axis);
    split.tie_primitive = references[half].primitive;
    split.left_count = uint32_t(half);
    split.right_count = uint32_t(references.size() - half);
    return split;
}

}  // namespace spacebvh::build
