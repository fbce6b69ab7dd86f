// SPDX-License-Identifier: MIT
// The generic top-down driver (Popov et al. 2009, "The Generic Algorithm"): at each node, evaluate
// every configured search space, take the configuration of lowest cost under the cost model, and make
// a leaf when nothing beats the leaf cost C_I*|N| (unless the node exceeds the leaf size limit) -
// the greedy step of builders/driver/split_search.hpp - or, with a lookahead depth, choose among the search
// spaces' best candidates by recursive cost evaluation (builders/driver/lookahead.hpp). Nodes at the top of the
// tree (DriverOptions::lookahead_top_share) may look ahead to the leaves, whatever the depth.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <vector>

#include "builders/driver/reference.hpp"
#include "builders/driver/split.hpp"
#include "builders/driver/split_search.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/bvh.hpp"

namespace spacebvh::builders {

// How the driver chooses splits and reports (all optional).
struct DriverOptions {
    uint32_t lookahead_depth = 0;               // recursive cost evaluation (builders/driver/lookahead.hpp); 0 = greedy
    uint32_t lookahead_candidates = 2;          // its candidates per axis and search space
    float lookahead_top_share = 0;              // nodes with this share of the root's references look
                                                // ahead to the leaves (0 = none)
    std::function<void(double)> progress;       // fraction of references that reached a leaf
    const std::atomic<bool>* cancel = nullptr;  // polled between nodes; when set, build() throws Cancelled
    const TerminationConfig* termination = nullptr;  // the termination-aware split choice; null = off
};

// Bytes per node slot; the driver keeps 2 * capacity - 1 slots (memory_estimate.cpp counts them).
inline constexpr size_t kSlotBytes = 36;

class TopDownBuilder {
public:
    TopDownBuilder(CostModel cost, BuildLimits limits, std::vector<std::unique_ptr<SplitFinder>> search_spaces,
                   std::span<const Triangle> triangles, DriverOptions options = {});
    ~TopDownBuilder();

    // Builds over the references (consumed). `capacity` (>= references.size()) is the reference
    // budget: how many references spatial splits may grow the set to. Parallel over subtrees with
    // oneTBB; the tree depends only on the input, never on scheduling (see the slot numbering).
    Bvh build(std::vector<Reference> references, size_t capacity);

private:
    struct Impl;
    CostModel cost_;
    BuildLimits limits_;
    std::vector<std::unique_ptr<SplitFinder>> search_spaces_;
    std::span<const Triangle> triangles_;
    DriverOptions options_;
};

}  // namespace spacebvh::builders
