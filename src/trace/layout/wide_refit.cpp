// SPDX-License-Identifier: MIT
// Refit of a wide layout in place (wide_layout.hpp): the same nodes and packs, boxes and vertices read
// again from the refitted binary tree and the moved triangles.
#include <algorithm>
#include <atomic>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "trace/layout/wide_layout.hpp"

namespace spacebvh::trace {

namespace {

// A lane holds a triangle unless all its coordinates are zero: packs start zeroed and only
// non-degenerate triangles, which have a nonzero coordinate, are stored.
bool lane_used(const TrianglePack& pack, int lane) {
    for (int k = 0; k < 3; ++k)
        for (int axis = 0; axis < 3; ++axis)
            if (pack.vertex[k][axis][lane] != 0.0f) return true;
    return false;
}

}  // namespace

template <int W>
bool refit_wide(WideLayout<W>& layout, std::span<const Triangle> triangles, const Bvh& bvh) {
    if (layout.source.size() != layout.nodes.size() * W) return false;
    // Exactly the triangles that are not degenerate now must be in the packs. Each pass below writes
    // disjoint slots (a pack, a node, a flag set to 1 by whoever sees it), so the result is the same
    // for any thread count; a layout that fails the check is discarded by the caller, so the packs
    // written before the failure is known do not matter.
    std::vector<uint8_t> stored(triangles.size(), 0);
    std::atomic<bool> changed = false;
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, layout.packs.size(), 2048), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t p = r.begin(); p != r.end() && !changed.load(std::memory_order_relaxed); ++p) {
                TrianglePack& pack = layout.packs[p];
                for (int lane = 0; lane < 4; ++lane) {
                    if (!lane_used(pack, lane)) continue;
                    const Triangle& t = triangles[pack.primitive[lane]];
                    if (t.is_degenerate()) changed.store(true, std::memory_order_relaxed);
                    std::atomic_ref<uint8_t>(stored[pack.primitive[lane]]).store(1, std::memory_order_relaxed);
                    const Vec3* vertices[3] = {&t.v0, &t.v1, &t.v2};
                    for (int k = 0; k < 3; ++k)
                        for (int axis = 0; axis < 3; ++axis) pack.vertex[k][axis][lane] = (*vertices[k])[axis];
                }
            }
        });
    if (changed) return false;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, bvh.primitives.size(), 1 << 14),
                      [&](const tbb::blocked_range<size_t>& r) {
                          bool missing = false;
                          for (size_t k = r.begin(); k != r.end(); ++k) {
                              const uint32_t primitive = bvh.primitives[k];
                              missing |= !stored[primitive] && !triangles[primitive].is_degenerate();
                          }
                          if (missing) changed.store(true, std::memory_order_relaxed);
                      });
    if (changed) return false;
    if (!layout.planes.empty()) layout.planes = make_pack_planes(layout.packs);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, layout.nodes.size(), 1024),
                      [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t n = r.begin(); n != r.end(); ++n)
                              for (int slot = 0; slot < W; ++slot) {
                                  const uint32_t from = layout.source[n * W + slot];
                                  if (from == kInvalidIndex) continue;
                                  const AABB& box = bvh.nodes[from].bounds;
                                  for (int axis = 0; axis < 3; ++axis) {
                                      layout.nodes[n].planes[2 * axis][slot] = box.lo[axis];
                                      layout.nodes[n].planes[2 * axis + 1][slot] = box.hi[axis];
                                  }
                              }
                      });
    return true;
}

template bool refit_wide<4>(WideLayout<4>&, std::span<const Triangle>, const Bvh&);
template bool refit_wide<8>(WideLayout<8>&, std::span<const Triangle>, const Bvh&);

}  // namespace spacebvh::trace
