// SPDX-License-Identifier: MIT
// A split configuration chosen from a search space, and the interface every search space implements.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "builders/driver/reference.hpp"
#include "spacebvh/cost_model.hpp"

namespace spacebvh::builders {

enum class SplitKind : uint8_t {
    none,
    // References that come before `tie` in CentroidOrder go left: a cut in the centroid-sorted order
    // (object sweep, and the median fallback).
    object_sorted,
    // References whose centroid falls in a bin below `bin` go left (binned object SAH). The bin
    // function is ObjectBinning's, so the partition reproduces the finder's counts exactly.
    object_binned,
    // A kd-style plane x[axis] = position: references entirely on one side go there, straddling
    // references are clipped exactly and go to both sides (or, with unsplitting, to the cheaper one).
    // Children never overlap.
    spatial,
    // Two child boxes on a grid over the node (GridSplitFinder): references go to the child that
    // contains them (both: the smaller one), references in neither are clipped into both.
    grid,
};

inline constexpr uint32_t kMaxObjectBins = 256;

struct ObjectBinning {
    int axis = 0;
    float origin = 0;  // centroid_bounds.lo[axis]
    float scale = 0;   // bins / extent
    uint32_t bins = 1;

    uint32_t bin_of(float centroid) const {
        const float position = (centroid - origin) * scale;
        // Clamped as the finder's MAXPS/MINPS clamp it, so both put every centroid in the same bin:
        // a NaN position (an infinite difference times a zero scale, on a node spanning more than
        // FLT_MAX) goes to bin 0, where std::max would keep the NaN.
        const float lower = position > 0.0f ? position : 0.0f;
        const float last = float(bins - 1);
        return uint32_t(lower < last ? lower : last);
    }
};

struct Split {
    SplitKind kind = SplitKind::none;
    float cost = kInfinity;
    int axis = 0;
    float position = 0;              // spatial: the plane
    Reference tie;                   // object_sorted: the first reference of the right child
    ObjectBinning binning;           // object_binned
    uint32_t bin = 0;                // object_binned: first bin of the right child
    AABB left_bounds, right_bounds;  // boxes of the children this split makes
    uint32_t left_count = 0, right_count = 0;
    bool unsplit = false;            // spatial: try reference unsplitting when applying
    AABB left_region, right_region;  // grid: the child boxes references are assigned to

    bool is_valid() const { return kind != SplitKind::none && cost < kInfinity; }
};

// The fields every search space fills: the kind, the cost, the axis and the two children the split
// makes. Each finder then adds its own (the plane, the tie, the bin, the grid regions).
inline Split make_split(SplitKind kind, float cost, int axis, const AABB& left_bounds, uint32_t left_count,
                        const AABB& right_bounds, uint32_t right_count) {
    Split split;
    split.kind = kind;
    split.cost = cost;
    split.axis = axis;
    split.left_bounds = left_bounds;
    split.right_bounds = right_bounds;
    split.left_count = left_count;
    split.right_count = right_count;
    return split;
}

// A node's references three times, each sorted by CentroidOrder on one axis (x, y, z), kept by the
// driver for the object sweep so that no node sorts (children inherit their parent's orders).
// Empty spans: not kept (the sweep sorts the node's references itself).
using CentroidOrders = std::array<std::span<const Reference>, 3>;

// What a search space sees of a node.
struct NodeContext {
    std::span<const Reference> references;
    const ReferenceSummary& summary;
    size_t capacity;           // references this node's subtree may hold (its share of the reference budget)
    float root_area;           // SA(root), for gates relative to the scene
    const Split& best_so_far;  // the cheapest split of the search spaces evaluated before this one
    bool must_split = false;   // too many references for a leaf: split even if no split pays
    CentroidOrders sorted{};   // the references in centroid order per axis, when the driver keeps them
};

// Where a finder's evaluation loop puts the configurations it evaluates. A finder offers a split
// only when its cost is below threshold(axis), so the common case builds no Split at all.
//
// CheapestSplit keeps the one cheapest configuration: find(). Of equal costs the lower axis wins,
// and on one axis the earlier offer, whatever order a finder visits the axes in (the object sweep
// starts with the axis its references are already sorted on).
struct CheapestSplit {
    Split best;
    float threshold(int axis) const { return axis < best.axis ? std::nextafter(best.cost, kInfinity) : best.cost; }
    void offer(const Split& split) { best = split; }
};

// SplitCandidates keeps the `per_axis` cheapest configurations on each axis, cheapest first
// (earlier offers win ties): the candidates of recursive cost evaluation (builders/driver/lookahead.hpp). Its
// cheapest() is the split that CheapestSplit keeps for the same offers.
class SplitCandidates {
public:
    explicit SplitCandidates(uint32_t per_axis) : per_axis_(std::max<uint32_t>(per_axis, 1)) {}
    float threshold(int axis) const {
        const std::vector<Split>& kept = axes_[axis];
        return kept.size() < per_axis_ ? kInfinity : kept.back().cost;
    }
    void offer(const Split& split) {
        std::vector<Split>& kept = axes_[split.axis];
        if (kept.size() == per_axis_) kept.pop_back();
        auto place = kept.end();
        while (place != kept.begin() && split.cost < (place - 1)->cost) --place;
        kept.insert(place, split);
    }
    // Axis by axis, cheapest first.
    std::vector<Split> all() const {
        std::vector<Split> splits;
        for (const std::vector<Split>& kept : axes_) splits.insert(splits.end(), kept.begin(), kept.end());
        return splits;
    }

private:
    uint32_t per_axis_;
    std::array<std::vector<Split>, 3> axes_;
};

// A search space: finds the lowest-cost configuration of its kind for a node. Finders read the
// node's references (sorting copies where they need an order) and must be deterministic: the same
// references give the same split, whatever the thread count.
class SplitFinder {
public:
    virtual ~SplitFinder() = default;
    virtual const char* name() const = 0;
    virtual Split find(const NodeContext& node, const CostModel& cost) const = 0;
    // Whether the search space reads NodeContext::sorted (the driver keeps the orders only then).
    virtual bool reads_centroid_orders() const { return false; }
    // The `per_axis` cheapest configurations on each axis, axis by axis and cheapest first; the first
    // cheapest of them is find()'s split. A search space without several candidates offers find()'s.
    virtual std::vector<Split> find_candidates(const NodeContext& node, const CostModel& cost,
                                               uint32_t /*per_axis*/) const {
        Split split = find(node, cost);
        if (!split.is_valid()) return {};
        return {split};
    }
};

}  // namespace spacebvh::builders
