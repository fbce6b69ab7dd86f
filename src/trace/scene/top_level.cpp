// SPDX-License-Identifier: MIT
// The top level of a scene: built by our binned builder over its geometries' boxes, refitted in place.
#include "trace/scene/top_level.hpp"

#include "trace/scene/top_level_wide.hpp"

#include "spacebvh/build.hpp"

namespace spacebvh::scene {

namespace {

void measure(TopLevel& top, std::span<const TopLevelItem> items) {
    top.padding = {};
    for (const TopLevelItem& item : items) {
        top.padding.pad0 = std::max(top.padding.pad0, item.padding.pad0);
        top.padding.pad1 = std::max(top.padding.pad1, item.padding.pad1);
    }
    top.extent = extent_of(top.bvh.root().bounds);
}

}  // namespace

std::vector<Triangle> top_level_triangles(std::span<const TopLevelItem> items) {
    // One triangle per box with two opposite corners as vertices: its bounds are the box exactly, and
    // the object-partitioning binned builder never clips it, so each item is in exactly one leaf.
    std::vector<Triangle> boxes(items.size());
    for (size_t i = 0; i < items.size(); ++i) {
        const AABB& b = items[i].box;
        boxes[i] = {b.lo, b.hi, Vec3{b.lo.x, b.hi.y, b.lo.z}};
    }
    return boxes;
}

TopLevel build_top_level(std::span<const TopLevelItem> items) {
    const std::vector<Triangle> boxes = top_level_triangles(items);
    BuildConfig config = BuildConfig::for_preset(Preset::binned);
    // One item per leaf: its box is then tested once, on the way down, and a leaf is one walk.
    config.limits.max_leaf_size = 1;
    TopLevel top;
    top.bvh = build(MeshView(boxes).named("top level"), config);
    measure(top, items);
    return top;
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
    measure(top, items);
}

namespace {

// Emits the node whose children are `slots` (binary node indices), then their subtrees.
uint32_t emit(const Bvh& bvh, std::vector<uint32_t> slots, std::vector<TopNode4>& out) {
    // Open the inner child of largest area until four children (Embree's collapse rule).
    while (slots.size() < 4) {
        int widest = -1;
        for (int k = 0; k < int(slots.size()); ++k)
            if (!bvh.nodes[slots[k]].is_leaf() &&
                (widest < 0 || bvh.nodes[slots[k]].bounds.area() > bvh.nodes[slots[widest]].bounds.area()))
                widest = k;
        if (widest < 0) break;
        const uint32_t first = bvh.nodes[slots[widest]].first;
        slots[widest] = first;
        slots.insert(slots.begin() + widest + 1, first + 1);
    }
    const uint32_t index = uint32_t(out.size());
    out.emplace_back();
    for (size_t k = 0; k < slots.size(); ++k) {
        const BvhNode& child = bvh.nodes[slots[k]];
        for (int i = 0; i < 3; ++i) {
            out[index].lo[i][k] = child.bounds.lo[i];
            out[index].hi[i][k] = child.bounds.hi[i];
        }
        out[index].valid |= 1u << k;
        const uint32_t ref = child.is_leaf() ? kItemBit | slots[k] : emit(bvh, {child.first, child.first + 1}, out);
        out[index].child[k] = ref;
    }
    return index;
}

}  // namespace

std::vector<TopNode4> collapse_top_level(const Bvh& bvh) {
    std::vector<TopNode4> nodes;
    const BvhNode& root = bvh.root();
    emit(bvh, root.is_leaf() ? std::vector<uint32_t>{0} : std::vector<uint32_t>{root.first, root.first + 1}, nodes);
    return nodes;
}

}  // namespace spacebvh::scene
