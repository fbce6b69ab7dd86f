// SPDX-License-Identifier: MIT
// Refit: a tree's boxes recomputed bottom-up for moved triangles (spacebvh/build.hpp).
#include <atomic>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh {

void refit_boxes(Bvh& bvh, std::span<const Triangle> triangles) {
    // The leaves' boxes (the triangles' bounds: nearly all of the work) in parallel, each leaf written
    // by one task and depending only on its triangles; then the inner nodes in one backward walk
    // (children follow their parent, so it meets every child before its parent), a merge each. The
    // result is the same for any thread count.
    // The tree is checked first, so that a refit that throws changes nothing.
    std::atomic<bool> outside = false;
    const size_t count = triangles.size();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, bvh.primitives.size(), 1 << 16),
                      [&](const tbb::blocked_range<size_t>& r) {
                          bool any = false;
                          for (size_t k = r.begin(); k != r.end(); ++k) any |= bvh.primitives[k] >= count;
                          if (any) outside.store(true, std::memory_order_relaxed);
                      });
    if (outside)
        for (const uint32_t primitive : bvh.primitives)
            if (primitive >= count)
                throw Error("refit: the tree names triangle " + std::to_string(primitive) + " of only " +
                            std::to_string(count));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, bvh.nodes.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t n = r.begin(); n != r.end(); ++n) {
            BvhNode& node = bvh.nodes[n];
            if (!node.is_leaf()) continue;
            AABB box;
            for (uint32_t k = 0; k < node.reference_count; ++k)
                box.extend(triangles[bvh.primitives[node.first + k]].bounds());
            node.bounds = box;
        }
    });
    for (size_t n = bvh.nodes.size(); n-- > 0;) {
        BvhNode& node = bvh.nodes[n];
        if (!node.is_leaf()) node.bounds = merge(bvh.nodes[node.first].bounds, bvh.nodes[node.first + 1].bounds);
    }
}

}  // namespace spacebvh
