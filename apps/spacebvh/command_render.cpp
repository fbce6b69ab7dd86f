// SPDX-License-Identifier: MIT
// spacebvh render SCENE -o image.png [--heatmap]: a shaded picture or a traversal-cost heat map.
#include <cstdio>

#include "cli_common.hpp"
#include "instanced_input.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tools/render.hpp"
#include "tree_option.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

namespace {

struct RenderOptions {
    std::string source, output, kernel = "auto";
    bool heatmap = false;
    std::string quantity = "work";
    double scale_max = 0.0;
    SceneOptions scene;
    BuildCliOptions build;
    CameraOptions camera;
    CommonOptions common;
    TreeOption tree;
};

// An instanced scene, shaded (its RenderScene built with the recipe, traced by the single-ray kernel
// --kernel names); heat maps count one tree's work and are refused.
void render_instances(const RenderOptions& options) {
    if (options.heatmap)
        throw Error("--heatmap: the traversal statistics are the one-mesh kernels'; scenes do not count them");
    const InstancedInput input(options.source, options.scene.transform());
    const TreeRecipe recipe = options.build.options(options.build.builder);
    const TracerConfig tracer = instanced_scene_kernel(options.kernel);
    const Camera camera = options.camera.camera.empty() ? input.default_camera() : Camera::parse(options.camera.camera);
    input.check_memory(recipe);
    const std::shared_ptr<RenderScene> scene = scene_for(options.tree, input, SceneConfig{recipe, tracer});
    const uint32_t width = options.camera.width, height = options.camera.height;
    if (width == 0 || height == 0 || width > kMaxImageSide || height > kMaxImageSide)
        throw Error("--width and --height must be in [1, " + std::to_string(kMaxImageSide) + "]");
    const auto normal = [&](const Ray& ray) -> std::optional<Vec3> {
        const SceneHit hit = scene->intersect(ray);
        if (!hit.is_hit()) return std::nullopt;
        return input.world_triangle(hit).geometric_normal();
    };
    write_png(options.output, render_shaded(normal, camera, width, height));
    std::printf("wrote %s (%ux%u, shaded, scene %s with %zu instances, builder %s)\n", options.output.c_str(), width,
                height, input.name().c_str(), input.instance_count(), options.build.builder.c_str());
    write_json(options.common.json_path, {{"output", options.output}, {"builder", options.build.builder}});
}

}  // namespace

void add_render_command(CLI::App& app) {
    auto options = std::make_shared<RenderOptions>();
    CLI::App* command = app.add_subcommand("render", "render a shaded image or a heat map of traversal cost per pixel");
    command->add_option("scene", options->source, "scene file or builtin:NAME")->required();
    command->add_option("--output,-o", options->output, "PNG file to write")->required();
    command->add_flag("--heatmap", options->heatmap, "colour pixels by traversal cost, with a colour legend");
    command
        ->add_option("--quantity", options->quantity, "heat map quantity: work (nodes + triangles), nodes, triangles")
        ->capture_default_str();
    command->add_option("--scale-max", options->scale_max,
                        "fixed top of the heat map's colour scale (default: the 99th percentile of this picture)");
    options->scene.add_to(*command);
    command->add_option("--kernel", options->kernel, kernel_help() + "; heat maps count that kernel's work")
        ->capture_default_str();
    options->build.add_to(*command);
    options->camera.add_to(*command);
    options->common.add_to(*command);
    options->tree.add_to(*command, "render with this saved tree (build --save) instead of building one");
    command->callback([options] {
        const auto limit = options->common.thread_limit();
        if (names_instanced_scene(options->source)) return render_instances(*options);
        const SceneTransform transform = options->scene.transform();
        const Scene scene = load_scene(options->source, transform);
        const Camera camera = options->camera.camera_for(scene, options->source, transform);
        const TreeRecipe build_options = options->build.options(options->build.builder);
        const Bvh bvh = tree_for(options->tree, scene, build_options);
        const std::unique_ptr<Tracer> tracer_pointer = make_tracer(options->kernel, scene, bvh);
        const Tracer& tracer = *tracer_pointer;
        const uint32_t width = options->camera.width, height = options->camera.height;
        if (!options->heatmap) {
            write_png(options->output, render_shaded(scene, tracer, camera, width, height));
            std::printf("wrote %s (%ux%u, shaded, builder %s)\n", options->output.c_str(), width, height,
                        bvh.builder.c_str());
            return;
        }
        HeatmapOptions heatmap;
        heatmap.scale_max = options->scale_max;
        heatmap.quantity = parse_heatmap_quantity(options->quantity);
        HeatmapInfo info;
        write_png(options->output, render_heatmap(scene, tracer, camera, width, height, &info, heatmap));
        const double pixels = double(width) * height;
        std::printf(
            "wrote %s (%ux%u heat map of %s, builder %s, %s): mean %.1f, max %llu, colour scale top %.1f; "
            "per ray %.2f nodes, %.2f triangles\n",
            options->output.c_str(), width, height, options->quantity.c_str(), bvh.builder.c_str(),
            (options->tree.given() ? bvh.cost : build_options.cost).describe().c_str(), info.mean_value,
            (unsigned long long)info.max_value, info.scale_max, double(info.totals.nodes_visited) / pixels,
            double(info.totals.triangles_tested) / pixels);
        write_json(options->common.json_path, {{"output", options->output},
                                               {"builder", bvh.builder},
                                               {"mean", info.mean_value},
                                               {"max", info.max_value},
                                               {"scale_max", info.scale_max}});
    });
}

}  // namespace spacebvh::cli
