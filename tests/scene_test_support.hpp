// SPDX-License-Identifier: MIT
// Helpers of the RenderScene tests: a scene described level by level beside the RenderScene it
// builds, its placements (each mesh under each instance path), and two independent references per
// ray: the exact arbiter on each placement's triangles for the ray taken into the placement's space
// by the documented float transform, and the exact arbiter on the flattened scene (every placement's
// triangles taken into world space).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/exact_triangle.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/tools/verify.hpp"
#include "test_support.hpp"
#include "trace/scene/instance_transform.hpp"

namespace spacebvh::scene_testing {

// Expects f() to throw Error whose message holds `part`.
template <class F>
void expect_error(F&& f, const std::string& part) {
    try {
        f();
        ADD_FAILURE() << "no error; expected one mentioning '" << part << "'";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
}

// The first `count` triangles of the built-in organic mesh.
inline std::vector<Triangle> organic(size_t count) {
    std::vector<Triangle> t = testing_support::cached_builtin_scene("organic").triangles;
    t.resize(std::min(count, t.size()));
    return t;
}

struct Level;
struct MeshPart {
    uint32_t id, mask;
    const std::vector<Triangle>* triangles;
};
struct InstancePart {
    uint32_t id, mask;
    Affine transform;
    const Level* child;
};

// One scene as the test describes it, and the RenderScene made from the same calls.
struct Level {
    std::shared_ptr<RenderScene> scene;
    std::vector<MeshPart> meshes;
    std::vector<InstancePart> instances;

    explicit Level(SceneConfig config, std::string name = "scene")
        : scene(std::make_shared<RenderScene>(std::move(config), std::move(name))) {}
    uint32_t mesh(const std::vector<Triangle>& triangles, uint32_t mask = 0xFFFFFFFFu) {
        const uint32_t id = scene->attach_mesh(MeshView(triangles), mask);
        meshes.push_back({id, mask, &triangles});
        return id;
    }
    uint32_t instance(const Level& child, const Affine& transform, uint32_t mask = 0xFFFFFFFFu) {
        const uint32_t id = scene->attach_instance(child.scene, transform, mask);
        instances.push_back({id, mask, transform, &child});
        return id;
    }
};

struct Placement {
    std::vector<Affine> forward;                    // top level first
    std::vector<scene::InstanceTransform> inverse;  // the same, as tracing takes rays in
    std::vector<uint32_t> masks;                    // the instances' masks, then the mesh's
    std::array<uint32_t, kMaxInstanceLevels> path{kInvalidIndex, kInvalidIndex, kInvalidIndex, kInvalidIndex};
    uint32_t geometry = kInvalidIndex;
    const std::vector<Triangle>* triangles = nullptr;

    bool visible(uint32_t ray_mask) const {
        for (uint32_t m : masks)
            if (!(m & ray_mask)) return false;
        return true;
    }
    Ray local(const Ray& ray) const {
        Ray r = ray;
        for (const auto& xf : inverse) r = scene::to_instance(xf, r);
        return r;
    }
    Triangle world(const Triangle& tri) const {
        Triangle w = tri;
        for (size_t level = forward.size(); level-- > 0;)
            w = {forward[level].apply(w.v0), forward[level].apply(w.v1), forward[level].apply(w.v2)};
        return w;
    }
};

inline void collect(const Level& level, Placement prefix, std::vector<Placement>& out) {
    for (const MeshPart& mesh : level.meshes) {
        Placement p = prefix;
        p.masks.push_back(mesh.mask);
        p.geometry = mesh.id;
        p.triangles = mesh.triangles;
        out.push_back(std::move(p));
    }
    for (const InstancePart& inst : level.instances) {
        Placement p = prefix;
        p.path[p.forward.size()] = inst.id;
        p.forward.push_back(inst.transform);
        p.inverse.push_back(scene::make_instance_transform(inst.transform, AABB{Vec3(0.0f), Vec3(1.0f)}, {}, "test"));
        p.masks.push_back(inst.mask);
        collect(*inst.child, std::move(p), out);
    }
}
inline std::vector<Placement> placements(const Level& top) {
    std::vector<Placement> out;
    collect(top, Placement{}, out);
    return out;
}

using Accept = std::function<bool(const Placement&, uint32_t primitive)>;

struct Reference {
    double t = INFINITY;
    int placement = -1;
    uint32_t primitive = kInvalidIndex;
    bool is_hit() const { return placement >= 0; }
};

// The exact arbiter per placement, for the ray in the placement's space.
inline Reference closest_in_instances(const std::vector<Placement>& all, const Ray& ray, uint32_t mask,
                                      const Accept& accept = {}) {
    Reference best;
    for (size_t p = 0; p < all.size(); ++p) {
        if (!all[p].visible(mask)) continue;
        const Ray local = all[p].local(ray);
        for (uint32_t i = 0; i < all[p].triangles->size(); ++i) {
            if (accept && !accept(all[p], i)) continue;
            const auto t = intersect_triangle_exact(local, (*all[p].triangles)[i]);
            if (t && *t < best.t) best = {*t, int(p), i};
        }
    }
    return best;
}

// The exact arbiter on the flattened scene (the placements' triangles in world space).
struct Flattened {
    std::vector<Triangle> triangles;
    std::vector<std::pair<int, uint32_t>> origin;  // placement, primitive
};
inline Flattened flatten(const std::vector<Placement>& all) {
    Flattened flat;
    for (size_t p = 0; p < all.size(); ++p)
        for (uint32_t i = 0; i < all[p].triangles->size(); ++i) {
            flat.triangles.push_back(all[p].world((*all[p].triangles)[i]));
            flat.origin.emplace_back(int(p), i);
        }
    return flat;
}
inline Reference closest_flattened(const std::vector<Placement>& all, const Flattened& flat, const Ray& ray,
                                   uint32_t mask, const Accept& accept = {}) {
    Reference best;
    for (size_t k = 0; k < flat.triangles.size(); ++k) {
        const auto [p, i] = flat.origin[k];
        if (!all[p].visible(mask) || (accept && !accept(all[p], i))) continue;
        const auto t = intersect_triangle_exact(ray, flat.triangles[k]);
        if (t && *t < best.t) best = {*t, p, i};
    }
    return best;
}

inline tools::HitRecord record_of(const Reference& r) {
    return r.is_hit() ? tools::HitRecord{float(r.t), r.primitive} : tools::HitRecord{};
}
inline tools::HitRecord record_of(const SceneHit& h) {
    return h.is_hit() ? tools::HitRecord{h.t, h.primitive} : tools::HitRecord{};
}

// Why `hit` is not a crossing of the placement it names (path, geometry, primitive) at its t, or "".
inline std::string not_a_crossing(const std::vector<Placement>& all, const SceneHit& hit, const Ray& ray,
                                  float diagonal) {
    for (const Placement& p : all) {
        if (p.path != hit.instance || p.geometry != hit.geometry) continue;
        if (hit.primitive >= p.triangles->size()) return "primitive out of range";
        const auto t = intersect_triangle_exact(p.local(ray), (*p.triangles)[hit.primitive]);
        if (!t) return "the named triangle is not crossed";
        if (!tools::hits_agree({float(*t), hit.primitive}, record_of(hit), ray, diagonal)) return "t differs";
        return "";
    }
    return "no placement has that instance path and geometry";
}

}  // namespace spacebvh::scene_testing
