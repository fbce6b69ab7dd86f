// The generic top-down driver (Popov et al. 2009, "The Generic Algorithm"): at each node, evaluate
// every configured search space, take the configuration of lowest cost under the cost model, and make
// a leaf when nothing beats the leaf cost C_I*|N| (unless the node exceeds the leaf size limit).
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "build/reference.hpp"
#include "build/split.hpp"
#include "spacebvh/bvh.hpp"

namespace spacebvh::build {

struct BuildLimits {
    uint32_t max_leaf_size = 8;
    uint32_t max_depth = 64;
};

class TopDownBuilder {
public:
    TopDownBuilder(CostModel cost, BuildLimits limits, std::vector<std::unique_ptr<SplitFinder>> search_spaces,
                   std::span<const Triangle> triangles, std::function<void(double)> progress = {});
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
    std::function<void(double)> progress_;
};

}  // namespace spacebvh::build
