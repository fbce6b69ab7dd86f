// SPDX-License-Identifier: MIT
// spacebvh build SCENE --builder NAME [--save FILE]: build one tree, print its quality metrics, and
// optionally save it as a tree file.
#include <cmath>
#include <cstdio>

#include "cli_common.hpp"
#include "spacebvh/tools/make_tree.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tree_file.hpp"
#include "tree_option.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

void add_build_command(CLI::App& app) {
    struct Options {
        std::string source;
        SceneOptions scene;
        BuildCliOptions build;
        CommonOptions common;
        bool no_epo = false;
        std::string save_path;
    };
    auto options = std::make_shared<Options>();
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
        const Scene scene = load_scene(options->source, options->scene.transform());
        TreeRecipe build_options = options->build.options(options->build.builder);
        Progress progress("building", options->common);
        build_options.hooks.progress = progress.callback();
        const auto start = std::chrono::steady_clock::now();
        const Bvh bvh = build_tree(scene, build_options);
        const double build_ms = milliseconds_since(start);
        const size_t build_peak_rss = peak_rss_bytes();  // before the metrics and the tracer's layout
        const TreeStats stats = compute_tree_stats(scene, bvh, build_options.cost, !options->no_epo);
        const Tracer tracer(scene, bvh, Kernel::binary);

        std::printf("scene            %s (%zu triangles)\n", scene.name.c_str(), scene.triangles.size());
        std::printf("builder          %s, %u threads\n", bvh.builder.c_str(), options->common.effective_threads());
        std::printf("cost model       %s, max leaf %u, max depth %u, lookahead %u, reinsertion iterations %u\n",
                    build_options.cost.describe().c_str(), build_options.limits.max_leaf_size,
                    build_options.limits.max_depth, build_options.lookahead.depth,
                    build_options.reinsertion.iterations);
        std::printf("build            %.1f ms\n", build_ms);
        std::printf("nodes            %zu (%zu inner, %zu leaves)\n", stats.nodes, stats.inner_nodes, stats.leaves);
        std::printf("depth            max %u, mean leaf %.2f\n", stats.max_depth, stats.mean_leaf_depth);
        std::printf("references       %zu (%zu distinct triangles, %.3f per triangle)\n", stats.references,
                    stats.distinct_primitives, double(stats.references) / double(scene.triangles.size()));
        std::printf("bytes            %zu tree, %zu traversal layout\n", stats.bytes, tracer.memory_bytes());
        std::printf("SAH              %.4f  (%s)\n", stats.sah, build_options.cost.describe().c_str());
        if (!options->no_epo) std::printf("EPO              %.4f\n", stats.epo);
        if (!options->save_path.empty()) {
            save_bvh(options->save_path, bvh, scene.triangles, build_settings_text(build_options));
            std::printf("saved            %s\n", options->save_path.c_str());
        }
        const size_t peak_rss = peak_rss_bytes();
        const uint64_t estimate = estimate_tree_memory(scene, build_options);
        std::printf(
            "peak memory      %.1f MiB (resident, whole process); %.1f MiB at the end of the build, of which "
            "%.1f MiB the scene; the build's estimate %.1f MiB\n",
            double(peak_rss) / 1048576.0, double(build_peak_rss) / 1048576.0,
            double(scene.triangles.size() * sizeof(Triangle)) / 1048576.0, double(estimate) / 1048576.0);

        nlohmann::json json = {{"scene", scene.name},
                               {"triangles", scene.triangles.size()},
                               {"builder", bvh.builder},
                               {"threads", options->common.effective_threads()},
                               {"cost",
                                {{"C_T", build_options.cost.traversal_cost},
                                 {"C_I", build_options.cost.intersection_cost},
                                 {"C_o", std::isinf(build_options.cost.overlap_penalty)
                                             ? nlohmann::json("inf")
                                             : nlohmann::json(build_options.cost.overlap_penalty)}}},
                               {"lookahead_depth", build_options.lookahead.depth},
                               {"lookahead_top_share", build_options.lookahead.top_share},
                               {"reinsertion_iterations", build_options.reinsertion.iterations},
                               {"build_ms", build_ms},
                               {"peak_rss_bytes", peak_rss},
                               {"build_peak_rss_bytes", build_peak_rss},
                               {"scene_bytes", scene.triangles.size() * sizeof(Triangle)},
                               {"estimated_build_bytes", estimate},
                               {"nodes", stats.nodes},
                               {"leaves", stats.leaves},
                               {"max_depth", stats.max_depth},
                               {"mean_leaf_depth", stats.mean_leaf_depth},
                               {"references", stats.references},
                               {"distinct_primitives", stats.distinct_primitives},
                               {"bytes", stats.bytes},
                               {"layout_bytes", tracer.memory_bytes()},
                               {"sah", stats.sah}};
        if (!options->no_epo) json["epo"] = stats.epo;
        if (!options->save_path.empty()) json["saved"] = options->save_path;
        write_json(options->common.json_path, json);
    });
}

}  // namespace spacebvh::cli
