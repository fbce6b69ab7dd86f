// SPDX-License-Identifier: MIT
#include "ray_sets.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

std::vector<Ray> make_ray_set(RayKind kind, const Scene& scene, const Tracer& tracer, const RaySetParameters& p) {
    switch (kind) {
        case RayKind::random:
            return generate_random_rays(scene.bounds(), p.random_count, p.seed);
        case RayKind::primary:
            return generate_primary_rays(p.camera, p.width, p.height);
        case RayKind::diffuse: {
            const std::vector<Ray> primary = generate_primary_rays(p.camera, p.width, p.height);
            std::vector<Hit> hits(primary.size());
            tracer.intersect(primary, hits);
            return generate_diffuse_rays(scene, primary, hits, p.seed, p.diffuse_epsilon);
        }
    }
    return {};
}

}  // namespace spacebvh::cli
