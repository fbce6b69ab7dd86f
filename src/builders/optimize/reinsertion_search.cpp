// SPDX-License-Identifier: MIT
#include <algorithm>

#include "builders/optimize/reinsertion_state.hpp"

namespace spacebvh::builders::reinsertion {

// Branch and bound over the subtree of `top`, every node of which keeps its box after N's removal.
// Putting N above a node X there costs the price of X u N for the new parent plus, for every node Y
// on the way down from `top` to X, the growth price(Y u N) - price(Y) ("induced cost", Bittner et al.
// 2013, Sec. 3.2); a subtree whose induced cost already leaves no more than the best gain (even with
// the cheapest possible new parent, N's box) is skipped. `depth_shift` is 1 in the subtree of N's
// sibling, which moves up a level when N's parent goes. With segments, Y u N lies inside (parent of
// Y) u N, and `top` u N inside `pivot`'s box, so each merged box is priced among its parent's list.
void Optimizer::search_subtree(uint32_t node, uint32_t top, uint32_t pivot, double base_gain, uint32_t depth_shift,
                               bool top_is_sibling, Move& best, SearchScratch& scratch) const {
    const AABB& node_box = bounds_[node];
    const double node_price = price_[node];
    auto& stack = scratch.stack;
    auto& arena = scratch.arena;
    stack.clear();
    arena.clear();
    stack.push_back({top, 0.0, pivot, 0, 0});
    while (!stack.empty()) {
        const SearchEntry entry = stack.back();
        const uint32_t candidate = entry.candidate;
        const double induced = entry.induced;
        stack.pop_back();
        if (base_gain - induced - node_price <= best.gain) continue;
        const uint32_t new_depth = depth_[candidate] - depth_shift;
        // Deeper candidates would only put N deeper still.
        if (new_depth + 1 + height_[node] > max_depth_) continue;
        const AABB merged = merge(bounds_[candidate], node_box);
        double merged_price;
        SearchEntry below{kNone, 0.0, kNone, 0, 0};  // where the children's merged boxes are priced
        if (merged == bounds_[candidate]) {
            merged_price = price_[candidate];
            below.list_node = candidate;
        } else if (!sampled_) {
            merged_price = price_among(merged, {}, {}, nullptr);
        } else {
            // A lower bound first: the merged box meets the candidate's segments and N's, so counting
            // N's that miss the candidate's box (a search per N's segment) often settles the
            // candidate and its subtree without scanning the larger list.
            const auto& candidate_list = lists_[candidate];
            size_t outside = 0;
            for (uint32_t i : lists_[node])
                outside += !std::binary_search(candidate_list.begin(), candidate_list.end(), i);
            const double least_price = price_[candidate] + double(outside) +
                                       area_weight_ * (area_in_double(merged) - area_in_double(bounds_[candidate]));
            const bool may_win = !(top_is_sibling && candidate == top) && base_gain - induced - least_price > best.gain;
            const bool may_descend =
                !is_leaf(candidate) && base_gain - (induced + least_price - price_[candidate]) - node_price > best.gain;
            if (!may_win && !may_descend) continue;
            // The arena may grow while it is read from: reserve first, then take the span.
            const size_t superset_size = entry.list_node != kNone ? lists_[entry.list_node].size() : entry.size;
            arena.reserve(arena.size() + superset_size);
            const std::span<const uint32_t> superset =
                entry.list_node != kNone ? std::span<const uint32_t>(lists_[entry.list_node])
                                         : std::span<const uint32_t>(arena.data() + entry.offset, entry.size);
            below.offset = uint32_t(arena.size());
            merged_price = price_among(merged, superset, lists_[candidate], is_leaf(candidate) ? nullptr : &arena);
            below.size = uint32_t(arena.size()) - below.offset;
        }
        // N back at its sibling is where it came from.
        if (!(top_is_sibling && candidate == top)) {
            const double gain = base_gain - induced - merged_price;
            if (gain > best.gain && depth_allows(node, candidate, new_depth)) best = {node, candidate, gain};
        }
        if (is_leaf(candidate)) continue;
        const double child_induced = induced + (merged_price - price_[candidate]);
        if (base_gain - child_induced - node_price <= best.gain) continue;
        below.induced = child_induced;
        below.candidate = children_[candidate][1];
        stack.push_back(below);
        below.candidate = children_[candidate][0];
        stack.push_back(below);  // left first
    }
}

// Taking N out: its parent P goes (gain SA(P)) and the ancestors c_2, c_3, ... of P shrink to the
// union of what stays below them. Putting N back below c_i's other child Q_i brings c_i and everything
// above it back to their old boxes, so only the shrinking of c_2 .. c_(i-1) counts; putting it above
// c_i itself (a new parent with c_i's old box) counts the shrinking of c_2 .. c_i. So the walk from P
// up to the root (the level-by-level search of bvh v2's reinsertion optimizer) prices every place
// exactly, with the gain of the removal known at each level.
Move Optimizer::find_best_move(uint32_t node, SearchScratch& scratch) const {
    Move best{node, kNone, minimum_gain_};
    const uint32_t parent = parent_[node];
    double base_gain = price_[parent];
    AABB shrunk;  // the box of `below` once N is out
    uint32_t below = node, pivot = parent;
    for (;;) {
        const auto& children = children_[pivot];
        const uint32_t other = children[0] == below ? children[1] : children[0];
        search_subtree(node, other, pivot, base_gain, pivot == parent ? 1 : 0, pivot == parent, best, scratch);
        if (pivot == kRoot) break;
        shrunk = pivot == parent ? bounds_[other] : merge(shrunk, bounds_[other]);
        below = pivot;
        pivot = parent_[pivot];
        if (below == parent) continue;  // P itself goes; counted at the start
        base_gain += price_[below] - price_inside(shrunk, below);
        // N as the sibling of the shrunk ancestor: the new parent has the ancestor's old box.
        const double gain = base_gain - price_[below];
        if (gain > best.gain && depth_allows(node, below, depth_[below])) best = {node, below, gain};
    }
    return best;
}

std::optional<double> Optimizer::price_move(uint32_t node, uint32_t destination) {
    if (node == kRoot || parent_[node] == kRoot) return std::nullopt;
    const uint32_t parent = parent_[node];
    if (destination == kRoot || destination == node || destination == parent || destination == sibling(node))
        return std::nullopt;
    // N's ancestors c_1 = P, c_2, ..., the root, stamped with their level.
    ++current_stamp_;
    chain_.clear();
    for (uint32_t ancestor = parent; ancestor != kNone; ancestor = parent_[ancestor]) {
        chain_.push_back(ancestor);
        stamp_[ancestor] = current_stamp_;
        level_[ancestor] = uint32_t(chain_.size());
    }
    // Up from the destination to the first of N's ancestors; meeting N means it lies in N's subtree.
    path_.clear();
    uint32_t meeting = destination;
    while (stamp_[meeting] != current_stamp_) {
        if (meeting == node) return std::nullopt;
        path_.push_back(meeting);
        meeting = parent_[meeting];
    }
    const uint32_t level = level_[meeting];
    const uint32_t meeting_depth = uint32_t(chain_.size()) - level;
    const bool above_ancestor = path_.empty();  // the destination is c_i itself (i >= 2)
    // The removal's gain: P, then the shrinking of c_2 .. c_(i-1), or .. c_i above an ancestor.
    double base_gain = price_[parent];
    AABB shrunk = bounds_[sibling(node)];
    const uint32_t last_shrunk = above_ancestor ? level : level - 1;
    for (uint32_t j = 2; j <= last_shrunk; ++j) {
        const uint32_t ancestor = chain_[j - 1], below = chain_[j - 2];
        const auto& children = children_[ancestor];
        shrunk = merge(shrunk, bounds_[children[0] == below ? children[1] : children[0]]);
        base_gain += price_[ancestor] - price_inside(shrunk, ancestor);
    }
    if (above_ancestor) {
        if (!depth_allows(node, destination, meeting_depth)) return std::nullopt;
        return base_gain - price_[destination];
    }
    const uint32_t new_depth = meeting_depth + uint32_t(path_.size()) - (level == 1 ? 1 : 0);
    if (!depth_allows(node, destination, new_depth)) return std::nullopt;
    // The insertion's cost, summed from the top down as search_subtree sums it, each merged box priced
    // among the segments of the one above it (the first inside the meeting node's box).
    const AABB& node_box = bounds_[node];
    double induced = 0.0, merged_price = 0.0;
    std::span<const uint32_t> superset =
        sampled_ ? std::span<const uint32_t>(lists_[meeting]) : std::span<const uint32_t>{};
    for (size_t k = path_.size(); k-- > 0;) {
        const uint32_t on_the_way = path_[k];
        const AABB merged = merge(bounds_[on_the_way], node_box);
        if (merged == bounds_[on_the_way]) {
            merged_price = price_[on_the_way];
            if (sampled_) superset = lists_[on_the_way];
        } else {
            std::vector<uint32_t>& meeting_list = path_lists_[k % 2];
            meeting_list.clear();
            merged_price =
                price_among(merged, superset,
                            sampled_ ? std::span<const uint32_t>(lists_[on_the_way]) : std::span<const uint32_t>{},
                            sampled_ ? &meeting_list : nullptr);
            superset = meeting_list;
        }
        if (k > 0) induced = induced + (merged_price - price_[on_the_way]);
    }
    return base_gain - induced - merged_price;
}

}  // namespace spacebvh::builders::reinsertion
