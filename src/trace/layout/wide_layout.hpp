// SPDX-License-Identifier: MIT
// The memory layout of wide BVHs (wide_tracer.hpp) and the collapse of a binary Bvh into it.
#pragma once

#include <cstdint>
#include <vector>

#include <span>

#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"
#include "trace/layout/huge_page_allocator.hpp"
#include "spacebvh/trace.hpp"
#include "trace/leaf_tests/moller_filter.hpp"
#include "trace/leaf_tests/triangle_pack.hpp"

namespace spacebvh::trace {

// One node: the boxes of its (up to) W children in SoA, so one SIMD load reads one plane of all
// children. planes[2 * axis] holds the lower bounds on `axis`, planes[2 * axis + 1] the upper ones.
// Unused slots hold empty boxes (lo = +inf, hi = -inf), which no ray enters; they come last, the others
// in decreasing order of the triangles under them (the any-hit order, wide_layout.cpp).
// child[i]: inner child (count[i] == 0): index of its WideNode; leaf (count[i] > 0): index of its
// first TrianglePack (triangle_pack.hpp); it is tested as count[i] lanes from there (LeafPacker).
template <int W>
struct alignas(64) WideNode {
    float planes[6][W];
    uint32_t child[W];
    uint32_t count[W];

    // Whether slot holds a child (unused slots hold empty boxes).
    [[gnu::always_inline]] bool used(int slot) const { return planes[0][slot] <= planes[1][slot]; }
};
static_assert(sizeof(WideNode<4>) == 128 && sizeof(WideNode<8>) == 256);

template <int W>
struct WideLayout {
    std::vector<WideNode<W>, HugePageAllocator<WideNode<W>>> nodes;  // nodes[0] is the root
    TrianglePacks packs;
    PackPlanesList planes;  // the moller leaf test's normals, planes[i] for packs[i]; empty without it
    // W per node: the binary node whose box slot `slot` of node n holds, source[n * W + slot]
    // (kInvalidIndex for an unused slot or a leaf of degenerate triangles). Refit reads the boxes
    // again from there.
    std::vector<uint32_t> source;
    // Per reference of the binary tree (Bvh::primitives), the pack lane (4 * pack + lane) that the
    // reference's triangle is copied into on refit, kInvalidIndex for none: each used lane has exactly
    // one. Made by the first refit_tree_and_wide (lanes_tried), empty when it could not be.
    std::vector<uint32_t> lanes;
    bool lanes_tried = false;
    bool lanes_cover_all = false;  // every triangle has a reference in the tree
};

// Collapses the binary tree into wide nodes, choosing each node's children by `collapse`
// (wide_collapse.hpp). Nodes are laid out depth first, a node's first inner child right after it.
// Degenerate triangles are dropped (never hit); a leaf of degenerate triangles only gets an empty box.
template <int W>
WideLayout<W> collapse_to_wide(std::span<const Triangle> triangles, const Bvh& bvh, WideCollapse collapse);

// The layout made for `bvh` updated in place for the same tree with its boxes refitted to moved
// `triangles` (same count, same topology, refit_boxes): the packs' vertices, the moller planes and
// every slot's box are read again; nodes, packing and slot order stay. Returns false, changing
// nothing, when a triangle's degeneracy changed (layouts store exactly the non-degenerate ones) or the
// layout has no sources: then it must be made anew. `same_degenerate`: the caller knows that exactly
// the triangles that were degenerate when the layout was last made or refitted are degenerate now (it
// compared them), so that check is skipped.
template <int W>
bool refit_wide(WideLayout<W>& layout, std::span<const Triangle> triangles, const Bvh& bvh,
                bool same_degenerate = false);

// refit_boxes(bvh, triangles) and refit_wide(layout, triangles, bvh, true) in one walk of the tree:
// each pack lane is rewritten by the reference that owns it while the walk holds its triangle, so the
// moved triangles are read once. `triangles` must be indexed by the tree and degenerate exactly where
// they were when the layout was last made or refitted. Without `restore` they must be finite. With
// it (the triangles the layout and tree hold now), every coordinate read is checked, and when one is
// not finite the walk is made again over `restore`, so nothing changes, and not_finite is returned;
// that needs every triangle referenced by the tree, else unsupported. unsupported (nothing changed)
// too when the layout has no sources: then the caller refits the tree and makes the layout anew.
enum class TreeRefit { done, unsupported, not_finite };
template <int W>
TreeRefit refit_tree_and_wide(WideLayout<W>& layout, std::span<const Triangle> triangles, Bvh& bvh,
                              std::span<const Triangle> restore = {});

extern template WideLayout<4> collapse_to_wide<4>(std::span<const Triangle>, const Bvh&, WideCollapse);
extern template WideLayout<8> collapse_to_wide<8>(std::span<const Triangle>, const Bvh&, WideCollapse);
extern template bool refit_wide<4>(WideLayout<4>&, std::span<const Triangle>, const Bvh&, bool);
extern template bool refit_wide<8>(WideLayout<8>&, std::span<const Triangle>, const Bvh&, bool);
extern template TreeRefit refit_tree_and_wide<4>(WideLayout<4>&, std::span<const Triangle>, Bvh&,
                                                 std::span<const Triangle>);
extern template TreeRefit refit_tree_and_wide<8>(WideLayout<8>&, std::span<const Triangle>, Bvh&,
                                                 std::span<const Triangle>);

}  // namespace spacebvh::trace
