// SPDX-License-Identifier: MIT
// The top level of a scene: built by our binned builder over its geometries' boxes, refitted in place.
#include "trace/scene/top_level.hpp"

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

TopLevel build_top_level(std::span<const TopLevelItem> items) {
    // One triangle per box with two opposite corners as vertices: its bounds are the box exactly, and
    // the object-partitioning binned builder never clips it, so each item is in exactly one leaf.
    std::vector<Triangle> boxes(items.size());
    for (size_t i = 0; i < items.size(); ++i) {
        const AABB& b = items[i].box;
        boxes[i] = {b.lo, b.hi, Vec3{b.lo.x, b.hi.y, b.lo.z}};
    }
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

void refit_boxes(Bvh& bvh, std::span<const Triangle> triangles) {
    for (size_t n = bvh.nodes.size(); n-- > 0;) {
        BvhNode& node = bvh.nodes[n];
        AABB box;
        if (node.is_leaf()) {
            for (uint32_t k = 0; k < node.reference_count; ++k)
                box.extend(triangles[bvh.primitives[node.first + k]].bounds());
        } else {
            box = merge(bvh.nodes[node.first].bounds, bvh.nodes[node.first + 1].bounds);
        }
        node.bounds = box;
    }
}

}  // namespace spacebvh::scene
