// SPDX-License-Identifier: MIT
// Refit of a wide layout in place (wide_layout.hpp): the same nodes and packs, boxes and vertices read
// again from the refitted binary tree and the moved triangles.
#include <algorithm>

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
    // Exactly the triangles that are not degenerate now must be in the packs.
    std::vector<uint8_t> stored(triangles.size(), 0);
    for (const TrianglePack& pack : layout.packs)
        for (int lane = 0; lane < 4; ++lane) {
            if (!lane_used(pack, lane)) continue;
            if (triangles[pack.primitive[lane]].is_degenerate()) return false;
            stored[pack.primitive[lane]] = 1;
        }
    for (const uint32_t primitive : bvh.primitives)
        if (!stored[primitive] && !triangles[primitive].is_degenerate()) return false;
    for (TrianglePack& pack : layout.packs)
        for (int lane = 0; lane < 4; ++lane) {
            if (!lane_used(pack, lane)) continue;
            const Triangle& t = triangles[pack.primitive[lane]];
            const Vec3* vertices[3] = {&t.v0, &t.v1, &t.v2};
            for (int k = 0; k < 3; ++k)
                for (int axis = 0; axis < 3; ++axis) pack.vertex[k][axis][lane] = (*vertices[k])[axis];
        }
    if (!layout.planes.empty()) layout.planes = make_pack_planes(layout.packs);
    for (size_t n = 0; n < layout.nodes.size(); ++n)
        for (int slot = 0; slot < W; ++slot) {
            const uint32_t from = layout.source[n * W + slot];
            if (from == kInvalidIndex) continue;
            const AABB& box = bvh.nodes[from].bounds;
            for (int axis = 0; axis < 3; ++axis) {
                layout.nodes[n].planes[2 * axis][slot] = box.lo[axis];
                layout.nodes[n].planes[2 * axis + 1][slot] = box.hi[axis];
            }
        }
    return true;
}

template bool refit_wide<4>(WideLayout<4>&, std::span<const Triangle>, const Bvh&);
template bool refit_wide<8>(WideLayout<8>&, std::span<const Triangle>, const Bvh&);

}  // namespace spacebvh::trace
