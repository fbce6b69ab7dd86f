// SPDX-License-Identifier: MIT
// The option groups the subcommands share (scene transform, build recipe, threads and output, camera),
// their value parsers, and building the tree a recipe names.
#pragma once

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include <memory>
#include <string>
#include <vector>

#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"
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

// A tree to build: one of our presets, or one of Embree's trees ("embree-high"), with its configuration.
struct TreeRecipe : BuildConfig {
    std::string builder;
    // Bounce rays traced on a quick tree to fill termination.segments before the build (0 = off).
    uint32_t termination_rays = 0;
};

struct BuildCliOptions {
    std::string builder = "binned";
    float traversal_cost = 1.0f, intersection_cost = 1.0f;
    uint32_t leaf_block = 1;
    std::string overlap_penalty;  // a number or "inf"; empty: the builder's own default
    uint32_t max_leaf_size = 8, max_depth = 64, bins = 32, spatial_bins = 32;
    float reference_budget = 1.3f;
    std::string memory_limit;  // "8G", "512M", bytes; empty: the memory available
    std::string spatial_gate;  // a number; empty: the builder's own
    bool no_unsplitting = false;
    std::string search;  // "object,spatial,grid"; empty: the builder's own search spaces
    float grid_resolution = 1.0f;
    uint32_t grid_max_cells = 8;
    bool no_grid_splitting = false;
    uint32_t lookahead = 0, lookahead_candidates = 2;
    float lookahead_top = 0;
    bool spatial_sweep = false;
    uint32_t sweep_samples = 0;
    uint32_t termination_rays = 0;
    float termination_shrinkage = 32.0f;
    uint32_t termination_candidates = 4;
    bool no_termination_split = false;
    uint32_t termination_optimize = 0;
    float termination_prior = 64.0f;
    bool optimize = false;  // reinsertion optimisation after the build
    uint32_t optimize_iterations = kDefaultReinsertionIterations;
    const CLI::Option* optimize_iterations_option = nullptr;  // given: implies --optimize

    void add_to(CLI::App& command, bool with_builder = true);
    // Options for a builder name; "NAME+opt" (e.g. binned+opt, embree-high+opt) turns the
    // reinsertion optimisation on for that tree as --optimize does.
    TreeRecipe options(const std::string& builder_name) const;
};

// "binned+opt" -> "binned", returning true; other names are left as they are.
bool strip_optimize_suffix(std::string& builder_name);

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

Bvh build_tree(const Scene& scene, const TreeRecipe& recipe);
// What build_tree is estimated to allocate at its peak beyond the scene (our builders' estimate, or
// Embree's trees').
uint64_t estimated_build_bytes(const Scene& scene, const TreeRecipe& recipe);
std::string builder_list();  // for --help
// --help text of --kernel: the kernels make_tracer knows on this CPU.
std::string kernel_help();

float parse_float_or_inf(const std::string& text, const char* what);
uint32_t parse_unsigned(const std::string& text, const char* what);
// "12345", "512K", "8M", "1.5G", "2T" (powers of 1024) -> bytes. Throws Error naming `what`.
uint64_t parse_bytes(const std::string& text, const char* what);

}  // namespace spacebvh::cli
