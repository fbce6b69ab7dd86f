// SPDX-License-Identifier: MIT
#include "trace/layout/wide_layout.hpp"

#include <algorithm>

#include "trace/layout/wide_collapse.hpp"

namespace spacebvh::trace {
namespace {

template <int W>
void set_child(WideNode<W>& node, int slot, const AABB& box, uint32_t child, uint32_t count) {
    for (int axis = 0; axis < 3; ++axis) {
        node.planes[2 * axis][slot] = box.lo[axis];
        node.planes[2 * axis + 1][slot] = box.hi[axis];
    }
    node.child[slot] = child;
    node.count[slot] = count;
}

template <int W>
WideNode<W> empty_node() {
    WideNode<W> node;
    for (int slot = 0; slot < W; ++slot) set_child(node, slot, AABB::empty(), 0, 0);
    return node;
}

// Puts a node's children in decreasing order of the triangle lanes under them (ties keep their order;
// empty slots go last). The any-hit kernels follow the farthest entered child and pop the others
// from the stack in reverse slot order (wide_kernel.inl), so of those the smallest subtree, the
// cheapest to search for an occluder, comes first; Embree orders its children by size for shadow
// rays too. Occlusion rays test fewer child boxes than in the collapse's own order; mostly free rays
// and closest hits do the same work (closest hits only see slot order when distances tie).
template <int W>
void order_slots_by_size(WideNode<W>& node, const uint64_t (&lanes)[W], uint32_t* source) {
    int order[W];
    for (int slot = 0; slot < W; ++slot) order[slot] = slot;
    std::stable_sort(order, order + W, [&](int a, int b) {
        if (node.used(a) != node.used(b)) return node.used(a);
        return lanes[a] > lanes[b];
    });
    const WideNode<W> old = node;
    uint32_t old_source[W];
    std::copy(source, source + W, old_source);
    for (int slot = 0; slot < W; ++slot) {
        for (int plane = 0; plane < 6; ++plane) node.planes[plane][slot] = old.planes[plane][order[slot]];
        node.child[slot] = old.child[order[slot]];
        node.count[slot] = old.count[order[slot]];
        source[slot] = old_source[order[slot]];
    }
}

template <int W>
class Collapser {
public:
    Collapser(std::span<const Triangle> triangles, const Bvh& bvh, WideLayout<W>& layout, WideCollapse collapse)
        : triangles_(triangles),
          bvh_(bvh),
          layout_(layout),
          plan_(triangles, bvh, W, collapse),
          packer_(triangles, bvh, layout.packs) {}

    struct MadeNode {
        uint32_t index;  // of its WideNode
        uint64_t lanes;  // triangle lanes in all leaves under it (its cost to search)
    };

    // Makes the wide node for binary inner node (or, for a leaf root, a node with that one leaf) and
    // its subtree.
    MadeNode make_node(uint32_t bvh_index) {
        const std::vector<CollapseSlot> children = plan_.slots(bvh_index);
        const uint32_t index = uint32_t(layout_.nodes.size());
        layout_.nodes.push_back(empty_node<W>());
        layout_.source.resize(layout_.source.size() + W, kInvalidIndex);
        uint64_t lanes[W] = {};
        // Leaves first, so the leaves of one node share packs (LeafPacker), then the subtrees.
        for (int slot = 0; slot < int(children.size()); ++slot) {
            if (!children[slot].leaf) continue;
            const BvhNode& child = bvh_.nodes[children[slot].node];
            const auto [first, count] = child.is_leaf()
                                            ? packer_.add(child)
                                            : packer_.add(subtree_triangles(triangles_, bvh_, children[slot].node));
            set_child(layout_.nodes[index], slot, count ? child.bounds : AABB::empty(), first, count);
            if (count) layout_.source[size_t(index) * W + slot] = children[slot].node;
            lanes[slot] = count;
        }
        for (int slot = 0; slot < int(children.size()); ++slot) {
            if (children[slot].leaf) continue;
            // Recursion depth is the tree depth, which build options cap at 1024.
            const MadeNode inner = make_node(children[slot].node);
            set_child(layout_.nodes[index], slot, bvh_.nodes[children[slot].node].bounds, inner.index, 0);
            layout_.source[size_t(index) * W + slot] = children[slot].node;
            lanes[slot] = inner.lanes;
        }
        order_slots_by_size(layout_.nodes[index], lanes, layout_.source.data() + size_t(index) * W);
        uint64_t total = 0;
        for (uint64_t slot_lanes : lanes) total += slot_lanes;
        return {index, total};
    }

private:
    std::span<const Triangle> triangles_;
    const Bvh& bvh_;
    WideLayout<W>& layout_;
    CollapsePlan plan_;
    LeafPacker packer_;
};

}  // namespace

template <int W>
WideLayout<W> collapse_to_wide(std::span<const Triangle> triangles, const Bvh& bvh, WideCollapse collapse) {
    WideLayout<W> layout;
    if (bvh.empty()) {
        layout.nodes.push_back(empty_node<W>());  // nothing to hit
        return layout;
    }
    layout.nodes.reserve(bvh.nodes.size() / (W - 1) + 1);
    layout.source.reserve((bvh.nodes.size() / (W - 1) + 1) * W);
    layout.packs.reserve(bvh.primitives.size() / 4 + 1);
    Collapser<W>(triangles, bvh, layout, collapse).make_node(0);
    return layout;
}

template WideLayout<4> collapse_to_wide<4>(std::span<const Triangle>, const Bvh&, WideCollapse);
template WideLayout<8> collapse_to_wide<8>(std::span<const Triangle>, const Bvh&, WideCollapse);

}  // namespace spacebvh::trace
