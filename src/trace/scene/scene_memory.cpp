// SPDX-License-Identifier: MIT
// estimate_scene_memory (spacebvh/memory_estimate.hpp): what a RenderScene keeps per mesh, per
// instance and per top level, and the scratch of its largest build, from counts alone.
#include <algorithm>

#include "spacebvh/memory_estimate.hpp"
#include "trace/scene/scene_impl.hpp"

namespace spacebvh {
namespace {

// What a mesh keeps per reference of its tree beyond its triangle copy: the binary tree (at most one
// node and one primitive id per reference when leaves hold one or more) and the kernel's layout (wide
// nodes and 160-byte packs of four triangles, leaves rounded up to whole packs, and the moller test's
// planes where it is chosen). Measured on built-in and shared meshes with the default recipe and
// kernels: 100 to 200 bytes per reference (tests/test_instanced_scene.cpp checks the bound).
constexpr uint64_t kKeptPerReference = sizeof(BvhNode) + sizeof(uint32_t) + 192;

// The top level per instance: its record, its box and padding, its leaf in the binary tree (two nodes
// per item with one item per leaf) and its id, a share of the 8-wide collapse (at most one node per
// two), and the walk's record of it with its index by id.
constexpr uint64_t kKeptPerInstance = sizeof(scene::Geometry) + sizeof(scene::TopLevelItem) + sizeof(uint32_t) +
                                      2 * sizeof(BvhNode) + sizeof(uint32_t) + sizeof(scene::TopNode) / 2 +
                                      sizeof(scene::TopRecord) + sizeof(uint32_t);
constexpr uint64_t kKeptPerScene = 4096;  // the scene object, its name and small vectors

}  // namespace

SceneMemoryEstimate estimate_scene_memory(std::span<const uint64_t> mesh_triangle_counts, uint64_t instance_count,
                                          uint64_t top_levels, const SceneConfig& config) {
    SceneMemoryEstimate estimate;
    for (uint64_t triangles : mesh_triangle_counts) {
        const MemoryEstimate build = estimate_build_memory(triangles, config.recipe);
        estimate.mesh_bytes += triangles * sizeof(Triangle) + build.references * kKeptPerReference;
        estimate.build_bytes = std::max(estimate.build_bytes, build.bytes);
    }
    // The top levels' builds (top_level_build.cpp): their scratch is at most that of one build over all
    // the instances.
    estimate.build_bytes = std::max(estimate.build_bytes, instance_count * scene::kTopLevelBuildBytesPerItem);
    estimate.instance_bytes = instance_count * kKeptPerInstance + top_levels * kKeptPerScene;
    return estimate;
}

}  // namespace spacebvh
