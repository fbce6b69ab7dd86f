// SPDX-License-Identifier: MIT
// spacebvh trace SCENE --rays FILE --hits FILE [--occlusion]: answer a ray file with a hit file.
#include <cstdio>

#include "cli_common.hpp"
#include "instanced_input.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"
#include "tree_option.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

namespace {

struct TraceOptions {
    std::string source, rays_path, hits_path, kernel = "auto";
    bool occlusion = false, stats = false;
    SceneOptions scene;
    BuildCliOptions build;
    CommonOptions common;
    TreeOption tree;
};

// The answers to a ray file as hit records, and what tracing them took.
struct TracedRays {
    std::vector<HitRecord> records;
    size_t hit_count = 0;
    double trace_ms = 0;
    TraversalStats stats;  // counted only when asked for
};

TracedRays trace_rays(const Tracer& tracer, const std::vector<Ray>& rays, bool occlusion, bool with_stats) {
    TracedRays traced;
    TraversalStats* stats_out = with_stats ? &traced.stats : nullptr;
    traced.records.resize(rays.size());
    const auto start = std::chrono::steady_clock::now();
    if (occlusion) {
        std::vector<uint8_t> occluded(rays.size());
        tracer.occluded(rays, occluded, stats_out);
        for (size_t i = 0; i < rays.size(); ++i) traced.records[i] = occlusion_record(occluded[i]);
    } else {
        std::vector<Hit> hits(rays.size());
        tracer.intersect(rays, hits, stats_out);
        for (size_t i = 0; i < rays.size(); ++i) traced.records[i] = to_record(hits[i]);
    }
    traced.trace_ms = milliseconds_since(start);
    for (const HitRecord& record : traced.records) traced.hit_count += record.is_hit();
    return traced;
}

// The work per ray (--stats), printed and added to `json`.
void report_work_per_ray(const TraversalStats& stats, size_t ray_count, nlohmann::json& json) {
    const double n = double(ray_count);
    std::printf("per ray: %.2f nodes visited, %.2f triangles tested\n", double(stats.nodes_visited) / n,
                double(stats.triangles_tested) / n);
    json["nodes_per_ray"] = double(stats.nodes_visited) / n;
    json["triangles_per_ray"] = double(stats.triangles_tested) / n;
    if (stats.exact_tests || stats.plane_distances) {
        std::printf("per ray: %.4f exact tests, %.4f double-precision distances\n", double(stats.exact_tests) / n,
                    double(stats.plane_distances) / n);
        json["exact_tests_per_ray"] = double(stats.exact_tests) / n;
        json["plane_distances_per_ray"] = double(stats.plane_distances) / n;
    }
}

// An instanced scene: its RenderScene built with the recipe and traced; the hit file's primitive is
// the triangle's id in its own mesh.
void trace_instances(const TraceOptions& options) {
    if (options.stats)
        throw Error("--stats: the traversal statistics are the one-mesh kernels'; scenes do not count them");
    const InstancedInput input(options.source, options.scene.transform());
    const std::vector<Ray> rays = read_ray_file(options.rays_path);
    const TreeRecipe recipe = options.build.options(options.build.builder);
    const TracerConfig tracer = instanced_scene_kernel(options.kernel);
    input.check_memory(recipe);
    double build_ms = 0.0;
    const std::shared_ptr<RenderScene> scene = scene_for(options.tree, input, SceneConfig{recipe, tracer}, &build_ms);
    std::vector<HitRecord> records(rays.size());
    const auto start = std::chrono::steady_clock::now();
    if (options.occlusion) {
        std::vector<uint8_t> occluded(rays.size());
        scene->occluded(rays, occluded);
        for (size_t i = 0; i < rays.size(); ++i) records[i] = occlusion_record(occluded[i]);
    } else {
        std::vector<SceneHit> hits(rays.size());
        scene->intersect(rays, hits);
        for (size_t i = 0; i < rays.size(); ++i) records[i] = {hits[i].t, hits[i].primitive};
    }
    const double trace_ms = milliseconds_since(start);
    size_t hit_count = 0;
    for (const HitRecord& record : records) hit_count += record.is_hit();
    write_hit_file(options.hits_path, records);
    if (options.tree.given()) std::printf("scene loaded from %s in %.1f ms\n", options.tree.path.c_str(), build_ms);
    const std::string kernel = options.kernel == "auto" ? "bvh8" : options.kernel;
    std::printf(
        "%zu rays, %zu %s, %.1f ms (%.2f Mrays/s, %u threads), scene %s (%zu instances), builder %s, kernel %s\n",
        rays.size(), hit_count, options.occlusion ? "occluded" : "hits", trace_ms,
        double(rays.size()) / trace_ms / 1000.0, options.common.effective_threads(), input.name().c_str(),
        input.instance_count(), options.build.builder.c_str(), kernel.c_str());
    write_json(options.common.json_path, {{"rays", rays.size()},
                                          {"hits", hit_count},
                                          {"trace_ms", trace_ms},
                                          {"builder", options.build.builder},
                                          {"kernel", kernel},
                                          {options.tree.given() ? "tree_load_ms" : "build_ms", build_ms},
                                          {"instances", input.instance_count()}});
}

}  // namespace

void add_trace_command(CLI::App& app) {
    auto options = std::make_shared<TraceOptions>();
    CLI::App* command = app.add_subcommand("trace", "trace a ray file and write a hit file (closest hit or occlusion)");
    command->add_option("scene", options->source, "scene file or builtin:NAME")->required();
    command->add_option("--rays", options->rays_path, "ray file (REFRAYS1)")->required();
    command->add_option("--hits", options->hits_path, "hit file to write (REFHITS1)")->required();
    command->add_flag("--occlusion", options->occlusion, "any-hit queries: t = 0 occluded, +inf free");
    command->add_flag("--stats", options->stats, "count nodes visited and triangles tested per ray");
    command->add_option("--kernel", options->kernel, kernel_help())->capture_default_str();
    options->scene.add_to(*command);
    options->build.add_to(*command);
    options->common.add_to(*command);
    options->tree.add_to(*command, "trace this saved tree (build --save) instead of building one");
    command->callback([options] {
        const auto limit = options->common.thread_limit();
        if (names_instanced_scene(options->source)) return trace_instances(*options);
        const Scene scene = load_scene(options->source, options->scene.transform());
        const std::vector<Ray> rays = read_ray_file(options->rays_path);
        const TreeRecipe build_options = options->build.options(options->build.builder);
        double tree_ms = 0;
        const Bvh bvh = tree_for(options->tree, scene, build_options, &tree_ms);
        const CostModel& cost = options->tree.given() ? bvh.cost : build_options.cost;
        const std::unique_ptr<Tracer> tracer = make_tracer(options->kernel, scene, bvh);
        const TracedRays traced = trace_rays(*tracer, rays, options->occlusion, options->stats);
        write_hit_file(options->hits_path, traced.records);
        std::printf("%zu rays, %zu %s, %.1f ms (%.2f Mrays/s, %u threads), builder %s (%s), kernel %s\n", rays.size(),
                    traced.hit_count, options->occlusion ? "occluded" : "hits", traced.trace_ms,
                    double(rays.size()) / traced.trace_ms / 1000.0, options->common.effective_threads(),
                    bvh.builder.c_str(), cost.describe().c_str(), tracer->name().c_str());
        if (options->tree.given()) std::printf("tree loaded from %s in %.1f ms\n", options->tree.path.c_str(), tree_ms);
        nlohmann::json json = {{"rays", rays.size()},
                               {"hits", traced.hit_count},
                               {"trace_ms", traced.trace_ms},
                               {"builder", bvh.builder},
                               {"kernel", tracer->name()}};
        json[options->tree.given() ? "tree_load_ms" : "build_ms"] = tree_ms;
        if (options->stats && !rays.empty()) report_work_per_ray(traced.stats, rays.size(), json);
        write_json(options->common.json_path, json);
    });
}

}  // namespace spacebvh::cli
