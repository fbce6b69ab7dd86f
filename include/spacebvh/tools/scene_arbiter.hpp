// SPDX-License-Identifier: MIT
// The exact arbiter of an instanced scene (docs/scenes.md, "The exactness contract"): each placement
// of a mesh (a mesh under a chain of instance transforms) is tested with the ray taken into the
// mesh's space by the documented float transform, level by level, as RenderScene traces it; the
// closest exact crossing over every placement is the answer. `compare` settles its disagreements
// with Embree's two-level scene with it.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "spacebvh/scene.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh::tools {

// One mesh as a scene places it: the instance transforms from the traced scene down (top level
// first; none for a mesh attached to the traced scene itself) and the ids a hit on it reports.
struct MeshPlacement {
    uint32_t mesh = 0;               // index into the scene's meshes
    std::vector<Affine> transforms;  // top level first
    std::array<uint32_t, kMaxInstanceLevels> path{kInvalidIndex, kInvalidIndex, kInvalidIndex, kInvalidIndex};
    uint32_t geometry = 0;  // the mesh's id in the scene that holds it
    // The instances' masks (top first), then the mesh's: a ray sees the placement when its mask
    // shares a bit with every one of them.
    std::vector<uint32_t> masks;

    bool visible(uint32_t ray_mask) const {
        for (uint32_t m : masks)
            if (!(m & ray_mask)) return false;
        return true;
    }
};

struct InstancedScene;

// Every placement of a mesh in the RenderScene that make_render_scene builds of `scene`
// (instanced_scene.hpp: instance k of a scene has id k there, and each mesh is geometry 0 of a scene
// of its own), with the meshes they index: the top scene's, then each nested scene object's, once.
struct ScenePlacements {
    std::vector<Scene> meshes;
    std::vector<MeshPlacement> placements;
};
ScenePlacements mesh_placements_of(const InstancedScene& scene);

// The closest exact hit and the placement it is on (-1 for a miss).
struct PlacedHit {
    HitRecord hit;
    int64_t placement = -1;
};

class SceneArbiter {
public:
    // Keeps pointers to `meshes` (which must outlive it); throws Error for a placement naming no mesh
    // or a transform the scenes refuse (non-finite, singular, badly conditioned).
    SceneArbiter(std::span<const Scene> meshes, std::vector<MeshPlacement> placements);
    ~SceneArbiter();
    SceneArbiter(SceneArbiter&&) noexcept;
    SceneArbiter& operator=(SceneArbiter&&) noexcept;

    // Brute force over every placement whose world box (padded far beyond the transforms' rounding)
    // the ray meets; equal t keeps the lower placement, then the lower triangle id.
    PlacedHit closest_hit(const Ray& ray, uint32_t mask = 0xFFFFFFFFu) const;
    bool occluded(const Ray& ray, uint32_t mask = 0xFFFFFFFFu) const;

    float diagonal() const;  // of the world bounds of every placement, for hits_agree
    AABB bounds() const;
    const std::vector<MeshPlacement>& placements() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace spacebvh::tools
