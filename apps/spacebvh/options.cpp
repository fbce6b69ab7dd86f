// SPDX-License-Identifier: MIT
#include "options.hpp"

#include "progress.hpp"
#include "spacebvh/memory_estimate.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/sample_rays.hpp"
#include "spacebvh/trace.hpp"

#include <tbb/info.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>

#include "spacebvh/tools/embree_builder.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh::cli {

// The seed of the termination-aware build's bounce rays: fixed, so a recipe names one tree.
constexpr uint64_t kTerminationSeed = 0x7E55A11;

using namespace spacebvh::tools;

void SceneOptions::add_to(CLI::App& command) {
    command.add_option("--rotate", rotate, "rotate every vertex at load time, degrees: x:45,y:45,z:45 (R = Rz*Ry*Rx)");
    command.add_option("--scale", scale, "uniform scale applied after the rotation");
    command.add_option("--translate", translate, "translation applied last: X Y Z")->expected(3);
}

SceneTransform SceneOptions::transform() const {
    SceneTransform transform;
    if (!rotate.empty()) transform.rotate_degrees = SceneTransform::parse_rotation(rotate);
    transform.scale = scale;
    if (translate.size() == 3) transform.translate = {translate[0], translate[1], translate[2]};
    if (const char* reason = transform.invalid_reason()) throw Error("--" + std::string(reason));
    return transform;
}

float parse_float_or_inf(const std::string& text, const char* what) {
    if (text == "inf" || text == "infinity" || text == "Inf") return kInfinity;
    try {
        size_t used = 0;
        const float value = std::stof(text, &used);
        if (used != text.size()) throw std::invalid_argument(text);
        return value;
    } catch (const std::exception&) {
        throw Error(std::string(what) + ": expected a number or 'inf', got '" + text + "'");
    }
}

void BuildCliOptions::add_to(CLI::App& command, bool with_builder) {
    if (with_builder) {
        command.add_option("--builder,-b", builder, "builder: " + builder_list())->capture_default_str();
    }
    command.add_option("--ct", traversal_cost, "C_T, cost of a traversal step")->capture_default_str();
    command.add_option("--ci", intersection_cost, "C_I, cost of a triangle test")->capture_default_str();
    command
        .add_option("--leaf-block", leaf_block,
                    "B: the SAH counts references in whole blocks of B (power of two; 4 = the kernels' packs of four, "
                    "as Embree's SAH; 1 = plain SAH)")
        ->capture_default_str();
    command.add_option("--co", overlap_penalty,
                       "C_o, overlap penalty (0 = plain SAH, inf = disjoint children only; default: the builder's)");
    command.add_option("--max-leaf", max_leaf_size, "largest leaf (nodes with more references are split)")
        ->capture_default_str();
    command.add_option("--max-depth", max_depth, "deepest level; nodes there become leaves")->capture_default_str();
    command.add_option("--bins", bins, "bins per axis of the binned object search space")->capture_default_str();
    command.add_option("--spatial-bins", spatial_bins, "bins per axis of the spatial search space")
        ->capture_default_str();
    command.add_option("--budget", reference_budget, "reference budget of spatial splits, x triangles")
        ->capture_default_str();
    command.add_option("--memory-limit", memory_limit,
                       "refuse, before starting, a build whose estimated peak memory exceeds this (bytes or "
                       "K/M/G/T; default: the memory available, MemAvailable)");
    command.add_option("--spatial-gate", spatial_gate,
                       "try spatial planes only where the best object split's children overlap by at least this "
                       "fraction of the root's surface area (0 = everywhere; default: the builder's)");
    command.add_flag("--no-unsplitting", no_unsplitting, "clip every straddling reference into both children");
    command.add_option("--search", search,
                       "search spaces combined at every node, any union of: object (exact SAH sweep), binned "
                       "(binned object SAH), spatial (kd planes, clipping), grid (child boxes on a grid); "
                       "e.g. object,spatial,grid (default: the builder's own)");
    command
        .add_option("--grid-resolution", grid_resolution,
                    "R of the grid search space: G = ceil(R * N^(1/6)) cells per axis for a node of N references")
        ->capture_default_str();
    command.add_option("--grid-max", grid_max_cells, "largest G of the grid search space (work per node ~26 G^6)")
        ->capture_default_str();
    command.add_flag("--no-grid-splitting", no_grid_splitting,
                     "grid search space without primitive splitting (a reference in neither child box is infeasible)");
    command
        .add_option("--lookahead", lookahead,
                    "recursive cost evaluation: choose each split by the SAH of the subtree built this many levels "
                    "below it (0 = greedy; slower, about 1 + depth x candidates times the search)")
        ->capture_default_str();
    command
        .add_option("--lookahead-candidates", lookahead_candidates,
                    "candidates the lookahead compares: the cheapest splits per axis and search space")
        ->capture_default_str();
    command
        .add_option("--lookahead-top", lookahead_top,
                    "recursive cost evaluation to the leaves at the top of the tree: nodes holding at least this "
                    "share of the root's references take the search space whose cheapest split leads to the "
                    "subtree of lowest SAH, each built out greedily (0 = off; about one build per search space "
                    "and level of such nodes)")
        ->capture_default_str();
    command.add_flag(
        "--spatial-sweep", spatial_sweep,
        "kd planes at every reference bound with exact child boxes (the sweep) instead of --spatial-bins bins");
    command
        .add_option(
            "--sweep-samples", sweep_samples,
            "spatial sweep: positions sampled inside the intervals next to the best event planes (0 = events only)")
        ->capture_default_str();
    command
        .add_option("--termination-rays", termination_rays,
                    "termination-aware split choice: trace this many bounce rays on a quick tree and choose splits "
                    "by the share of their segments (each ending at its first hit) that meets each child, where "
                    "at least 8 reach a node (0 = off)")
        ->capture_default_str();
    command
        .add_option("--termination-shrinkage", termination_shrinkage,
                    "n_0 of the blend: a node met by n segments weighs the sampled cost n / (n + n_0)")
        ->capture_default_str();
    command
        .add_option("--termination-candidates", termination_candidates,
                    "cheapest splits per axis and search space the termination-aware cost chooses among")
        ->capture_default_str();
    command.add_flag("--no-termination-split", no_termination_split,
                     "the termination rays serve --termination-optimize only; the cost model chooses every split");
    command
        .add_option("--termination-optimize", termination_optimize,
                    "after the build, this many reinsertion iterations that price each inner node by the "
                    "termination rays' segments meeting its box plus --termination-prior pseudo-rays spread by "
                    "area (needs --termination-rays; 0 = off)")
        ->capture_default_str();
    command
        .add_option("--termination-prior", termination_prior,
                    "--termination-optimize: pseudo-rays spread by area (the SAH's share of the price)")
        ->capture_default_str();
    command.add_flag("--optimize", optimize,
                     "after the build, move subtrees to where they lower the tree SAH (reinsertion, Bittner et al. "
                     "2013); leaves stay as built; also as a builder name suffix: binned+opt");
    optimize_iterations_option =
        command
            .add_option(
                "--optimize-iterations", optimize_iterations,
                "effort of --optimize (implies it): at most this many batches of moves, each searching 5 % of "
                "the nodes (the largest not yet settled); it stops earlier once 20 batches in a row gain < 0.01 %")
            ->capture_default_str();
}

bool strip_optimize_suffix(std::string& builder_name) {
    constexpr std::string_view kSuffix = "+opt";
    if (!builder_name.ends_with(kSuffix)) return false;
    builder_name.resize(builder_name.size() - kSuffix.size());
    return true;
}

uint32_t parse_unsigned(const std::string& text, const char* what) {
    try {
        size_t used = 0;
        const unsigned long value = std::stoul(text, &used);
        if (used != text.size() || text.front() == '-' || value > 0xffffffffUL) throw std::invalid_argument(text);
        return uint32_t(value);
    } catch (const std::exception&) {
        throw Error(std::string(what) + ": expected a whole number >= 0, got '" + text + "'");
    }
}

uint64_t parse_bytes(const std::string& text, const char* what) {
    static constexpr std::string_view kUnits = "KMGT";
    double value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    const std::string_view unit(end, text.data() + text.size());
    const size_t power = unit.empty() ? 0 : unit.size() == 1 ? kUnits.find(char(std::toupper(unit[0]))) + 1 : 0;
    if (ec != std::errc() || !(value > 0) || (!unit.empty() && power == 0) || !std::isfinite(value))
        throw Error(std::string(what) + ": expected a positive size in bytes, or with K, M, G or T, got '" + text +
                    "'");
    const double bytes = std::ldexp(value, int(10 * power));
    if (bytes >= 0x1p64) throw Error(std::string(what) + ": '" + text + "' is more than 2^64 bytes");
    return uint64_t(bytes);
}

TreeRecipe BuildCliOptions::options(const std::string& builder_text) const {
    std::string builder_name = builder_text;
    const bool optimized_name = strip_optimize_suffix(builder_name);
    // Embree's trees take the same limits and costs; their name is not one of our presets.
    TreeRecipe options{config_for(is_embree_tree(builder_name) ? "binned" : builder_name), builder_name};
    options.cost.traversal_cost = traversal_cost;
    options.cost.intersection_cost = intersection_cost;
    options.cost.leaf_block = leaf_block;
    if (!overlap_penalty.empty()) options.cost.overlap_penalty = parse_float_or_inf(overlap_penalty, "--co");
    options.limits.max_leaf_size = max_leaf_size;
    options.limits.max_depth = max_depth;
    options.object.bins = bins;
    options.spatial.bins = spatial_bins;
    options.limits.reference_budget = reference_budget;
    if (!memory_limit.empty()) options.limits.memory_limit_bytes = parse_bytes(memory_limit, "--memory-limit");
    options.spatial.unsplitting = !no_unsplitting;
    if (!spatial_gate.empty()) options.spatial.gate_alpha = parse_float_or_inf(spatial_gate, "--spatial-gate");
    if (!search.empty()) options.search_spaces = parse_search_spaces(search);
    options.grid.resolution = grid_resolution;
    options.grid.max_cells = grid_max_cells;
    options.grid.splitting = !no_grid_splitting;
    options.lookahead.depth = lookahead;
    options.lookahead.candidates = lookahead_candidates;
    options.lookahead.top_share = lookahead_top;
    options.hooks.cancel = interrupt_flag();
    options.spatial.exact_sweep = spatial_sweep;
    options.spatial.sweep_interior_samples = sweep_samples;
    options.termination_rays = termination_rays;
    options.termination.shrinkage = termination_shrinkage;
    options.termination.candidates = termination_candidates;
    options.termination.split_choice = !no_termination_split;
    options.termination.reinsertion_iterations = termination_optimize;
    options.termination.reinsertion_prior = termination_prior;
    if (termination_optimize > 0 && termination_rays == 0)
        throw Error("--termination-optimize needs --termination-rays (the segments it prices nodes by)");
    const bool iterations_given = optimize_iterations_option && optimize_iterations_option->count() > 0;
    if (optimize || optimized_name || iterations_given) {
        if (optimize_iterations == 0) throw Error("--optimize-iterations must be at least 1");
        options.reinsertion.iterations = optimize_iterations;
    }
    options.validate();
    return options;
}

void CommonOptions::add_to(CLI::App& command) {
    command.add_option("--threads,-j", threads, "worker threads (0 = all cores)")->capture_default_str();
    command.add_flag("--quiet,-q", quiet, "no progress bar");
    command.add_flag("--progress", progress,
                     "show progress even when stderr is not a terminal (a line every few seconds)");
    command.add_option("--json", json_path, "also write the results as JSON to this file");
}

std::unique_ptr<tbb::global_control> CommonOptions::thread_limit() const {
    if (threads > 4096) throw Error("--threads must be at most 4096");
    if (threads == 0) return nullptr;
    return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
}

unsigned CommonOptions::effective_threads() const {
    return threads ? threads : unsigned(tbb::info::default_concurrency());
}

void add_manifest_option(CLI::App& command, std::string& manifest) {
    command
        .add_option("--manifest", manifest,
                    "a scene collection's MANIFEST.md: the camera its table lists for the "
                    "scene file's stem is the default camera")
        ->envname("SPACEBVH_SCENE_MANIFEST");
}

void CameraOptions::add_to(CLI::App& command) {
    command.add_option("--camera", camera,
                       "eye, target, up, fovy: ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy "
                       "(default: the --manifest camera, else the spec's default)");
    add_manifest_option(command, manifest);
    command.add_option("--width", width, "image width in pixels")->capture_default_str();
    command.add_option("--height", height, "image height in pixels")->capture_default_str();
}

Camera CameraOptions::camera_for(const Scene& scene, const std::string& source, const SceneTransform& transform) const {
    if (width == 0 || height == 0 || width > kMaxImageSide || height > kMaxImageSide)
        throw Error("--width and --height must be in [1, " + std::to_string(kMaxImageSide) + "]");
    if (!camera.empty()) return Camera::parse(camera);
    return camera_for_scene(scene, source, transform, manifest);
}

Bvh build_tree(const Scene& scene, const TreeRecipe& options) {
    if (is_embree_tree(options.builder) && (options.lookahead.depth > 0 || options.lookahead.top_share > 0))
        throw Error("--lookahead applies to our builders, not to Embree's tree '" + options.builder + "'");
    if (is_embree_tree(options.builder) && options.termination_rays > 0)
        throw Error("--termination-rays applies to our builders, not to Embree's tree '" + options.builder + "'");
    const InterruptScope interrupts;  // our builders poll the flag; Embree's finish, then we stop
    Bvh bvh;
    if (is_embree_tree(options.builder)) {
        bvh = build_embree_tree(scene, options.builder, options);
    } else if (options.termination_rays > 0 && !options.termination.split_choice) {
        // The segments serve the reinsertion only: traced on the built tree itself, no quick tree.
        BuildConfig config = options;
        config.termination.reinsertion_iterations = 0;
        bvh = spacebvh::build(scene, config);
        const Tracer built(scene, bvh, Kernel::binary);  // no wide collapse to build
        config.termination = options.termination;
        config.termination.segments = termination_segments(scene, built, options.termination_rays, kTerminationSeed);
        optimize_for_termination(bvh, config.termination, config.limits.max_depth, config.hooks);
    } else if (options.termination_rays > 0) {
        BuildConfig config = options;
        const Tracer quick(scene, spacebvh::build(scene, Quality::fast));
        config.termination.segments = termination_segments(scene, quick, options.termination_rays, kTerminationSeed);
        bvh = spacebvh::build(scene, config);
    } else {
        bvh = spacebvh::build(scene, options);  // our presets (optimised there); reports an unknown name
    }
    throw_if_interrupted();
    return bvh;
}

uint64_t estimated_build_bytes(const Scene& scene, const TreeRecipe& recipe) {
    if (is_embree_tree(recipe.builder))
        return estimate_embree_tree_memory(scene.triangles.size(), recipe.builder, recipe);
    return estimate_build_memory(scene.triangles.size(), recipe).bytes;
}

std::string builder_list() {
    std::string names;
    for (const auto& name : builder_names()) names += name + ", ";
    for (const auto& name : embree_tree_names()) names += name + ", ";
    names.resize(names.size() - 2);
    return names + " (Embree 3's own binary trees under our kernel)";
}

std::string kernel_help() {
    std::string help = "traversal kernel:";
    for (const std::string& name : kernel_names()) help += " " + name;
    return help +
           " (auto: bvh8 with the widest node test); wide kernels collapse the binary tree SAH-optimally, NAME@area as "
           "Embree does (open the largest child)";
}

}  // namespace spacebvh::cli
