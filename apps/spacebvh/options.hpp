// SPDX-License-Identifier: MIT
// The option groups the subcommands share (scene transform, build recipe, threads and output, camera),
// and building the tree a recipe names.
#pragma once

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include <memory>
#include <string>
#include <vector>

#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/recipe.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;

struct SceneOptions {
    std::string rotate;  // "x:45,y:45,z:45"
    float scale = 1.0f;
    std::vector<float> translate;

    void add_to(CLI::App& command);
    SceneTransform transform() const;
};

// The build settings as options of a command: one per entry of the settings table
// (spacebvh/settings.hpp), made from it, plus the builder and --optimize.
struct BuildCliOptions {
    std::string builder = "binned";
    // A quality level in place of a builder (--quality fast|balanced|high: BuildConfig::for_quality);
    // empty: the builder decides.
    std::string quality;
    bool optimize = false;  // reinsertion optimisation with the default effort, as NAME+opt
    // Per setting, in build_settings() order: the text given, and the option (null before add_to).
    std::vector<std::string> values;
    std::vector<const CLI::Option*> given;

    void add_to(CLI::App& command, bool with_builder = true);
    // The recipe of a builder name (TreeRecipe::for_builder: also "NAME+opt" and Embree's trees), or of
    // --quality when given (TreeRecipe::for_quality), with the settings given on the command line, validated.
    TreeRecipe options(const std::string& builder_name) const;
};

struct CommonOptions {
    unsigned threads = 0;  // 0: all cores
    bool quiet = false;
    bool progress = false;  // progress lines even when stderr is not a terminal
    std::string json_path;

    void add_to(CLI::App& command);
    // Limits oneTBB to `threads` for the lifetime of the returned object.
    std::unique_ptr<tbb::global_control> thread_limit() const;
    unsigned effective_threads() const;
};

// --manifest FILE (default $SPACEBVH_SCENE_MANIFEST): the MANIFEST.md whose camera table gives a scene file's camera.
void add_manifest_option(CLI::App& command, std::string& manifest);

struct CameraOptions {
    std::string camera;    // "ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy"
    std::string manifest;  // see add_manifest_option; empty: no manifest
    uint32_t width = 1024, height = 1024;

    void add_to(CLI::App& command);
    Camera camera_for(const Scene& scene, const std::string& source, const SceneTransform& transform) const;
};

// tools::make_tree, stopped by Ctrl-C (our builders poll the flag; Embree's finish, then it stops).
Bvh build_tree(const Scene& scene, const TreeRecipe& recipe);
std::string builder_list();  // for --help
// --help text of --kernel: the kernels make_tracer knows on this CPU.
std::string kernel_help();

}  // namespace spacebvh::cli
