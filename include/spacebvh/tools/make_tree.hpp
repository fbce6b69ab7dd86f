// SPDX-License-Identifier: MIT
// Resolving any recipe (spacebvh/recipe.hpp) over a scene: the one way the command line, its compare
// rows and Python turn what their users wrote into a tree.
// Implemented in src/tools/recipe/make_tree.cpp.
#pragma once

#include <cstdint>

#include "spacebvh/bvh.hpp"
#include "spacebvh/recipe.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh::tools {

// The tree the recipe names, after recipe.validate(): its tree file loaded (checked against the
// scene's triangles), Embree's tree (build_embree_tree; Error when the tools were built without
// Embree), or our builder's, with termination_rays > 0 the termination-aware build (the sample rays'
// segments traced first, then the build; TreeRecipe::termination_rays says on which tree). Each build
// refuses, before it starts, one whose estimate exceeds the recipe's memory limit.
Bvh make_tree(const Scene& scene, const TreeRecipe& recipe);

// The peak bytes make_tree is estimated to allocate beyond the scene: estimate_build_memory for our
// builders, estimate_embree_tree_memory for Embree's trees, 0 for a tree file.
uint64_t estimate_tree_memory(const Scene& scene, const TreeRecipe& recipe);

}  // namespace spacebvh::tools
