// SPDX-License-Identifier: MIT
// Instanced scenes as the tools load them: a few triangle meshes, each stored once, placed many times
// by affine transforms (builtin:forest:N, glTF 2.0 node hierarchies and EXT_mesh_gpu_instancing), and
// the RenderScene that builds each mesh's tree once and instances it (docs/scenes.md, "Scene files").
// The description is plain data: the memory it takes is the meshes' triangles plus 80 bytes per
// instance, so a million placements of a few meshes (10^10 instanced triangles) fit in a laptop.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "spacebvh/geometry.hpp"
#include "spacebvh/memory_estimate.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh::tools {

struct InstancedScene;

// One placement: a mesh of the scene (by index into InstancedScene::meshes) or a nested scene (when
// `scene` is set; `mesh` is then ignored), by `transform` (instance space to the scene's space), seen by
// rays whose mask shares a bit with `mask`.
struct SceneInstance {
    uint32_t mesh = 0;
    std::shared_ptr<const InstancedScene> scene;
    Affine transform;
    uint32_t mask = 0xFFFFFFFFu;
};

// Each mesh has at least one triangle and a name (the RenderScene of the mesh takes it); meshes are
// listed once however many instances place them. Every instance names an existing mesh; transforms
// are finite and invertible (the loaders check; RenderScene checks again at attach).
struct InstancedScene {
    std::string name;
    std::vector<Scene> meshes;
    std::vector<SceneInstance> instances;

    // Nesting levels below this scene: 1 when the instances place meshes only.
    uint32_t depth() const;
    // Triangles stored (each mesh once, nested scenes' meshes once per nested scene object).
    uint64_t unique_triangle_count() const;
    // Triangles the instances place (a mesh counted once per placement, nested levels multiplied).
    uint64_t instanced_triangle_count() const;
    // Placements of meshes down all levels (an instance of a nested scene counts its placements).
    uint64_t placement_count() const;
};

// A placement flattened to one level: a mesh of `scene` (the scene object that holds it) and the
// composition of the transforms down to it, in double, rounded once to float; masks are ANDed.
struct FlatPlacement {
    const InstancedScene* scene = nullptr;
    uint32_t mesh = 0;
    Affine transform;
    uint32_t mask = 0xFFFFFFFFu;
};
// Every placement of `scene` in instance order, depth first (for one-level consumers such as Embree 3,
// and for tests). Throws Error when there are more than `max_placements` (they would not fit).
std::vector<FlatPlacement> flatten_placements(const InstancedScene& scene, uint64_t max_placements = 100'000'000);

// The placed triangles in world space (each vertex by FlatPlacement::transform, Affine::apply), named
// after the scene; for comparisons against one flattened mesh. Throws Error when there would be more
// than `max_triangles`.
Scene flatten_scene(const InstancedScene& scene, uint64_t max_triangles = 50'000'000);

// True for the specs load_instanced_scene reads as instanced scenes: builtin:forest:N and .gltf / .glb
// files (case-insensitive extension). Decided from the text alone: nothing is read.
bool is_instanced_scene_spec(std::string_view spec);

// builtin:forest:N: N placements (1 <= N <= kMaxForestInstances) of a few built-in meshes. A .gltf /
// .glb: one mesh per glTF mesh used, one instance per node that places it (transforms composed down the
// hierarchy, matrix or T * R * S) and per EXT_mesh_gpu_instancing entry. Any other spec (a file or
// builtin:NAME): that mesh with one identity instance. `transform` (load_scene's, identity by default)
// is composed onto every instance. Throws Error naming the file and node / mesh / accessor for bad
// input (singular or NaN transforms, cycles, out-of-range indices, absurd N).
InstancedScene load_instanced_scene(std::string_view spec, const SceneTransform& transform = {});

inline constexpr uint64_t kMaxForestInstances = 1'000'000;

// The RenderScene of `scene`: one RenderScene per mesh (each tree built once with config.recipe, mask
// all ones), instanced by the top scene with each instance's transform and mask; nested scenes become
// nested RenderScenes (each nested scene object built once). The RenderScenes view the meshes'
// triangles (refit reads them again): `scene` must outlive the result. The shared_ptr overload keeps
// `scene` alive as long as the result. Before building anything, refuses (Error "... needs about E
// (estimate), more than ...") a scene whose estimate_scene_memory total exceeds
// config.recipe.limits.memory_limit_bytes, or the memory available when that is 0.
std::shared_ptr<RenderScene> make_render_scene(const InstancedScene& scene, const SceneConfig& config);
std::shared_ptr<RenderScene> make_render_scene(std::shared_ptr<const InstancedScene> scene, const SceneConfig& config);

// estimate_scene_memory (memory_estimate.hpp) for what make_render_scene(scene, config) builds: each
// mesh that an instance places once (every nested scene object once), every instance, every top level.
// The description itself (`scene`) is not counted. A front end prints total() and refuses before a
// build with check_memory_estimate(what, total(), limit) (memory_estimate.hpp), as make_render_scene does.
SceneMemoryEstimate estimate_scene_memory(const InstancedScene& scene, const SceneConfig& config);

}  // namespace spacebvh::tools
