// SPDX-License-Identifier: MIT
// Refit of a wide layout in place (wide_layout.hpp): the same nodes and packs, boxes and vertices read
// again from the refitted binary tree and the moved triangles.
#include <algorithm>
#include <atomic>
#include <bit>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "builders/refit_walk.hpp"
#include "trace/layout/wide_layout.hpp"

namespace spacebvh::trace {

namespace {

constexpr size_t kPrefetchPacks = 4;

// A lane holds a triangle unless all its coordinates are zero: packs start zeroed and only
// non-degenerate triangles, which have a nonzero coordinate, are stored.
bool lane_used(const TrianglePack& pack, int lane) {
    for (int k = 0; k < 3; ++k)
        for (int axis = 0; axis < 3; ++axis)
            if (pack.vertex[k][axis][lane] != 0.0f) return true;
    return false;
}

// Whether the packs hold exactly the triangles of the tree that are not degenerate now (layouts store
// exactly those): none stored became degenerate, and none of the tree's became non-degenerate. Reads only.
bool same_live_triangles(const TrianglePacks& packs, std::span<const Triangle> triangles, const Bvh& bvh) {
    // Each pass writes disjoint slots (a flag set to 1 by whoever sees it), so the answer is the same for
    // any thread count.
    std::vector<uint8_t> stored(triangles.size(), 0);
    std::atomic<bool> changed = false;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, packs.size(), 2048), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t p = r.begin(); p != r.end() && !changed.load(std::memory_order_relaxed); ++p)
            for (int lane = 0; lane < 4; ++lane) {
                if (!lane_used(packs[p], lane)) continue;
                const uint32_t primitive = packs[p].primitive[lane];
                if (triangles[primitive].is_degenerate()) changed.store(true, std::memory_order_relaxed);
                std::atomic_ref<uint8_t>(stored[primitive]).store(1, std::memory_order_relaxed);
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
    return !changed;
}

void put_lane(TrianglePack& pack, int lane, const Triangle& t) {
    const Vec3* vertices[3] = {&t.v0, &t.v1, &t.v2};
    for (int k = 0; k < 3; ++k)
        for (int axis = 0; axis < 3; ++axis) pack.vertex[k][axis][lane] = (*vertices[k])[axis];
}

// Whether every coordinate is finite (its exponent bits not all set).
bool is_finite(const Triangle& t) {
    uint32_t bad = 0;
    for (const Vec3* p : {&t.v0, &t.v1, &t.v2})
        for (int axis = 0; axis < 3; ++axis) bad |= (std::bit_cast<uint32_t>((*p)[axis]) & 0x7F800000u) == 0x7F800000u;
    return !bad;
}

// Which reference of the tree rewrites each used pack lane (WideLayout::lanes): the lanes of a triangle
// go to distinct references of it, in order. Empty when a lane's triangle has no reference left (a
// layout the tree did not make): then refit rewrites the packs in a pass of their own. `cover_all`:
// whether every triangle has a reference.
std::vector<uint32_t> make_lane_map(const TrianglePacks& packs, const Bvh& bvh, size_t triangle_count,
                                    bool& cover_all) {
    // The references of each triangle, grouped by triangle (counting sort): refs[start[q] .. start[q + 1]).
    std::vector<uint32_t> start(triangle_count + 1, 0), refs(bvh.primitives.size());
    for (const uint32_t q : bvh.primitives) ++start[q + 1];
    cover_all = true;
    for (size_t q = 0; q < triangle_count; ++q) {
        cover_all &= start[q + 1] > 0;
        start[q + 1] += start[q];
    }
    std::vector<uint32_t> next(start.begin(), start.end() - 1);
    for (uint32_t k = 0; k < bvh.primitives.size(); ++k) refs[next[bvh.primitives[k]]++] = k;
    std::vector<uint32_t> lanes(bvh.primitives.size(), kInvalidIndex);
    std::copy(start.begin(), start.end() - 1, next.begin());
    for (size_t p = 0; p < packs.size(); ++p)
        for (int lane = 0; lane < 4; ++lane) {
            if (!lane_used(packs[p], lane)) continue;
            const uint32_t q = packs[p].primitive[lane];
            if (q >= triangle_count || next[q] == start[q + 1]) return {};
            lanes[refs[next[q]++]] = uint32_t(4 * p + lane);
        }
    return lanes;
}

// Every slot's box read again from the binary node it was made from, and the moller planes (when the
// layout has them) from the packs.
template <int W>
void refit_nodes(WideLayout<W>& layout, const Bvh& bvh) {
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
}

}  // namespace

template <int W>
bool refit_wide(WideLayout<W>& layout, std::span<const Triangle> triangles, const Bvh& bvh, bool same_degenerate) {
    if (layout.source.size() != layout.nodes.size() * W) return false;
    if (!same_degenerate && !same_live_triangles(layout.packs, triangles, bvh)) return false;
    // Each pass writes disjoint slots (a pack, a node), so the result is the same for any thread count.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, layout.packs.size(), 2048),
                      [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t p = r.begin(); p != r.end(); ++p) {
                              // The packs' triangles are scattered over the mesh: ask for those a few packs ahead.
                              if (p + kPrefetchPacks < r.end())
                                  for (const uint32_t primitive : layout.packs[p + kPrefetchPacks].primitive)
                                      __builtin_prefetch(&triangles[primitive]);
                              TrianglePack& pack = layout.packs[p];
                              for (int lane = 0; lane < 4; ++lane)
                                  if (lane_used(pack, lane)) put_lane(pack, lane, triangles[pack.primitive[lane]]);
                          }
                      });
    refit_nodes(layout, bvh);
    return true;
}

template <int W>
TreeRefit refit_tree_and_wide(WideLayout<W>& layout, std::span<const Triangle> triangles, Bvh& bvh,
                              std::span<const Triangle> restore) {
    if (layout.source.size() != layout.nodes.size() * W) return TreeRefit::unsupported;
    if (!layout.lanes_tried) {
        layout.lanes = make_lane_map(layout.packs, bvh, triangles.size(), layout.lanes_cover_all);
        layout.lanes_tried = true;
    }
    const bool check = !restore.empty();
    if (check && (layout.lanes.empty() || !layout.lanes_cover_all)) return TreeRefit::unsupported;
    if (layout.lanes.empty()) {  // no owner for some lane: the tree, then the packs on their own
        builders::refit_walk(bvh, triangles, [](uint32_t, const Triangle&) {});
        refit_wide(layout, triangles, bvh, true);
        return TreeRefit::done;
    }
    // Each lane has one owning reference and each reference is walked by one task, so the writes are
    // disjoint and the packs, like the boxes, are the same for any thread count.
    std::atomic<bool> finite = true;
    const auto walk = [&](std::span<const Triangle> from, bool check_finite) {
        builders::refit_walk(bvh, from, [&](uint32_t reference, const Triangle& t) {
            if (check_finite && !is_finite(t)) finite.store(false, std::memory_order_relaxed);
            const uint32_t slot = layout.lanes[reference];
            if (slot != kInvalidIndex) put_lane(layout.packs[slot / 4], int(slot % 4), t);
        });
    };
    walk(triangles, check);
    if (!finite) {  // every triangle is referenced, so the walk saw the bad one: put the old ones back
        walk(restore, false);
        return TreeRefit::not_finite;
    }
    refit_nodes(layout, bvh);
    return TreeRefit::done;
}

template bool refit_wide<4>(WideLayout<4>&, std::span<const Triangle>, const Bvh&, bool);
template bool refit_wide<8>(WideLayout<8>&, std::span<const Triangle>, const Bvh&, bool);
template TreeRefit refit_tree_and_wide<4>(WideLayout<4>&, std::span<const Triangle>, Bvh&, std::span<const Triangle>);
template TreeRefit refit_tree_and_wide<8>(WideLayout<8>&, std::span<const Triangle>, Bvh&, std::span<const Triangle>);

}  // namespace spacebvh::trace
