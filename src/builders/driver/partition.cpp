// SPDX-License-Identifier: MIT
#include "builders/driver/partition.hpp"

#include <algorithm>
#include <vector>

#include "builders/search_spaces/grid_split_finder.hpp"
#include "builders/search_spaces/object_sweep_split_finder.hpp"
#include "builders/search_spaces/spatial_split.hpp"

namespace spacebvh::builders {

namespace {
// The side of a binned object split: the reference's centroid bin against the cut.
bool left_of_bin(const Reference& reference, const ObjectBinning& binning, int axis, uint32_t bin) {
    return binning.bin_of(reference.centroid(axis)) < bin;
}
}  // namespace

bool goes_left(const Reference& reference, const Split& split) {
    switch (split.kind) {
        case SplitKind::object_sorted:
            return CentroidOrder{split.axis}(reference, split.tie);
        case SplitKind::object_binned:
            return left_of_bin(reference, split.binning, split.axis, split.bin);
        case SplitKind::spatial:
            return reference.bounds.hi[split.axis] <= split.position;
        case SplitKind::grid:  // may clip: apply_grid_split
        case SplitKind::none:
            break;
    }
    return false;
}

namespace {

// Moves the references for which goes_left holds to the front, both sides in their order; returns
// how many went left. `expected_right`: a size hint for the buffer. A stable partition, written out:
// std::stable_partition (libstdc++) allocates a buffer of the whole range on every call, which makes
// builds slower; this one buffers only the right side.
template <class GoesLeft>
uint32_t partition_in_order(std::span<Reference> references, uint32_t expected_right, GoesLeft goes_left) {
    std::vector<Reference> right;
    right.reserve(expected_right);
    auto left_end = references.begin();
    for (const Reference& reference : references) {
        if (goes_left(reference))
            *left_end++ = reference;
        else
            right.push_back(reference);
    }
    std::copy(right.begin(), right.end(), left_end);
    return uint32_t(left_end - references.begin());
}

ChildRanges share_capacity(uint32_t capacity, uint32_t left_count, uint32_t right_count) {
    const uint64_t spare = capacity - left_count - right_count;
    const uint32_t left_extra = uint32_t(spare * left_count / (uint64_t(left_count) + right_count));
    ChildRanges ranges;
    ranges.left_count = left_count;
    ranges.left_capacity = left_count + left_extra;
    ranges.right_count = right_count;
    ranges.right_capacity = capacity - ranges.left_capacity;
    return ranges;
}

// Stores the children's references at their places in the node's storage (see ChildRanges).
ChildRanges store_children(std::span<Reference> storage, const std::vector<Reference>& left,
                           const std::vector<Reference>& right) {
    const ChildRanges ranges = share_capacity(uint32_t(storage.size()), uint32_t(left.size()), uint32_t(right.size()));
    std::copy(left.begin(), left.end(), storage.begin());
    std::copy(right.begin(), right.end(), storage.begin() + ranges.left_capacity);
    return ranges;
}

// Stich et al. 2009, "reference unsplitting": for a straddling reference B, compare
//   both sides: SA(L)*|L| + SA(R)*|R|,  left only: SA(L ∪ B)*|L| + SA(R)*(|R|-1),
//   right only: SA(L)*(|L|-1) + SA(R ∪ B)*|R|   (L, R, counts: the split's estimate).
enum class Placement { both, left, right };
struct PlacementCosts {
    float both, left_only, right_only;
};
PlacementCosts placement_costs(const Split& split, const AABB& whole) {
    const float left_area = split.left_bounds.area(), right_area = split.right_bounds.area();
    const float nl = float(split.left_count), nr = float(split.right_count);
    return {left_area * nl + right_area * nr, merge(split.left_bounds, whole).area() * nl + right_area * (nr - 1.0f),
            left_area * (nl - 1.0f) + merge(split.right_bounds, whole).area() * nr};
}
// The cheaper of left only and right only: where the budget allows no duplicate.
Placement cheaper_side(const PlacementCosts& costs) {
    return costs.left_only <= costs.right_only ? Placement::left : Placement::right;
}
Placement cheapest_placement(const PlacementCosts& costs) {
    if (costs.both <= costs.left_only && costs.both <= costs.right_only) return Placement::both;
    return cheaper_side(costs);
}

ChildRanges apply_spatial_split(std::span<Reference> storage, uint32_t count, const Split& split,
                                std::span<const Triangle> triangles) {
    std::vector<Reference> left, right, left_from_straddlers, right_from_straddlers;
    left.reserve(split.left_count);
    right.reserve(split.right_count);
    // Every reference clipped into both sides costs one more slot of this subtree's capacity.
    size_t duplicates_left = storage.size() - count;
    for (uint32_t i = 0; i < count; ++i) {
        const Reference& reference = storage[i];
        const PlaneSide side = plane_side(reference, split.axis, split.position);
        if (side == PlaneSide::left) {
            left.push_back(reference);
        } else if (side == PlaneSide::right) {
            right.push_back(reference);
        } else {
            const PlacementCosts costs = placement_costs(split, reference.bounds);
            Placement placement = split.unsplit ? cheapest_placement(costs) : Placement::both;
            if (placement == Placement::both && duplicates_left == 0) placement = cheaper_side(costs);
            if (placement == Placement::both) {
                auto [left_piece, right_piece] =
                    split_reference(reference, triangles[reference.primitive], split.axis, split.position);
                const bool has_left = !left_piece.bounds.is_empty(), has_right = !right_piece.bounds.is_empty();
                if (has_left && has_right) {
                    left_from_straddlers.push_back(left_piece);
                    right_from_straddlers.push_back(right_piece);
                    --duplicates_left;
                } else if (has_left) {
                    left_from_straddlers.push_back(left_piece);
                } else if (has_right) {
                    right_from_straddlers.push_back(right_piece);
                } else {
                    left_from_straddlers.push_back(reference);  // clipping found nothing (rounding): keep it whole
                }
            } else {
                (placement == Placement::left ? left_from_straddlers : right_from_straddlers).push_back(reference);
            }
        }
    }
    left.insert(left.end(), left_from_straddlers.begin(), left_from_straddlers.end());
    right.insert(right.end(), right_from_straddlers.begin(), right_from_straddlers.end());
    ChildRanges ranges = store_children(storage, left, right);
    ranges.left_from_straddlers = uint32_t(left_from_straddlers.size());
    ranges.right_from_straddlers = uint32_t(right_from_straddlers.size());
    return ranges;
}

// The finder's own assignment (place_in_grid_children), so the children get exactly the references
// the finder counted; its clipped references fit the spare capacity by construction.
ChildRanges apply_grid_split(std::span<Reference> storage, uint32_t count, const Split& split,
                             std::span<const Triangle> triangles) {
    std::vector<Reference> left, right;
    left.reserve(split.left_count);
    right.reserve(split.right_count);
    for (uint32_t i = 0; i < count; ++i) {
        const Reference& reference = storage[i];
        const auto [left_piece, right_piece] =
            place_in_grid_children(reference, triangles[reference.primitive], split.left_region, split.right_region);
        if (!left_piece.bounds.is_empty()) left.push_back(left_piece);
        if (!right_piece.bounds.is_empty()) right.push_back(right_piece);
    }
    return store_children(storage, left, right);
}

}  // namespace

ChildRanges apply_split(std::span<Reference> storage, uint32_t count, const Split& split,
                        std::span<const Triangle> triangles) {
    if (split.kind == SplitKind::spatial) return apply_spatial_split(storage, count, split, triangles);
    if (split.kind == SplitKind::grid) return apply_grid_split(storage, count, split, triangles);
    // In order (a stable partition): the children keep the node's order, so the driver's centroid
    // orders stay sorted (top_down_builder.cpp) and, without them, a child sorted on an axis skips
    // that sort (object_sweep_split_finder.cpp, sweep_order).
    uint32_t left_count = 0;
    if (split.kind == SplitKind::object_binned) {
        // The common case of the binned builders, without goes_left's dispatch per reference.
        const ObjectBinning binning = split.binning;
        const int axis = split.axis;
        const uint32_t bin = split.bin;
        left_count = partition_in_order(storage.first(count), split.right_count, [&](const Reference& reference) {
            return left_of_bin(reference, binning, axis, bin);
        });
    } else if (split.kind == SplitKind::object_sorted) {
        const CentroidOrder before{split.axis};
        const Reference tie = split.tie;
        left_count = partition_in_order(storage.first(count), split.right_count,
                                        [&](const Reference& reference) { return before(reference, tie); });
    } else {
        left_count = partition_in_order(storage.first(count), split.right_count,
                                        [&](const Reference& reference) { return goes_left(reference, split); });
    }
    const ChildRanges ranges = share_capacity(uint32_t(storage.size()), left_count, count - left_count);
    // The right block moves up to where the right child's capacity starts (never down); without spare
    // capacity (no spatial splits) it is already there.
    if (ranges.left_capacity != left_count)
        std::move_backward(storage.begin() + left_count, storage.begin() + count,
                           storage.begin() + ranges.left_capacity + ranges.right_count);
    return ranges;
}

Split median_split(std::span<const Reference> references, const ReferenceSummary& node) {
    Split split;
    split.kind = SplitKind::object_sorted;
    split.axis = node.centroid_bounds.largest_axis();
    const size_t half = references.size() / 2;
    // On a copy: the node's references keep their order (the driver's centroid orders). The order is
    // total, so the median is one reference whatever the input order.
    std::vector<Reference> copy(references.begin(), references.end());
    std::nth_element(copy.begin(), copy.begin() + half, copy.end(), CentroidOrder{split.axis});
    split.tie = copy[half];
    split.left_count = uint32_t(half);
    split.right_count = uint32_t(references.size() - half);
    return split;
}

}  // namespace spacebvh::builders
