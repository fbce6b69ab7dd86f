#include "trace/wide_layout.hpp"

#include <algorithm>

#include "trace/wide_collapse.hpp"

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
    Collapser(const Scene& scene, const Bvh& bvh, WideLayout<W>& layout, WideCollapse collapse)
        : scene_(scene), bvh_(bvh), layout_(layout), plan_(scene, bvh, W, collapse), packer_(scene, bvh, layout.packs) {}

    // Makes the wide node for binary inner node (or, for a leaf root, a node with that one leaf) and
    // its subtree; returns its index.
    uint32_t make_node(uint32_t bvh_index) {
        const std::vector<CollapseSlot> children = plan_.slots(bvh_index);
        const uint32_t index = uint32_t(layout_.nodes.size());
        layout_.nodes.push_back(empty_node<W>());
        // Leaves first, so the leaves of one node share packs (LeafPacker), then the subtrees.
        for (int slot = 0; slot < int(children.size()); ++slot) {
            if (!children[slot].leaf) continue;
            const BvhNode& child = bvh_.nodes[children[slot].node];
            const auto [first, count] =
                child.is_leaf() ? packer_.add(child) : packer_.add(subtree_triangles(scene_, bvh_, children[slot].node));
            set_child(layout_.nodes[index], slot, count ? child.bounds : AABB::empty(), first, count);
        }
        for (int slot = 0; slot < int(children.size()); ++slot) {
            if (children[slot].leaf) continue;
            // Recursion depth is the tree depth, which build options cap at 1024.
            const uint32_t inner = make_node(children[slot].node);
            set_child(layout_.nodes[index], slot, bvh_.nodes[children[slot].node].bounds, inner, 0);
        }
        return index;
    }

private:
    const Scene& scene_;
    const Bvh& bvh_;
    WideLayout<W>& layout_;
    CollapsePlan plan_;
    LeafPacker packer_;
};

}  // namespace

template <int W>
WideLayout<W> collapse_to_wide(const Scene& scene, const Bvh& bvh, WideCollapse collapse) {
    WideLayout<W> layout;
    if (bvh.empty()) {
        layout.nodes.push_back(empty_node<W>());  // nothing to hit
        return layout;
    }
    layout.nodes.reserve(bvh.nodes.size() / (W - 1) + 1);
    layout.packs.reserve(bvh.primitives.size() / 4 + 1);
    Collapser<W>(scene, bvh, layout, collapse).make_node(0);
    return layout;
}

template WideLayout<4> collapse_to_wide<4>(const Scene&, const Bvh&, WideCollapse);
template WideLayout<8> collapse_to_wide<8>(const Scene&, const Bvh&, WideCollapse);

}  // namespace spacebvh::trace
