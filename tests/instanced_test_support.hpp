// SPDX-License-Identifier: MIT
// Helpers of the instanced-scene tests (tools::InstancedScene): its placements as the RenderScene
// tests describe them (scene_test_support.hpp), and every ray's answer from make_render_scene checked
// against the exact arbiter per placement and on the flattened scene.
#pragma once

#include <sstream>
#include <string>
#include <vector>

#include "scene_test_support.hpp"
#include "spacebvh/tools/instanced_scene.hpp"
#include "spacebvh/tools/rays.hpp"

namespace spacebvh::scene_testing {

// One level: instance k of the top scene places mesh m by its transform; in the RenderScene that
// make_render_scene builds, it is instance id k of a scene whose mesh is geometry 0.
inline std::vector<Placement> placements_of(const tools::InstancedScene& scene) {
    std::vector<Placement> out;
    for (size_t k = 0; k < scene.instances.size(); ++k) {
        const tools::SceneInstance& instance = scene.instances[k];
        Placement p;
        p.forward.push_back(instance.transform);
        p.inverse.push_back(
            scene::make_instance_transform(instance.transform, AABB{Vec3(0.0f), Vec3(1.0f)}, {}, "test"));
        p.masks = {instance.mask, 0xFFFFFFFFu};
        p.path[0] = uint32_t(k);
        p.geometry = 0;
        p.triangles = &scene.meshes[instance.mesh].triangles;
        out.push_back(std::move(p));
    }
    return out;
}

// The placements whose world box (the mesh box's corners placed, padded by 10^-4 of the box and of
// the ray's origin) the ray meets: the references below only need those, which keeps brute force
// over scenes of many large meshes affordable.
inline std::vector<Placement> near_ray(const std::vector<Placement>& all, const Ray& ray) {
    std::vector<Placement> out;
    for (const Placement& p : all) {
        const AABB local = bounds_of(*p.triangles);
        AABB box;
        for (int c = 0; c < 8; ++c)
            box.extend(p.world(Triangle{Vec3{(c & 1) ? local.hi.x : local.lo.x, (c & 2) ? local.hi.y : local.lo.y,
                                             (c & 4) ? local.hi.z : local.lo.z},
                                        {},
                                        {}})
                           .v0);
        const double pad = 1e-4 * (length(box.extent()) + length(ray.org));
        double near = ray.tmin, far = ray.tmax;
        for (int a = 0; a < 3 && near <= far; ++a) {
            const double lo = box.lo[a] - pad - double(ray.org[a]), hi = box.hi[a] + pad - double(ray.org[a]);
            if (ray.dir[a] == 0.0f) {
                if (lo > 0 || hi < 0) near = INFINITY;
                continue;
            }
            const double t0 = lo / ray.dir[a], t1 = hi / ray.dir[a];
            near = std::max(near, std::min(t0, t1));
            far = std::min(far, std::max(t0, t1));
        }
        if (near <= far) out.push_back(p);
    }
    return out;
}

struct Check {
    size_t rays = 0, hits = 0, wrong = 0, misnamed = 0, flat_disagree = 0;
    std::string first;  // the first few failures
};

// Closest hits and occlusion of `rays` with `mask` on `render` against both references.
inline Check check_against_arbiter(const RenderScene& render, const tools::InstancedScene& scene,
                                   std::span<const Ray> rays, uint32_t mask = 0xFFFFFFFFu) {
    const std::vector<Placement> every = placements_of(scene);
    const float diagonal = length(render.bounds().extent());
    std::vector<SceneHit> hits(rays.size());
    std::vector<uint8_t> blocked(rays.size());
    TraceContext context;
    context.mask = mask;
    render.intersect(rays, hits, context);
    render.occluded(rays, blocked, context);
    Check check;
    std::ostringstream text;
    for (size_t i = 0; i < rays.size(); ++i) {
        const std::vector<Placement> all = near_ray(every, rays[i]);
        const Reference truth = closest_in_instances(all, rays[i], mask);
        ++check.rays;
        check.hits += hits[i].is_hit();
        if (!tools::hits_agree(record_of(hits[i]), record_of(truth), rays[i], diagonal) ||
            bool(blocked[i]) != truth.is_hit()) {
            if (check.wrong++ < 3) text << "ray " << i << ": t " << hits[i].t << " vs " << truth.t << "; ";
        }
        if (hits[i].is_hit()) {
            const std::string why = not_a_crossing(all, hits[i], rays[i], diagonal);
            if (!why.empty() && check.misnamed++ < 3) text << "ray " << i << ": " << why << "; ";
        }
        const Reference flat_truth = closest_flattened(all, flatten(all), rays[i], mask);
        check.flat_disagree += !tools::hits_agree(record_of(hits[i]), record_of(flat_truth), rays[i], diagonal);
    }
    check.first = text.str();
    return check;
}

}  // namespace spacebvh::scene_testing
