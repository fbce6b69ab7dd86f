// SPDX-License-Identifier: MIT
#include "spacebvh/cost_model.hpp"

#include <cmath>
#include <sstream>
#include <string>

#include "spacebvh/error.hpp"

namespace spacebvh {

void CostModel::validate() const {
    auto check = [](float value, const char* name, bool allow_infinity) {
        if (std::isnan(value) || value < 0.0f || (!allow_infinity && std::isinf(value))) {
            std::ostringstream message;
            message << "cost model: " << name << " must be a finite number >= 0" << (allow_infinity ? " or inf" : "")
                    << ", got " << value;
            throw Error(message.str());
        }
    };
    check(traversal_cost, "C_T (traversal cost)", false);
    check(intersection_cost, "C_I (intersection cost)", false);
    check(overlap_penalty, "C_o (overlap penalty)", true);
    if (intersection_cost == 0.0f) throw Error("cost model: C_I (intersection cost) must be > 0");
    if (leaf_block < 1 || leaf_block > 64 || (leaf_block & (leaf_block - 1)) != 0)
        throw Error("cost model: leaf block B must be a power of two in [1, 64], got " + std::to_string(leaf_block));
}

std::string CostModel::describe() const {
    std::ostringstream text;
    text << "C_T=" << traversal_cost << " C_I=" << intersection_cost << " C_o=" << overlap_penalty;
    if (leaf_block != 1) text << " B=" << leaf_block;
    return text.str();
}

float overlap_fraction(const AABB& node, const AABB& left, const AABB& right) {
    if (left.is_empty() || right.is_empty()) return 0.0f;
    const AABB overlap = intersect(left, right);
    const Vec3 node_extent = node.extent();
    const Vec3 overlap_extent = overlap.extent();
    float fraction = 1.0f;
    for (int axis = 0; axis < 3; ++axis) {
        if (overlap_extent[axis] < 0.0f) return 0.0f;  // disjoint
        // Axes on which the node is flat do not count: the measure is taken in N's own dimension.
        if (node_extent[axis] > 0.0f) fraction *= overlap_extent[axis] / node_extent[axis];
    }
    return fraction;
}

}  // namespace spacebvh
