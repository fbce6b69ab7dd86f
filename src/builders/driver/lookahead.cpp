// SPDX-License-Identifier: MIT
#include "builders/driver/lookahead.hpp"

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <vector>

#include "spacebvh/error.hpp"

namespace spacebvh::builders {
namespace {

double area_weighted(float cost, const ReferenceSummary& summary) {
    return double(cost) * double(summary.bounds.area());
}

}  // namespace

void Lookahead::poll_cancel() const {
    if (cancel_ && cancel_->load(std::memory_order_relaxed)) throw Cancelled("build cancelled");
}

double Lookahead::greedy_subtree_cost(std::span<Reference> storage, uint32_t count, const ReferenceSummary& summary,
                                      uint32_t node_depth, uint32_t levels) const {
    const CostModel& cost = search_.cost();
    const double leaf = area_weighted(cost.leaf_cost(count), summary);
    if (search_.must_be_leaf(count, node_depth)) return leaf;
    poll_cancel();
    std::optional<Split> split = search_.greedy_decision(storage.first(count), summary, storage.size());
    if (!split) return leaf;
    if (levels == 0) {
        // The frontier: the greedy split's local cost stands for the subtree below. (The median
        // fallback has no cost of its own: price it as an inner node over one leaf.)
        return split->is_valid() ? area_weighted(split->cost, summary)
                                 : area_weighted(cost.traversal_cost + cost.leaf_cost(count), summary);
    }
    return split_subtree_cost(storage, count, *split, summary, node_depth, levels - 1);
}

double Lookahead::split_subtree_cost(std::span<Reference> storage, uint32_t count, Split split,
                                     const ReferenceSummary& summary, uint32_t node_depth,
                                     uint32_t child_levels) const {
    const CostModel& cost = search_.cost();
    search_.order_for_apply(storage.first(count));
    const std::optional<ChildRanges> children = search_.apply(storage, count, split, summary);
    if (!children) return area_weighted(cost.leaf_cost(count), summary);  // the driver makes a leaf then

    const std::span<Reference> left_storage = storage.first(children->left_capacity);
    const std::span<Reference> right_storage = storage.subspan(children->left_capacity, children->right_capacity);
    double left_cost = 0, right_cost = 0;
    auto price_left = [&] {
        left_cost =
            greedy_subtree_cost(left_storage, children->left_count, summarize(left_storage.first(children->left_count)),
                                node_depth + 1, child_levels);
    };
    auto price_right = [&] {
        right_cost =
            greedy_subtree_cost(right_storage, children->right_count,
                                summarize(right_storage.first(children->right_count)), node_depth + 1, child_levels);
    };
    if (count >= kParallelSubtreeThreshold) {
        tbb::parallel_invoke(price_left, price_right);
    } else {
        price_left();
        price_right();
    }
    return area_weighted(cost.traversal_cost, summary) + left_cost + right_cost;
}

LookaheadChoice Lookahead::choose(std::span<Reference> storage, uint32_t count, const ReferenceSummary& summary,
                                  uint32_t node_depth) const {
    const std::span<Reference> references = storage.first(count);
    const CostModel& cost = search_.cost();
    const bool must_split = search_.must_split(count);
    const std::vector<Split> candidates =
        candidates_per_axis_ == 0 ? search_.cheapest_per_space(references, summary, storage.size())
                                  : search_.candidates(references, summary, storage.size(), candidates_per_axis_);

    // The greedy decision, exactly as SplitSearch::greedy_decision makes it (candidates[0] is the
    // cheapest split).
    std::optional<Split> greedy;
    const bool split_pays = !candidates.empty() && candidates.front().cost < cost.leaf_cost(count);
    if (must_split || split_pays) greedy = candidates.empty() ? median_split(references, summary) : candidates.front();

    LookaheadChoice choice;
    // Nothing to compare (one search space, or the others offer nothing here, and no leaf option):
    // the greedy decision, unpriced. Pricing it would build its whole subtree for nothing.
    const bool greedy_is_first_candidate = greedy && !candidates.empty();
    const size_t alternatives =
        (greedy && !must_split ? 1 : 0) + candidates.size() - (greedy_is_first_candidate ? 1 : 0);
    if (alternatives == 0) {
        choice.split = greedy;
        choice.options = 1;
        return choice;
    }

    // A candidate is priced on a copy of the node's storage, so each starts from the same references.
    std::vector<Reference> scratch(storage.size());
    auto evaluate = [&](const std::optional<Split>& option) {
        if (!option) return area_weighted(cost.leaf_cost(count), summary);
        poll_cancel();
        std::copy(references.begin(), references.end(), scratch.begin());
        return split_subtree_cost(scratch, count, *option, summary, node_depth, depth_ - 1);
    };

    auto consider = [&](const std::optional<Split>& option, bool is_greedy) {
        const double option_cost = evaluate(option);
        if (is_greedy) choice.greedy_cost = option_cost;
        if (choice.options++ == 0 || option_cost < choice.cost) {
            choice.cost = option_cost;
            choice.split = option;
            choice.greedy = is_greedy;
        }
    };
    // The greedy decision first, so that ties keep it.
    consider(greedy, true);
    if (greedy && !must_split) consider(std::nullopt, false);
    for (size_t i = greedy_is_first_candidate ? 1 : 0; i < candidates.size(); ++i) consider(candidates[i], false);
    return choice;
}

}  // namespace spacebvh::builders
