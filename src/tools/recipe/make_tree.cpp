// SPDX-License-Identifier: MIT
#include "spacebvh/tools/make_tree.hpp"

#include "spacebvh/error.hpp"
#include "spacebvh/memory_estimate.hpp"
#include "spacebvh/tools/sample_rays.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tree_file.hpp"
#ifdef SPACEBVH_WITH_EMBREE
#include "spacebvh/tools/embree_builder.hpp"
#endif

namespace spacebvh::tools {
namespace {

// The seed of the termination-aware build's bounce rays: fixed, so a recipe names one tree.
constexpr uint64_t kTerminationSeed = 0x7E55A11;

Bvh build_embree(const Scene& scene, const TreeRecipe& recipe) {
#ifdef SPACEBVH_WITH_EMBREE
    return build_embree_tree(scene, recipe.builder, recipe);
#else
    (void)scene;
    throw Error("'" + recipe.builder + "' is Embree's own tree, and this build of spacebvh has no Embree");
#endif
}

// The segments serve the termination-aware reinsertion only: traced on the built tree itself, so no
// quick tree is built.
Bvh build_then_optimize_for_termination(const Scene& scene, const TreeRecipe& recipe) {
    BuildConfig config = recipe;
    config.termination.reinsertion_iterations = 0;
    Bvh bvh = spacebvh::build(scene, config);
    const Tracer built(scene, bvh, Kernel::binary);  // no wide collapse to build
    config.termination = recipe.termination;
    config.termination.segments = termination_segments(scene, built, recipe.termination_rays, kTerminationSeed);
    optimize_for_termination(bvh, config.termination, config.limits.max_depth, config.hooks);
    return bvh;
}

// The segments choose splits: traced on a quick binned tree first.
Bvh build_with_termination_segments(const Scene& scene, const TreeRecipe& recipe) {
    BuildConfig quick_config = BuildConfig::for_quality(Quality::fast);
    quick_config.limits.memory_limit_bytes = recipe.limits.memory_limit_bytes;
    quick_config.hooks.cancel = recipe.hooks.cancel;
    const Tracer quick(scene, spacebvh::build(scene, quick_config));
    BuildConfig config = recipe;
    config.termination.segments = termination_segments(scene, quick, recipe.termination_rays, kTerminationSeed);
    return spacebvh::build(scene, config);
}

}  // namespace

Bvh make_tree(const Scene& scene, const TreeRecipe& recipe) {
    recipe.validate();
    if (!recipe.tree_file.empty()) return load_bvh(recipe.tree_file, scene.triangles);
    if (recipe.is_embree_tree()) return build_embree(scene, recipe);
    if (recipe.termination_rays == 0) return spacebvh::build(scene, static_cast<const BuildConfig&>(recipe));
    if (!recipe.termination.split_choice) return build_then_optimize_for_termination(scene, recipe);
    return build_with_termination_segments(scene, recipe);
}

uint64_t estimate_tree_memory(const Scene& scene, const TreeRecipe& recipe) {
    if (!recipe.tree_file.empty()) return 0;
    if (recipe.is_embree_tree()) {
#ifdef SPACEBVH_WITH_EMBREE
        return estimate_embree_tree_memory(scene.triangles.size(), recipe.builder, recipe);
#else
        return 0;
#endif
    }
    return estimate_build_memory(scene.triangles.size(), recipe).bytes;
}

}  // namespace spacebvh::tools
