#include "build/binned_object_split_finder.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <array>
#include <vector>

namespace spacebvh::build {
namespace {

struct Bin {
    AABB bounds;
    uint32_t count = 0;
};

// Bins of all three axes. Merging takes min/max of boxes and sums of counts, both exact, so a
// parallel reduction gives the same bins whatever the thread count.
struct BinGrid {
    std::array<ObjectBinning, 3> binning;
    std::array<std::vector<Bin>, 3> bins;

    explicit BinGrid(const std::array<ObjectBinning, 3>& b) : binning(b) {
        for (int axis = 0; axis < 3; ++axis) bins[axis].resize(binning[axis].bins);
    }
    void add(std::span<const Reference> references) {
        for (const Reference& reference : references) {
            for (int axis = 0; axis < 3; ++axis) {
                Bin& bin = bins[axis][binning[axis].bin_of(reference.centroid(axis))];
                bin.bounds.extend(reference.bounds);
                bin.count++;
            }
        }
    }
    void merge(const BinGrid& other) {
        for (int axis = 0; axis < 3; ++axis)
            for (size_t i = 0; i < bins[axis].size(); ++i) {
                bins[axis][i].bounds.extend(other.bins[axis][i].bounds);
                bins[axis][i].count += other.bins[axis][i].count;
            }
    }
};

}  // namespace

Split BinnedObjectSplitFinder::find(std::span<Reference> references, const ReferenceSummary& node,
                                    const CostModel& cost) const {
    Split best;
    if (references.size() < 2) return best;

    std::array<ObjectBinning, 3> binning;
    for (int axis = 0; axis < 3; ++axis) {
        const float extent = node.centroid_bounds.hi[axis] - node.centroid_bounds.lo[axis];
        binning[axis].axis = axis;
        binning[axis].origin = node.centroid_bounds.lo[axis];
        binning[axis].bins = bins_;
        // Slightly below B / extent so the largest centroid lands in the last bin, not past it.
        binning[axis].scale = extent > 0.0f ? float(bins_) * (1.0f - 1e-6f) / extent : 0.0f;
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

    std::vector<AABB> suffix_bounds(bins_);
    std::vector<uint32_t> suffix_counts(bins_);
    for (int axis = 0; axis < 3; ++axis) {
        if (binning[axis].scale == 0.0f) continue;  // all centroids on one plane: nothing to cut
        const std::vector<Bin>& bins = grid.bins[axis];
        AABB right;
        uint32_t right_count = 0;
        for (uint32_t i = bins_; i-- > 1;) {
            right.extend(bins[i].bounds);
            right_count += bins[i].count;
            suffix_bounds[i] = right;
            suffix_counts[i] = right_count;
        }
        AABB left;
        uint32_t left_count = 0;
        for (uint32_t i = 1; i < bins_; ++i) {
            left.extend(bins[i - 1].bounds);
            left_count += bins[i - 1].count;
            if (left_count == 0 || suffix_counts[i] == 0) continue;
            const float split_cost = cost.split_cost(node.bounds, left, left_count, suffix_bounds[i], suffix_counts[i]);
            if (split_cost < best.cost) {
                best.kind = SplitKind::object_binned;
                best.cost = split_cost;
                best.axis = axis;
                best.binning = binning[axis];
                best.bin = i;
                best.left_bounds = left;
                best.right_bounds = suffix_bounds[i];
                best.left_count = left_count;
                best.right_count = suffix_counts[i];
            }
        }
    }
    return best;
}

}  // namespace spacebvh::build
