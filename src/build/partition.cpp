#include "build/partition.hpp"

#include <algorithm>
#include <vector>

#include "build/grid_split_finder.hpp"
#include "build/object_sweep_split_finder.hpp"
#include "build/spatial_split.hpp"

namespace spacebvh::build {

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
    std::vector<Reference> left, right;
    left.reserve(split.left_count);
    right.reserve(split.right_count);
    // Every reference clipped into both sides costs one more slot of this subtree's capacity.
    size_t duplicates_left = storage.size() - count;
    for (uint32_t i = 0; i < count; ++i) {
        const Reference& reference = storage[i];
        const float lo = reference.bounds.lo[split.axis], hi = reference.bounds.hi[split.axis];
        if (hi <= split.position && lo < split.position) {
            left.push_back(reference);
        } else if (lo >= split.position && hi > split.position) {
            right.push_back(reference);
        } else if (lo == hi) {
            left.push_back(reference);  // flat in the plane itself: one side is enough
        } else {
            const PlacementCosts costs = placement_costs(split, reference.bounds);
            Placement placement = split.unsplit ? cheapest_placement(costs) : Placement::both;
            if (placement == Placement::both && duplicates_left == 0) placement = cheaper_side(costs);
            if (placement == Placement::both) {
                auto [left_piece, right_piece] = split_reference(reference, triangles[reference.primitive], split.axis, split.position);
                const bool has_left = !left_piece.bounds.is_empty(), has_right = !right_piece.bounds.is_empty();
                if (has_left && has_right) {
                    left.push_back(left_piece);
                    right.push_back(right_piece);
                    --duplicates_left;
                } else if (has_left) {
                    left.push_back(left_piece);
                } else if (has_right) {
                    right.push_back(right_piece);
                } else {
                    left.push_back(reference);  // clipping found nothing (rounding): keep it whole
                }
            } else {
                (placement == Placement::left ? left : right).push_back(reference);
            }
        }
    }
    return store_children(storage, left, right);
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
        const auto [left_piece, right_piece] = place_in_grid_children(reference, triangles[reference.primitive],
                                                                      split.left_region, split.right_region);
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
    auto middle = storage.begin();
    if (split.kind == SplitKind::object_binned) {
        // The common case of the binned builders, without goes_left's dispatch per reference.
        const ObjectBinning binning = split.binning;
        const int axis = split.axis;
        const uint32_t bin = split.bin;
        middle = std::partition(storage.begin(), storage.begin() + count,
                                [&](const Reference& reference) { return left_of_bin(reference, binning, axis, bin); });
    } else if (split.kind == SplitKind::object_sorted) {
        // In order: the sweep left the references sorted on the last axis it swept, and children that
        // keep that order skip one of their three sorts (object_sweep_split_finder.cpp, sweep_order).
        const CentroidOrder before{split.axis};
        const Reference tie = split.tie;
        std::vector<Reference> right;
        right.reserve(split.right_count);
        auto left_end = storage.begin();
        for (auto reference = storage.begin(); reference != storage.begin() + count; ++reference) {
            if (before(*reference, tie)) *left_end++ = *reference;
            else right.push_back(*reference);
        }
        std::copy(right.begin(), right.end(), left_end);
        middle = left_end;
    } else {
        middle = std::partition(storage.begin(), storage.begin() + count,
                                [&](const Reference& reference) { return goes_left(reference, split); });
    }
    const uint32_t left_count = uint32_t(middle - storage.begin());
    const ChildRanges ranges = share_capacity(uint32_t(storage.size()), left_count, count - left_count);
    // The right block moves up to where the right child's capacity starts (never down); without spare
    // capacity (no spatial splits) it is already there.
    if (ranges.left_capacity != left_count)
        std::move_backward(storage.begin() + left_count, storage.begin() + count,
                           storage.begin() + ranges.left_capacity + ranges.right_count);
    return ranges;
}

Split median_split(std::span<Reference> references, const ReferenceSummary& node) {
    Split split;
    split.kind = SplitKind::object_sorted;
    split.axis = node.centroid_bounds.largest_axis();
    const size_t half = references.size() / 2;
    std::nth_element(references.begin(), references.begin() + half, references.end(), CentroidOrder{split.axis});
    split.tie = references[half];
    split.left_count = uint32_t(half);
    split.right_count = uint32_t(references.size() - half);
    return split;
}

}  // namespace spacebvh::build
