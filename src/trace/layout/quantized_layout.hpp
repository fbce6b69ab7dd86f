// SPDX-License-Identifier: MIT
// Quantized 8-wide nodes (after Ylitie, Karras, Laine 2017, "Efficient Incoherent Ray Traversal on
// GPUs Through Compressed Wide BVHs"): each child box stored as 8-bit offsets on a per-node grid, so
// a node is two cache lines instead of the four of WideNode<8>. Same tree, same slot order, same
// node indices and the same leaf packs as the WideLayout<8> it is made from (quantize_wide).
//
// Decoding: plane = fma(float(q), scale[axis], origin[axis]), one int->float convert and one fma
// (rounded once). The kernel then takes the decoded planes through the same fused slab test as the
// float nodes (FusedSlabs, traversal_common.hpp), so the slab test's proof that it never culls a box
// the ray touches holds unchanged, provided every decoded box contains its exact child box.
//
// Why no decoded box is smaller than its child box (per axis; s = scale > 0, o = origin, both floats):
//  - decode(q) = fl(o + q s) is non-decreasing in q: o + q s grows with q and correctly rounded
//    arithmetic (one rounding, to nearest) is monotone.
//  - the encoder takes o = the lowest lower bound of the node's children (a float), so decode(0) = o
//    <= every child's lo; and a power-of-two s with decode(255) >= the highest upper bound (an
//    overflow to +inf also qualifies: an infinite plane is conservative in the slab test).
//  - lo code: the largest q with decode(q) <= lo; hi code: the smallest q with decode(q) >= hi. Both
//    exist by the two bounds above, and the encoder checks them with the very fma the kernels
//    evaluate (std::fma and the FMA instructions are both the correctly rounded a * b + c), so
//    decoded lo <= lo and decoded hi >= hi: the box only grows, and a point or zero-width box keeps
//    a decoded box that contains it.
// Empty slots are never entered: they are not in `used_mask`, which the kernel ANDs into its hit mask
// (an empty slot has no box to decode; codes alone could not make every ray miss it).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "trace/layout/huge_page_allocator.hpp"
#include "trace/leaf_tests/moller_filter.hpp"
#include "trace/leaf_tests/triangle_pack.hpp"
#include "trace/layout/wide_layout.hpp"

namespace spacebvh::trace {

// Two cache lines. q[2 * axis] holds the lower-bound codes on `axis`, q[2 * axis + 1] the upper ones
// (the plane order of WideNode, so the kernel picks entry and exit planes alike). child and count as in
// WideNode<8>; count is 16 bits (a leaf of more than 65535 lanes is refused).
struct alignas(64) QuantizedNode8 {
    uint8_t q[6][8];
    float origin[3];
    float scale[3];  // a power of two per axis
    uint32_t child[8];
    uint16_t count[8];
    uint8_t used_mask;  // bit i: slot i holds a child
    uint8_t padding[7];

    [[gnu::always_inline]] bool used(int slot) const { return (used_mask >> slot) & 1u; }
};
static_assert(sizeof(QuantizedNode8) == 128);

struct QuantizedLayout8 {
    std::vector<QuantizedNode8, HugePageAllocator<QuantizedNode8>> nodes;  // nodes[0] is the root
    TrianglePacks packs;
    PackPlanesList planes;  // the moller leaf test's normals; empty without it
};

// The decoded plane of code q on an axis of scale s and origin o: what the kernels compute.
inline float decode_plane(uint8_t q, float scale, float origin) { return std::fma(float(q), scale, origin); }

// One node quantized (its children's boxes rounded outward). Throws Error for a leaf count over 65535.
QuantizedNode8 quantize_node(const WideNode<8>& node);

// The whole layout (node i of the result is node i of `wide`); takes over the packs and planes.
QuantizedLayout8 quantize_wide(WideLayout<8>&& wide);

// The decoded box of slot `slot` (for tests and checks).
AABB decoded_box(const QuantizedNode8& node, int slot);

}  // namespace spacebvh::trace
