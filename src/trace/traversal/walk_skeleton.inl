// SPDX-License-Identifier: MIT
// The walk skeleton's loop (walk.hpp describes the query it takes), without an include guard: walk.hpp
// includes it into spacebvh::trace, and a file that compiles walks per instruction set includes it
// again into each ISA's namespace under that ISA's target (query_walks.cpp), because a function
// compiled for the baseline may not inline a query's node test compiled for AVX2.
template <class Query, class LeafVisitor>
[[gnu::always_inline]] inline void walk(const Query& query, typename Query::Bound& bound, LeafVisitor&& visit_leaf) {
    using Entry = typename Query::Entry;
    Entry stack[Query::kStackCapacity];  // uninitialised: Entry is trivial
    int top = 0;
    // The next pending entry still within the bound into `next`; false when none is left.
    const auto pop = [&](Entry& next) {
        do {
            if (top == 0) return false;
            next = stack[--top];
        } while (query.beyond(next, bound));
        return true;
    };
    Entry current = query.root();
    while (true) {
        // Inner nodes: down to the child visited first each time (the others are pushed; as in bvh
        // v2, the first is followed without a push), popping when no child is entered.
        while (!query.is_leaf(current)) {
            const int entered = query.enter(current, bound, stack + top);
            if (entered > 0)
                top += entered - 1;
            else if (!pop(current))
                return;
        }
        // Leaves, as long as they come one after another (a node's leaves are pushed together):
        // the visitor's calls stay out of the node loop, which keeps the query's constants in
        // registers.
        do {
            if (visit_leaf(current) || !pop(current)) return;
        } while (query.is_leaf(current));
    }
}
