// SPDX-License-Identifier: MIT
// The compact binary layout: two child boxes per 64-byte node, leaves in the shared packs of four
// triangles, and its single-ray kernel (binary_kernel.cpp), the reference kernel of every tracer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "trace/layout/huge_page_allocator.hpp"
#include "trace/kernels/kernels.hpp"
#include "trace/leaf_tests/triangle_pack.hpp"

namespace spacebvh::trace {

// One inner node holds the boxes of both children in the order the SSE slab test reads them:
// per axis [lo of child 0, lo of child 1, hi of child 0, hi of child 1].
struct alignas(64) CompactNode {
    float planes[3][4];
    // Where the child lies in the layout's one buffer, in kUnit-byte units from its start: an inner
    // child's CompactNode (0 lanes), or a leaf child's first TrianglePack, tested as lanes > 0 lanes
    // from there (LeafPacker).
    uint32_t child[2];
    // Bits 0-29: the child's lanes (kLanes). Bits 30-31 of word 0: the node's order axis, along which
    // child 0's box centre is not above child 1's (order_children).
    uint32_t word[2];

    uint32_t lanes(int slot) const { return word[slot] & kLanes; }
    unsigned order_axis() const { return word[0] >> 30; }
    static constexpr uint32_t kLanes = (1u << 30) - 1;
};
static_assert(sizeof(CompactNode) == 64);

// Nodes and leaf packs share one buffer, addressed in 32-byte units (a node is 2 units, a pack 5), so
// a child's address is the same `base + child * kUnit` whether it is a node or a leaf: the kernel
// prefetches either without a branch on its kind, which at the deep levels of an incoherent walk is a
// coin toss the branch predictor often loses.
constexpr size_t kUnit = 32;
static_assert(sizeof(CompactNode) % kUnit == 0 && sizeof(TrianglePack) % kUnit == 0);
constexpr size_t kNodeUnits = sizeof(CompactNode) / kUnit;   // 2
constexpr size_t kPackUnits = sizeof(TrianglePack) / kUnit;  // 5

struct BinaryLayout {
    std::vector<CompactNode, HugePageAllocator<CompactNode>> buffer;  // nodes, then packs
    size_t node_count = 0;
};

// Lays out a binary tree over its triangles. Throws std::length_error past the 32-bit offsets.
BinaryLayout make_binary_layout(std::span<const Triangle> triangles, const Bvh& bvh);
// The kernels over a BinaryLayout (passed as const void*).
SingleRayKernels binary_kernels();

}  // namespace spacebvh::trace
