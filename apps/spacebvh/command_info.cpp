// SPDX-License-Identifier: MIT
// spacebvh info SCENE: what a scene holds.
#include <cstdio>

#include "cli_common.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

void add_info_command(CLI::App& app) {
    struct Options {
        std::string source;
        SceneOptions scene;
        std::string manifest;
        CommonOptions common;
    };
    auto options = std::make_shared<Options>();
    CLI::App* command =
        app.add_subcommand("info", "print a scene's triangle count, degenerate triangles, bounds and camera");
    command->add_option("scene", options->source, "scene file (.obj .ply .gltf .glb) or builtin:NAME")->required();
    options->scene.add_to(*command);
    add_manifest_option(*command, options->manifest);
    options->common.add_to(*command);
    command->callback([options] {
        const auto start = std::chrono::steady_clock::now();
        const SceneTransform transform = options->scene.transform();
        const Scene scene = load_scene(options->source, transform);
        const double load_ms = milliseconds_since(start);
        const AABB bounds = scene.bounds();
        const Camera camera = camera_for_scene(scene, options->source, transform, options->manifest);
        std::printf("scene       %s\n", scene.name.c_str());
        std::printf("triangles   %zu (%zu degenerate: kept, never hit)\n", scene.triangles.size(),
                    scene.degenerate_count);
        std::printf("bounds      (%g, %g, %g) -> (%g, %g, %g)\n", bounds.lo.x, bounds.lo.y, bounds.lo.z, bounds.hi.x,
                    bounds.hi.y, bounds.hi.z);
        std::printf("diagonal    %g\n", scene.diagonal());
        std::printf("camera      %g,%g,%g,%g,%g,%g,%g,%g,%g,%g\n", camera.eye.x, camera.eye.y, camera.eye.z,
                    camera.target.x, camera.target.y, camera.target.z, camera.up.x, camera.up.y, camera.up.z,
                    camera.fovy_degrees);
        std::printf("load        %.1f ms\n", load_ms);
        nlohmann::json json = {
            {"scene", scene.name},
            {"triangles", scene.triangles.size()},
            {"degenerate_triangles", scene.degenerate_count},
            {"bounds", {{bounds.lo.x, bounds.lo.y, bounds.lo.z}, {bounds.hi.x, bounds.hi.y, bounds.hi.z}}},
            {"diagonal", scene.diagonal()},
            {"load_ms", load_ms}};
        write_json(options->common.json_path, json);
    });
}

}  // namespace spacebvh::cli
