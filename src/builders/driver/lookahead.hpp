// SPDX-License-Identifier: MIT
// Recursive cost evaluation (Popov et al. 2009, slides: "use recursive cost evaluation"): choose a
// node's split by the SAH of the subtree that each candidate leads to, built a few levels deep,
// instead of by the split's local cost alone (the greedy choice).
//
// At a node N with lookahead depth D >= 1:
//   options    the leaf (unless N must be split), and the candidates: each search space's K
//              cheapest splits on each axis (SplitSearch::candidates; K = candidates_per_axis,
//              LookaheadConfig::candidates), the greedy split among them. So at most 1 + 3K
//              options per search space, and 1 + 6K for object + spatial. With K = 0, each search
//              space's cheapest split (SplitSearch::cheapest_per_space): the choice between kinds of
//              split, as the driver makes it at the top of the tree (lookahead to the leaves).
//   evaluation a candidate is applied to a copy of N's references (its reference budget included)
//              and its children are built greedily D - 1 more levels (SplitSearch::greedy_decision
//              at every node, as the driver would). Its cost is the subtree's SAH weighted by area:
//                sum_inner C_T*SA(n) + sum_leaf C_I*SA(l)*|l| + sum_frontier cost(greedy split)*SA(f)
//              where a frontier node f (D levels below N, not a leaf) is priced by the local cost of
//              its greedy split (C_T*SA(f) + (1 + C_o*overlap)*C_I*(SA(L)|L| + SA(R)|R|)) and the
//              leaf option by C_I*SA(N)*|N|. (With D = 0 this is the greedy choice itself.)
//   choice     the cheapest option; ties go to the greedy decision (leaf or cheapest split), so the
//              chosen option's evaluated cost is never above the greedy decision's.
//
// Cost: about (1 + D * candidates) times the greedy search per node; memory: one copy of the node's
// reference storage per node being evaluated (nodes evaluated at once lie in disjoint subtrees, so
// at most the root's storage once more). Deterministic: candidates are evaluated in a fixed order
// and the costs summed in a fixed order.
#pragma once

#include <atomic>
#include <optional>
#include <span>

#include "builders/driver/split_search.hpp"

namespace spacebvh::builders {

struct LookaheadChoice {
    std::optional<Split> split;  // nothing: make the node a leaf
    double cost = 0;             // the chosen option's evaluated cost (area-weighted, see above); 0 when
                                 // the greedy decision was the only option (options == 1: not priced)
    double greedy_cost = 0;      // the greedy decision's evaluated cost (likewise)
    bool greedy = true;          // the choice is the greedy decision
    size_t options = 0;          // options evaluated (leaf and candidates)
};

class Lookahead {
public:
    // `candidates_per_axis` = 0: each search space's cheapest split (see above). `cancel` (may be null)
    // is polled between evaluated nodes; when set, evaluation throws Cancelled.
    Lookahead(const SplitSearch& search, uint32_t depth, uint32_t candidates_per_axis, const std::atomic<bool>* cancel)
        : search_(search), depth_(depth), candidates_per_axis_(candidates_per_axis), cancel_(cancel) {}

    // For a node that may be split (!search.must_be_leaf): its references are storage[0, count), its
    // subtree may use all of storage. Reorders the references (as the finders do) but leaves the
    // node unsplit; apply the chosen split with SplitSearch::apply.
    LookaheadChoice choose(std::span<Reference> storage, uint32_t count, const ReferenceSummary& summary,
                           uint32_t node_depth) const;

    // The evaluated cost of the greedy subtree of a node, `levels` levels deep (0: the greedy local
    // cost of the node). Rebuilds storage in place.
    double greedy_subtree_cost(std::span<Reference> storage, uint32_t count, const ReferenceSummary& summary,
                               uint32_t node_depth, uint32_t levels) const;

private:
    // Applies `split` to storage and prices the node as an inner node over its children's greedy
    // subtrees, each `child_levels` levels deep.
    double split_subtree_cost(std::span<Reference> storage, uint32_t count, Split split,
                              const ReferenceSummary& summary, uint32_t node_depth, uint32_t child_levels) const;
    void poll_cancel() const;

    const SplitSearch& search_;
    uint32_t depth_;
    uint32_t candidates_per_axis_;
    const std::atomic<bool>* cancel_;
};

}  // namespace spacebvh::builders
