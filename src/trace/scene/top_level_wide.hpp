// SPDX-License-Identifier: MIT
// The top level as tracing walks it: the binary tree collapsed into nodes of up to eight children,
// whose boxes one vector test checks at once with the float operations of scene::meets lane by lane
// (so the allowance argument of top_level.hpp holds for every lane).
#pragma once

#include <immintrin.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "trace/scene/top_level.hpp"

namespace spacebvh::scene {

// A child that is a leaf: kItemBit | its binary node as collapse_top_level makes it; a scene then
// points it at the leaf's first TopRecord instead (RenderScene::Impl::make_records).
inline constexpr uint32_t kItemBit = 0x80000000u;
inline constexpr int kTopWidth = 8;  // children per node of the walked top level (lane_signs: 8)

struct TopNode {
    alignas(32) float lo[3][kTopWidth];
    alignas(32) float hi[3][kTopWidth];  // the children's boxes, one axis per row
    uint32_t child[kTopWidth];           // a node index, or kItemBit | a leaf (kItemBit)
    uint32_t valid = 0;                  // a bit per child slot in use
};

// Node 0 is the root; a binary tree whose root is a leaf becomes one node with that leaf.
std::vector<TopNode> collapse_top_level(const Bvh& bvh);

// Lanes per vector operation of the top level's box test: eight with AVX, else four (SSE), twice per
// node. Written at the width the target has: GCC lowers wider generic vectors lane by lane.
#if defined(__AVX__)
inline constexpr int kTopLanes = 8;
#else
inline constexpr int kTopLanes = 4;
#endif

// A bit per lane of a vector compare's result (all ones or zero per lane).
template <class M>
[[gnu::always_inline]] inline unsigned lane_signs(const M& lanes) {
#if defined(__AVX__)
    __m256 v;
#else
    __m128 v;
#endif
    static_assert(sizeof v == sizeof lanes);
    __builtin_memcpy(&v, &lanes, sizeof v);
#if defined(__AVX__)
    return unsigned(_mm256_movemask_ps(v));
#else
    return unsigned(_mm_movemask_ps(v));
#endif
}

// The vector types of the box test: kTopLanes floats, and their compare results.
using TopLanes = float __attribute__((vector_size(4 * kTopLanes)));
using TopMask = int __attribute__((vector_size(4 * kTopLanes)));

// A BoxRay as the 8-wide test takes it, made once per walk: per axis the row of the children's
// planes the ray enters by and the row it leaves by (lower planes first where the inverse direction
// is positive, upper planes first where it is negative: Embree's near/far planes by octant), the
// grown origin each row is measured from, and the constants already broadcast across the lanes, so
// a node costs two loads, a subtract, a multiply and a min or max per plane row, and no branch.
//
// An axis the ray runs parallel to (BoxRay::parallel, rare: `parallel` says whether any) takes
// meets' test `lo <= lo_org && hi >= hi_org` as a lane mask. Its inverse becomes +inf with the
// lower planes near, so the shared arithmetic leaves `near` and `far` as meets does: a plane at or
// on the inner side of the grown origin gives -inf or NaN (0 * inf) for near, +inf or NaN for far,
// which change nothing (a compare with NaN is false); a plane on the outer side gives +inf or -inf,
// which only ever culls a lane the mask culls too.
struct WideRay {
    TopLanes near_org[3], far_org[3], inv[3];
    TopLanes tmin;
    uint32_t near_row[3], far_row[3];  // byte offsets of the rows in a TopNode (lo[i] or hi[i])
    bool parallel = false;             // some axis is parallel (BoxRay::parallel)

    explicit WideRay(const BoxRay& ray) {
        for (int i = 0; i < 3; ++i) {
            const bool negative = !ray.parallel[i] && ray.inv[i] < 0.0f;
            const float inv_i = ray.parallel[i] ? kInfinity : ray.inv[i];
            inv[i] = inv_i - TopLanes{};
            near_org[i] = (negative ? ray.hi_org[i] : ray.lo_org[i]) - TopLanes{};
            far_org[i] = (negative ? ray.lo_org[i] : ray.hi_org[i]) - TopLanes{};
            near_row[i] = uint32_t(negative ? offsetof(TopNode, hi) : offsetof(TopNode, lo)) + 4 * kTopWidth * i;
            far_row[i] = uint32_t(negative ? offsetof(TopNode, lo) : offsetof(TopNode, hi)) + 4 * kTopWidth * i;
            parallel = parallel || ray.parallel[i];
        }
        tmin = ray.tmin - TopLanes{};
    }
};

struct WideTopQuery {
    struct Entry {
        uint32_t ref;  // node index, or kItemBit | a leaf (kItemBit)
        float key;
    };
    using Bound = float;
    // The top level's depth limit 64, kTopWidth - 1 pushes per level.
    static constexpr int kStackCapacity = (kTopWidth - 1) * 64 + 2 * kTopWidth;

    const std::vector<TopNode>& nodes;
    BoxRay ray;
    WideRay wide;

    WideTopQuery(const std::vector<TopNode>& nodes_, const BoxRay& ray_) : nodes(nodes_), ray(ray_), wide(ray_) {}

    Entry root() const { return {0, ray.tmin}; }
    bool is_leaf(const Entry& e) const { return (e.ref & kItemBit) != 0; }
    // A bit per child whose box holds the grown origin on every parallel axis (WideRay).
    [[gnu::noinline]] unsigned inside_parallel_slabs(const TopNode& n) const {
        unsigned inside = 0;
        for (int slot = 0; slot < kTopWidth; ++slot) {
            bool in = true;
            for (int i = 0; i < 3; ++i)
                in = in && (!ray.parallel[i] || (n.lo[i][slot] <= ray.lo_org[i] && n.hi[i][slot] >= ray.hi_org[i]));
            inside |= unsigned(in) << slot;
        }
        return inside;
    }
    bool beyond(const Entry& e, Bound bound) const { return e.key > bound; }
    // All children's boxes at once, with the float operations of scene::meets lane by lane (GCC
    // vector extensions: AVX where the build has it, SSE halves otherwise; no FMA contraction): per
    // axis the entry distance is meets' min(t0, t1) and the exit its max(t0, t1), since with lo <= hi
    // and lo_org >= hi_org the differences are ordered before and after rounding, so the sign of the
    // inverse picks them (WideRay; equal values where they tie). max(near, x) = near < x ? x : near.
    int enter(Entry& node, Bound bound, Entry* out) const {
        const TopNode& n = nodes[node.ref];
        const char* base = reinterpret_cast<const char*>(&n);
        alignas(32) float key[kTopWidth];
        unsigned entered = 0;
        const TopLanes far_bound = bound - TopLanes{};
        for (int first = 0; first < kTopWidth; first += kTopLanes) {
            TopLanes near = wide.tmin, far = far_bound;
            for (int i = 0; i < 3; ++i) {
                TopLanes entry_planes, exit_planes;
                __builtin_memcpy(&entry_planes, base + wide.near_row[i] + 4 * first, sizeof entry_planes);
                __builtin_memcpy(&exit_planes, base + wide.far_row[i] + 4 * first, sizeof exit_planes);
                const TopLanes low = (entry_planes - wide.near_org[i]) * wide.inv[i];
                const TopLanes high = (exit_planes - wide.far_org[i]) * wide.inv[i];
                near = near < low ? low : near;
                far = high < far ? high : far;
            }
            const TopMask hit = near <= far;
            entered |= lane_signs(hit) << first;
            __builtin_memcpy(key + first, &near, sizeof near);
        }
        entered &= n.valid;
        if (wide.parallel) [[unlikely]]
            entered &= inside_parallel_slabs(n);
        if (!entered) return 0;
        // One child, the usual case below the root: no sort.
        if ((entered & (entered - 1)) == 0) {
            const int slot = __builtin_ctz(entered);
            node = Entry{n.child[slot], key[slot]};
            return 1;
        }
        return trace::nearest_first(entered, key, node, out, [&](int slot) { return Entry{n.child[slot], key[slot]}; });
    }
};

}  // namespace spacebvh::scene
