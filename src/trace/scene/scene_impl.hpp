// SPDX-License-Identifier: MIT
// What a RenderScene holds: its geometries by id (meshes with their trees and layouts, instances with
// their transforms), the top level over them, and the walks that trace it (scene_walks.cpp).
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "spacebvh/scene.hpp"
#include "trace/kernels/kernels.hpp"
#include "trace/scene/instance_transform.hpp"
#include "trace/scene/top_level.hpp"
#include "trace/scene/top_level_wide.hpp"

namespace spacebvh {

namespace scene {

struct MeshRecord {
    MeshView view;  // the caller's buffers, read again by refit
    TreeRecipe recipe;
    Bvh bvh;                          // kept for refit and for filtered walks
    std::vector<Triangle> triangles;  // the filtered walk's leaf data
    std::unique_ptr<Tracer> tracer;
    bool duplicates = false;  // some triangle is in several leaves (spatial splits)
    double extent = 0.0;      // scene::extent_of(the tree's root box)
    // The triangles `view` shows when the scene owns them (loaded from a scene file); else null.
    std::shared_ptr<const std::vector<Triangle>> owned;
};

struct InstanceRecord {
    std::shared_ptr<const RenderScene> scene;
    Affine transform;
    InstanceTransform xf;
    uint64_t child_generation = 0;  // the child's generation when the box was taken
};

// A mesh record is large and rare, an instance record small and possibly one of millions: the mesh
// is held through a pointer (which also keeps its address fixed for TopRecord::mesh) so that a
// geometry is an instance's size.
struct Geometry {
    uint32_t mask = 0xFFFFFFFFu;
    std::variant<std::monostate, std::unique_ptr<MeshRecord>, InstanceRecord> what;  // monostate: detached

    bool alive() const { return what.index() != 0; }
    MeshRecord* mesh() const {
        const auto* mesh = std::get_if<std::unique_ptr<MeshRecord>>(&what);
        return mesh ? mesh->get() : nullptr;
    }
    const InstanceRecord* instance() const { return std::get_if<InstanceRecord>(&what); }
    InstanceRecord* instance() { return std::get_if<InstanceRecord>(&what); }
};

// What a walk needs of one top-level item, stored in the order the walk reaches the top level's
// leaves (a wide node's leaf child is kItemBit | its leaf's first record): the geometry's id and
// mask, and for a mesh or an instance of a one-mesh scene the mesh's kernel entry, so entering an
// instance reads this record and the mesh's layout, nothing between (docs/scenes.md, "Speed").
// 192 bytes on 64-byte boundaries: what every visit reads (mask, flags, kernel entry, mesh) in the
// first cache line, the ray transform an instance's entry reads in the next two.
struct alignas(64) TopRecord {
    enum Kind : uint8_t { kMesh, kInstanceOfMesh, kInstanceOfScene };
    uint32_t mask = 0;     // the geometry's (RenderScene::set_mask keeps it current)
    uint32_t id = 0;       // the geometry's id
    uint32_t item = 0;     // the top-level item (its box, tested when its leaf holds several)
    uint32_t mesh_id = 0;  // kInstanceOfMesh: the mesh's id in the instanced scene
    Kind kind = kMesh;
    bool last = false;                 // the last record of its leaf
    bool test_box = false;             // its leaf holds several items: its box was not tested on the way down
    trace::KernelEntry kernel;         // of `mesh`
    const MeshRecord* mesh = nullptr;  // kMesh, kInstanceOfMesh
    union {
        const uint32_t* mesh_mask = nullptr;  // kInstanceOfMesh: that mesh's mask in the instanced scene
        const RenderScene::Impl* child;       // kInstanceOfScene
    };
    RayTransform to_instance;  // an instance's (InstanceTransform::inverse, inverse_shift)
};
static_assert(sizeof(TopRecord) == 192 && offsetof(TopRecord, to_instance) == 64);

// The instance ids from the traced scene down to the scene being walked.
using InstancePath = std::array<uint32_t, kMaxInstanceLevels>;

// One query's state across levels.
struct QueryState {
    uint32_t mask;
    const TraceContext* context;
    const Ray* world_ray;
    InstancePath path;
};

}  // namespace scene

struct RenderScene::Impl {
    SceneConfig config;
    std::string name;
    std::vector<scene::Geometry> geometries;  // by id
    bool committed = false;
    scene::TopLevel top;
    std::vector<scene::TopNode> wide;  // top.bvh collapsed, as the walks take it
    std::vector<uint32_t> item_ids;    // top-level item -> geometry id
    std::vector<scene::TopLevelItem> items;
    std::vector<scene::TopRecord> records;  // in leaf order (TopRecord)
    std::vector<uint32_t> record_of;        // geometry id -> its record, kInvalidIndex if none
    AABB bounds;
    scene::Padding root_padding;
    uint32_t depth = 0;
    // The distinct scenes instanced, with their generation when this scene's boxes were taken.
    std::vector<std::pair<const RenderScene*, uint64_t>> children;
    uint64_t generation = 1;                   // bumped by every commit and refit
    mutable std::atomic<int> instanced_by{0};  // instances of this scene held by other scenes

    std::string what(uint32_t id) const { return "scene '" + name + "': geometry " + std::to_string(id); }
    scene::Geometry& geometry(uint32_t id);
    void check_traceable() const;
    void check_unshared(const char* action) const;
    scene::TopLevelItem item_of(const scene::Geometry& g) const;
    void list_children();
    // Throws Error starting with what() when `child` cannot be instanced by `self` (none, itself,
    // uncommitted, nested too deep).
    void check_child(const RenderScene& self, const RenderScene* child, const std::function<std::string()>& what) const;
    // Adds an instance of a checked child whose transform `xf` was made from `transform`.
    void add_instance(std::shared_ptr<const RenderScene> child, const Affine& transform,
                      const scene::InstanceTransform& xf, uint32_t mask);
    // Adds a mesh whose view, triangles and tree are set: lays it out for the kernel. Returns its id.
    uint32_t add_mesh(scene::MeshRecord record, uint32_t mask);
    // The live geometries' ids and top-level items as they are now (instances' boxes retaken from
    // their scenes), and the depth below this scene. Throws Error when there is none.
    void gather(std::vector<uint32_t>& ids, std::vector<scene::TopLevelItem>& items, uint32_t& depth);
    // Makes `records` and points `wide`'s leaf children at them (after every collapse).
    void make_records();
    scene::TopRecord record_of_item(uint32_t item) const;
    // Makes `top` (over `items`, of geometries `ids`) the committed top level.
    void install(scene::TopLevel top, std::vector<uint32_t> ids, std::vector<scene::TopLevelItem> items,
                 uint32_t depth);

    // The mesh and its id when the committed top level holds just that one mesh (an instance of a
    // built mesh): the walks then go straight to its kernel, as the instance's own box, tested by the
    // parent, already bounds it. Else {nullptr, kInvalidIndex}.
    std::pair<const scene::MeshRecord*, uint32_t> only_mesh() const {
        if (item_ids.size() != 1) return {nullptr, kInvalidIndex};
        return {geometries[item_ids[0]].mesh(), item_ids[0]};
    }

    // The walks (scene_walks.cpp). The ray's tmax is the bound so far; `hit` keeps the best.
    void closest(const Ray& ray, scene::QueryState& state, uint32_t level, SceneHit& hit) const;
    bool occluded(const Ray& ray, scene::QueryState& state, uint32_t level) const;
};

}  // namespace spacebvh
