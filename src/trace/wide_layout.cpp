#include "trace/wide_layout.hpp"

#include <algorithm>

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

template <int W>
class Collapser {
public:
    Collapser(const Scene& scene, const Bvh& bvh, WideLayout<W>& layout)
        : bvh_(bvh), layout_(layout), packer_(scene, bvh, layout.packs) {}

    // Makes the wide node for binary inner node (or, for a leaf root, a node with that one leaf) and
    // its subtree; returns its index.
    uint32_t make_node(uint32_t bvh_index) {
        // The children of the wide node, as binary node indices, in left-to-right tree order.
        std::vector<uint32_t> children;
        const BvhNode& node = bvh_.nodes[bvh_index];
        if (node.is_leaf()) {
            children.push_back(bvh_index);
        } else {
            children = {node.first, node.first + 1};
        }
        while (int(children.size()) < W) {
            int widest = -1;
            float widest_area = -1.0f;
            for (int i = 0; i < int(children.size()); ++i) {
                const BvhNode& child = bvh_.nodes[children[i]];
                if (!child.is_leaf() && child.bounds.area() > widest_area) {
                    widest = i;
                    widest_area = child.bounds.area();
                }
            }
            if (widest < 0) break;
            const uint32_t first = bvh_.nodes[children[widest]].first;
            children[widest] = first;
            children.insert(children.begin() + widest + 1, first + 1);
        }

        const uint32_t index = uint32_t(layout_.nodes.size());
        layout_.nodes.push_back(empty_node<W>());
        // Leaves first, so the leaves of one node share packs (LeafPacker), then the subtrees.
        for (int slot = 0; slot < int(children.size()); ++slot) {
            const BvhNode& child = bvh_.nodes[children[slot]];
            if (!child.is_leaf()) continue;
            const auto [first, count] = packer_.add(child);
            set_child(layout_.nodes[index], slot, count ? child.bounds : AABB::empty(), first, count);
        }
        for (int slot = 0; slot < int(children.size()); ++slot) {
            const BvhNode& child = bvh_.nodes[children[slot]];
            if (child.is_leaf()) continue;
            // Recursion depth is the tree depth, which build options cap at 1024.
            const uint32_t inner = make_node(children[slot]);
            set_child(layout_.nodes[index], slot, child.bounds, inner, 0);
        }
        return index;
    }

private:
    const Bvh& bvh_;
    WideLayout<W>& layout_;
    LeafPacker packer_;
};

}  // namespace

template <int W>
WideLayout<W> collapse_to_wide(const Scene& scene, const Bvh& bvh) {
    WideLayout<W> layout;
    if (bvh.empty()) {
        layout.nodes.push_back(empty_node<W>());  // nothing to hit
        return layout;
    }
    layout.nodes.reserve(bvh.nodes.size() / (W - 1) + 1);
    layout.packs.reserve(bvh.primitives.size() / 4 + 1);
    Collapser<W>(scene, bvh, layout).make_node(0);
    return layout;
}

template WideLayout<4> collapse_to_wide<4>(const Scene&, const Bvh&);
template WideLayout<8> collapse_to_wide<8>(const Scene&, const Bvh&);

}  // namespace spacebvh::trace
