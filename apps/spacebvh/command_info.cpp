// SPDX-License-Identifier: MIT
// spacebvh info SCENE: what a scene holds.
#include <cstdio>

#include "cli_common.hpp"
#include "instanced_input.hpp"
#include "spacebvh/memory_estimate.hpp"
#include "spacebvh/scene_file.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

namespace {

void print_camera(const Camera& camera) {
    std::printf("camera      %g,%g,%g,%g,%g,%g,%g,%g,%g,%g\n", camera.eye.x, camera.eye.y, camera.eye.z,
                camera.target.x, camera.target.y, camera.target.z, camera.up.x, camera.up.y, camera.up.z,
                camera.fovy_degrees);
}

nlohmann::json box_json(const AABB& bounds) {
    return {{bounds.lo.x, bounds.lo.y, bounds.lo.z}, {bounds.hi.x, bounds.hi.y, bounds.hi.z}};
}

// An instanced scene: its meshes, instances, instanced triangles and the memory its build takes.
nlohmann::json info_of_instances(const std::string& source, const SceneTransform& transform) {
    const auto start = std::chrono::steady_clock::now();
    const InstancedInput input(source, transform);
    const double load_ms = milliseconds_since(start);
    const AABB bounds = input.bounds();
    uint64_t triangles = 0, degenerate = 0;
    for (const Scene& mesh : input.meshes()) {
        triangles += mesh.triangles.size();
        degenerate += mesh.degenerate_count;
    }
    const TreeRecipe recipe = TreeRecipe::for_builder("binned");
    const uint64_t estimate = input.memory_estimate(recipe);
    std::printf("scene       %s (instanced)\n", input.name().c_str());
    std::printf("meshes      %zu (%llu triangles, %llu degenerate: kept, never hit)\n", input.meshes().size(),
                (unsigned long long)triangles, (unsigned long long)degenerate);
    for (const Scene& mesh : input.meshes())
        std::printf("  mesh      %s: %zu triangles\n", mesh.name.c_str(), mesh.triangles.size());
    std::printf("instances   %zu (%zu placements of a mesh)\n", input.instance_count(), input.placements().size());
    std::printf("instanced   %llu triangles\n", (unsigned long long)input.instanced_triangles());
    std::printf("bounds      (%g, %g, %g) -> (%g, %g, %g)\n", bounds.lo.x, bounds.lo.y, bounds.lo.z, bounds.hi.x,
                bounds.hi.y, bounds.hi.z);
    std::printf("diagonal    %g\n", length(bounds.extent()));
    print_camera(input.default_camera());
    std::printf(
        "memory      %s estimated to build it with binned (each mesh's tree once, the instances, the top "
        "levels)\n",
        format_bytes(estimate).c_str());
    std::printf("load        %.1f ms\n", load_ms);
    return {{"scene", input.name()},
            {"meshes", input.meshes().size()},
            {"instances", input.instance_count()},
            {"triangles", triangles},
            {"degenerate_triangles", degenerate},
            {"instanced_triangles", input.instanced_triangles()},
            {"estimated_build_bytes", estimate},
            {"bounds", box_json(bounds)},
            {"diagonal", length(bounds.extent())},
            {"load_ms", load_ms}};
}

// A scene file (build SCENE --save): what it holds, loaded and validated as --tree loads it.
nlohmann::json info_of_scene_file(const std::string& path) {
    const auto start = std::chrono::steady_clock::now();
    SceneFileInfo info;
    const std::shared_ptr<RenderScene> scene = load_render_scene(path, {}, &info);
    const double load_ms = milliseconds_since(start);
    const AABB bounds = scene->bounds();
    std::printf("scene file  %s (format version %u, scene '%s')\n", path.c_str(), info.format_version,
                scene->name().c_str());
    std::printf("scenes      %llu (the saved one and those it instances)\n", (unsigned long long)info.scene_count);
    std::printf("meshes      %llu (%llu triangles)\n", (unsigned long long)info.mesh_count,
                (unsigned long long)info.triangle_count);
    std::printf("instances   %llu (over all its scenes, not multiplied out)\n",
                (unsigned long long)info.instance_count);
    std::printf("bounds      (%g, %g, %g) -> (%g, %g, %g)\n", bounds.lo.x, bounds.lo.y, bounds.lo.z, bounds.hi.x,
                bounds.hi.y, bounds.hi.z);
    std::printf("settings    %s\n", info.settings.c_str());
    std::printf("memory      %s (the loaded scene's layouts)\n", format_bytes(scene->memory_bytes()).c_str());
    std::printf("load        %.1f ms\n", load_ms);
    return {{"scene_file", path},
            {"scene", scene->name()},
            {"format_version", info.format_version},
            {"scenes", info.scene_count},
            {"meshes", info.mesh_count},
            {"instances", info.instance_count},
            {"triangles", info.triangle_count},
            {"settings", info.settings},
            {"bounds", box_json(bounds)},
            {"load_ms", load_ms}};
}

}  // namespace

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
    command
        ->add_option("scene", options->source,
                     "scene file (.obj .ply .gltf .glb), builtin:NAME, an instanced scene (builtin:forest:N) or a "
                     "scene file that build --save wrote")
        ->required();
    options->scene.add_to(*command);
    add_manifest_option(*command, options->manifest);
    options->common.add_to(*command);
    command->callback([options] {
        const SceneTransform transform = options->scene.transform();
        if (is_scene_file(options->source))
            return write_json(options->common.json_path, info_of_scene_file(options->source));
        if (names_instanced_scene(options->source))
            return write_json(options->common.json_path, info_of_instances(options->source, transform));
        const auto start = std::chrono::steady_clock::now();
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
        print_camera(camera);
        std::printf("load        %.1f ms\n", load_ms);
        nlohmann::json json = {{"scene", scene.name},
                               {"triangles", scene.triangles.size()},
                               {"degenerate_triangles", scene.degenerate_count},
                               {"bounds", box_json(bounds)},
                               {"diagonal", scene.diagonal()},
                               {"load_ms", load_ms}};
        write_json(options->common.json_path, json);
    });
}

}  // namespace spacebvh::cli
