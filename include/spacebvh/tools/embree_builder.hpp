// SPDX-License-Identifier: MIT
// Embree 3's own binary trees, imported into our Bvh: Embree's tree quality measured under our
// kernel, metrics and verification.
#pragma once

#include <string>
#include <vector>

#include "spacebvh/tools/embree_scene.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh::tools {

// Builds a binary BVH with Embree's rtcBuildBVH and converts it to our layout.
//
//  * quality medium: RTC_BUILD_QUALITY_MEDIUM, Embree's binned SAH builder; primitiveArrayCapacity
//    is exactly the triangle count.
//  * quality high: RTC_BUILD_QUALITY_HIGH with spatial splits. The splitPrimitive callback clips
//    exactly (split_triangle_bounds, the same clipping as our spatial builders), and
//    primitiveArrayCapacity = floor(options.limits.reference_budget * triangles), so the tree never holds
//    more references than that. (Below 5 triangles the capacity can equal the count and Embree
//    falls back to its binned SAH builder.)
//  * quality low is not offered (Embree's Morton builder splits to leaves of one triangle); it
//    throws Error.
//
// Settings: maxBranchingFactor 2, minLeafSize 1, maxLeafSize = options.limits.max_leaf_size (Embree allows
// at most RTC_BUILD_MAX_PRIMITIVES_PER_LEAF = 32; more throws Error), maxDepth = options.limits.max_depth,
// sahBlockSize 1, traversalCost/intersectionCost = options.cost's C_T/C_I. options.cost's overlap
// penalty C_o, the bin counts and `unsplitting` have no counterpart in Embree and are ignored;
// options.builder is ignored too. options.hooks.progress, when set, receives Embree's progress.
//
// The result: nodes depth-first, left child first, the two children of a node adjacent; a leaf
// lists each triangle id once (Embree may put two pieces of one split triangle in the same leaf;
// they are merged), in increasing order; node boxes are Embree's (union of the children / of the
// leaf's references' bounds). bvh.builder = "embree-medium" / "embree-high", bvh.cost =
// options.cost. Degenerate (zero-area) triangles are handed to Embree like the others.
//
// NOT deterministic: Embree builds in parallel in the caller's oneTBB arena, and its trees (HIGH
// especially) can differ from run to run and with the thread count. Use our own builders where
// reproducibility matters.
//
// Thread-safe (each call has its own Embree BVH object). Throws Error for an empty scene, bad
// options, or an Embree error.
Bvh build_bvh_with_embree(const Scene& scene, EmbreeQuality quality, const BuildConfig& options);

// The peak bytes build_embree_tree(scene, builder, options) allocates beyond the scene, for
// `triangle_count` triangles: the build primitives (32 bytes per reference of capacity), Embree's
// temporary tree and the converted tree (measured on builtin:city:N with bench/scale.sh). Like
// build(), build_embree_tree refuses a build over options.limits.memory_limit_bytes (0: the memory
// available) before it starts.
uint64_t estimate_embree_tree_memory(uint64_t triangle_count, const std::string& builder, const BuildConfig& options);

// Embree's trees as builder names beside our presets ("embree-medium", "embree-high"): the core's
// registry of names (spacebvh/presets.hpp), so every front end reads a builder name the same way.
using spacebvh::embree_tree_names;
using spacebvh::is_embree_tree;

// The Embree tree named `builder` (is_embree_tree): build_bvh_with_embree at that quality, then
// optimize_bvh with `options` (a no-op without reinsertion iterations). Throws Error for another name.
Bvh build_embree_tree(const Scene& scene, const std::string& builder, const BuildConfig& options);

}  // namespace spacebvh::tools
