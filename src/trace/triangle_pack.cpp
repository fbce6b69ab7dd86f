#include "trace/triangle_pack.hpp"

namespace spacebvh::trace {

std::pair<uint32_t, uint32_t> append_leaf_packs(const Scene& scene, const Bvh& bvh, const BvhNode& leaf, TrianglePacks& packs) {
    const uint32_t first_pack = uint32_t(packs.size());
    uint32_t count = 0;
    for (uint32_t i = leaf.first; i < leaf.first + leaf.reference_count; ++i) {
        const uint32_t primitive = bvh.primitives[i];
        const Triangle& triangle = scene.triangles[primitive];
        if (triangle.is_degenerate()) continue;
        const int lane = int(count % 4);
        if (lane == 0) packs.push_back(TrianglePack{});
        TrianglePack& pack = packs.back();
        const Vec3* vertices[3] = {&triangle.v0, &triangle.v1, &triangle.v2};
        for (int k = 0; k < 3; ++k)
            for (int axis = 0; axis < 3; ++axis) pack.vertex[k][axis][lane] = (*vertices[k])[axis];
        pack.primitive[lane] = primitive;
        ++count;
    }
    return {count ? first_pack : 0, count};
}

}  // namespace spacebvh::trace
