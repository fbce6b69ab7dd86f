// SPDX-License-Identifier: MIT
// RenderScene: attaching and detaching geometries, commit, refit, and the checks that keep a scene
// either whole or unchanged (docs/scenes.md, "Errors").
#include <algorithm>
#include <atomic>
#include <bit>
#include <functional>
#include <optional>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "trace/scene/scene_impl.hpp"
#include "trace/tracer_access.hpp"

namespace spacebvh {

using scene::Geometry;
using scene::InstanceRecord;
using scene::MeshRecord;

RenderScene::RenderScene(SceneConfig config, std::string name) : impl_(std::make_unique<Impl>()) {
    const Kernel k = config.tracer.kernel;
    if (k == Kernel::packet8 || k == Kernel::packet16)
        throw Error(std::string("scene '") + name + "': kernel '" + to_string(k) +
                    "' cannot trace scenes (single-ray kernels only: binary, bvh4, bvh8; docs/scenes.md)");
    config.recipe.validate();
    impl_->config = std::move(config);
    impl_->name = std::move(name);
}

RenderScene::~RenderScene() {
    for (const Geometry& g : impl_->geometries)
        if (const InstanceRecord* inst = g.instance()) --inst->scene->impl_->instanced_by;
}

Geometry& RenderScene::Impl::geometry(uint32_t id) {
    if (id >= geometries.size() || !geometries[id].alive())
        throw Error("scene '" + name + "': no geometry with id " + std::to_string(id) +
                    (id < geometries.size() ? " (detached)" : ""));
    return geometries[id];
}

void RenderScene::Impl::check_unshared(const char* action) const {
    if (instanced_by > 0)
        throw Error("scene '" + name + "': cannot " + action + " while " + std::to_string(instanced_by.load()) +
                    " instance(s) in other scenes use it (detach them first; refit() is allowed)");
}

void RenderScene::Impl::check_traceable() const {
    if (!committed) throw Error("scene '" + name + "': not committed (call commit() after attaching or detaching)");
    for (const auto& [child, generation] : children)
        if (child->impl_->generation != generation)
            throw Error("scene '" + name + "' instances scene '" + child->name() +
                        "', which was refitted since: call refit() on this scene");
}

void RenderScene::Impl::list_children() {
    children.clear();
    // Scenes mostly place a few scenes many times: a short list is searched; past 16 distinct
    // scenes the rest is taken whole, then sorted and made unique.
    bool many = false;
    for (uint32_t id : item_ids) {
        const InstanceRecord* inst = geometries[id].instance();
        if (!inst) continue;
        const std::pair<const RenderScene*, uint64_t> child(inst->scene.get(), inst->child_generation);
        if (!many && std::find(children.begin(), children.end(), child) != children.end()) continue;
        children.push_back(child);
        many = children.size() > 16;
    }
    std::sort(children.begin(), children.end());
    children.erase(std::unique(children.begin(), children.end()), children.end());
}

scene::TopLevelItem RenderScene::Impl::item_of(const Geometry& g) const {
    if (const MeshRecord* mesh = g.mesh()) return {mesh->bvh.root().bounds, {}};
    const InstanceRecord& inst = *g.instance();
    return {inst.xf.box, inst.xf.padding};
}

namespace {

// Whether every coordinate is finite (its exponent bits not all set), over blocks in parallel.
bool all_finite(std::span<const Triangle> triangles) {
    std::atomic<bool> finite = true;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, triangles.size(), 1 << 14),
                      [&](const tbb::blocked_range<size_t>& r) {
                          uint32_t bad = 0;
                          for (size_t t = r.begin(); t != r.end(); ++t)
                              for (int v = 0; v < 3; ++v) {
                                  const Vec3 p = triangles[t].vertex(v);
                                  for (float x : {p.x, p.y, p.z})
                                      bad |= (std::bit_cast<uint32_t>(x) & 0x7F800000u) == 0x7F800000u;
                              }
                          if (bad) finite.store(false, std::memory_order_relaxed);
                      });
    return finite;
}

// Copies `moved` into `into` (same size) in parallel, and says whether any triangle became or stopped
// being degenerate (both are in cache there).
bool copy_comparing_degeneracy(std::span<const Triangle> moved, std::vector<Triangle>& into) {
    std::atomic<bool> changed = false;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, moved.size(), 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
        bool any = false;
        for (size_t t = r.begin(); t != r.end(); ++t) {
            any |= into[t].is_degenerate() != moved[t].is_degenerate();
            into[t] = moved[t];
        }
        if (any) changed.store(true, std::memory_order_relaxed);
    });
    return changed;
}

uint32_t next_id(const std::vector<Geometry>& geometries, const std::string& name) {
    if (geometries.size() >= kInvalidIndex) throw Error("scene '" + name + "': out of geometry ids");
    return uint32_t(geometries.size());
}

}  // namespace

uint32_t RenderScene::attach_mesh(const MeshView& mesh, uint32_t mask) {
    return attach_mesh(mesh, impl_->config.recipe, mask);
}

uint32_t RenderScene::attach_mesh(const MeshView& mesh, const TreeRecipe& recipe, uint32_t mask) {
    impl_->check_unshared("attach a mesh");
    const uint32_t id = next_id(impl_->geometries, impl_->name);
    MeshRecord record{mesh, recipe, {}, {}, {}, false, 0.0, {}};
    record.view.named("scene '" + impl_->name + "' mesh " + std::to_string(id) + " ('" + mesh.name() + "')");
    const TriangleStore store(record.view);
    record.triangles.assign(store.triangles().begin(), store.triangles().end());
    if (record.triangles.empty()) throw Error(record.view.name() + ": no triangles");
    record.bvh = build(record.view, recipe);
    return impl_->add_mesh(std::move(record), mask);
}

uint32_t RenderScene::Impl::add_mesh(MeshRecord record, uint32_t mask) {
    const uint32_t id = next_id(geometries, name);
    record.duplicates = record.bvh.primitives.size() > record.triangles.size();
    record.extent = scene::extent_of(record.bvh.root().bounds);
    TracerConfig tracer = config.tracer;
    tracer.keep_refit_map = true;  // meshes of a scene are refitted in place
    record.tracer = std::make_unique<Tracer>(MeshView(record.triangles), record.bvh, tracer);
    geometries.push_back({mask, std::make_unique<MeshRecord>(std::move(record))});
    committed = false;
    return id;
}

void RenderScene::Impl::check_child(const RenderScene& self, const RenderScene* child,
                                    const std::function<std::string()>& what) const {
    if (!child) throw Error(what() + ": no scene given");
    if (child == &self) throw Error(what() + ": a scene cannot instance itself");
    if (!child->committed()) throw Error(what() + ": scene '" + child->name() + "' is not committed");
    const uint32_t levels = child->impl_->depth;
    if (levels + 1 > kMaxInstanceLevels)
        throw Error(what() + ": scene '" + child->name() + "' nests " + std::to_string(levels) +
                    " levels already; at most " + std::to_string(kMaxInstanceLevels) + " levels in all");
}

void RenderScene::Impl::add_instance(std::shared_ptr<const RenderScene> child, const Affine& transform,
                                     const scene::InstanceTransform& xf, uint32_t mask) {
    InstanceRecord record;
    record.xf = xf;
    record.transform = transform;
    record.child_generation = child->impl_->generation;
    ++child->impl_->instanced_by;
    record.scene = std::move(child);
    geometries.push_back({mask, std::move(record)});
    committed = false;
}

uint32_t RenderScene::attach_instance(std::shared_ptr<const RenderScene> child, const Affine& transform,
                                      uint32_t mask) {
    impl_->check_unshared("attach an instance");
    const uint32_t id = next_id(impl_->geometries, impl_->name);
    // The name for errors is made only when one is thrown: attaching 10^6 instances makes none.
    const auto what = [&] { return impl_->what(id) + " (instance)"; };
    impl_->check_child(*this, child.get(), what);
    const Impl& c = *child->impl_;
    scene::InstanceTransform xf;
    try {
        xf = scene::make_instance_transform(transform, c.bounds, c.root_padding, std::string());
    } catch (const Error& e) {
        throw Error(what() + e.what());  // its messages start with ": ", after the name it was given
    }
    impl_->add_instance(std::move(child), transform, xf, mask);
    return id;
}

void RenderScene::detach(uint32_t id) {
    Geometry& g = impl_->geometry(id);
    impl_->check_unshared(("detach geometry " + std::to_string(id)).c_str());
    if (const InstanceRecord* inst = g.instance()) --inst->scene->impl_->instanced_by;
    g.what = std::monostate{};
    impl_->committed = false;
}

void RenderScene::set_mask(uint32_t id, uint32_t mask) {
    impl_->geometry(id).mask = mask;
    if (id < impl_->record_of.size() && impl_->record_of[id] != kInvalidIndex)
        impl_->records[impl_->record_of[id]].mask = mask;
}

void RenderScene::Impl::gather(std::vector<uint32_t>& ids, std::vector<scene::TopLevelItem>& items, uint32_t& depth) {
    depth = 0;
    ids.reserve(geometries.size());
    items.reserve(geometries.size());
    for (uint32_t id = 0; id < geometries.size(); ++id) {
        Geometry& g = geometries[id];
        if (!g.alive()) continue;
        if (InstanceRecord* inst = g.instance()) {
            // The child's box as it is now: retaken when the child was committed or refitted since
            // the box was taken (a generation is bumped by each).
            const Impl& c = *inst->scene->impl_;
            if (inst->child_generation != c.generation) {
                scene::place_box(inst->xf, c.bounds, c.root_padding);
                inst->child_generation = c.generation;
            }
            depth = std::max(depth, c.depth + 1);
        }
        ids.push_back(id);
        items.push_back(item_of(g));
    }
    if (ids.empty()) throw Error("scene '" + name + "': nothing to commit (no geometry attached)");
}

void RenderScene::Impl::install(scene::TopLevel built, std::vector<uint32_t> ids,
                                std::vector<scene::TopLevelItem> top_items, uint32_t top_depth) {
    wide = scene::collapse_top_level(built.bvh);
    top = std::move(built);
    item_ids = std::move(ids);
    items = std::move(top_items);
    bounds = top.bvh.root().bounds;
    root_padding = top.padding;
    depth = top_depth;
    make_records();
    list_children();
    ++generation;
    committed = true;
}

scene::TopRecord RenderScene::Impl::record_of_item(uint32_t item) const {
    const uint32_t id = item_ids[item];
    const Geometry& g = geometries[id];
    scene::TopRecord r;
    r.mask = g.mask;
    r.id = id;
    r.item = item;
    if (const MeshRecord* mesh = g.mesh()) {
        r.kind = scene::TopRecord::kMesh;
        r.mesh = mesh;
        r.kernel = TracerInternals::entry(*mesh->tracer);
        return r;
    }
    const InstanceRecord& inst = *g.instance();
    r.to_instance = scene::RayTransform(inst.xf);
    const Impl& child = *inst.scene->impl_;
    if (const auto [mesh, mesh_id] = child.only_mesh(); mesh) {
        // The instance's box, tested on the way down, already bounds the mesh: its scene's one-item
        // top level is skipped.
        r.kind = scene::TopRecord::kInstanceOfMesh;
        r.mesh = mesh;
        r.mesh_id = mesh_id;
        r.mesh_mask = &child.geometries[mesh_id].mask;
        r.kernel = TracerInternals::entry(*mesh->tracer);
    } else {
        r.kind = scene::TopRecord::kInstanceOfScene;
        r.child = &child;
    }
    return r;
}

void RenderScene::Impl::make_records() {
    // The leaves in the order the walks reach them, each slot pointed at its leaf's first record;
    // then the records, leaf by leaf across the calling thread's oneTBB arena (each writes its own
    // records and its geometries' record_of entries, so any thread count gives the same).
    std::vector<std::pair<uint32_t, uint32_t>> leaves;  // (binary leaf, its first record)
    leaves.reserve(item_ids.size());
    uint32_t count = 0;
    for (scene::TopNode& node : wide)
        for (int slot = 0; slot < scene::kTopWidth; ++slot) {
            if (!(node.valid >> slot & 1u) || !(node.child[slot] & scene::kItemBit)) continue;
            const uint32_t leaf = node.child[slot] & ~scene::kItemBit;
            node.child[slot] = scene::kItemBit | count;
            leaves.emplace_back(leaf, count);
            count += top.bvh.nodes[leaf].reference_count;
        }
    records.assign(count, scene::TopRecord{});
    record_of.assign(geometries.size(), kInvalidIndex);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
            const BvhNode& leaf = top.bvh.nodes[leaves[i].first];
            for (uint32_t k = 0; k < leaf.reference_count; ++k) {
                const uint32_t at = leaves[i].second + k;
                records[at] = record_of_item(top.bvh.primitives[leaf.first + k]);
                records[at].last = k + 1 == leaf.reference_count;
                records[at].test_box = leaf.reference_count > 1;
                record_of[records[at].id] = at;
            }
        }
    });
}

void RenderScene::commit() {
    Impl& s = *impl_;
    s.check_unshared("commit");
    std::vector<uint32_t> ids;
    std::vector<scene::TopLevelItem> items;
    uint32_t depth = 0;
    s.gather(ids, items, depth);
    scene::TopLevel top = scene::build_top_level(items);
    s.install(std::move(top), std::move(ids), std::move(items), depth);
}

void RenderScene::refit(uint32_t id) {
    Geometry& g = impl_->geometry(id);
    MeshRecord* mesh = g.mesh();
    if (!mesh) throw Error(impl_->what(id) + " is an instance: refit() the scene it places, then refit() this one");
    // In place: the tree keeps its shape (split references get their triangles' whole boxes), and the
    // kernel's layout keeps its nodes and packing where it can (Tracer::refit). Every pass runs across
    // the calling thread's oneTBB arena and writes disjoint parts, so the result is the same for any
    // thread count. Nothing changes before the moved triangles are known to be finite.
    const auto refitted = [&] {
        mesh->extent = scene::extent_of(mesh->bvh.root().bounds);
        if (impl_->committed) refit();
    };
    std::span<const Triangle> moved = mesh->view.soup();
    if (mesh->view.is_soup() && moved.size() == mesh->triangles.size()) {
        // A soup: the tree, its layout and the finite check in one walk over the caller's buffer where
        // the layout allows (it reads each triangle once); then the copy the scene keeps.
        const trace::TreeRefit walked =
            TracerInternals::refit_tree_unchecked(*mesh->tracer, moved, mesh->triangles, mesh->bvh);
        if (walked == trace::TreeRefit::not_finite) {
            const TriangleStore named(mesh->view);  // throws, naming the first bad triangle
            throw Error(mesh->view.name() + ": refit needs finite coordinates");
        }
        if (walked == trace::TreeRefit::done) {
            if (copy_comparing_degeneracy(moved, mesh->triangles))  // the layout stores other triangles now
                TracerInternals::refit_checked(*mesh->tracer, MeshView(mesh->triangles), mesh->triangles, mesh->bvh);
            return refitted();
        }
    }
    // Checked (finite coordinates) before anything changes: a soup in place, in parallel (TriangleStore
    // then names the first bad triangle); an indexed mesh expanded by TriangleStore.
    std::optional<TriangleStore> expanded;
    if (!mesh->view.is_soup() || !all_finite(moved)) {
        expanded.emplace(mesh->view);
        moved = expanded->triangles();
    }
    if (moved.size() != mesh->triangles.size())
        throw Error(mesh->view.name() + ": refit needs the same triangles, got " + std::to_string(moved.size()) +
                    " instead of " + std::to_string(mesh->triangles.size()));
    // When no triangle's degeneracy changed, the layout keeps exactly its triangles and need not check
    // that itself. The tracer's refit skips the checks TriangleStore and refit_boxes made.
    if (copy_comparing_degeneracy(moved, mesh->triangles)) {
        refit_boxes(mesh->bvh, mesh->triangles);
        TracerInternals::refit_checked(*mesh->tracer, MeshView(mesh->triangles), mesh->triangles, mesh->bvh);
    } else {
        TracerInternals::refit_tree_checked(*mesh->tracer, MeshView(mesh->triangles), mesh->triangles, mesh->bvh);
    }
    refitted();
}

void RenderScene::refit() {
    Impl& s = *impl_;
    if (!s.committed) throw Error("scene '" + s.name + "': refit() needs a committed scene (call commit())");
    for (size_t k = 0; k < s.item_ids.size(); ++k) {
        Geometry& g = s.geometries[s.item_ids[k]];
        if (InstanceRecord* inst = g.instance()) {
            const Impl& c = *inst->scene->impl_;
            scene::place_box(inst->xf, c.bounds, c.root_padding);
            inst->child_generation = c.generation;
        }
        s.items[k] = s.item_of(g);
    }
    scene::refit_top_level(s.top, s.items);
    s.wide = scene::collapse_top_level(s.top.bvh);
    s.make_records();
    s.bounds = s.top.bvh.root().bounds;
    s.root_padding = s.top.padding;
    s.list_children();
    ++s.generation;
}

const std::string& RenderScene::name() const { return impl_->name; }
const SceneConfig& RenderScene::config() const { return impl_->config; }
bool RenderScene::committed() const { return impl_->committed; }
AABB RenderScene::bounds() const { return impl_->committed ? impl_->bounds : AABB{}; }
uint32_t RenderScene::depth() const { return impl_->depth; }

size_t RenderScene::geometry_count() const {
    return size_t(
        std::count_if(impl_->geometries.begin(), impl_->geometries.end(), [](const Geometry& g) { return g.alive(); }));
}

size_t RenderScene::memory_bytes() const {
    size_t bytes = impl_->top.bvh.nodes.size() * sizeof(BvhNode) + impl_->top.bvh.primitives.size() * sizeof(uint32_t) +
                   impl_->geometries.size() * sizeof(Geometry) + impl_->wide.size() * sizeof(scene::TopNode) +
                   impl_->records.size() * sizeof(scene::TopRecord) + impl_->record_of.size() * sizeof(uint32_t);
    for (const Geometry& g : impl_->geometries)
        if (const MeshRecord* mesh = g.mesh())
            bytes += mesh->tracer->memory_bytes() + mesh->triangles.size() * sizeof(Triangle) +
                     mesh->bvh.nodes.size() * sizeof(BvhNode) + mesh->bvh.primitives.size() * sizeof(uint32_t);
    return bytes;
}

}  // namespace spacebvh
