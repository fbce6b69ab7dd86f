// SPDX-License-Identifier: MIT
#include "trace/queries/query_layout.hpp"

#include <string>
#include <utility>

#include "spacebvh/error.hpp"
#include "trace/kernels/kernels.hpp"

namespace spacebvh {

namespace {

using trace::queries::kEmptySlot;
using trace::queries::kStackSize;
using trace::queries::QueryNode;
using Layout = RayQueries::Layout;

// Appends the leaf's live triangles as packs of its own; returns {first pack, lanes} or an empty slot.
std::pair<uint32_t, uint32_t> add_leaf(Layout& layout, std::span<const Triangle> triangles, const Bvh& bvh,
                                       const BvhNode& leaf) {
    std::vector<uint32_t> live;
    for (uint32_t i = leaf.first; i < leaf.first + leaf.reference_count; ++i) {
        const uint32_t id = bvh.primitives[i];
        if (id >= triangles.size())
            throw Error("queries: the tree refers to triangle " + std::to_string(id) + " of " +
                        std::to_string(triangles.size()));
        if (!triangles[id].is_degenerate()) live.push_back(id);
    }
    if (live.empty()) return {0, kEmptySlot};
    const uint32_t first = uint32_t(layout.packs.size());
    for (size_t k = 0; k < live.size(); ++k) {
        if (k % 4 == 0) layout.packs.emplace_back();
        trace::TrianglePack& pack = layout.packs.back();  // value-initialised: unused lanes are zero
        const Triangle& tri = triangles[live[k]];
        const int lane = int(k % 4);
        for (int v = 0; v < 3; ++v)
            for (int a = 0; a < 3; ++a) pack.vertex[v][a][lane] = tri.vertex(v)[a];
        pack.primitive[lane] = live[k];
    }
    return {first, uint32_t(live.size())};
}

void set_slot(QueryNode& node, int slot, const AABB& box, uint32_t child, uint32_t count) {
    for (int a = 0; a < 3; ++a) {
        node.planes[a][slot] = box.lo[a];
        node.planes[a][slot + 2] = box.hi[a];
    }
    node.child[slot] = child;
    node.count[slot] = count;
}

// Lays out the subtree under bvh node `index` as the children of a new query node; returns its index.
uint32_t add_node(Layout& layout, std::span<const Triangle> triangles, const Bvh& bvh, uint32_t index, int depth) {
    if (depth > kStackSize / 2)
        throw Error("queries: the tree is deeper than " + std::to_string(kStackSize / 2) + " levels");
    const uint32_t at = uint32_t(layout.nodes.size());
    layout.nodes.emplace_back();
    const BvhNode& node = bvh.nodes[index];
    const uint32_t children[2] = {node.first, node.first + 1};
    for (int slot = 0; slot < 2; ++slot) {
        if (children[slot] >= bvh.nodes.size()) throw Error("queries: a tree node refers to a missing child");
        const BvhNode& child = bvh.nodes[children[slot]];
        if (child.is_leaf()) {
            const auto [first, lanes] = add_leaf(layout, triangles, bvh, child);
            set_slot(layout.nodes[at], slot, child.bounds, first, lanes);
        } else {
            const uint32_t inner = add_node(layout, triangles, bvh, children[slot], depth + 1);
            set_slot(layout.nodes[at], slot, child.bounds, inner, 0);
        }
    }
    return at;
}

}  // namespace

RayQueries::Layout::Layout(std::span<const Triangle> triangles, const Bvh& bvh) : triangle_count(triangles.size()) {
    for (size_t i = 0; i < triangles.size(); ++i) {
        if (!is_finite(triangles[i].v0) || !is_finite(triangles[i].v1) || !is_finite(triangles[i].v2))
            throw Error("queries: triangle " + std::to_string(i) + " has a vertex that is not finite");
        bounds.extend(triangles[i].bounds());
    }
    if (bvh.empty() || triangles.empty()) return;
    const BvhNode& root = bvh.root();
    if (root.is_leaf()) {
        // A root leaf gets a node of its own: every walk starts at an inner node.
        nodes.emplace_back();
        const auto [first, lanes] = add_leaf(*this, triangles, bvh, root);
        set_slot(nodes[0], 0, root.bounds, first, lanes);
        set_slot(nodes[0], 1, AABB{}, 0, kEmptySlot);
    } else {
        add_node(*this, triangles, bvh, 0, 0);
    }
    if (trace::cpu_has(NodeTest::avx2)) {
        wide = trace::collapse_to_wide<8>(triangles, bvh, WideCollapse::sah_optimal);
        has_wide = !wide.nodes.empty();
    }
}

}  // namespace spacebvh
