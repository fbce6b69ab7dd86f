// SPDX-License-Identifier: MIT
// spacebvh rays SCENE --kind random|primary|diffuse|bounce|area: write a ray file (docs/rays.md; bounce
// and area are the view-independent samples of spacebvh/tools/sample_rays.hpp).
#include <cstdio>

#include "cli_common.hpp"
#include "ray_sets.hpp"
#include "spacebvh/tools/sample_rays.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

void add_rays_command(CLI::App& app) {
    struct Options {
        std::string source, kind = "random", output;
        size_t count = 1000000;
        uint64_t seed = 1;
        float epsilon = 0.0f;
        SceneOptions scene;
        CameraOptions camera;
        CommonOptions common;
    };
    auto options = std::make_shared<Options>();
    CLI::App* command = app.add_subcommand(
        "rays", "generate a ray set (random, primary, diffuse, or a bounce or area sample) as a ray file");
    command->add_option("scene", options->source, "scene file or builtin:NAME")->required();
    command
        ->add_option("--kind,-k", options->kind,
                     "random, primary, diffuse, bounce (bounces off random rays' hits) or area (bounces off "
                     "area-weighted surface points)")
        ->capture_default_str();
    command->add_option("--count,-n", options->count, "number of random, bounce or area rays")->capture_default_str();
    command->add_option("--seed", options->seed, "splitmix64 seed (random, diffuse, bounce, area)")
        ->capture_default_str();
    command->add_option("--epsilon", options->epsilon, "bounce origin offset (default 1e-4 x scene diagonal)");
    command->add_option("--output,-o", options->output, "ray file to write")->required();
    options->scene.add_to(*command);
    options->camera.add_to(*command);
    options->common.add_to(*command);
    command->callback([options] {
        const auto limit = options->common.thread_limit();
        if (options->count == 0 || options->count > (size_t(1) << 31)) throw Error("--count must be in [1, 2^31]");
        const SceneTransform transform = options->scene.transform();
        if (options->kind == "bounce" || options->kind == "area") {
            const SampleKind sample = parse_sample_kind(options->kind);
            const Scene scene = load_scene(options->source, transform);
            const Bvh tree = sample == SampleKind::bounce ? spacebvh::build(scene, BuildConfig{}) : Bvh{};
            const Tracer tracer(scene, tree, Kernel::binary);
            const std::vector<Ray> rays =
                generate_sample_rays(sample, scene, tracer, options->count, options->seed, options->epsilon);
            write_ray_file(options->output, rays);
            std::printf("wrote %zu %s rays to %s\n", rays.size(), to_string(sample), options->output.c_str());
            return;
        }
        if (options->kind != "random" && options->kind != "primary" && options->kind != "diffuse")
            throw Error("--kind: unknown ray kind '" + options->kind +
                        "' (expected random, primary, diffuse, bounce or area)");
        const RayKind kind = parse_ray_kind(options->kind);
        const Scene scene = load_scene(options->source, transform);
        RaySetParameters parameters;
        parameters.random_count = options->count;
        parameters.seed = options->seed;
        parameters.camera = options->camera.camera_for(scene, options->source, transform);
        parameters.width = options->camera.width;
        parameters.height = options->camera.height;
        parameters.diffuse_epsilon = options->epsilon;
        std::optional<Tracer> tracer;
        if (kind == RayKind::diffuse) tracer.emplace(scene, spacebvh::build(scene, BuildConfig{}));
        const Bvh no_tree;
        const Tracer empty_tracer(scene, no_tree, Kernel::binary);
        const std::vector<Ray> rays = make_ray_set(kind, scene, tracer ? *tracer : empty_tracer, parameters);
        write_ray_file(options->output, rays);
        std::printf("wrote %zu %s rays to %s\n", rays.size(), to_string(kind), options->output.c_str());
    });
}

}  // namespace spacebvh::cli
