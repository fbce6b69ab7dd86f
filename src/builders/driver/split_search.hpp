// SPDX-License-Identifier: MIT
// One step of the generic algorithm (Popov et al. 2009, "The Generic Algorithm") at one node: ask
// every search space for its cheapest configuration, take the cheapest under the cost model, make a
// leaf when nothing beats the leaf cost C_I*|N| (unless the node exceeds the leaf size limit), and
// apply the chosen split. The driver (top_down_builder) takes this greedy step at every node;
// recursive cost evaluation (lookahead) takes it below a node to price the node's candidates.
#pragma once

#include <algorithm>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "builders/driver/partition.hpp"
#include "builders/driver/split.hpp"

namespace spacebvh::builders {

// Nodes with at least this many references build (or price) their two subtrees in parallel.
inline constexpr uint32_t kParallelSubtreeThreshold = 4096;

struct BuildLimits {
    uint32_t max_leaf_size = 8;
    uint32_t max_depth = 64;
};

class SplitSearch {
public:
    SplitSearch(const CostModel& cost, BuildLimits limits, std::span<const std::unique_ptr<SplitFinder>> search_spaces,
                std::span<const Triangle> triangles, float root_area)
        : cost_(cost), limits_(limits), search_spaces_(search_spaces), triangles_(triangles), root_area_(root_area) {}

    const CostModel& cost() const { return cost_; }
    // Nodes that are leaves whatever the search spaces offer.
    bool must_be_leaf(size_t count, uint32_t depth) const { return count <= 1 || depth >= limits_.max_depth; }
    // Nodes that are split even when no split pays.
    bool must_split(size_t count) const { return count > limits_.max_leaf_size; }

    // The cheapest split over all search spaces (invalid when none is feasible). `sorted`: the
    // driver's centroid orders of the references, when it keeps them.
    Split cheapest(std::span<const Reference> references, const ReferenceSummary& summary, size_t capacity,
                   const CentroidOrders& sorted = {}) const;

    // Whether a search space reads the references in centroid order per axis (NodeContext::sorted),
    // so the driver should keep them.
    bool reads_centroid_orders() const {
        return std::ranges::any_of(search_spaces_, [](const auto& space) { return space->reads_centroid_orders(); });
    }

    // Puts a node's references in the order the driver applies splits to: CentroidOrder{x} when it
    // keeps centroid orders (`references` is its x order then), else as they are. Which straddlers
    // a spatial split still duplicates once the reference budget runs out depends on the order, so
    // the lookahead prices its candidates on this order to build the driver's trees.
    void order_for_apply(std::span<Reference> references) const;

    // Every search space's `per_axis` cheapest splits on each axis (SplitFinder::find_candidates),
    // with cheapest()'s split first.
    std::vector<Split> candidates(std::span<const Reference> references, const ReferenceSummary& summary,
                                  size_t capacity, uint32_t per_axis) const;

    // Each search space's cheapest split (the invalid ones left out), cheapest()'s split first.
    std::vector<Split> cheapest_per_space(std::span<const Reference> references, const ReferenceSummary& summary,
                                          size_t capacity) const;

    // The greedy decision for a node that may be split (!must_be_leaf): nothing when it should be a
    // leaf (no split beats C_I*|N| and the node may be a leaf); else the cheapest split, or the
    // median split when the node must be split and no search space offers a feasible one.
    std::optional<Split> greedy_decision(std::span<const Reference> references, const ReferenceSummary& summary,
                                         size_t capacity, const CentroidOrders& sorted = {}) const;

    // Applies `split` to the node's references storage[0, count) (see ChildRanges). When a side comes
    // out empty (never for the finders' own splits; a guard against float surprises) the median split
    // is applied instead and `split` updated; nothing when that fails too (make a leaf).
    std::optional<ChildRanges> apply(std::span<Reference> storage, uint32_t count, Split& split,
                                     const ReferenceSummary& summary) const;

private:
    // The splits `offers(space, context)` gives for each search space in turn, cheapest() first.
    template <class Offers>
    std::vector<Split> collect(std::span<const Reference> references, const ReferenceSummary& summary, size_t capacity,
                               Offers&& offers) const;

    CostModel cost_;
    BuildLimits limits_;
    std::span<const std::unique_ptr<SplitFinder>> search_spaces_;
    std::span<const Triangle> triangles_;
    float root_area_;
};

}  // namespace spacebvh::builders
