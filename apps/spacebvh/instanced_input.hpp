// SPDX-License-Identifier: MIT
// A SCENE argument that names an instanced scene (builtin:forest:N, a glTF whose nodes instance its
// meshes): loaded once, with every placement of a mesh (for Embree's two-level scene and the exact
// arbiter), the RenderScene the commands build from it, and world triangles of hits (for shading and
// diffuse rays). One-mesh specs never come here: they keep the one-mesh path of every command.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "spacebvh/recipe.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/tools/instanced_scene.hpp"
#include "spacebvh/tools/scene_arbiter.hpp"

namespace spacebvh::cli {

// Whether `source` names an instanced scene rather than one mesh: builtin:forest:N, or a glTF file
// whose nodes place a mesh more than once (or nest scenes). A glTF that places each mesh once stays
// one mesh, as it always was (node transforms applied); so does one that does not load as a scene
// (the one-mesh reader then reports what is wrong with it).
bool names_instanced_scene(const std::string& source);

// The tracer of a --kernel name on an instanced scene: "auto" is bvh8 for every ray kind; a packet
// kernel is refused (they do not take instances, docs/scenes.md).
TracerConfig instanced_scene_kernel(const std::string& kernel);

class InstancedInput {
public:
    // Loads the scene (throws Error naming the spec and what is wrong with it); `transform` (the
    // load-time transform options) is composed onto every instance.
    InstancedInput(const std::string& source, const tools::SceneTransform& transform);

    const std::string& name() const { return name_; }
    // Every mesh placed: the scene's, then each nested scene's.
    const std::vector<tools::Scene>& meshes() const { return meshes_; }
    size_t instance_count() const;         // the scene's own instances (placements() counts every level's)
    uint64_t instanced_triangles() const;  // triangles over every placement
    const std::vector<tools::MeshPlacement>& placements() const { return arbiter_->placements(); }
    const tools::SceneArbiter& arbiter() const { return *arbiter_; }
    AABB bounds() const { return arbiter_->bounds(); }

    // The memory a RenderScene of it takes to build with `recipe`: each mesh's tree once, plus the
    // instances and the top levels.
    uint64_t memory_estimate(const TreeRecipe& recipe) const;
    // Prints the estimate and throws Error when it is over --memory-limit (or the memory available).
    void check_memory(const TreeRecipe& recipe) const;
    // The same for several scenes kept at once (compare's rows: one per recipe, `copies` of each),
    // against the first recipe's limit.
    void check_memory(std::span<const TreeRecipe> recipes, size_t copies) const;
    // Builds the RenderScene: every mesh's tree once with `config.recipe`, traced by `config.tracer`.
    std::shared_ptr<RenderScene> build(const SceneConfig& config) const;

    // The default camera: the world box framed as default_camera frames a mesh.
    tools::Camera default_camera() const;
    // A stand-in mesh for what needs only the world box (default cameras, random rays): one
    // degenerate triangle from its low to its high corner.
    tools::Scene world_box() const;

    // The world-space triangle a hit (of our RenderScene or Embree's two-level scene) is on; throws
    // Error for a hit naming no placement.
    Triangle world_triangle(const SceneHit& hit) const;

private:
    std::string name_;
    std::shared_ptr<const tools::InstancedScene> description_;
    std::vector<tools::Scene> meshes_;
    std::unique_ptr<tools::SceneArbiter> arbiter_;
    struct Key {
        std::array<uint32_t, kMaxInstanceLevels> path;
        uint32_t geometry;
        bool operator==(const Key&) const = default;
    };
    struct KeyHash {
        size_t operator()(const Key& key) const;
    };
    std::unordered_map<Key, uint32_t, KeyHash> placement_of_;  // a hit's path and geometry -> its placement
};

}  // namespace spacebvh::cli
