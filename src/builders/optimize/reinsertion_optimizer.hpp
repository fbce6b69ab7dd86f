// SPDX-License-Identifier: MIT
// Tree optimisation by subtree reinsertion, after the build (Bittner, Hapala & Havran 2013, "Fast
// insertion-based optimization of bounding volume hierarchies"; in batches, as Meister & Bittner 2018
// and madmann91's bvh v2 do).
//
// A move takes a node N (a leaf or a whole subtree) out of the tree - its parent P goes, N's sibling
// takes P's place - and puts it back elsewhere: a node P' (P reused) with children X and N takes the
// place of some node X. Leaves are never touched (their boxes and triangles stay as built, so trees
// with spatial splits, whose leaves hold clipped references, are optimised alike); only the topology
// of the inner nodes above them changes, and the number of inner nodes stays the same. So the change
// of the tree SAH (src/tools/metrics/tree_metrics.cpp) is C_T / SA(root) times the change of the summed
// areas of the inner nodes, and the gain of a move is exact (the figure in find_best_move).
//
// With C_o > 0 the tree's cost model also has an overlap penalty; that penalty prices split choices
// during the build, it is no term of the tree SAH, so the optimiser lowers the plain tree SAH.
//
// One iteration: a batch of nodes (5 % of all; the largest boxes first, Bittner et al.'s M_area)
// each get the best place found by branch and bound over the whole tree (in parallel, each result in
// its own slot); the moves are then applied one after the other in a fixed order (largest gain
// first, ties by node index), each re-priced exactly on the tree as it is by then and skipped unless
// it still gains and keeps the depth within the cap. Boxes are refitted after every move (the root's
// box is kept, so SA(root), the SAH's normaliser, never changes). A node whose search finds nothing
// is settled: later batches pass it over until a move changes its parent, its subtree or a box
// above it, so the batches work their way down from the largest nodes to where gains remain.
// Termination-aware pricing (ReinsertionOptions::segments): an inner node's box is priced by the
// number of sample segments that meet it - each segment ends where its ray stops, so this counts the
// visits of the node by the sample - plus `area_prior` pseudo-segments spread by area (the SAH's
// isotropic rays) where few segments reach. Every formula above needs only that the price of a box
// never falls when the box grows, which both terms satisfy; the gains stay exact for this price.
// Each node keeps the list of segments meeting its box, so a box inside it is priced among those.
//
// Iterations stop at the cap, when no node is left unsettled, or when the last 20 (5 % each: a batch's
// worth of every node) together gain less than 0.01 % of the inner nodes' area. Every applied move lowers the SAH, so
// the result is never worse than the input, and the same input gives the same tree for any thread count.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <span>

#include "spacebvh/bvh.hpp"

namespace spacebvh::builders {

struct ReinsertionOptions {
    uint32_t iterations = 0;  // batches at most (ReinsertionConfig::iterations)
    // No move may put a node deeper than this (LimitConfig::max_depth); a tree that is already
    // deeper keeps its own depth as the cap.
    uint32_t max_depth = 64;
    std::function<void(double)> progress;       // fraction of the iterations done; may be empty
    const std::atomic<bool>* cancel = nullptr;  // polled between searches; when set, throws Cancelled
    // Non-empty: price inner nodes by these sample segments (tmin to where each ray stops) and
    // `area_prior` pseudo-segments spread by area, instead of by area alone (the SAH).
    std::span<const Ray> segments;
    float area_prior = 0.0f;
};

struct ReinsertionReport {
    uint32_t iterations = 0;  // batches run
    size_t moves = 0;         // moves applied
    // Sum of the inner nodes' areas (the part of the tree SAH that moves change; with segments, their
    // prices: sampled visits plus the prior's share): as built, after
    // the first refit (tight boxes), and at the end; and the gains of the applied moves as priced
    // (refitted - after, up to rounding).
    double inner_area_before = 0, inner_area_refitted = 0, inner_area_after = 0;
    double applied_gain = 0;
};

// Optimises `bvh` in place with its own cost model (bvh.cost). Any binary tree of ours or Embree's;
// empty trees and trees of fewer than 5 nodes have nothing to move. Parallel with oneTBB.
ReinsertionReport optimize_by_reinsertion(Bvh& bvh, const ReinsertionOptions& options);

}  // namespace spacebvh::builders
