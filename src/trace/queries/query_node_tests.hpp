// SPDX-License-Identifier: MIT
// The node tests of RayQueries' walks, as queries of the walk skeleton (walk.hpp): double slabs over
// the binary query nodes (every ray). The eight-wide nodes' fused float slabs (rays with tmin >= 0, on
// CPUs with AVX2 and FMA) are in query_wide_tests.inl, compiled under that target only. Both are
// conservative: a box a ray touches within [tmin, tmax] is entered; the leaf test decides the answers
// exactly.
#pragma once

#include <immintrin.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include "spacebvh/geometry.hpp"
#include "trace/queries/query_layout.hpp"
#include "trace/traversal/traversal_common.hpp"
#include "trace/traversal/walk.hpp"

namespace spacebvh::trace::queries {

// A child slot of either layout: an inner node (count 0, child = node index) or a leaf (child = first
// pack, count = lanes). Nearest-first walks keep the distance the child was entered at as its key.
struct SlotEntry {
    uint32_t child, count;
};
template <class Key>
struct KeyedSlotEntry {
    uint32_t child, count;
    Key key;
};
// What the queries of both layouts share: their entries, the leaf test of an entry, and the bound
// check of nearest-first walks (whose keys are entry distances, the bound the best t so far).
template <ChildOrder Order, class Key>
struct SlotQuery {
    static constexpr bool kNearestFirst = Order == ChildOrder::nearest_first;
    using Entry = std::conditional_t<kNearestFirst, KeyedSlotEntry<Key>, SlotEntry>;
    using Bound = Key;

    static Entry make_entry(uint32_t child, uint32_t count, Key key) {
        if constexpr (kNearestFirst)
            return {child, count, key};
        else
            return {child, count};
    }
    static bool is_leaf(const Entry& entry) { return entry.count != 0; }
    static bool beyond(const Entry& entry, Bound bound) {
        if constexpr (kNearestFirst)
            return entry.key > bound;
        else
            return false;
    }
};

// ---------------------------------------------------------------------------------------------
// Double slabs over the binary query nodes.

typedef double Double4 __attribute__((vector_size(32)));
typedef float Float4 __attribute__((vector_size(16)));

// Per-ray constants of the two-box slab test, in double: t = (plane - o) * inv + bias. An axis the ray
// does not move along gets a huge inverse and a bias that opens its slab to +-2^300 when the origin is
// inside (including on a plane), and keeps it shut otherwise: no 0 * inf.
struct SlabRay {
    Double4 org[3], inv[3], bias[3];
    explicit SlabRay(const Ray& ray) {
        for (int a = 0; a < 3; ++a) {
            const double d = ray.dir[a];
            const bool parallel = d == 0.0;
            const double o = ray.org[a];
            org[a] = Double4{o, o, o, o};
            const double inverse = parallel ? 0x1p600 : 1.0 / d;
            inv[a] = Double4{inverse, inverse, inverse, inverse};
            const double b = parallel ? 0x1p300 : 0.0;
            bias[a] = Double4{-b, -b, b, b};
        }
    }
};

// The relative widening of the slab distances: the difference, reciprocal and product each round once
// (relative 2^-53); 1e-15 is over 9 of those.
inline constexpr double kWiden = 1e-15;

// Which of the node's two children the ray enters within [tmin, tmax] (bit i: child i), and their entry
// distances.
inline unsigned enter_children(const QueryNode& node, const SlabRay& s, double tmin, double tmax, double near_out[2]) {
    // Clamped to +-2^400: a crossing inside a box lies within the box's slab on an axis the ray moves
    // along, so |t| <= 2^129 / 2^-149 there; a parallel axis whose slab misses the origin gives
    // distances beyond 2^450 and is culled even when tmax is infinite.
    const double low = std::max(tmin, -0x1p400), high = std::min(tmax, 0x1p400);
    Double4 near = {low, low, low, low}, far = {high, high, high, high};
    for (int a = 0; a < 3; ++a) {
        Float4 pf;
        std::memcpy(&pf, node.planes[a], sizeof pf);
        const Double4 p = __builtin_convertvector(pf, Double4);
        const Double4 t = (p - s.org[a]) * s.inv[a] + s.bias[a];
        const Double4 swapped = __builtin_shufflevector(t, t, 2, 3, 0, 1);
        const Double4 lo = t < swapped ? t : swapped;
        const Double4 hi = t < swapped ? swapped : t;
        near = near > lo ? near : lo;
        far = far < hi ? far : hi;
    }
    unsigned mask = 0;
    for (int i = 0; i < 2; ++i) {
        const double n = near[i] - std::fabs(near[i]) * kWiden, f = far[i] + std::fabs(far[i]) * kWiden;
        if (node.count[i] != kEmptySlot && n <= f) mask |= 1u << i;
        near_out[i] = n;
    }
    return mask;
}

// The binary layout's query: any ray (no condition on tmin).
template <ChildOrder Order>
class BinarySlabQuery : public SlotQuery<Order, double> {
public:
    using Base = SlotQuery<Order, double>;
    using typename Base::Bound;
    using typename Base::Entry;
    static constexpr int kStackCapacity = kStackSize;  // one pending child per level (add_node's limit)

    BinarySlabQuery(const RayQueries::Layout& layout, const Ray& ray)
        : nodes_(layout.nodes.data()), packs_(layout.packs.data()), slabs_(ray), tmin_(ray.tmin) {}

    Entry root() const { return Base::make_entry(0, 0, -std::numeric_limits<double>::infinity()); }

    [[gnu::always_inline]] int enter(Entry& entry, Bound bound, Entry* out) const {
        const QueryNode& node = nodes_[entry.child];
        double near[2];
        const unsigned entered = enter_children(node, slabs_, tmin_, bound, near);
        if (entered == 0) return 0;
        // Fetched ahead: the inner children, and the leaves of walks that test every leaf on the ray.
        [[maybe_unused]] unsigned leaves = 0;
        for (unsigned m = entered; m; m &= m - 1) {
            const int slot = __builtin_ctz(m);
            if (node.count[slot] == 0) {
                __builtin_prefetch(&nodes_[node.child[slot]]);
            } else {
                leaves |= 1u << slot;
                if constexpr (!Base::kNearestFirst) prefetch_pack(packs_[node.child[slot]]);
            }
        }
        const auto entry_at = [&](int slot) {
            return Base::make_entry(node.child[slot], node.count[slot], near[slot]);
        };
        if constexpr (Base::kNearestFirst)
            return nearest_first(entered, near, entry, out, entry_at);
        else
            return leaves_first(entered, leaves, entry, out, entry_at);
    }

private:
    const QueryNode* nodes_;
    const TrianglePack* packs_;
    SlabRay slabs_;
    double tmin_;
};

}  // namespace spacebvh::trace::queries
