// SPDX-License-Identifier: MIT
// Scenes as renderers hand them over: many triangle meshes, instances of other scenes placed by affine
// transforms (nested up to kMaxInstanceLevels), ids, 32-bit masks, intersection filters and refit.
// docs/scenes.md states the exactness contract and the errors. The name RenderScene keeps apart from
// spacebvh::tools::Scene (and Python's spacebvh.Scene), which are one loaded triangle mesh.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "spacebvh/geometry.hpp"
#include "spacebvh/mesh.hpp"
#include "spacebvh/recipe.hpp"
#include "spacebvh/trace.hpp"

namespace spacebvh {

// The deepest nesting of instances a hit can report (an instance of a scene of instances of a mesh is
// two levels).
inline constexpr uint32_t kMaxInstanceLevels = 4;

// An affine transform from an instance's space to its parent's, row-major 3x4 [A | b]:
// parent = A * local + b. Must be finite and invertible (docs/scenes.md).
struct Affine {
    std::array<float, 12> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};

    static Affine identity() { return {}; }
    // From a row-major 4x4 whose last row must be (0, 0, 0, 1); throws Error otherwise.
    static Affine from_4x4(std::span<const float, 16> rows);
    Vec3 apply(Vec3 p) const;  // in double, rounded once per coordinate
};

struct SceneHit {
    float t = kInfinity;       // world units: the parameter of the ray as given (units of |dir|), see docs/scenes.md
    float u = 0.0f, v = 0.0f;  // barycentrics of v1 and v2 in the mesh's own triangle
    uint32_t primitive = kInvalidIndex;  // triangle id in the mesh's order; kInvalidIndex for a miss
    uint32_t geometry = kInvalidIndex;   // the mesh's id in the scene that holds it
    // Instance ids from the traced scene down, then kInvalidIndex: instance[0] is an id of the traced
    // scene, instance[1] an id in the scene that instance places, ... All kInvalidIndex for a mesh
    // attached to the traced scene itself.
    std::array<uint32_t, kMaxInstanceLevels> instance{kInvalidIndex, kInvalidIndex, kInvalidIndex, kInvalidIndex};

    bool is_hit() const { return primitive != kInvalidIndex; }
};

// A candidate hit offered to an intersection filter, and the world ray it was found on.
struct FilterCandidate {
    const Ray& ray;  // the traced (world) ray
    const SceneHit& hit;
};
// Returns true to accept the candidate, false to reject it (the walk goes on as if the triangle were
// not there). Called from the tracing thread; `user` is TraceContext::user.
using IntersectionFilter = bool (*)(const FilterCandidate& candidate, void* user);

// What one trace call asks besides the rays.
struct TraceContext {
    uint32_t mask = 0xFFFFFFFFu;  // a geometry or instance is seen when (mask & its mask) != 0
    // Each (ray, instance path, geometry, primitive) candidate reaches the filter at most once per
    // query, spatial splits included (docs/scenes.md). Null: no filter.
    IntersectionFilter filter = nullptr;
    void* user = nullptr;
};

// One instance of a batch (RenderScene::attach_instances): the batch's scenes[scene] placed by
// `transform`, seen by rays whose mask meets `mask`.
struct InstancePlacement {
    uint32_t scene = 0;  // an index into the batch's scenes
    Affine transform;
    uint32_t mask = 0xFFFFFFFFu;
};

// How a scene builds the trees of its meshes and which kernel traces them.
struct SceneConfig {
    TreeRecipe recipe = TreeRecipe::for_builder("binned");  // each mesh's tree (our builders or a tree file)
    // Single-ray kernels only (binary, bvh4, bvh8 with their node tests, leaf tests and formats):
    // the packet kernels are refused, docs/scenes.md says why.
    TracerConfig tracer;
};

// A scene of meshes and instances. Ids come from one counter per scene, in attach order, and are not
// reused. Attach and detach change the scene; commit() builds its top level; tracing an uncommitted
// scene, or one whose instanced scenes changed since, throws Error. Tracing is const and thread-safe;
// changing a scene while it is traced is not.
class RenderScene {
public:
    explicit RenderScene(SceneConfig config = {}, std::string name = "scene");
    ~RenderScene();
    RenderScene(const RenderScene&) = delete;
    RenderScene& operator=(const RenderScene&) = delete;

    // Builds the mesh's tree with config().recipe (or `recipe`) and lays it out for the kernel. The
    // vertex and index buffers stay the caller's; refit() reads them again. Throws Error for a
    // malformed or empty mesh; the scene is unchanged then.
    uint32_t attach_mesh(const MeshView& mesh, uint32_t mask = 0xFFFFFFFFu);
    uint32_t attach_mesh(const MeshView& mesh, const TreeRecipe& recipe, uint32_t mask = 0xFFFFFFFFu);
    // Places a committed scene by `transform`. Throws Error for a non-finite or singular transform, an
    // uncommitted or empty scene, nesting deeper than kMaxInstanceLevels, or this very scene.
    uint32_t attach_instance(std::shared_ptr<const RenderScene> scene, const Affine& transform,
                             uint32_t mask = 0xFFFFFFFFu);
    // attach_instance for each placement, its transforms checked across the calling thread's oneTBB
    // arena: the ids are consecutive, the first returned (the next id when `placements` is empty).
    // Throws Error naming the first bad scene (by its index in `scenes`) or placement (by its index
    // in `placements`: a scene index out of range, a bad transform); the scene is unchanged then.
    uint32_t attach_instances(std::span<const std::shared_ptr<const RenderScene>> scenes,
                              std::span<const InstancePlacement> placements);
    // Throws Error for an unknown id, or when committed scenes instance this one.
    void detach(uint32_t id);
    void set_mask(uint32_t id, uint32_t mask);

    // Builds the top level over the geometries' boxes (binned SAH). Throws Error for a scene with no
    // geometry, or when committed scenes instance this one (they would hold stale boxes).
    void commit();
    // After the vertices of mesh `id` moved in the caller's buffers (same triangles, same count): its
    // tree's boxes are recomputed bottom-up (split references become whole triangles' boxes again),
    // its layout is redone and the top level is refitted. Throws Error for an unknown id or a changed
    // triangle count. Scenes instancing this one then need their own refit().
    void refit(uint32_t id);
    // Refits the top level over the current boxes of the geometries (after instanced scenes refitted).
    void refit();

    SceneHit intersect(const Ray& ray, const TraceContext& context = {}) const;
    bool occluded(const Ray& ray, const TraceContext& context = {}) const;
    // Batches across the calling thread's oneTBB arena; `masks`, when not empty, gives each ray its
    // own mask (context.mask is then unused). Same answers for any thread count.
    void intersect(std::span<const Ray> rays, std::span<SceneHit> hits, const TraceContext& context = {},
                   std::span<const uint32_t> masks = {}) const;
    void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded, const TraceContext& context = {},
                  std::span<const uint32_t> masks = {}) const;

    const std::string& name() const;
    const SceneConfig& config() const;
    bool committed() const;
    AABB bounds() const;            // of the committed top level (empty before)
    uint32_t depth() const;         // instance levels below this scene: 0 with meshes only
    size_t geometry_count() const;  // attached meshes and instances
    size_t memory_bytes() const;    // layouts of the meshes, top level, transforms

    struct Impl;

private:
    friend struct SceneFileAccess;  // scene files (spacebvh/scene_file.hpp) save and restore the parts
    std::unique_ptr<Impl> impl_;
};

}  // namespace spacebvh
