// SPDX-License-Identifier: MIT
// The top level as tracing walks it: the binary tree collapsed into nodes of up to eight children,
// whose boxes one vector test checks at once with the float operations of scene::meets lane by lane
// (so the allowance argument of top_level.hpp holds for every lane).
#pragma once

#include <immintrin.h>

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

    Entry root() const { return {0, ray.tmin}; }
    bool is_leaf(const Entry& e) const { return (e.ref & kItemBit) != 0; }
    bool beyond(const Entry& e, Bound bound) const { return e.key > bound; }
    // All children's boxes at once, with the float operations of scene::meets lane by lane (GCC
    // vector extensions: AVX where the build has it, SSE halves otherwise; no FMA contraction).
    int enter(Entry& node, Bound bound, Entry* out) const {
        using V = float __attribute__((vector_size(4 * kTopLanes)));
        using M = int __attribute__((vector_size(4 * kTopLanes)));
        const TopNode& n = nodes[node.ref];
        alignas(32) float key[kTopWidth];
        unsigned entered = 0;
        for (int first = 0; first < kTopWidth; first += kTopLanes) {
            V near = ray.tmin - V{}, far = bound - V{};
            M inside = M{} == M{};
            for (int i = 0; i < 3; ++i) {
                V lo, hi;
                __builtin_memcpy(&lo, n.lo[i] + first, sizeof lo);
                __builtin_memcpy(&hi, n.hi[i] + first, sizeof hi);
                if (ray.parallel[i]) {
                    inside &= (lo <= ray.lo_org[i]) & (hi >= ray.hi_org[i]);
                    continue;
                }
                const V t0 = (lo - ray.lo_org[i]) * ray.inv[i], t1 = (hi - ray.hi_org[i]) * ray.inv[i];
                // As std::min / std::max in meets: min(t0, t1), max(t0, t1). With lo <= hi and lo_org
                // >= hi_org the differences are ordered before and after rounding, so t0 <= t1 exactly
                // when the inverse is positive: the sign picks them (equal values where they tie).
                const bool negative = ray.inv[i] < 0.0f;
                const V low = negative ? t1 : t0, high = negative ? t0 : t1;
                // max(near, x) = near < x ? x : near, as in meets.
                near = near < low ? low : near;
                far = high < far ? high : far;
            }
            const M hit = inside & (near <= far);
            entered |= lane_signs(hit) << first;
            __builtin_memcpy(key + first, &near, sizeof near);
        }
        entered &= n.valid;
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
