// SPDX-License-Identifier: MIT
// The reinsertion optimiser's working tree (Bittner et al. 2013; Meister & Bittner 2018): parent and
// child links, tight boxes, prices and the search for the best place of one node. Used by
// optimize_by_reinsertion only; reinsertion_state.cpp keeps the tree, reinsertion_search.cpp searches it.
#pragma once

#include <array>
#include <optional>
#include <span>
#include <vector>

#include "builders/driver/termination_term.hpp"
#include "builders/optimize/reinsertion_optimizer.hpp"

namespace spacebvh::builders::reinsertion {

inline constexpr uint32_t kNone = ~0u;
inline constexpr uint32_t kRoot = 0;  // the root never moves: neither N, nor N's parent, nor a destination
// Nodes searched per iteration, as a fraction of all nodes (Meister & Bittner 2018 and bvh v2: 5 %).
inline constexpr double kBatchFraction = 0.05;
// The optimisation ends once the last 1 / kBatchFraction iterations (a batch's worth of every node)
// have together lowered the inner nodes' area by less than this fraction of it. (Not one iteration:
// in a triangle soup the largest nodes may have nowhere better to go while smaller ones still gain.)
inline constexpr double kMinimumGain = 1e-4;
inline constexpr size_t kGainWindow = size_t(1.0 / kBatchFraction + 0.5);
// A move must gain more than this fraction of SA(root), so that rounding never passes for a gain.
inline constexpr double kMinimumMoveGain = 1e-9;

struct Move {
    uint32_t node = kNone, destination = kNone;
    double gain = 0;  // decrease of the summed inner-node price
};

// A search's candidate, with the segments among which the box of (candidate u N) is priced: the list
// of node `list_node`, or, when that is kNone, `size` entries of the search's arena from `offset`.
struct SearchEntry {
    uint32_t candidate;
    double induced;
    uint32_t list_node, offset, size;
};
struct SearchScratch {
    std::vector<SearchEntry> stack;
    std::vector<uint32_t> arena;  // segment lists of the merged boxes priced in one subtree search
};

class Optimizer {
public:
    Optimizer(const Bvh& bvh, uint32_t max_depth, std::span<const Ray> segments, float area_prior);

    // Boxes of the inner nodes (the root's excepted) shrunk to the union of their children: a moved
    // node's old ancestors must be tight for the gains below to be exact.
    void refit_all();
    // The next batch: of the eligible nodes (depth >= 2) that are not settled, the `count` with the
    // largest boxes (Bittner et al.'s M_area; with segments, the highest prices), largest first, ties by index.
    std::vector<uint32_t> select_candidates(size_t count) const;
    // A node whose search found no move stays where it is until a move changes its surroundings.
    void settle(uint32_t node) { settled_[node] = 1; }
    // The best place for `node` on the tree as it was at the start of the iteration; destination kNone
    // when no place gains more than the threshold.
    Move find_best_move(uint32_t node, SearchScratch& scratch) const;
    // The gain of moving `node` to `destination` on the tree as it is now, priced exactly as
    // find_best_move prices it; nothing when the move is impossible or breaks the depth cap.
    std::optional<double> price_move(uint32_t node, uint32_t destination);
    void apply(uint32_t node, uint32_t destination);
    void compute_depths();
    double inner_price() const;
    double minimum_gain() const { return minimum_gain_; }
    Bvh emit(const Bvh& source) const;

private:
    bool is_leaf(uint32_t node) const { return children_[node][0] == kNone; }
    uint32_t sibling(uint32_t node) const {
        const auto& children = children_[parent_[node]];
        return children[0] == node ? children[1] : children[0];
    }
    void replace_child(uint32_t parent, uint32_t old_child, uint32_t new_child) {
        auto& children = children_[parent];
        children[children[0] == old_child ? 0 : 1] = new_child;
        parent_[new_child] = parent;
    }
    bool depth_allows(uint32_t node, uint32_t destination, uint32_t destination_depth) const {
        // The new parent takes the destination's depth; N and the destination go one level down.
        return destination_depth + 1 + std::max(height_[node], height_[destination]) <= max_depth_;
    }
    void refit_upwards(uint32_t node);
    // Lists and prices of every node, from the root down.
    void price_all();
    // Lists and prices of the nodes whose boxes the last move changed, parents first.
    void reprice_changed();
    void set_price(uint32_t node) {
        price_[node] = area_weight_ * area_in_double(bounds_[node]) + (sampled_ ? double(lists_[node].size()) : 0.0);
    }
    // The price of `box`, whose meeting segments are all among `superset`; the meeting ones are
    // appended to `meeting` when given (which must not hold `superset`'s storage). `known`: segments
    // known to meet it (those of a box inside it), taken without a test; all lists increase.
    double price_among(const AABB& box, std::span<const uint32_t> superset, std::span<const uint32_t> known,
                       std::vector<uint32_t>* meeting) const {
        const double area_part = area_weight_ * area_in_double(box);
        if (!sampled_) return area_part;
        size_t count = 0, next_known = 0;
        for (uint32_t i : superset) {
            bool meets;
            if (next_known < known.size() && known[next_known] == i) {
                ++next_known;
                meets = true;
            } else {
                meets = segment_meets(segments_[i], box);
            }
            if (meets) {
                ++count;
                if (meeting) meeting->push_back(i);
            }
        }
        return area_part + double(count);
    }
    // The price of `box`, a box inside `node`'s.
    double price_inside(const AABB& box, uint32_t node) const {
        if (box == bounds_[node]) return price_[node];
        // Without segments lists_ is empty (indexing it would be undefined): the area part alone.
        return price_among(box, sampled_ ? std::span<const uint32_t>(lists_[node]) : std::span<const uint32_t>{}, {},
                           nullptr);
    }
    void search_subtree(uint32_t node, uint32_t top, uint32_t pivot, double base_gain, uint32_t depth_shift,
                        bool top_is_sibling, Move& best, SearchScratch& scratch) const;
    void emit_node(uint32_t node, uint32_t out_index, const Bvh& source, Bvh& out) const;

    std::vector<AABB> bounds_;
    std::vector<uint32_t> parent_;
    std::vector<std::array<uint32_t, 2>> children_;  // {kNone, kNone} for a leaf
    std::vector<uint32_t> height_;                   // levels below the node (0 for a leaf)
    std::vector<uint32_t> depth_;                    // as of the last compute_depths()
    std::vector<uint8_t> settled_;                   // searched without a move since its surroundings last changed
    // The price of an inner node's box: area_weight_ * area, plus, with segments, the number meeting it.
    bool sampled_ = false;
    double area_weight_ = 1.0;
    std::vector<SampleSegment> segments_;
    std::vector<std::vector<uint32_t>> lists_;  // with segments: those meeting each node's box, increasing
    std::vector<double> price_;                 // each node's price, as of its current box
    std::vector<uint32_t> changed_;             // nodes whose boxes the refits since the last repricing changed
    uint32_t max_depth_ = 0;
    double minimum_gain_ = 0;
    // price_move's scratch: N's ancestors stamped with their level, and a path.
    std::vector<uint32_t> stamp_, level_;
    uint32_t current_stamp_ = 0;
    std::vector<uint32_t> chain_, path_;
    std::array<std::vector<uint32_t>, 2> path_lists_;
};

}  // namespace spacebvh::builders::reinsertion
