// SPDX-License-Identifier: MIT
#include "tree_option.hpp"

#include <cmath>
#include <filesystem>
#include <sstream>

#include "cli_common.hpp"
#include "instanced_input.hpp"
#include "spacebvh/scene_file.hpp"

namespace spacebvh::cli {

void TreeOption::add_to(CLI::App& command, const std::string& help) {
    CLI::Option* option = command.add_option("--tree", path, help);
    for (const char* name : {"--builder", "--quality"})
        if (CLI::Option* other = command.get_option_no_throw(name)) option->excludes(other);
}

Bvh tree_for(const TreeOption& tree, const Scene& scene, const TreeRecipe& options, double* milliseconds) {
    if (tree.given() && is_scene_file(tree.path))
        throw Error("--tree: " + tree.path + " is a scene file (build --save of an instanced scene); " + scene.name +
                    " is one mesh: give the tree file its build --save wrote");
    const auto start = std::chrono::steady_clock::now();
    Bvh bvh = build_tree(scene, tree.given() ? TreeRecipe::from_file(tree.path) : options);
    if (milliseconds) *milliseconds = milliseconds_since(start);
    return bvh;
}

namespace {

// Throws Error when the loaded scene file is not the scene `input` describes: its counts differ, or its
// world box is not the input's (up to the input box's float slack, 1e-5 of its diagonal).
void check_same_scene(const std::string& path, const SceneFileInfo& info, const RenderScene& loaded,
                      const InstancedInput& input) {
    uint64_t triangles = 0;
    for (const Scene& mesh : input.meshes()) triangles += mesh.triangles.size();
    const std::string is = "--tree: " + path + " is not a scene file of " + input.name() + ": it holds ";
    if (info.mesh_count != input.meshes().size() || info.triangle_count != triangles)
        throw Error(is + std::to_string(info.mesh_count) + " meshes of " + std::to_string(info.triangle_count) +
                    " triangles, the scene " + std::to_string(input.meshes().size()) + " of " +
                    std::to_string(triangles));
    if (loaded.geometry_count() != input.instance_count())
        throw Error(is + std::to_string(loaded.geometry_count()) + " instances, the scene " +
                    std::to_string(input.instance_count()));
    const AABB a = loaded.bounds(), b = input.bounds();
    const double slack = 1e-5 * length(b.extent());
    for (int axis = 0; axis < 3; ++axis)
        if (std::abs(double(a.lo[axis]) - double(b.lo[axis])) > slack ||
            std::abs(double(a.hi[axis]) - double(b.hi[axis])) > slack)
            throw Error(is + "another world box (another transform or scene)");
}

}  // namespace

std::shared_ptr<RenderScene> scene_for(const TreeOption& tree, const InstancedInput& input, const SceneConfig& config,
                                       double* milliseconds) {
    const auto start = std::chrono::steady_clock::now();
    std::shared_ptr<RenderScene> scene;
    if (!tree.given()) {
        scene = input.build(config);
    } else {
        std::error_code error;
        if (std::filesystem::is_regular_file(tree.path, error) && !is_scene_file(tree.path))
            throw Error("--tree: " + tree.path + " is not a scene file; " + input.name() +
                        " is an instanced scene: give the file `spacebvh build " + input.name() +
                        " --save FILE` wrote");
        SceneFileInfo info;
        scene = load_render_scene(tree.path, SceneLoadOptions{config.tracer}, &info);
        check_same_scene(tree.path, info, *scene, input);
    }
    if (milliseconds) *milliseconds = milliseconds_since(start);
    return scene;
}

std::string build_settings_text(const TreeRecipe& options) {
    std::ostringstream text;
    text << "builder=" << options.builder << " " << options.cost.describe()
         << " max_leaf=" << options.limits.max_leaf_size << " max_depth=" << options.limits.max_depth
         << " bins=" << options.object.bins << " spatial_bins=" << options.spatial.bins
         << " budget=" << options.limits.reference_budget << " unsplitting=" << options.spatial.unsplitting
         << " spatial_gate=" << options.spatial.gate_alpha
         << " search=" << (options.search_spaces ? search_space_names(options.search_spaces) : "preset")
         << " grid_resolution=" << options.grid.resolution << " grid_max=" << options.grid.max_cells
         << " grid_splitting=" << options.grid.splitting << " lookahead=" << options.lookahead.depth
         << " lookahead_candidates=" << options.lookahead.candidates << " lookahead_top=" << options.lookahead.top_share
         << " spatial_sweep=" << options.spatial.exact_sweep
         << " sweep_samples=" << options.spatial.sweep_interior_samples
         << " reinsertion_iterations=" << options.reinsertion.iterations;
    return text.str();
}

}  // namespace spacebvh::cli
