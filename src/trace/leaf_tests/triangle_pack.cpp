// SPDX-License-Identifier: MIT
#include "trace/leaf_tests/triangle_pack.hpp"

#include <algorithm>

namespace spacebvh::trace {

void LeafPacker::put(uint32_t primitive) {
    if (open_lanes_ == 4) {
        packs_.push_back(TrianglePack{});
        open_lanes_ = 0;
    }
    TrianglePack& pack = packs_.back();
    const Triangle& triangle = triangles_[primitive];
    const Vec3* vertices[3] = {&triangle.v0, &triangle.v1, &triangle.v2};
    for (int k = 0; k < 3; ++k)
        for (int axis = 0; axis < 3; ++axis) pack.vertex[k][axis][open_lanes_] = (*vertices[k])[axis];
    pack.primitive[open_lanes_] = primitive;
    ++open_lanes_;
}

std::pair<uint32_t, uint32_t> LeafPacker::add(const BvhNode& leaf) {
    std::vector<uint32_t>& triangles = scratch_;
    triangles.clear();
    append_live_triangles(triangles_, bvh_, leaf, triangles);
    return add(std::span<const uint32_t>(triangles));
}

std::pair<uint32_t, uint32_t> LeafPacker::add(std::span<const uint32_t> triangles) {
    if (triangles.empty()) return {0, 0};

    if (open_lanes_ < 4) {
        const uint32_t* open_begin = packs_.back().primitive;
        const uint32_t* open_end = open_begin + open_lanes_;
        const auto stored = [&](uint32_t primitive) { return std::find(open_begin, open_end, primitive) != open_end; };
        const size_t fresh =
            size_t(std::count_if(triangles.begin(), triangles.end(), [&](uint32_t p) { return !stored(p); }));
        if (open_lanes_ + fresh <= 4) {
            const uint32_t pack = uint32_t(packs_.size() - 1);
            for (uint32_t primitive : triangles)
                if (!stored(primitive)) put(primitive);
            return {pack, open_lanes_};
        }
    }
    open_lanes_ = 4;  // start a new pack
    const uint32_t first = uint32_t(packs_.size());
    for (uint32_t primitive : triangles) put(primitive);
    return {first, uint32_t(triangles.size())};
}

}  // namespace spacebvh::trace
