// SPDX-License-Identifier: MIT
// A scene's top level: a binary tree over its geometries' boxes with the largest padding of those
// boxes (instance_transform.hpp), and the walk query that tests the boxes conservatively in float. The
// same query walks a mesh's own binary tree (no padding) for filtered queries.
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "spacebvh/bvh.hpp"
#include "spacebvh/geometry.hpp"
#include "trace/scene/instance_transform.hpp"
#include "trace/traversal/walk.hpp"

namespace spacebvh::scene {

struct TopLevelItem {
    AABB box;  // in the scene's space
    Padding padding;
};

struct TopLevel {
    Bvh bvh;              // primitives are item indices; one item per leaf
    Padding padding;      // the largest of the items'
    double extent = 0.0;  // extent_of(the root's box)
};

// The binned SAH tree over the items' boxes, one item per leaf and at most 64 levels, the same for any
// thread count (top_level_build.cpp); or refitted to their current boxes.
TopLevel build_top_level(std::span<const TopLevelItem> items);
// Its scratch per item: the items' boxes twice (32 bytes each: in place and the partition's copy) and
// a byte of the chunked partition's sides.
inline constexpr uint64_t kTopLevelBuildBytesPerItem = 2 * 32 + 1;
// Those flat triangles, one per item (a scene file's top level is stored as a tree over them).
std::vector<Triangle> top_level_triangles(std::span<const TopLevelItem> items);
void refit_top_level(TopLevel& top, std::span<const TopLevelItem> items);
// Sets the padding and extent of `top` from its root box and the items.
void measure_top_level(TopLevel& top, std::span<const TopLevelItem> items);

// The ray as the box tests of one walk need it. Every box is grown by one allowance `grow`: the
// tree's largest padding for this ray's origin, plus 2^-20 of the largest coordinate of the tree's
// boxes and of the origin. The float slab test below errs by at most about 4 ulps of those
// magnitudes (the rounding of org +- grow, of the difference and of the product), far below that
// 2^-20, so it never culls a box the ray truly meets within the padding.
struct BoxRay {
    float lo_org[3], hi_org[3];  // org + grow (tested against lower planes), org - grow (upper)
    float inv[3];
    bool parallel[3];  // the direction's component is 0, or its inverse is not finite
    float tmin;
    double org_norm;

    BoxRay(const Ray& ray, Padding padding, double extent) : tmin(ray.tmin) {
        org_norm = std::max({std::fabs(double(ray.org.x)), std::fabs(double(ray.org.y)), std::fabs(double(ray.org.z))});
        const double grow = padding.pad0 + padding.pad1 * org_norm + 0x1p-20 * (extent + org_norm);
        for (int i = 0; i < 3; ++i) {
            inv[i] = 1.0f / ray.dir[i];
            parallel[i] = !std::isfinite(inv[i]);
            lo_org[i] = float(double(ray.org[i]) + grow);
            hi_org[i] = float(double(ray.org[i]) - grow);
            // A direction too small to invert still moves along the axis: no test on that axis.
            if (parallel[i] && ray.dir[i] != 0.0f) lo_org[i] = kInfinity, hi_org[i] = -kInfinity;
        }
    }
};

// Whether the ray meets `box` (grown as BoxRay says) within [tmin, tmax], and where it enters.
[[gnu::always_inline]] inline bool meets(const BoxRay& r, const AABB& box, float tmax, float& entry) {
    float near = r.tmin, far = tmax;
    for (int i = 0; i < 3; ++i) {
        if (r.parallel[i]) {
            if (box.lo[i] > r.lo_org[i] || box.hi[i] < r.hi_org[i]) return false;
            continue;
        }
        const float t0 = (box.lo[i] - r.lo_org[i]) * r.inv[i], t1 = (box.hi[i] - r.hi_org[i]) * r.inv[i];
        near = std::max(near, std::min(t0, t1));
        far = std::min(far, std::max(t0, t1));
    }
    entry = near;
    return near <= far;
}

// The largest coordinate of a box, for BoxRay.
inline double extent_of(const AABB& box) {
    double m = 0.0;
    for (int i = 0; i < 3; ++i) m = std::max({m, std::fabs(double(box.lo[i])), std::fabs(double(box.hi[i]))});
    return m;
}

// The walk query (trace/traversal/walk.hpp) over a binary tree with padded boxes, nearest first.
struct PaddedQuery {
    struct Entry {
        uint32_t node;
        float key;
    };
    using Bound = float;
    static constexpr int kStackCapacity = 2 * 1024 + 4;  // depth limit 1024 (LimitConfig), one push per level

    const Bvh& bvh;
    BoxRay ray;

    Entry root() const { return {0, float(ray.tmin)}; }
    bool is_leaf(const Entry& e) const { return bvh.nodes[e.node].is_leaf(); }
    bool beyond(const Entry& e, Bound bound) const { return e.key > bound; }
    int enter(Entry& node, Bound bound, Entry* out) const {
        const uint32_t first = bvh.nodes[node.node].first;
        float key[2];
        unsigned entered = 0;
        for (unsigned c = 0; c < 2; ++c)
            if (meets(ray, bvh.nodes[first + c].bounds, bound, key[c])) entered |= 1u << c;
        if (!entered) return 0;
        return trace::nearest_first(entered, key, node, out, [&](int slot) { return Entry{first + slot, key[slot]}; });
    }
};

}  // namespace spacebvh::scene
