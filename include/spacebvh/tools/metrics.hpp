// SPDX-License-Identifier: MIT
// Quality metrics of a tree: structure, memory, tree SAH and EPO (Aila, Karras, Laine 2013).
// Implemented in src/tools/metrics/tree_metrics.cpp.
#pragma once

#include <cstddef>
#include <cstdint>

#include "spacebvh/build.hpp"
#include "spacebvh/cost_model.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh::tools {

struct TreeStats {
    size_t nodes = 0, inner_nodes = 0, leaves = 0;
    uint32_t max_depth = 0;
    double mean_leaf_depth = 0;
    size_t references = 0;           // leaf entries (a split triangle counts once per leaf)
    size_t distinct_primitives = 0;  // triangles reachable from the root
    size_t bytes = 0;                // BvhNode array + primitive index array
    double sah = 0;                  // tree SAH under the given cost model
    double epo = 0;                  // end-point overlap, C_n = C_T for inner nodes, C_I*|l| for leaves
};

// Tree SAH: sum_inner C_T*SA(n)/SA(root) + sum_leaf C_I*SA(l)*|l|/SA(root), |l| = distinct
// triangles in the leaf.
double tree_sah(const Bvh& bvh, const CostModel& cost);

// EPO = sum_n C_n * A((S \ Q(n)) ∩ n) / A(S): for each node n, the surface area of the scene's
// triangles that lie inside n's box but are not in n's subtree, with exact clipping; parallel.
double tree_epo(const Scene& scene, const Bvh& bvh, const CostModel& cost);

// Everything above; EPO only when `with_epo` (it is the expensive one).
TreeStats compute_tree_stats(const Scene& scene, const Bvh& bvh, const CostModel& cost, bool with_epo = true);

}  // namespace spacebvh::tools
