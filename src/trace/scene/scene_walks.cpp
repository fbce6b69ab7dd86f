// SPDX-License-Identifier: MIT
// Tracing a RenderScene: the top level's walk (walk.hpp with padded double box tests), rays taken into
// instances, meshes traced by their kernel, or, with a filter, by the filtered walk over the mesh's
// binary tree that offers each candidate to the filter once (docs/scenes.md, "Filters").
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <unordered_set>

#include "spacebvh/error.hpp"
#include "trace/leaf_tests/watertight_triangle.hpp"
#include "trace/scene/scene_impl.hpp"
#include "trace/traversal/traversal_common.hpp"

namespace spacebvh {

namespace {

using scene::Geometry;
using scene::InstanceRecord;
using scene::MeshRecord;
using scene::QueryState;
using scene::TopRecord;

// The triangles of one mesh walk that reached the filter. A triangle is in several leaves only after
// spatial splits; there the walk asks this set before offering a candidate again.
class SeenSet {
public:
    // False when `id` was there already.
    bool insert(uint32_t id) {
        for (uint32_t k = 0; k < count_; ++k)
            if (inline_[k] == id) return false;
        if (count_ < kInline) {
            if (!spill_.empty() && spill_.contains(id)) return false;
            inline_[count_++] = id;
            return true;
        }
        return spill_.insert(id).second;
    }

private:
    static constexpr uint32_t kInline = 16;
    uint32_t inline_[kInline];
    uint32_t count_ = 0;
    std::unordered_set<uint32_t> spill_;
};

SceneHit make_hit(const QueryState& state, uint32_t geometry, float t, float u, float v, uint32_t primitive) {
    return SceneHit{t, u, v, primitive, geometry, state.path};
}

// The filtered walk over one mesh: every crossing within the bound is a candidate, offered to the
// filter at most once. Closest hit: accepted candidates lower the bound and the nearest is kept;
// occlusion (`any`): the first accepted one ends the walk. Returns whether one was accepted.
bool filtered_mesh_walk(const MeshRecord& mesh, uint32_t id, const Ray& ray, QueryState& state, bool any,
                        SceneHit& best) {
    const scene::PaddedQuery query{mesh.bvh, scene::BoxRay(ray, {}, mesh.extent)};
    const trace::WatertightRay sheared(ray);
    float bound = ray.tmax;
    bool accepted_any = false;
    SeenSet seen;
    trace::walk(query, bound, [&](const scene::PaddedQuery::Entry& entry) {
        const BvhNode& leaf = mesh.bvh.nodes[entry.node];
        for (uint32_t k = 0; k < leaf.reference_count; ++k) {
            const uint32_t primitive = mesh.bvh.primitives[leaf.first + k];
            const Triangle& tri = mesh.triangles[primitive];
            trace::TriangleHit th;
            if (!trace::intersect_watertight(ray, sheared, tri.v0, tri.v1, tri.v2, bound, th)) continue;
            if (mesh.duplicates && !seen.insert(primitive)) continue;
            const SceneHit candidate = make_hit(state, id, th.t, th.u, th.v, primitive);
            if (!state.context->filter(FilterCandidate{*state.world_ray, candidate}, state.context->user)) continue;
            accepted_any = true;
            if (any) return true;
            if (!best.is_hit() || th.t < best.t) best = candidate;
            bound = std::min(bound, th.t);
        }
        return false;
    });
    return accepted_any;
}

// A mesh (kernel: its tracer's, scene::TopRecord) traced for the closest hit, `best` kept when nearer.
void mesh_closest(const MeshRecord& mesh, const trace::KernelEntry& kernel, uint32_t id, const Ray& ray,
                  QueryState& state, SceneHit& best) {
    if (state.context->filter) {
        filtered_mesh_walk(mesh, id, ray, state, false, best);
        return;
    }
    Hit hit;
    if (kernel.closest(kernel.layout, ray, hit) && (!best.is_hit() || hit.t < best.t))
        best = make_hit(state, id, hit.t, hit.u, hit.v, hit.primitive);
}

bool mesh_occluded(const MeshRecord& mesh, const trace::KernelEntry& kernel, uint32_t id, const Ray& ray,
                   QueryState& state) {
    if (state.context->filter) {
        SceneHit unused;
        return filtered_mesh_walk(mesh, id, ray, state, true, unused);
    }
    Hit unused;
    return kernel.occluded(kernel.layout, ray, unused);
}

// Calls visit(record) for each record of a top-level leaf (scene::TopRecord) that the mask sees: one
// per leaf, whose box was tested on the way down, unless the depth limit left more, whose boxes are
// then tested here. Stops when a call returns true, and returns whether one did.
template <class Visit>
[[gnu::always_inline]] inline bool visit_records(const RenderScene::Impl& s, uint32_t leaf_ref,
                                                 const scene::BoxRay& ray, float bound, uint32_t mask, Visit&& visit) {
    for (const TopRecord* r = &s.records[leaf_ref & ~scene::kItemBit];; ++r) {
        float entry;
        if ((r->mask & mask) && (!r->test_box || scene::meets(ray, s.items[r->item].box, bound, entry)) && visit(*r))
            return true;
        if (r->last) return false;
    }
}

}  // namespace

void RenderScene::Impl::closest(const Ray& ray, QueryState& state, uint32_t level, SceneHit& best) const {
    const scene::WideTopQuery query{wide, scene::BoxRay(ray, top.padding, top.extent)};
    float bound = ray.tmax;
    const auto bounded = [&] {
        Ray r = ray;
        r.tmax = bound;
        return r;
    };
    trace::walk(query, bound, [&](const scene::WideTopQuery::Entry& entry) {
        return visit_records(*this, entry.ref, query.ray, bound, state.mask, [&](const TopRecord& r) {
            if (r.kind == TopRecord::kMesh) {
                mesh_closest(*r.mesh, r.kernel, r.id, bounded(), state, best);
            } else {
                state.path[level] = r.id;
                Ray local;
                if (!r.to_instance.apply_finite(bounded(), local)) {
                    // no hit in this instance (docs/scenes.md)
                } else if (r.kind == TopRecord::kInstanceOfMesh) {
                    if (*r.mesh_mask & state.mask) mesh_closest(*r.mesh, r.kernel, r.mesh_id, local, state, best);
                } else {
                    r.child->closest(local, state, level + 1, best);
                }
                state.path[level] = kInvalidIndex;
            }
            if (best.is_hit()) bound = std::min(bound, best.t);
            return false;
        });
    });
}

bool RenderScene::Impl::occluded(const Ray& ray, QueryState& state, uint32_t level) const {
    const scene::WideTopQuery query{wide, scene::BoxRay(ray, top.padding, top.extent)};
    float bound = ray.tmax;
    bool blocked = false;
    trace::walk(query, bound, [&](const scene::WideTopQuery::Entry& entry) {
        return blocked = visit_records(*this, entry.ref, query.ray, bound, state.mask, [&](const TopRecord& r) {
                   if (r.kind == TopRecord::kMesh) return mesh_occluded(*r.mesh, r.kernel, r.id, ray, state);
                   state.path[level] = r.id;
                   Ray local;
                   bool hit;
                   if (!r.to_instance.apply_finite(ray, local))
                       hit = false;  // no hit in this instance (docs/scenes.md)
                   else if (r.kind == TopRecord::kInstanceOfMesh)
                       hit = (*r.mesh_mask & state.mask) && mesh_occluded(*r.mesh, r.kernel, r.mesh_id, local, state);
                   else
                       hit = r.child->occluded(local, state, level + 1);
                   state.path[level] = kInvalidIndex;
                   return hit;
               });
    });
    return blocked;
}

namespace {

scene::QueryState start_state(const Ray& ray, const TraceContext& context, uint32_t mask) {
    scene::QueryState state{mask, &context, &ray, {}};
    state.path.fill(kInvalidIndex);
    return state;
}

void check_batch(const std::string& name, size_t rays, size_t answers, size_t masks) {
    if (answers != rays)
        throw Error("scene '" + name + "': " + std::to_string(rays) + " rays but " + std::to_string(answers) +
                    " answers");
    if (masks != 0 && masks != rays)
        throw Error("scene '" + name + "': " + std::to_string(rays) + " rays but " + std::to_string(masks) +
                    " masks (give one per ray, or none)");
}

template <typename Body>
void for_each_ray(size_t count, Body&& body) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 256), [&](const tbb::blocked_range<size_t>& range) {
        const trace::StandardFloatingPointMode mode;
        for (size_t i = range.begin(); i != range.end(); ++i) body(i);
    });
}

}  // namespace

SceneHit RenderScene::intersect(const Ray& ray, const TraceContext& context) const {
    impl_->check_traceable();
    const trace::StandardFloatingPointMode mode;
    scene::QueryState state = start_state(ray, context, context.mask);
    SceneHit hit;
    impl_->closest(ray, state, 0, hit);
    return hit;
}

bool RenderScene::occluded(const Ray& ray, const TraceContext& context) const {
    impl_->check_traceable();
    const trace::StandardFloatingPointMode mode;
    scene::QueryState state = start_state(ray, context, context.mask);
    return impl_->occluded(ray, state, 0);
}

void RenderScene::intersect(std::span<const Ray> rays, std::span<SceneHit> hits, const TraceContext& context,
                            std::span<const uint32_t> masks) const {
    check_batch(impl_->name, rays.size(), hits.size(), masks.size());
    impl_->check_traceable();
    for_each_ray(rays.size(), [&](size_t i) {
        scene::QueryState state = start_state(rays[i], context, masks.empty() ? context.mask : masks[i]);
        hits[i] = SceneHit{};
        impl_->closest(rays[i], state, 0, hits[i]);
    });
}

void RenderScene::occluded(std::span<const Ray> rays, std::span<uint8_t> result, const TraceContext& context,
                           std::span<const uint32_t> masks) const {
    check_batch(impl_->name, rays.size(), result.size(), masks.size());
    impl_->check_traceable();
    for_each_ray(rays.size(), [&](size_t i) {
        scene::QueryState state = start_state(rays[i], context, masks.empty() ? context.mask : masks[i]);
        result[i] = impl_->occluded(rays[i], state, 0) ? 1 : 0;
    });
}

}  // namespace spacebvh
