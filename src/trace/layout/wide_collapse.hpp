// SPDX-License-Identifier: MIT
// Which binary nodes become the children of each wide node when a binary Bvh is collapsed into a
// W-wide layout (wide_layout.hpp). Two strategies:
//  - largest area (Embree's): from a node's two children, open the inner child of largest surface
//    area until the node has W children or only leaves;
//  - SAH-optimal (Ylitie, Karras, Laine 2017, "Efficient Incoherent Ray Traversal on GPUs Through
//    Compressed Wide BVHs", section 3): a dynamic program over the binary tree that finds, under a
//    wide-node SAH, the cheapest way to cut it into wide nodes, and may turn a small subtree into
//    one leaf (its leaves merged), or leave a node with fewer than W children.
#pragma once

#include <cstdint>
#include <vector>

#include <span>

#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/trace.hpp"

namespace spacebvh::trace {

// One child of a wide node: binary node `node`, made a leaf (all the distinct triangles of its
// subtree) or an inner wide node.
struct CollapseSlot {
    uint32_t node;
    bool leaf;
};

// The SAH of a wide layout: every ray that enters a box pays `node` for a wide node (all its child
// boxes are tested at once) and `pack` per pack of four triangles of a leaf (tested at once).
struct WideCost {
    double node = 1.0;
    double pack = 1.0;
    uint32_t max_merged_leaf = 8;  // largest leaf the collapse may make by merging a subtree's leaves
};

class CollapsePlan {
public:
    CollapsePlan(std::span<const Triangle> triangles, const Bvh& bvh, int width, WideCollapse strategy,
                 const WideCost& cost = {});

    // The children of the wide node made for binary inner node `node`, left to right.
    std::vector<CollapseSlot> slots(uint32_t node) const;

    // The wide SAH of the whole layout (relative to the root's area), under `cost`.
    double cost() const;

private:
    std::vector<CollapseSlot> largest_area_slots(uint32_t node) const;
    void expand(uint32_t node, int slots, std::vector<CollapseSlot>& out) const;
    double leaf_cost(uint32_t node) const;

    const Bvh& bvh_;
    int width_;
    WideCollapse strategy_;
    WideCost cost_;
    std::vector<uint32_t> distinct_;  // distinct non-degenerate triangles under a node, capped at max_merged_leaf + 1
    // SAH-optimal plan, per node and slot count i = 1..W (index node * W + i - 1): the cheapest cost
    // of the node's subtree as at most i children of a wide node, the i' <= i that achieves it, and
    // how: 0 = one child (a leaf if single_is_leaf_), k > 0 = k children from the left subtree.
    std::vector<double> best_;
    std::vector<uint8_t> used_, split_left_;
    std::vector<uint8_t> single_is_leaf_;
    std::vector<uint8_t> inner_split_;  // the k of a wide node made for this node: k children from the left
};

// The distinct non-degenerate triangles of all leaves under binary node `node`, ascending.
std::vector<uint32_t> subtree_triangles(std::span<const Triangle> triangles, const Bvh& bvh, uint32_t node);

}  // namespace spacebvh::trace
