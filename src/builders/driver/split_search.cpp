// SPDX-License-Identifier: MIT
#include "builders/driver/split_search.hpp"

#include <algorithm>

#include "builders/search_spaces/object_sweep_split_finder.hpp"

namespace spacebvh::builders {

Split SplitSearch::cheapest(std::span<const Reference> references, const ReferenceSummary& summary, size_t capacity,
                            const CentroidOrders& sorted) const {
    Split best;
    for (const auto& search_space : search_spaces_) {
        const NodeContext context{references, summary, capacity, root_area_, best, must_split(references.size()),
                                  sorted};
        Split candidate = search_space->find(context, cost_);
        if (candidate.cost < best.cost) best = candidate;
    }
    return best;
}

template <class Offers>
std::vector<Split> SplitSearch::collect(std::span<const Reference> references, const ReferenceSummary& summary,
                                        size_t capacity, Offers&& offers) const {
    // The same walk as cheapest(): each space sees the cheapest split of the spaces before it (the
    // spatial gate reads it), and the first cheapest offer, cheapest()'s split, is moved to the front.
    Split best;
    size_t best_index = 0;
    std::vector<Split> all;
    for (const auto& search_space : search_spaces_) {
        const NodeContext context{references, summary, capacity, root_area_, best, must_split(references.size())};
        for (const Split& candidate : offers(*search_space, context)) {
            if (candidate.cost < best.cost) {
                best = candidate;
                best_index = all.size();
            }
            all.push_back(candidate);
        }
    }
    if (!all.empty()) std::rotate(all.begin(), all.begin() + best_index, all.begin() + best_index + 1);
    return all;
}

std::vector<Split> SplitSearch::candidates(std::span<const Reference> references, const ReferenceSummary& summary,
                                           size_t capacity, uint32_t per_axis) const {
    return collect(references, summary, capacity, [&](const SplitFinder& space, const NodeContext& context) {
        return space.find_candidates(context, cost_, per_axis);
    });
}

std::vector<Split> SplitSearch::cheapest_per_space(std::span<const Reference> references,
                                                   const ReferenceSummary& summary, size_t capacity) const {
    return collect(references, summary, capacity, [&](const SplitFinder& space, const NodeContext& context) {
        const Split split = space.find(context, cost_);
        return split.is_valid() ? std::vector<Split>{split} : std::vector<Split>{};
    });
}

std::optional<Split> SplitSearch::greedy_decision(std::span<const Reference> references,
                                                  const ReferenceSummary& summary, size_t capacity,
                                                  const CentroidOrders& sorted) const {
    const size_t count = references.size();
    const Split split = cheapest(references, summary, capacity, sorted);
    const bool split_pays = split.is_valid() && split.cost < cost_.leaf_cost(count);
    if (!must_split(count) && !split_pays) return std::nullopt;
    if (!split.is_valid()) return median_split(references, summary);
    return split;
}

void SplitSearch::order_for_apply(std::span<Reference> references) const {
    if (!reads_centroid_orders() || std::is_sorted(references.begin(), references.end(), CentroidOrder{0})) return;
    sort_in_centroid_order(references, 0);
}

std::optional<ChildRanges> SplitSearch::apply(std::span<Reference> storage, uint32_t count, Split& split,
                                              const ReferenceSummary& summary) const {
    ChildRanges children = apply_split(storage, count, split, triangles_);
    if (children.left_count != 0 && children.right_count != 0) return children;
    split = median_split(storage.first(count), summary);
    children = apply_split(storage, count, split, triangles_);
    if (children.left_count != 0 && children.right_count != 0) return children;
    return std::nullopt;
}

}  // namespace spacebvh::builders
