// SPDX-License-Identifier: MIT
// View-independent ray samples shaped like the benchmark's diffuse bounce rays (docs/rays.md
// "diffuse"), for predicting what a tree costs rays that stop at their first or any hit without a
// camera. Both use the spec's cosine bounce (generate_diffuse_rays) and its seeded splitmix64.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "spacebvh/tools/rays.hpp"

namespace spacebvh::tools {

enum class SampleKind {
    bounce,  // bounces off the closest hits of the spec's random rays (surfaces seen from free space)
    area,    // bounces off points picked uniformly by area on the triangles, either side at random
};
SampleKind parse_sample_kind(const std::string& text);  // throws Error
const char* to_string(SampleKind kind);

// `count` rays (fewer only when the scene has no surface to start from). `tracer` answers the
// random rays of `bounce` and must trace `scene`; `area` does not use it. epsilon <= 0 means the
// spec's default offset, 1e-4 * |scene diagonal|.
std::vector<Ray> generate_sample_rays(SampleKind kind, const Scene& scene, const Tracer& tracer, size_t count,
                                      uint64_t seed, float epsilon = 0.0f);

// TerminationConfig::segments: `count` bounce rays (seeded), each ending at its closest hit under
// `tracer` (a quick tree of `scene` will do: only the hit distances are read), free rays unbounded.
std::vector<Ray> termination_segments(const Scene& scene, const Tracer& tracer, size_t count, uint64_t seed);

}  // namespace spacebvh::tools
