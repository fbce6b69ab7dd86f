// SPDX-License-Identifier: MIT
// Refit: a tree's boxes recomputed bottom-up for moved triangles (spacebvh/build.hpp).
#include <string>

#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh {

void refit_boxes(Bvh& bvh, std::span<const Triangle> triangles) {
    for (const uint32_t primitive : bvh.primitives)
        if (primitive >= triangles.size())
            throw Error("refit: the tree names triangle " + std::to_string(primitive) + " of only " +
                        std::to_string(triangles.size()));
    // Children follow their parent, so walking the nodes backwards meets every child before its parent.
    for (size_t n = bvh.nodes.size(); n-- > 0;) {
        BvhNode& node = bvh.nodes[n];
        AABB box;
        if (node.is_leaf()) {
            for (uint32_t k = 0; k < node.reference_count; ++k)
                box.extend(triangles[bvh.primitives[node.first + k]].bounds());
        } else {
            box = merge(bvh.nodes[node.first].bounds, bvh.nodes[node.first + 1].bounds);
        }
        node.bounds = box;
    }
}

}  // namespace spacebvh
