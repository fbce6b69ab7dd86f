// SPDX-License-Identifier: MIT
// Refit: a tree's boxes recomputed bottom-up for moved triangles (spacebvh/build.hpp).
#include <atomic>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "spacebvh/build.hpp"
#include "builders/refit_walk.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh {

namespace {

void check_primitives(const Bvh& bvh, size_t count) {
    std::atomic<bool> outside = false;
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
}

}  // namespace

void refit_boxes(Bvh& bvh, std::span<const Triangle> triangles) {
    // The tree is checked first, so that a refit that throws changes nothing; then one bottom-up pass
    // (refit_walk.hpp), the same for any thread count.
    check_primitives(bvh, triangles.size());
    builders::refit_walk(bvh, triangles, [](uint32_t, const Triangle&) {});
}

}  // namespace spacebvh
