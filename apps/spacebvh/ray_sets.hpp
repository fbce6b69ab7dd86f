// SPDX-License-Identifier: MIT
// The three ray sets of docs/rays.md for one scene, made the same way by `rays` and `compare`.
#pragma once

#include <vector>

#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

struct RaySetParameters {
    size_t random_count = 1000000;
    uint64_t seed = 1;
    Camera camera;
    uint32_t width = 1024, height = 1024;
    float diffuse_epsilon = 0.0f;  // <= 0: the spec's default 1e-4 * |diagonal|
};

// Diffuse rays start where primary rays hit, so they need a tracer for the primary hits.
std::vector<Ray> make_ray_set(RayKind kind, const Scene& scene, const Tracer& tracer,
                              const RaySetParameters& parameters);

}  // namespace spacebvh::cli
