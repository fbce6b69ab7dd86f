// SPDX-License-Identifier: MIT
// The binary BVH every builder produces: nodes in depth-first order and the leaves' triangle ids.
// Header-only.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "spacebvh/cost_model.hpp"
#include "spacebvh/geometry.hpp"

namespace spacebvh {

struct BvhNode {
    AABB bounds;
    // Inner node (reference_count == 0): children are nodes[first] and nodes[first + 1].
    // Leaf (reference_count > 0): triangles are primitives[first .. first + reference_count).
    uint32_t first = 0;
    uint32_t reference_count = 0;

    bool is_leaf() const { return reference_count > 0; }
};

struct Bvh {
    std::vector<BvhNode> nodes;        // nodes[0] is the root; depth-first order, left child first
    std::vector<uint32_t> primitives;  // triangle ids of the leaves, leaf by leaf (a split triangle may repeat)
    std::string builder;               // what built it: a preset name ("spatial", "binned+opt")
    CostModel cost;                    // the cost model it was built with

    const BvhNode& root() const { return nodes.front(); }
    bool empty() const { return nodes.empty(); }
};

}  // namespace spacebvh
