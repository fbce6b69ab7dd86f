// SPDX-License-Identifier: MIT
// Tree files on the command line: `build --save FILE` writes the built tree, `--tree FILE` on trace,
// render and compare uses a saved tree in place of building one (include/spacebvh/tree_file.hpp); for
// an instanced SCENE both are scene files (include/spacebvh/scene_file.hpp).
#pragma once

#include <CLI/CLI.hpp>

#include <memory>
#include <string>

#include "cli_common.hpp"
#include "spacebvh/bvh.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

struct TreeOption {
    std::string path;

    // Adds --tree to the command, exclusive with --builder where the command has one (the file
    // names the tree's builder). `help` says what the command does with the tree.
    void add_to(CLI::App& command, const std::string& help);
    bool given() const { return !path.empty(); }
};

// The tree a command uses: loaded from --tree when given (validated against the scene's triangles:
// another scene or transform is an error), else built with `options`. `milliseconds` gets the load
// or build time.
Bvh tree_for(const TreeOption& tree, const Scene& scene, const TreeRecipe& options, double* milliseconds = nullptr);

class InstancedInput;

// The RenderScene a command traces for an instanced SCENE: loaded from --tree when given (a scene file
// of `build SCENE --save`, traced by config.tracer; a file of another scene, told by its meshes,
// triangles, instances or world box, is an error, as is a one-mesh tree file), else built by `input`
// with `config`. `milliseconds` gets the load or build time.
std::shared_ptr<RenderScene> scene_for(const TreeOption& tree, const InstancedInput& input, const SceneConfig& config,
                                       double* milliseconds = nullptr);

// The build flags as text stored in a saved tree file (informative: loading does not read them).
std::string build_settings_text(const TreeRecipe& options);

}  // namespace spacebvh::cli
