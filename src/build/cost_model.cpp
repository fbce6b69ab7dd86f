#include "spacebvh/cost_model.hpp"

#include <cmath>
#include <sstream>

#include "spacebvh/error.hpp"

namespace spacebvh {

void CostModel::validate() const {
    auto check = [](float value, const char* name, bool allow_infinity) {
        if (std::isnan(value) || value < 0.0f || (!allow_infinity && std::isinf(value))) {
            std::ostringstream message;
            message << "cost model: " << name << " must be a finite number >= 0"
                    << (allow_infinity ? " or inf" : "") << ", got " << value;
            throw Error(message.str());
        }
    };
    check(traversal_cost, "C_T (traversal cost)", false);
    check(intersection_cost, "C_I (intersection cost)", false);
    check(overlap_penalty, "C_o (overlap penalty)", true);
    if (intersection_cost == 0.0f) throw Error("cost model: C_I (intersection cost) must be > 0");
}

std::string CostModel::describe() const {
    std::ostringstream text;
    text << "C_T=" << traversal_cost << " C_I=" << intersection_cost << " C_o=" << overlap_penalty;
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

float CostModel::split_cost(const AABB& node, const AABB& left, size_t left_count, const AABB& right,
                            size_t right_count) const {
    const float node_area = node.area();
    float weighted_area;
    if (node_area > 0.0f) {
        weighted_area = (left.area() * float(left_count) + right.area() * float(right_count)) / node_area;
    } else {
        // A point or a line of primitives: no area to divide, each reference costs one test.
        weighted_area = float(left_count + right_count);
    }
    float overlap_factor = 1.0f;
    if (overlap_penalty != 0.0f) {
        const float overlap = overlap_fraction(node, left, right);
        if (overlap > 0.0f) {
            if (std::isinf(overlap_penalty)) return kInfinity;  // disjoint children only
            overlap_factor += overlap_penalty * overlap;
        }
    }
    return traversal_cost + overlap_factor * intersection_cost * weighted_area;
}

}  // namespace spacebvh
