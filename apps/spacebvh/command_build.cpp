// SPDX-License-Identifier: MIT
// spacebvh build SCENE --builder NAME [--save FILE]: build one tree, print its quality metrics, and
// optionally save it as a tree file.
#include <cmath>
#include <cstdio>

#include "cli_common.hpp"
#include "instanced_input.hpp"
#include "spacebvh/tools/make_tree.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/scene_file.hpp"
#include "spacebvh/tree_file.hpp"
#include "tree_option.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

namespace {

struct BuildOptions {
    std::string source;
    SceneOptions scene;
    BuildCliOptions build;
    CommonOptions common;
    bool no_epo = false;
    std::string save_path;
};

// The tree built over the scene and what was measured of it.
struct BuiltTree {
    const Scene& scene;
    const TreeRecipe& recipe;
    Bvh bvh{};
    double build_ms = 0;
    size_t build_peak_rss = 0;  // before the metrics and the traversal layout
    TreeStats stats{};
    size_t layout_bytes = 0;  // the binary kernel's traversal layout
};

BuiltTree build_and_measure(const Scene& scene, const TreeRecipe& recipe, bool with_epo) {
    BuiltTree built{scene, recipe};
    const auto start = std::chrono::steady_clock::now();
    built.bvh = build_tree(scene, recipe);
    built.build_ms = milliseconds_since(start);
    built.build_peak_rss = peak_rss_bytes();
    built.stats = compute_tree_stats(scene, built.bvh, recipe.cost, with_epo);
    built.layout_bytes = Tracer(scene, built.bvh, Kernel::binary).memory_bytes();
    return built;
}

void print_tree(const BuildOptions& options, const BuiltTree& built) {
    const TreeRecipe& recipe = built.recipe;
    const TreeStats& stats = built.stats;
    std::printf("scene            %s (%zu triangles)\n", built.scene.name.c_str(), built.scene.triangles.size());
    std::printf("builder          %s, %u threads\n", built.bvh.builder.c_str(), options.common.effective_threads());
    std::printf("cost model       %s, max leaf %u, max depth %u, lookahead %u, reinsertion iterations %u\n",
                recipe.cost.describe().c_str(), recipe.limits.max_leaf_size, recipe.limits.max_depth,
                recipe.lookahead.depth, recipe.reinsertion.iterations);
    std::printf("build            %.1f ms\n", built.build_ms);
    std::printf("nodes            %zu (%zu inner, %zu leaves)\n", stats.nodes, stats.inner_nodes, stats.leaves);
    std::printf("depth            max %u, mean leaf %.2f\n", stats.max_depth, stats.mean_leaf_depth);
    std::printf("references       %zu (%zu distinct triangles, %.3f per triangle)\n", stats.references,
                stats.distinct_primitives, double(stats.references) / double(built.scene.triangles.size()));
    std::printf("bytes            %zu tree, %zu traversal layout\n", stats.bytes, built.layout_bytes);
    std::printf("SAH              %.4f  (%s)\n", stats.sah, recipe.cost.describe().c_str());
    if (!options.no_epo) std::printf("EPO              %.4f\n", stats.epo);
}

// Memory at the end of the run, against the build's own estimate.
struct BuildMemory {
    size_t peak_rss = 0;
    uint64_t estimate = 0;
};

BuildMemory report_memory(const BuiltTree& built) {
    const BuildMemory memory{peak_rss_bytes(), estimate_tree_memory(built.scene, built.recipe)};
    std::printf(
        "peak memory      %.1f MiB (resident, whole process); %.1f MiB at the end of the build, of which "
        "%.1f MiB the scene; the build's estimate %.1f MiB\n",
        double(memory.peak_rss) / 1048576.0, double(built.build_peak_rss) / 1048576.0,
        double(built.scene.triangles.size() * sizeof(Triangle)) / 1048576.0, double(memory.estimate) / 1048576.0);
    return memory;
}

nlohmann::json build_json(const BuildOptions& options, const BuiltTree& built, const BuildMemory& memory) {
    const TreeRecipe& recipe = built.recipe;
    const TreeStats& stats = built.stats;
    nlohmann::json json = {
        {"scene", built.scene.name},
        {"triangles", built.scene.triangles.size()},
        {"builder", built.bvh.builder},
        {"threads", options.common.effective_threads()},
        {"cost",
         {{"C_T", recipe.cost.traversal_cost},
          {"C_I", recipe.cost.intersection_cost},
          {"C_o", std::isinf(recipe.cost.overlap_penalty) ? nlohmann::json("inf")
                                                          : nlohmann::json(recipe.cost.overlap_penalty)}}},
        {"lookahead_depth", recipe.lookahead.depth},
        {"lookahead_top_share", recipe.lookahead.top_share},
        {"reinsertion_iterations", recipe.reinsertion.iterations},
        {"build_ms", built.build_ms},
        {"peak_rss_bytes", memory.peak_rss},
        {"build_peak_rss_bytes", built.build_peak_rss},
        {"scene_bytes", built.scene.triangles.size() * sizeof(Triangle)},
        {"estimated_build_bytes", memory.estimate},
        {"nodes", stats.nodes},
        {"leaves", stats.leaves},
        {"max_depth", stats.max_depth},
        {"mean_leaf_depth", stats.mean_leaf_depth},
        {"references", stats.references},
        {"distinct_primitives", stats.distinct_primitives},
        {"bytes", stats.bytes},
        {"layout_bytes", built.layout_bytes},
        {"sah", stats.sah}};
    if (!options.no_epo) json["epo"] = stats.epo;
    if (!options.save_path.empty()) json["saved"] = options.save_path;
    return json;
}

// An instanced scene: its RenderScene built (each mesh's tree once, then the top levels) after the
// memory estimate is printed and checked against the limit.
void build_instances(const BuildOptions& options, const TreeRecipe& recipe) {
    const InstancedInput input(options.source, options.scene.transform());
    input.check_memory(recipe);
    const auto start = std::chrono::steady_clock::now();
    const std::shared_ptr<RenderScene> scene = input.build(SceneConfig{recipe, TracerConfig{}});
    const double build_ms = milliseconds_since(start);
    if (!options.save_path.empty()) save_render_scene(options.save_path, *scene, build_settings_text(recipe));
    const size_t peak = peak_rss_bytes();
    const uint64_t estimate = input.memory_estimate(recipe);
    std::printf("scene            %s (instanced: %zu meshes, %zu instances, %llu instanced triangles)\n",
                input.name().c_str(), input.meshes().size(), input.instance_count(),
                (unsigned long long)input.instanced_triangles());
    const std::string builder =
        options.build.quality.empty() ? options.build.builder : "--quality " + options.build.quality;
    std::printf("builder          %s (each mesh's tree), %u threads\n", builder.c_str(),
                options.common.effective_threads());
    std::printf("build            %.1f ms (every mesh's tree and layout, the instances, the top levels)\n", build_ms);
    std::printf(
        "bytes            %zu (the top scene: its top level and instances; the meshes' own scenes not "
        "counted)\n",
        scene->memory_bytes());
    std::printf("peak memory      %.1f MiB (resident, whole process); the build's estimate %.1f MiB\n",
                double(peak) / 1048576.0, double(estimate) / 1048576.0);
    if (!options.save_path.empty()) std::printf("saved            %s (a scene file)\n", options.save_path.c_str());
    nlohmann::json json = {{"scene", input.name()},
                           {"triangles", input.instanced_triangles()},
                           {"meshes", input.meshes().size()},
                           {"instances", input.instance_count()},
                           {"builder", builder},
                           {"threads", options.common.effective_threads()},
                           {"build_ms", build_ms},
                           {"bytes", scene->memory_bytes()},
                           {"peak_rss_bytes", peak},
                           {"estimated_build_bytes", estimate}};
    if (!options.save_path.empty()) json["saved"] = options.save_path;
    write_json(options.common.json_path, json);
}

}  // namespace

void add_build_command(CLI::App& app) {
    auto options = std::make_shared<BuildOptions>();
    CLI::App* command =
        app.add_subcommand("build", "build a BVH and print nodes, depth, references, bytes, SAH and EPO");
    command->add_option("scene", options->source, "scene file or builtin:NAME")->required();
    options->scene.add_to(*command);
    options->build.add_to(*command);
    options->common.add_to(*command);
    command->add_flag("--no-epo", options->no_epo, "skip the EPO metric (the slow one)");
    command->add_option("--save", options->save_path,
                        "save the tree to this file (docs/tree-format.md), for --tree of trace, render and compare");
    command->callback([options] {
        const auto limit = options->common.thread_limit();
        if (names_instanced_scene(options->source))
            return build_instances(*options, options->build.options(options->build.builder));
        const Scene scene = load_scene(options->source, options->scene.transform());
        TreeRecipe recipe = options->build.options(options->build.builder);
        Progress progress("building", options->common);
        recipe.hooks.progress = progress.callback();
        const BuiltTree built = build_and_measure(scene, recipe, !options->no_epo);
        print_tree(*options, built);
        if (!options->save_path.empty()) {
            save_bvh(options->save_path, built.bvh, built.scene.triangles, build_settings_text(built.recipe));
            std::printf("saved            %s\n", options->save_path.c_str());
        }
        const BuildMemory memory = report_memory(built);
        write_json(options->common.json_path, build_json(*options, built, memory));
    });
}

}  // namespace spacebvh::cli
