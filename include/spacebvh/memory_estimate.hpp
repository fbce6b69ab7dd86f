// SPDX-License-Identifier: MIT
// The memory a build needs, known before it starts: build() refuses a mesh whose estimate exceeds
// LimitConfig::memory_limit_bytes (by default the memory available) instead of running out of memory
// part way through, or making the machine swap.
#pragma once

#include <cstdint>
#include <string>

#include <span>

#include "spacebvh/build.hpp"
#include "spacebvh/scene.hpp"

namespace spacebvh {

struct MemoryEstimate {
    uint64_t bytes = 0;       // peak bytes build() allocates beyond the caller's mesh
    uint64_t references = 0;  // the most references the build may hold (the reference budget's capacity)
};

// The estimate for `triangle_count` triangles under `config`: the references (three copies when a
// search space reads centroid orders), the driver's node slots, the split search's scratch at the
// root, the tree and, for an indexed mesh, the triangle copy. On builtin:city:N from 10^6 to 5 x 10^7
// triangles the measured peak RSS is 0.90 to 1.00 of the scene's bytes plus this (bench/scale.sh
// prints both).
MemoryEstimate estimate_build_memory(uint64_t triangle_count, const BuildConfig& config, bool indexed_mesh = false);

// The memory a RenderScene needs, known before anything is built: what its meshes keep (each mesh's
// tree, the filtered walk's triangle copy and the kernel's layout), what each instance and each top
// level keeps, and the scratch of the largest single build (meshes are built one after another, so
// their scratch is not summed). The bytes kept are an upper estimate; RenderScene::memory_bytes()
// reports the measured size (tests/test_instanced_scene.cpp states the factor between them).
struct SceneMemoryEstimate {
    uint64_t mesh_bytes = 0;      // kept by the meshes, each mesh once however many instances place it
    uint64_t instance_bytes = 0;  // kept per instance and by the top levels
    uint64_t build_bytes = 0;     // the largest build's scratch beyond what it keeps (a mesh's or a top level's)
    uint64_t total() const { return mesh_bytes + instance_bytes + build_bytes; }
};

// `mesh_triangle_counts`: one entry per mesh built (each once), with config.recipe;
// `instance_count`: the instances of all scenes together; `top_levels`: the scenes committed (each
// mesh sits in a scene of its own when it is instanced, so count those too).
SceneMemoryEstimate estimate_scene_memory(std::span<const uint64_t> mesh_triangle_counts, uint64_t instance_count,
                                          uint64_t top_levels, const SceneConfig& config);

// MemAvailable of /proc/meminfo in bytes: what a new allocation can take without swapping out other
// programs. 0 where it is unknown (no /proc/meminfo).
uint64_t available_memory_bytes();

// Throws Error "WHAT: the build needs about E (estimate), more than the memory limit of L" (or "than
// the L available (MemAvailable)" when memory_limit_bytes is 0) when estimate_bytes exceeds the limit.
// No check when the limit is 0 and the memory available is unknown.
void check_memory_estimate(const std::string& what, uint64_t estimate_bytes, uint64_t memory_limit_bytes);

// "1.50 GiB", "640.0 MiB", "2.0 KiB", "512 bytes".
std::string format_bytes(uint64_t bytes);

}  // namespace spacebvh
