// SPDX-License-Identifier: MIT
// The top level as tracing walks it: the binary tree collapsed into nodes of up to eight children,
// whose boxes one vector test checks at once with the float operations of scene::meets lane by lane
// (so the allowance argument of top_level.hpp holds for every lane).
#pragma once

#include <cstdint>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "trace/scene/top_level.hpp"

namespace spacebvh::scene {

inline constexpr uint32_t kItemBit = 0x80000000u;  // a child that is a leaf: kItemBit | its binary node
inline constexpr int kTopWidth = 8;                // children per node of the walked top level

struct TopNode {
    alignas(32) float lo[3][kTopWidth];
    alignas(32) float hi[3][kTopWidth];  // the children's boxes, one axis per row
    uint32_t child[kTopWidth];           // a node index, or kItemBit | the binary tree's leaf
    uint32_t valid = 0;                  // a bit per child slot in use
};

// Node 0 is the root; a binary tree whose root is a leaf becomes one node with that leaf.
std::vector<TopNode> collapse_top_level(const Bvh& bvh);

struct WideTopQuery {
    struct Entry {
        uint32_t ref;  // node index, or kItemBit | the binary tree's leaf
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
        using V = float __attribute__((vector_size(4 * kTopWidth)));
        using M = int __attribute__((vector_size(4 * kTopWidth)));
        const TopNode& n = nodes[node.ref];
        V near = ray.tmin - V{}, far = bound - V{};
        M inside = M{} == M{};
        for (int i = 0; i < 3; ++i) {
            V lo, hi;
            __builtin_memcpy(&lo, n.lo[i], sizeof lo);
            __builtin_memcpy(&hi, n.hi[i], sizeof hi);
            if (ray.parallel[i]) {
                inside &= (lo <= ray.lo_org[i]) & (hi >= ray.hi_org[i]);
                continue;
            }
            const V t0 = (lo - ray.lo_org[i]) * ray.inv[i], t1 = (hi - ray.hi_org[i]) * ray.inv[i];
            // As std::min / std::max in meets: min(t0, t1) = t1 < t0 ? t1 : t0, max(near, x) = near < x ? x : near.
            const V low = t1 < t0 ? t1 : t0, high = t0 < t1 ? t1 : t0;
            near = near < low ? low : near;
            far = high < far ? high : far;
        }
        const M hit = inside & (near <= far);
        unsigned entered = 0;
        for (int k = 0; k < kTopWidth; ++k) entered |= unsigned(hit[k] != 0) << k;
        entered &= n.valid;
        if (!entered) return 0;
        float key[kTopWidth];
        __builtin_memcpy(key, &near, sizeof key);
        return trace::nearest_first(entered, key, node, out, [&](int slot) { return Entry{n.child[slot], key[slot]}; });
    }
};

}  // namespace spacebvh::scene
