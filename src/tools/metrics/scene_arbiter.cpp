// SPDX-License-Identifier: MIT
// The exact arbiter of an instanced scene (scene_arbiter.hpp).
#include "spacebvh/tools/scene_arbiter.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <string>

#include "core/exact_triangle.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/tools/instanced_scene.hpp"
#include "trace/scene/instance_transform.hpp"

namespace spacebvh::tools {

namespace {

struct Box64 {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    void grow(const double p[3]) {
        for (int i = 0; i < 3; ++i) {
            lo[i] = std::min(lo[i], p[i]);
            hi[i] = std::max(hi[i], p[i]);
        }
    }
    double largest_coordinate() const {
        double m = 0.0;
        for (int i = 0; i < 3; ++i) m = std::max({m, std::abs(lo[i]), std::abs(hi[i])});
        return m;
    }
};

// The box of the affine image of `box` (its eight corners mapped in double).
Box64 mapped(const Affine& a, const Box64& box) {
    Box64 out;
    for (int corner = 0; corner < 8; ++corner) {
        const double p[3] = {corner & 1 ? box.hi[0] : box.lo[0], corner & 2 ? box.hi[1] : box.lo[1],
                             corner & 4 ? box.hi[2] : box.lo[2]};
        double q[3];
        for (int i = 0; i < 3; ++i)
            q[i] = double(a.m[4 * i]) * p[0] + double(a.m[4 * i + 1]) * p[1] + double(a.m[4 * i + 2]) * p[2] +
                   double(a.m[4 * i + 3]);
        out.grow(q);
    }
    return out;
}

// ||A||_inf * ||A^-1||_inf of the linear part, in double (the adjugate over the determinant).
double condition_number(const Affine& a) {
    const auto m = [&](int r, int c) { return double(a.m[4 * r + c]); };
    const double cof[3][3] = {{m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1), m(0, 2) * m(2, 1) - m(0, 1) * m(2, 2),
                               m(0, 1) * m(1, 2) - m(0, 2) * m(1, 1)},
                              {m(1, 2) * m(2, 0) - m(1, 0) * m(2, 2), m(0, 0) * m(2, 2) - m(0, 2) * m(2, 0),
                               m(0, 2) * m(1, 0) - m(0, 0) * m(1, 2)},
                              {m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0), m(0, 1) * m(2, 0) - m(0, 0) * m(2, 1),
                               m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0)}};
    const double det = m(0, 0) * cof[0][0] + m(0, 1) * cof[1][0] + m(0, 2) * cof[2][0];
    double norm = 0.0, inverse_norm = 0.0;
    for (int r = 0; r < 3; ++r) {
        norm = std::max(norm, std::abs(m(r, 0)) + std::abs(m(r, 1)) + std::abs(m(r, 2)));
        inverse_norm =
            std::max(inverse_norm, (std::abs(cof[r][0]) + std::abs(cof[r][1]) + std::abs(cof[r][2])) / std::abs(det));
    }
    return norm * inverse_norm;
}

// A world-box allowance far above what the ray transforms round: the hit a placement reports for a
// world ray lies within about 4 * 2^-23 * cond * (|org| + reach) of its exact world box (scenes.md,
// "Boxes of instances"); 1e-4 * cond * (|org| + reach) is some 400 times that.
constexpr double kWorldPadding = 1e-4;

// Walks `level` (reached by `prefix`), appending its meshes to `out` once per scene object.
void collect_placements(const InstancedScene& level, const MeshPlacement& prefix, size_t depth,
                        std::map<const InstancedScene*, uint32_t>& first_mesh, ScenePlacements& out) {
    auto [found, added] = first_mesh.emplace(&level, uint32_t(out.meshes.size()));
    if (added) out.meshes.insert(out.meshes.end(), level.meshes.begin(), level.meshes.end());
    const uint32_t offset = found->second;
    if (depth >= kMaxInstanceLevels) throw Error("scene '" + level.name + "': nested deeper than the scenes allow");
    for (size_t k = 0; k < level.instances.size(); ++k) {
        const SceneInstance& instance = level.instances[k];
        MeshPlacement p = prefix;
        p.transforms.push_back(instance.transform);
        p.path[depth] = uint32_t(k);
        p.masks.push_back(instance.mask);
        if (instance.scene) {
            collect_placements(*instance.scene, p, depth + 1, first_mesh, out);
            continue;
        }
        p.mesh = offset + instance.mesh;
        p.geometry = 0;
        p.masks.push_back(0xFFFFFFFFu);  // the mesh's own, in its scene of its own
        out.placements.push_back(std::move(p));
    }
}

}  // namespace

ScenePlacements mesh_placements_of(const InstancedScene& scene) {
    ScenePlacements out;
    std::map<const InstancedScene*, uint32_t> first_mesh;
    out.placements.reserve(scene.instances.size());
    collect_placements(scene, MeshPlacement{}, 0, first_mesh, out);
    return out;
}

struct SceneArbiter::Impl {
    std::span<const Scene> meshes;
    std::vector<MeshPlacement> placements;
    std::vector<scene::InstanceTransform> inverse;  // every placement's levels, top first
    std::vector<size_t> first_level;                // placement p: inverse[first_level[p] .. first_level[p+1])
    std::vector<Box64> world;                       // each placement's world box
    std::vector<double> pad_scale, reach;           // its allowance: pad_scale * (|org|_inf + reach)
    AABB bounds;

    bool meets(size_t p, const Ray& ray) const {
        const double o[3] = {ray.org.x, ray.org.y, ray.org.z}, d[3] = {ray.dir.x, ray.dir.y, ray.dir.z};
        const double pad = pad_scale[p] * (std::max({std::abs(o[0]), std::abs(o[1]), std::abs(o[2])}) + reach[p]);
        double t0 = ray.tmin, t1 = ray.tmax;
        for (int i = 0; i < 3; ++i) {
            const double lo = world[p].lo[i] - pad, hi = world[p].hi[i] + pad;
            if (d[i] == 0.0) {
                if (o[i] < lo || o[i] > hi) return false;
                continue;
            }
            double a = (lo - o[i]) / d[i], b = (hi - o[i]) / d[i];
            if (a > b) std::swap(a, b);
            t0 = std::max(t0, a);
            t1 = std::min(t1, b);
        }
        return t0 <= t1 * (1.0 + 1e-12) + 1e-300;
    }
    // The ray in placement p's space; none where a level overflows float (no hit there, docs/scenes.md).
    std::optional<Ray> local(size_t p, const Ray& ray) const {
        Ray r = ray;
        for (size_t level = first_level[p]; level < first_level[p + 1]; ++level) {
            r = scene::to_instance(inverse[level], r);
            if (!scene::is_finite_ray(r)) return std::nullopt;
        }
        return r;
    }
};

SceneArbiter::SceneArbiter(std::span<const Scene> meshes, std::vector<MeshPlacement> placements)
    : impl_(std::make_unique<Impl>()) {
    Impl& s = *impl_;
    s.meshes = meshes;
    s.placements = std::move(placements);
    std::vector<Box64> mesh_boxes(meshes.size());
    for (size_t m = 0; m < meshes.size(); ++m)
        for (const Triangle& tri : meshes[m].triangles)
            for (int k = 0; k < 3; ++k) {
                const Vec3 v = tri.vertex(k);
                const double p[3] = {v.x, v.y, v.z};
                mesh_boxes[m].grow(p);
            }
    s.first_level.push_back(0);
    Box64 all;
    for (size_t p = 0; p < s.placements.size(); ++p) {
        const MeshPlacement& placement = s.placements[p];
        if (placement.mesh >= meshes.size())
            throw Error("scene arbiter: placement " + std::to_string(p) + " names mesh " +
                        std::to_string(placement.mesh) + " of " + std::to_string(meshes.size()));
        const Box64& local = mesh_boxes[placement.mesh];
        Box64 box = local;
        double cond = 1.0, reach = 0.0;
        for (size_t level = placement.transforms.size(); level-- > 0;) {
            const Affine& a = placement.transforms[level];
            box = box.lo[0] <= box.hi[0] ? mapped(a, box) : box;
            cond *= condition_number(a);
            reach += std::max({std::abs(a.m[3]), std::abs(a.m[7]), std::abs(a.m[11])});
        }
        for (const Affine& a : placement.transforms)
            s.inverse.push_back(scene::make_instance_transform(a, AABB{Vec3(0.0f), Vec3(1.0f)}, {},
                                                               "scene arbiter: placement " + std::to_string(p)));
        s.first_level.push_back(s.inverse.size());
        s.world.push_back(box);
        s.pad_scale.push_back(kWorldPadding * cond);
        // The translations are bounded here by their own sizes; a nested level's shift is scaled by the
        // levels above it, which the condition numbers' product (>= each level's norm ratio) covers.
        s.reach.push_back(reach * cond + box.largest_coordinate());
        if (box.lo[0] <= box.hi[0]) {
            all.grow(box.lo);
            all.grow(box.hi);
        }
    }
    if (all.lo[0] <= all.hi[0])
        s.bounds = AABB{Vec3(float(all.lo[0]), float(all.lo[1]), float(all.lo[2])),
                        Vec3(float(all.hi[0]), float(all.hi[1]), float(all.hi[2]))};
}

SceneArbiter::~SceneArbiter() = default;
SceneArbiter::SceneArbiter(SceneArbiter&&) noexcept = default;
SceneArbiter& SceneArbiter::operator=(SceneArbiter&&) noexcept = default;

PlacedHit SceneArbiter::closest_hit(const Ray& ray, uint32_t mask) const {
    const Impl& s = *impl_;
    double best_t = std::numeric_limits<double>::infinity();
    PlacedHit best;
    for (size_t p = 0; p < s.placements.size(); ++p) {
        if (!s.placements[p].visible(mask) || !s.meets(p, ray)) continue;
        const std::optional<Ray> local = s.local(p, ray);
        if (!local) continue;
        const std::vector<Triangle>& triangles = s.meshes[s.placements[p].mesh].triangles;
        for (size_t i = 0; i < triangles.size(); ++i) {
            const std::optional<double> t = intersect_triangle_exact(*local, triangles[i]);
            if (t && *t < best_t) {  // strict: equal t keeps the lower placement and triangle
                best_t = *t;
                best = {{float(best_t), uint32_t(i)}, int64_t(p)};
            }
        }
    }
    return best;
}

bool SceneArbiter::occluded(const Ray& ray, uint32_t mask) const {
    const Impl& s = *impl_;
    for (size_t p = 0; p < s.placements.size(); ++p) {
        if (!s.placements[p].visible(mask) || !s.meets(p, ray)) continue;
        const std::optional<Ray> local = s.local(p, ray);
        if (!local) continue;
        for (const Triangle& tri : s.meshes[s.placements[p].mesh].triangles)
            if (intersect_triangle_exact(*local, tri)) return true;
    }
    return false;
}

float SceneArbiter::diagonal() const { return length(impl_->bounds.extent()); }
AABB SceneArbiter::bounds() const { return impl_->bounds; }
const std::vector<MeshPlacement>& SceneArbiter::placements() const { return impl_->placements; }

}  // namespace spacebvh::tools
