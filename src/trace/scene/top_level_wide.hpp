// SPDX-License-Identifier: MIT
// The top level as tracing walks it: the binary tree collapsed into nodes of up to four children, whose
// boxes one SSE test checks at once with the float operations of scene::meets lane by lane (so the
// allowance argument of top_level.hpp holds for every lane).
#pragma once

#include <immintrin.h>

#include <cstdint>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "trace/scene/top_level.hpp"

namespace spacebvh::scene {

inline constexpr uint32_t kItemBit = 0x80000000u;  // a child that is a leaf: kItemBit | its binary node

struct TopNode4 {
    float lo[3][4], hi[3][4];  // the children's boxes, one axis per row
    uint32_t child[4];         // a node index, or kItemBit | the binary tree's leaf
    uint32_t valid = 0;        // a bit per child slot in use
};

// Node 0 is the root; a binary tree whose root is a leaf becomes one node with that leaf.
std::vector<TopNode4> collapse_top_level(const Bvh& bvh);

struct WideTopQuery {
    struct Entry {
        uint32_t ref;  // node index, or kItemBit | the binary tree's leaf
        float key;
    };
    using Bound = float;
    static constexpr int kStackCapacity = 3 * 64 + 8;  // the top level's depth limit 64, three pushes per level

    const std::vector<TopNode4>& nodes;
    BoxRay ray;

    Entry root() const { return {0, ray.tmin}; }
    bool is_leaf(const Entry& e) const { return (e.ref & kItemBit) != 0; }
    bool beyond(const Entry& e, Bound bound) const { return e.key > bound; }
    int enter(Entry& node, Bound bound, Entry* out) const {
        const TopNode4& n = nodes[node.ref];
        __m128 near = _mm_set1_ps(ray.tmin), far = _mm_set1_ps(bound);
        __m128 inside = _mm_castsi128_ps(_mm_set1_epi32(-1));
        for (int i = 0; i < 3; ++i) {
            const __m128 lo = _mm_loadu_ps(n.lo[i]), hi = _mm_loadu_ps(n.hi[i]);
            const __m128 lo_org = _mm_set1_ps(ray.lo_org[i]), hi_org = _mm_set1_ps(ray.hi_org[i]);
            if (ray.parallel[i]) {
                inside = _mm_and_ps(inside, _mm_and_ps(_mm_cmple_ps(lo, lo_org), _mm_cmpge_ps(hi, hi_org)));
                continue;
            }
            const __m128 inv = _mm_set1_ps(ray.inv[i]);
            const __m128 t0 = _mm_mul_ps(_mm_sub_ps(lo, lo_org), inv), t1 = _mm_mul_ps(_mm_sub_ps(hi, hi_org), inv);
            // Operand order as std::min / std::max in meets: min(t0, t1) = t1 < t0 ? t1 : t0.
            near = _mm_max_ps(_mm_min_ps(t1, t0), near);
            far = _mm_min_ps(_mm_max_ps(t1, t0), far);
        }
        const unsigned entered = unsigned(_mm_movemask_ps(_mm_and_ps(inside, _mm_cmple_ps(near, far)))) & n.valid;
        if (!entered) return 0;
        alignas(16) float key[4];
        _mm_store_ps(key, near);
        return trace::nearest_first(entered, key, node, out, [&](int slot) { return Entry{n.child[slot], key[slot]}; });
    }
};

}  // namespace spacebvh::scene
