// SPDX-License-Identifier: MIT
// The top level of a scene: refitted in place, collapsed into wide nodes, and stored as flat triangles
// (its build: top_level_build.cpp).
#include "trace/scene/top_level.hpp"

#include <algorithm>
#include <array>

#include "trace/scene/top_level_wide.hpp"

namespace spacebvh::scene {

void measure_top_level(TopLevel& top, std::span<const TopLevelItem> items) {
    top.padding = {};
    for (const TopLevelItem& item : items) {
        top.padding.pad0 = std::max(top.padding.pad0, item.padding.pad0);
        top.padding.pad1 = std::max(top.padding.pad1, item.padding.pad1);
    }
    top.extent = extent_of(top.bvh.root().bounds);
}

std::vector<Triangle> top_level_triangles(std::span<const TopLevelItem> items) {
    // One triangle per box with two opposite corners as vertices: its bounds are the box exactly, so a
    // tree file's checks of a tree over them hold for the top level's tree.
    std::vector<Triangle> boxes(items.size());
    for (size_t i = 0; i < items.size(); ++i) {
        const AABB& b = items[i].box;
        boxes[i] = {b.lo, b.hi, Vec3{b.lo.x, b.hi.y, b.lo.z}};
    }
    return boxes;
}

void refit_top_level(TopLevel& top, std::span<const TopLevelItem> items) {
    for (size_t n = top.bvh.nodes.size(); n-- > 0;) {
        BvhNode& node = top.bvh.nodes[n];
        AABB box;
        if (node.is_leaf()) {
            for (uint32_t k = 0; k < node.reference_count; ++k)
                box.extend(items[top.bvh.primitives[node.first + k]].box);
        } else {
            box = merge(top.bvh.nodes[node.first].bounds, top.bvh.nodes[node.first + 1].bounds);
        }
        node.bounds = box;
    }
    measure_top_level(top, items);
}

namespace {

// Emits the node whose children are slots[0, count) (binary node indices), then their subtrees.
uint32_t emit(const Bvh& bvh, std::array<uint32_t, kTopWidth> slots, int count, std::vector<TopNode>& out) {
    // Open the inner child of largest area until kTopWidth children (Embree's collapse rule).
    while (count < kTopWidth) {
        int widest = -1;
        float widest_area = 0.0f;
        for (int k = 0; k < count; ++k) {
            const BvhNode& node = bvh.nodes[slots[k]];
            if (node.is_leaf()) continue;
            const float area = node.bounds.area();
            if (widest < 0 || area > widest_area) widest = k, widest_area = area;
        }
        if (widest < 0) break;
        const uint32_t first = bvh.nodes[slots[widest]].first;
        std::copy_backward(slots.begin() + widest + 1, slots.begin() + count, slots.begin() + count + 1);
        slots[widest] = first;
        slots[widest + 1] = first + 1;
        ++count;
    }
    const uint32_t index = uint32_t(out.size());
    out.emplace_back();
    for (int k = 0; k < count; ++k) {
        const BvhNode& child = bvh.nodes[slots[k]];
        for (int i = 0; i < 3; ++i) {
            out[index].lo[i][k] = child.bounds.lo[i];
            out[index].hi[i][k] = child.bounds.hi[i];
        }
        out[index].valid |= 1u << k;
        const uint32_t ref = child.is_leaf() ? kItemBit | slots[k] : emit(bvh, {child.first, child.first + 1}, 2, out);
        out[index].child[k] = ref;
    }
    return index;
}

}  // namespace

std::vector<TopNode> collapse_top_level(const Bvh& bvh) {
    std::vector<TopNode> nodes;
    // About one wide node per four items (each holds up to eight children, leaves and nodes).
    nodes.reserve(bvh.primitives.size() / 4 + 1);
    const BvhNode& root = bvh.root();
    if (root.is_leaf())
        emit(bvh, {0}, 1, nodes);
    else
        emit(bvh, {root.first, root.first + 1}, 2, nodes);
    return nodes;
}

}  // namespace spacebvh::scene
