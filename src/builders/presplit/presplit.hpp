// SPDX-License-Identifier: MIT
// Pre-splitting: turn a scene into references (triangle id + box) before the build, giving large or
// badly bounded triangles several references with tighter boxes that together cover the triangle.
// The result feeds an ordinary object-partitioning builder (the `esc` and `evh` presets: the
// object-sweep driver over these references).
//
//   early_split_clipping   Ernst & Greiner 2007, "Early Split Clipping for Bounding Volume
//                          Hierarchies" (ESC): recursive midpoint splits of the box's longest axis,
//                          the triangle clipped exactly into each half.
//   edge_volume_heuristic  Dammertz & Keller 2008, "The Edge Volume Heuristic - Robust Triangle
//                          Subdivision for Improved BVH Performance" (EVH): recursive splits of the
//                          edge with the largest box volume at its midpoint while that volume exceeds
//                          V_scene * 2^-t.
//
// Shared guarantees (both passes):
//  * Output order: triangle by triangle in triangle order, each triangle's references in a fixed
//    order. Deterministic and independent of the thread count (the splitting itself is serial, see
//    detail::greedy_presplit; only per-triangle preparation runs in parallel, into fixed slots).
//  * Budget: at most detail::reference_limit(triangles, budget) = max(n, floor(budget * n))
//    references, never fewer than one per triangle. When the heuristic wants more splits than the
//    budget allows, the splits go to the pieces of highest priority over the whole scene.
//  * Degenerate (zero-area) triangles get exactly one reference: their box.
//  * Every reference box is non-empty and contained in its triangle's box, and the union of a
//    triangle's reference boxes covers the whole triangle (boxes are rounded outward).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "builders/driver/reference.hpp"
#include <span>

#include "spacebvh/geometry.hpp"

namespace spacebvh::builders {

struct PresplitOptions {
    float reference_budget = 1.5f;  // max references as a multiple of the triangle count
    float evh_threshold = 14.0f;    // t of Dammertz & Keller: split while V_edge > V_scene * 2^-t
};

// ESC. Rule (ours; the paper leaves the threshold to the user per scene): a piece (the part of the
// triangle inside a box) is split while its box "waste" SA(box) - 4 * area(piece) exceeds the mean
// surface area of the non-degenerate triangles' boxes. See early_split_clipping.cpp.
std::vector<Reference> early_split_clipping(std::span<const Triangle> triangles, const PresplitOptions& options);

// EVH as in the paper, t = options.evh_threshold. See edge_volume_heuristic.cpp.
std::vector<Reference> edge_volume_heuristic(std::span<const Triangle> triangles, const PresplitOptions& options);

namespace detail {

// max(n, floor(budget * n)); a budget below 1 (or NaN) means one reference per triangle.
inline size_t reference_limit(size_t triangles, float budget) {
    const double limit = std::floor(double(budget) * double(triangles));
    if (!(limit > double(triangles))) return triangles;
    return size_t(std::min(limit, double(triangles) * 1024.0));
}

// Pieces are never split beyond this depth (keeps EVH's barycentric coordinates exact in double and
// bounds the work on pathological input).
inline constexpr uint32_t kMaxPresplitDepth = 24;

// The budgeted greedy driver shared by ESC and EVH. `Policy` provides:
//   using Piece = ...;                                   a part of one triangle
//   Piece root(uint32_t triangle) const;                 the whole (non-degenerate) triangle
//   double priority(uint32_t triangle, const Piece&) const;   split wanted when > threshold()
//   double threshold() const;
//   int split(uint32_t triangle, const Piece&, Piece out[2]) const;  0 (cannot), 1 or 2 non-empty parts
//   AABB bounds(uint32_t triangle, const Piece&) const;  non-empty, inside the triangle's box
// Every piece whose priority exceeds the threshold waits in one max-heap over the whole scene,
// ordered by (priority desc, triangle asc, creation number asc): a strict total order, so the pops
// and hence the output do not depend on anything but the input. Pops stop when the heap is empty
// or the extra references reach the budget; each split adds (parts - 1) references.
template <class Policy>
std::vector<Reference> greedy_presplit(std::span<const Triangle> triangles, const PresplitOptions& options,
                                       const Policy& policy) {
    using Piece = typename Policy::Piece;
    const size_t n = triangles.size();
    if (n == 0) return {};
    const size_t extra_budget = reference_limit(n, options.reference_budget) - n;
    const double threshold = policy.threshold();

    struct Node {
        Piece piece;
        double priority;
        uint32_t triangle;
        uint64_t sequence;  // creation number within the whole run (the root of triangle i: i)
        uint32_t depth;
    };
    auto heap_less = [](const Node& a, const Node& b) {  // "a pops after b"
        if (a.priority != b.priority) return a.priority < b.priority;
        if (a.triangle != b.triangle) return a.triangle > b.triangle;
        return a.sequence > b.sequence;
    };

    // Root priorities in parallel, each into its own slot (no order dependence).
    std::vector<double> root_priority(n, 0.0);
    std::vector<uint8_t> candidate(n, 0);
    if (extra_budget > 0) {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& range) {
            for (size_t i = range.begin(); i != range.end(); ++i) {
                if (triangles[i].is_degenerate()) continue;
                const double p = policy.priority(uint32_t(i), policy.root(uint32_t(i)));
                if (p > threshold) {
                    root_priority[i] = p;
                    candidate[i] = 1;
                }
            }
        });
    }

    std::vector<Node> heap;
    for (size_t i = 0; i < n; ++i)
        if (candidate[i]) heap.push_back({policy.root(uint32_t(i)), root_priority[i], uint32_t(i), uint64_t(i), 0});
    std::make_heap(heap.begin(), heap.end(), heap_less);

    std::vector<Node> finished;        // pieces of split triangles that will not be split further
    std::vector<uint8_t> split(n, 0);  // triangle has more than its root piece
    uint64_t next_sequence = n;
    size_t extra = 0;
    while (!heap.empty() && extra < extra_budget) {
        std::pop_heap(heap.begin(), heap.end(), heap_less);
        Node node = heap.back();
        heap.pop_back();
        Piece parts[2];
        const int count = node.depth < kMaxPresplitDepth ? policy.split(node.triangle, node.piece, parts) : 0;
        if (count <= 0) {
            finished.push_back(node);
            continue;
        }
        split[node.triangle] = 1;
        extra += size_t(count - 1);
        for (int k = 0; k < count; ++k) {
            Node child{parts[k], policy.priority(node.triangle, parts[k]), node.triangle, next_sequence++,
                       node.depth + 1};
            if (child.priority > threshold) {
                heap.push_back(child);
                std::push_heap(heap.begin(), heap.end(), heap_less);
            } else {
                finished.push_back(child);
            }
        }
    }
    // Pieces of split triangles, grouped by triangle in creation order.
    std::vector<Node> pieces;
    pieces.reserve(finished.size() + heap.size());
    for (const Node& node : finished)
        if (split[node.triangle]) pieces.push_back(node);
    for (const Node& node : heap)
        if (split[node.triangle]) pieces.push_back(node);
    std::sort(pieces.begin(), pieces.end(), [](const Node& a, const Node& b) {
        return a.triangle != b.triangle ? a.triangle < b.triangle : a.sequence < b.sequence;
    });

    std::vector<Reference> references;
    references.reserve(n + extra);
    size_t cursor = 0;
    for (size_t i = 0; i < n; ++i) {
        if (!split[i]) {
            references.push_back({triangles[i].bounds(), uint32_t(i)});
            continue;
        }
        for (; cursor < pieces.size() && pieces[cursor].triangle == i; ++cursor)
            references.push_back({policy.bounds(uint32_t(i), pieces[cursor].piece), uint32_t(i)});
    }
    return references;
}

}  // namespace detail
}  // namespace spacebvh::builders
