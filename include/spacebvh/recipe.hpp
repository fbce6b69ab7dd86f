// SPDX-License-Identifier: MIT
// A recipe names one tree: one of our builders or a quality level with its settings
// (spacebvh/settings.hpp), one of Embree's own trees, or a saved tree file. Every front end (the
// command line, its compare rows, Python) turns what its user wrote into a recipe, and the recipe
// alone decides the tree: spacebvh::tools::make_tree (spacebvh/tools/make_tree.hpp) resolves any
// recipe, build() below every recipe that needs neither Embree nor a tracer.
// Implemented in src/builders/recipe.cpp.
#pragma once

#include <cstdint>
#include <string>

#include "spacebvh/build.hpp"

namespace spacebvh {

// A recipe is a BuildConfig (what every builder reads; Embree's trees read their limits, costs and
// reinsertion from it too) plus what picks the tree.
struct TreeRecipe : BuildConfig {
    // One of builder_names() or embree_tree_names() (spacebvh/presets.hpp).
    std::string builder = "binned";
    // The termination-aware build: this many bounce rays (a fixed seed, so a recipe names one tree)
    // are traced for their first hits, and their segments replace termination.segments: on a quick
    // binned tree before the build, or with termination.split_choice off on the built tree itself for
    // the termination-aware reinsertion only. 0 = off (termination.segments, if any, are used as given).
    uint32_t termination_rays = 0;
    // Not empty: the tree is loaded from this file (spacebvh/tree_file.hpp), not built; the settings
    // are not used.
    std::string tree_file;

    // A builder name, or "NAME+opt": NAME with kDefaultReinsertionIterations of reinsertion. Our
    // builders start from BuildConfig::for_preset; Embree's trees from the binned preset's
    // configuration. Throws Error for an unknown name, listing the known ones.
    static TreeRecipe for_builder(const std::string& name);
    // BuildConfig::for_quality; `builder` is the quality's preset.
    static TreeRecipe for_quality(Quality quality);
    static TreeRecipe from_file(const std::string& path);

    bool is_embree_tree() const;
    // BuildConfig::validate, and: the builder is known; termination.reinsertion_iterations has segments
    // to price nodes by (termination_rays or termination.segments); Embree's trees are not asked for a
    // setting they cannot honour (BuildSetting::ours_only). Errors name the setting in every spelling.
    void validate() const;
};

// The tree of a recipe of our builders: build(mesh, BuildConfig) (with its reinsertion and memory
// limit), or the recipe's tree file loaded and checked against the mesh. Throws Error for Embree's trees
// and for termination_rays > 0, which need the tools library (spacebvh::tools::make_tree).
[[nodiscard]] Bvh build(const MeshView& mesh, const TreeRecipe& recipe);

}  // namespace spacebvh
