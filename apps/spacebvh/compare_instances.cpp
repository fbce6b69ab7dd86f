// SPDX-License-Identifier: MIT
// `compare` on an instanced scene: our rows are RenderScenes (each mesh's tree by the row's builder,
// traced by the row's single-ray kernel), Embree's are its two-level scene (instance geometries over
// a scene per mesh) with single rays and 16-ray packets; every answer is checked against the first
// Embree row and the instanced scene's exact arbiter settles the disagreements.
#include <cstdio>

#include "compare_scene.hpp"
#include "compare_table.hpp"
#include "spacebvh/presets.hpp"

namespace spacebvh::cli::compare {
namespace {

std::string kernel_label(const std::string& kernel) { return kernel == "auto" ? "bvh8" : kernel; }

// The three ray sets over the scene's world box and camera; diffuse rays start where primary rays hit
// `traced`, off the world triangle of each hit.
void make_instanced_ray_sets(SceneComparison& comparison, const RenderScene& traced) {
    const RaySetParameters& p = comparison.parameters;
    const InstancedInput& input = *comparison.instanced;
    comparison.ray_sets[int(RayKind::random)] = generate_random_rays(input.bounds(), p.random_count, p.seed);
    const std::vector<Ray> primary = generate_primary_rays(p.camera, p.width, p.height);
    std::vector<SceneHit> hits(primary.size());
    traced.intersect(primary, hits);
    Scene hit_triangles;  // triangle k: the world triangle of the k-th primary hit
    std::vector<Hit> numbered(primary.size());
    for (size_t i = 0; i < primary.size(); ++i) {
        if (!hits[i].is_hit()) continue;
        numbered[i].t = hits[i].t;
        numbered[i].primitive = uint32_t(hit_triangles.triangles.size());
        hit_triangles.triangles.push_back(input.world_triangle(hits[i]));
    }
    const float epsilon = 1e-4f * length(input.bounds().extent());  // the spec's default for the world
    comparison.ray_sets[int(RayKind::diffuse)] =
        generate_diffuse_rays(hit_triangles, primary, numbered, p.seed, epsilon);
    comparison.primary_row_major = primary;
    comparison.ray_sets[int(RayKind::primary)] = gathered(primary, comparison.primary_order);
}

// Our row of one builder under one kernel: the RenderScene built --build-runs times (attach every mesh
// and instance, commit), the last kept; for --tree's row, loaded from the scene file as many times.
void add_instanced_row(const ComparePlan& plan, SceneComparison& comparison, const BuilderSpec& builder,
                       const std::string& kernel) {
    const SceneConfig config{builder.options, instanced_scene_kernel(kernel)};
    Row& row = comparison.rows.emplace_back();
    row.name = builder.saved_tree
                   ? plan.options.tree.path
                   : builder.label + " (C_o=" + number_or_dash(builder.options.cost.overlap_penalty, 2) + ")";
    row.cost = builder.options.cost;
    std::shared_ptr<RenderScene>& scene = comparison.render_scenes.emplace_back();
    for (int run = 0; run < plan.options.build_runs; ++run) {
        scene.reset();
        double milliseconds = 0.0;
        scene = scene_for(builder.saved_tree ? plan.options.tree : TreeOption{}, *comparison.instanced, config,
                          &milliseconds);
        row.build_ms_runs.push_back(milliseconds);
        throw_if_interrupted();
    }
    row.build_ms = median(row.build_ms_runs);
    if (comparison.ray_sets[0].empty()) make_instanced_ray_sets(comparison, *scene);
    // RenderScene::memory_bytes() counts the top scene's own geometries; the instanced meshes' layouts
    // are in the scenes it instances, which make_render_scene does not hand out: not known here.
    row.kernel = kernel_label(kernel);
    const RenderScene* traced = scene.get();
    for (RayKind kind : kKinds) {
        row.kernels[int(kind)] = row.kernel;
        Measurement& m = add_measurement(comparison, row.kinds[int(kind)], comparison.ray_sets[int(kind)], {},
                                         [traced](auto r, auto o) { traced->occluded(r, o); });
        m.intersect_scene = [traced](auto r, auto h) { traced->intersect(r, h); };
    }
    row.peak_rss_bytes = peak_rss_bytes();
}

}  // namespace

void add_embree_instanced_row(const ComparePlan& plan, SceneComparison& comparison, EmbreeQuality quality, bool packets,
                              const EmbreePacketOrder& packet_order) {
    const InstancedInput& input = *comparison.instanced;
    Row& row = comparison.rows.emplace_back();
    row.name = std::string("embree-") + to_string(quality);
    row.kernel =
        packets ? "Embree two-level rtcIntersect16/rtcOccluded16" : "Embree two-level rtcIntersect1/rtcOccluded1";
    std::unique_ptr<EmbreeInstancedScene>& embree = comparison.embree_instanced.emplace_back();
    for (int run = 0; run < plan.options.build_runs; ++run) {
        embree.reset();
        embree = std::make_unique<EmbreeInstancedScene>(input.meshes(), input.placements(), quality);
        row.build_ms_runs.push_back(embree->build_milliseconds());
        throw_if_interrupted();
    }
    row.build_ms = median(row.build_ms_runs);
    row.layout_bytes_per_triangle = double(embree->memory_bytes()) / double(comparison.triangle_count());
    const EmbreeInstancedScene* traced = embree.get();
    for (RayKind kind : kKinds) {
        Measurement& m = add_measurement(comparison, row.kinds[int(kind)], comparison.ray_sets[int(kind)], {}, {});
        if (packets) {
            m.occluded = [traced](auto r, auto o) { traced->occluded16(r, o); };
            m.intersect_scene = [traced](auto r, auto h) { traced->intersect16(r, h); };
            if (kind == RayKind::primary) packet_order.apply(comparison, m);
        } else {
            m.occluded = [traced](auto r, auto o) { traced->occluded(r, o); };
            m.intersect_scene = [traced](auto r, auto h) { traced->intersect(r, h); };
        }
    }
    row.peak_rss_bytes = peak_rss_bytes();
}

void load_instanced_comparison(const ComparePlan& plan, SceneComparison& comparison) {
    comparison.instanced = std::make_unique<InstancedInput>(comparison.source, plan.transform);
    comparison.scene = comparison.instanced->world_box();  // for the camera
    std::vector<TreeRecipe> recipes;  // every row's scene is built and kept before the rays are traced
    for (const BuilderSpec& builder : plan.builders) recipes.push_back(builder.options);
    comparison.instanced->check_memory(recipes, plan.kernels.size());
}

void add_our_instanced_rows(const ComparePlan& plan, SceneComparison& comparison, Progress& progress) {
    for (const BuilderSpec& builder : plan.builders)
        for (const std::string& kernel : plan.kernels) {
            add_instanced_row(plan, comparison, builder, kernel);
            show_rows_built(plan, comparison, progress);
        }
}

}  // namespace spacebvh::cli::compare
