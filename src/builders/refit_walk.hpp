// SPDX-License-Identifier: MIT
// The bottom-up walk of a refit (spacebvh::refit_boxes), shared with the traced layouts' refit, which
// rewrites each leaf triangle's copy in its pack while the walk holds the triangle (wide_refit.cpp).
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"

namespace spacebvh::builders {

namespace refit_detail {

// Subtrees rooted this deep (or leaves above) are refitted as one task each: up to 2^kTaskDepth tasks,
// enough to balance two to a few dozen threads, few enough that the serial merges above them cost nothing.
constexpr int kTaskDepth = 10;
// How many references ahead the walk asks for triangles: leaves are met in the order of their
// references (depth first, as builders lay them out), and the triangles they name are scattered over
// the mesh, so each read would otherwise wait on memory.
constexpr uint32_t kPrefetchAhead = 16;

// The boxes of the subtree under `root`, in one walk: its inner nodes listed parent before children
// (while each leaf's box is computed as it is met), then merged in the reverse of that order, which
// meets both children of a node before the node. An explicit stack, so any depth of tree is safe.
template <class Visit>
void refit_subtree(Bvh& bvh, uint32_t root, std::span<const Triangle> triangles, const Visit& visit) {
    std::vector<uint32_t> stack{root}, inner;
    const size_t references = bvh.primitives.size();
    while (!stack.empty()) {
        const uint32_t n = stack.back();
        stack.pop_back();
        BvhNode& node = bvh.nodes[n];
        if (node.is_leaf()) {
            const size_t end = std::min<size_t>(node.first + node.reference_count + kPrefetchAhead, references);
            for (size_t k = node.first + kPrefetchAhead; k < end; ++k)
                __builtin_prefetch(&triangles[bvh.primitives[k]]);
            AABB box;
            for (uint32_t k = node.first; k < node.first + node.reference_count; ++k) {
                const Triangle& t = triangles[bvh.primitives[k]];
                box.extend(t.bounds());
                visit(k, t);
            }
            node.bounds = box;
        } else {
            inner.push_back(n);
            stack.push_back(node.first + 1);
            stack.push_back(node.first);
        }
    }
    for (size_t k = inner.size(); k-- > 0;) {
        BvhNode& node = bvh.nodes[inner[k]];
        node.bounds = merge(bvh.nodes[node.first].bounds, bvh.nodes[node.first + 1].bounds);
    }
}

}  // namespace refit_detail

// Recomputes every box of `bvh` bottom-up from `triangles` (which the tree's references must index:
// unchecked) and calls visit(reference index, its triangle) once per reference, from any thread. The
// nodes down to kTaskDepth are listed breadth first, the subtrees under them refitted as parallel tasks
// (each writes only its own nodes), and the nodes above merged serially from the deepest up. Every box
// is the same union of the same triangle boxes (min and max are exact), so the result is the same for
// any thread count.
template <class Visit>
void refit_walk(Bvh& bvh, std::span<const Triangle> triangles, const Visit& visit) {
    if (bvh.nodes.empty()) return;
    std::vector<uint32_t> upper, tasks;  // inner nodes above the task roots (breadth first); task roots
    std::vector<uint32_t> level{0}, next;
    for (int depth = 0; !level.empty(); ++depth) {
        next.clear();
        for (const uint32_t n : level) {
            const BvhNode& node = bvh.nodes[n];
            if (node.is_leaf() || depth == refit_detail::kTaskDepth) {
                tasks.push_back(n);
            } else {
                upper.push_back(n);
                next.push_back(node.first);
                next.push_back(node.first + 1);
            }
        }
        level.swap(next);
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, tasks.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t k = r.begin(); k != r.end(); ++k) refit_detail::refit_subtree(bvh, tasks[k], triangles, visit);
    });
    for (size_t k = upper.size(); k-- > 0;) {
        BvhNode& node = bvh.nodes[upper[k]];
        node.bounds = merge(bvh.nodes[node.first].bounds, bvh.nodes[node.first + 1].bounds);
    }
}

}  // namespace spacebvh::builders
