// SPDX-License-Identifier: MIT
// The cost model: one definition used by every builder and every report.
//
// Split cost (Popov et al. 2009, slide "Penalizing Overlap"):
//   cost = C_T + (1 + C_o * V(L ∩ R) / V(N)) * C_I * (SA(L)*|L| + SA(R)*|R|) / SA(N)
// Leaf cost: C_I * |N|.
// With a leaf block B > 1 (a power of two), |L|, |R| and |N| above count references in whole blocks of
// B, rounded up (Embree's SAH, for kernels that test B triangles at once: our packs of four make a leaf
// of 1 to 4 triangles cost one test). B = 1 is the plain SAH. The tree SAH metric never rounds.
// Tree SAH: sum_inner C_T*SA(n)/SA(root) + sum_leaf C_I*SA(l)*|l|/SA(root) (Aila, Karras, Laine 2013).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "spacebvh/geometry.hpp"

namespace spacebvh {

struct CostModel {
    float traversal_cost = 1.0f;     // C_T
    float intersection_cost = 1.0f;  // C_I
    // C_o: 0 = plain SAH; +inf = children must be disjoint (any overlap makes a split infeasible).
    float overlap_penalty = 0.0f;
    // B: references are counted in whole blocks of B (a power of two, 1 = plain SAH); see above.
    uint32_t leaf_block = 1;

    // Throws Error for negative or NaN constants.
    void validate() const;
    std::string describe() const;  // "C_T=1 C_I=1 C_o=0" (and " B=4" for blocks), printed with every figure

    // The reference count rounded up to whole blocks.
    float counted(size_t reference_count) const {
        return float((reference_count + leaf_block - 1) & ~size_t(leaf_block - 1));
    }
    float leaf_cost(size_t reference_count) const { return intersection_cost * counted(reference_count); }

    // The split cost above; +inf when infeasible (C_o = inf and the children overlap).
    // SA(N) = 0 (a point or a line of primitives): the area ratio is taken as 1 per reference, so
    // splitting never pays by area and only the leaf size limit forces it.
    float split_cost(const AABB& node, const AABB& left, size_t left_count, const AABB& right,
                     size_t right_count) const;
    // The same from the three surface areas, for a split without overlap penalty (or with its factor
    // 1 + C_o * overlap already known): split_cost is this, to the bit.
    float split_cost_of_areas(float node_area, float left_area, size_t left_count, float right_area, size_t right_count,
                              float overlap_factor = 1.0f) const;
    // 1 + C_o * overlap for an overlap fraction (overlap_fraction below); infinity when C_o = inf and
    // the children overlap at all.
    float overlap_factor(float overlap) const;
};

// Overlap fraction V(L ∩ R) / V(N) generalised to flat nodes: the product, over the axes on which N
// has positive extent, of (extent of L ∩ R) / (extent of N). For a box of positive volume this is
// exactly the volume ratio; for a flat N (V(N) = 0) it is the area (or length) ratio in N's own
// dimension, so overlap inside a planar node is still penalised. Children that merely touch (or
// are disjoint, or empty) give 0.
float overlap_fraction(const AABB& node, const AABB& left, const AABB& right);

// Inline: the split finders evaluate it for every candidate.
inline float CostModel::split_cost_of_areas(float node_area, float left_area, size_t left_count, float right_area,
                                            size_t right_count, float overlap_factor) const {
    // A point or a line of primitives (SA(N) = 0): no area to divide, each reference costs one test.
    const float weighted_area = node_area > 0.0f
                                    ? (left_area * counted(left_count) + right_area * counted(right_count)) / node_area
                                    : counted(left_count) + counted(right_count);
    return traversal_cost + overlap_factor * intersection_cost * weighted_area;
}

inline float CostModel::overlap_factor(float overlap) const {
    if (!(overlap > 0.0f)) return 1.0f;
    if (overlap_penalty == kInfinity) return kInfinity;  // disjoint children only
    return 1.0f + overlap_penalty * overlap;
}

inline float CostModel::split_cost(const AABB& node, const AABB& left, size_t left_count, const AABB& right,
                                   size_t right_count) const {
    const float factor = overlap_penalty != 0.0f ? overlap_factor(overlap_fraction(node, left, right)) : 1.0f;
    if (factor == kInfinity) return kInfinity;
    return split_cost_of_areas(node.area(), left.area(), left_count, right.area(), right_count, factor);
}

}  // namespace spacebvh
