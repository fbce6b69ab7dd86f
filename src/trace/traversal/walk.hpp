// SPDX-License-Identifier: MIT
// The one stack loop of every tree walk that is not a SIMD kernel (RayQueries' walks, Tracer64's),
// in the shape of bvh v2's `intersect` (madmann91/bvh, src/bvh/v2/bvh.h): a query says what a
// node is and which children it enters, a leaf visitor decides what a leaf holds; the loop between
// them is written once. The SIMD kernels keep their own loops (docs/design.md, "Traversal").
#pragma once

namespace spacebvh::trace {

// The order a query's enter leaves the children it enters in: slot order with the leaves first
// (leaves_first), or nearest first (nearest_first).
enum class ChildOrder { leaves_first, nearest_first };

// A query, the node-test policy of a walk, provides:
//   Entry                 a child to visit, node or leaf, with the `key` it was entered at (the entry
//                         distance of a ray; of a point query, the distance to the box)
//   Bound                 the type of the bound: how far the walk reaches (a ray's tmax; of a point
//                         query, the largest distance still of interest)
//   kStackCapacity        entries the stack needs: the most pending at once for the deepest tree the
//                         query accepts, plus one node's children
//   Entry root()          where the walk starts
//   bool is_leaf(Entry)
//   int enter(Entry& node, Bound bound, Entry* out)
//                         tests the node's children and returns how many it enters within the bound;
//                         when any, `node` becomes the child visited next and out[0, n - 1) holds
//                         the others in reverse visit order (they pop in turn). The order is the
//                         query's: slot order, or nearest first (leaves_first and nearest_first below)
//   bool beyond(Entry, Bound bound)
//                         whether an entry pushed earlier lies past the bound as it is now: it is
//                         dropped when popped
// The leaf visitor is called with each leaf entry and returns true to stop the walk. A closest-hit
// visitor lowers `bound` as it finds crossings (bvh v2's leaf function shortens ray.tmax alike).
//
// The query holds only what stays fixed during the walk (the ray's constants); the one thing the
// visitor changes is the bound, kept apart, so the compiler may keep the query's constants in
// registers across the visitor's calls.
//
// A nearest-triangle query for distances fits as it is: a point instead of a ray, enter = the
// distance from the point to each child's box, nearest first, beyond = key > bound, and a visitor
// that measures the leaf's triangles and lowers the bound to the best distance so far.
#include "trace/traversal/walk_skeleton.inl"  // walk(), in this namespace

// The two child orders, for a query's enter: `entered` holds a bit per child slot entered (not
// zero), entry_at(slot) makes that child's Entry. Each sets `next` to the child visited first,
// writes the others to out in reverse visit order and returns how many children there are.

// Slot order, leaves first: the leaves in slot order, then the inner children from the last slot
// down. For walks that visit every leaf on the ray (all hits, counts, any hit), where the order
// changes no answer: a node's leaves are tested while its inner children, fetched ahead, arrive from
// memory.
template <class Entry, class EntryAt>
[[gnu::always_inline]] inline int leaves_first(unsigned entered, unsigned leaves, Entry& next, Entry* out,
                                               EntryAt&& entry_at) {
    const unsigned leaf_slots = entered & leaves, inner_slots = entered & ~leaves;
    const int first = leaf_slots ? __builtin_ctz(leaf_slots) : 31 - __builtin_clz(inner_slots);
    next = entry_at(first);
    int n = 0;
    for (unsigned rest = inner_slots & ~(1u << first); rest; rest &= rest - 1) out[n++] = entry_at(__builtin_ctz(rest));
    for (unsigned rest = leaf_slots & ~(1u << first); rest; rest &= ~(1u << (31 - __builtin_clz(rest))))
        out[n++] = entry_at(31 - __builtin_clz(rest));
    return n + 1;
}

// Nearest first, by `key[slot]`: the nearest (the lowest slot among equals) visited next, the others
// in increasing key, so a child entered beyond a crossing found meanwhile is dropped when popped
// (closest-hit walks; a nearest-triangle walk alike).
template <class Entry, class Key, class EntryAt>
[[gnu::always_inline]] inline int nearest_first(unsigned entered, const Key* key, Entry& next, Entry* out,
                                                EntryAt&& entry_at) {
    int nearest = __builtin_ctz(entered);
    for (unsigned rest = entered & (entered - 1); rest; rest &= rest - 1) {
        const int slot = __builtin_ctz(rest);
        if (key[slot] < key[nearest]) nearest = slot;
    }
    next = entry_at(nearest);
    // The others farthest first (insertion: few children), so they pop nearest first.
    int n = 0;
    for (unsigned rest = entered & ~(1u << nearest); rest; rest &= rest - 1) {
        const int slot = __builtin_ctz(rest);
        int k = n++;
        while (k > 0 && out[k - 1].key < key[slot]) {
            out[k] = out[k - 1];
            --k;
        }
        out[k] = entry_at(slot);
    }
    return n + 1;
}

}  // namespace spacebvh::trace
