// SPDX-License-Identifier: MIT
// The layout RayQueries walks (queries.hpp): binary nodes with both child boxes side by side and, on
// CPUs that report AVX2 and FMA, the same tree collapsed to eight-wide nodes; leaves as packs of four
// triangles (triangle_pack.hpp).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/queries.hpp"
#include "trace/layout/wide_layout.hpp"
#include "trace/leaf_tests/triangle_pack.hpp"

namespace spacebvh {

namespace trace::queries {

inline constexpr uint32_t kEmptySlot = 0xFFFFFFFFu;

// The binary layout's node: a query node holds two children's boxes, so one two-box slab test
// (query_node_tests.hpp) decides both.
struct alignas(64) QueryNode {
    float planes[3][4];  // per axis: lo of child 0, lo of child 1, hi of child 0, hi of child 1
    uint32_t child[2];   // inner child: node index; leaf: first pack
    uint32_t count[2];   // 0: inner child; kEmptySlot: no child; else the leaf's lanes
};

// The stack of the binary walks; the layout refuses trees deeper than half of it.
inline constexpr int kStackSize = 2048;

}  // namespace trace::queries

struct RayQueries::Layout {
    std::vector<trace::queries::QueryNode> nodes;  // nodes[0] is the root; empty for an empty tree
    trace::TrianglePacks packs;
    size_t triangle_count = 0;
    AABB bounds;  // of every triangle: the grid containment batches are ordered on (coherent_order)
    // The same tree collapsed to eight-wide nodes (wide_layout.hpp), on CPUs with AVX2 and FMA (chosen
    // at run time, whatever the build targets): the walk of every crossing visits a third of the nodes
    // it visits in the binary layout. Rays with tmin >= 0 only (FusedSlabs). has_wide also picks the
    // walks compiled for AVX2 (query_walks.cpp).
    trace::WideLayout<8> wide;
    bool has_wide = false;

    // Lays out the tree over the triangles; throws Error for a vertex that is not finite, a tree that
    // refers to missing triangles or nodes, or one deeper than kStackSize / 2.
    Layout(std::span<const Triangle> triangles, const Bvh& bvh);
};

}  // namespace spacebvh
