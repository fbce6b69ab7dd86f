// SPDX-License-Identifier: MIT
// A scene's top level: a binary tree over its geometries' boxes, each with the padding of its box
// (instance_transform.hpp), and the walk query that tests those boxes conservatively in double. The
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
    Bvh bvh;                       // primitives are item indices
    std::vector<Padding> padding;  // per node: the largest of its items'
};

// The binned SAH tree over the items' boxes (built by build() over one flat triangle per box, whose
// bounds are the box exactly), or refitted to their current boxes.
TopLevel build_top_level(std::span<const TopLevelItem> items);
void refit_top_level(TopLevel& top, std::span<const TopLevelItem> items);
// A binary tree's boxes recomputed bottom-up from its leaves' triangles (nodes are in depth-first
// order, so children follow their parent).
void refit_boxes(Bvh& bvh, std::span<const Triangle> triangles);

// The ray as the box tests need it, in double.
struct BoxRay {
    double org[3], dir[3], inv[3];
    double tmin, org_norm;
    explicit BoxRay(const Ray& ray) : tmin(ray.tmin) {
        org_norm = 0.0;
        for (int i = 0; i < 3; ++i) {
            org[i] = ray.org[i];
            dir[i] = ray.dir[i];
            inv[i] = 1.0 / dir[i];
            org_norm = std::max(org_norm, std::fabs(org[i]));
        }
    }
};

// Whether the ray meets `box` grown by `pad` within [tmin, tmax], and where it enters. The box is also
// grown by 2^-30 of its largest coordinate and the origin's: far above the double rounding of the
// slab distances (about 2^-52 of the same), so no box the ray truly meets is culled.
inline bool meets(const BoxRay& r, const AABB& box, double pad, double tmax, float& entry) {
    const double m = std::max({std::fabs(double(box.lo.x)), std::fabs(double(box.lo.y)), std::fabs(double(box.lo.z)),
                               std::fabs(double(box.hi.x)), std::fabs(double(box.hi.y)), std::fabs(double(box.hi.z))});
    const double grow = pad + 0x1p-30 * (m + r.org_norm);
    double near = r.tmin, far = tmax;
    for (int i = 0; i < 3; ++i) {
        const double lo = double(box.lo[i]) - grow, hi = double(box.hi[i]) + grow;
        if (r.dir[i] == 0.0) {
            if (r.org[i] < lo || r.org[i] > hi) return false;
            continue;
        }
        double t0 = (lo - r.org[i]) * r.inv[i], t1 = (hi - r.org[i]) * r.inv[i];
        if (t0 > t1) std::swap(t0, t1);
        near = std::max(near, t0);
        far = std::min(far, t1);
    }
    if (!(near <= far)) return false;
    entry = float(near);
    return true;
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
    const Padding* padding;  // per node, or null for none
    BoxRay ray;

    Entry root() const { return {0, float(ray.tmin)}; }
    bool is_leaf(const Entry& e) const { return bvh.nodes[e.node].is_leaf(); }
    bool beyond(const Entry& e, Bound bound) const { return e.key > bound; }
    double pad_of(uint32_t node) const {
        return padding ? padding[node].pad0 + padding[node].pad1 * ray.org_norm : 0.0;
    }
    int enter(Entry& node, Bound bound, Entry* out) const {
        const uint32_t first = bvh.nodes[node.node].first;
        float key[2];
        unsigned entered = 0;
        for (unsigned c = 0; c < 2; ++c)
            if (meets(ray, bvh.nodes[first + c].bounds, pad_of(first + c), bound, key[c])) entered |= 1u << c;
        if (!entered) return 0;
        return trace::nearest_first(entered, key, node, out, [&](int slot) { return Entry{first + slot, key[slot]}; });
    }
};

}  // namespace spacebvh::scene
