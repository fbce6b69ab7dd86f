// SPDX-License-Identifier: MIT
#include "trace/layout/wide_collapse.hpp"

#include <algorithm>
#include <iterator>
#include <limits>

#include "trace/leaf_tests/triangle_pack.hpp"

namespace spacebvh::trace {
namespace {

// Binary nodes with every child listed before its parent.
std::vector<uint32_t> children_first_order(const Bvh& bvh) {
    std::vector<uint32_t> order, stack{0};
    order.reserve(bvh.nodes.size());
    while (!stack.empty()) {
        const uint32_t node = stack.back();
        stack.pop_back();
        order.push_back(node);
        if (!bvh.nodes[node].is_leaf()) {
            stack.push_back(bvh.nodes[node].first);
            stack.push_back(bvh.nodes[node].first + 1);
        }
    }
    std::reverse(order.begin(), order.end());
    return order;
}

void sort_unique(std::vector<uint32_t>& values) {
    std::sort(values.begin(), values.end());
    values.erase(std::unique(values.begin(), values.end()), values.end());
}

}  // namespace

std::vector<uint32_t> subtree_triangles(std::span<const Triangle> triangles, const Bvh& bvh, uint32_t node) {
    std::vector<uint32_t> live, stack{node};
    while (!stack.empty()) {
        const BvhNode& n = bvh.nodes[stack.back()];
        stack.pop_back();
        if (n.is_leaf()) {
            append_live_triangles(triangles, bvh, n, live);
        } else {
            stack.push_back(n.first + 1);
            stack.push_back(n.first);
        }
    }
    sort_unique(live);
    return live;
}

CollapsePlan::CollapsePlan(std::span<const Triangle> triangles, const Bvh& bvh, int width, WideCollapse strategy,
                           const WideCost& cost)
    : bvh_(bvh), width_(width), strategy_(strategy), cost_(cost) {
    if (bvh.empty()) return;
    const size_t count = bvh.nodes.size();
    const uint32_t cap = cost_.max_merged_leaf;
    distinct_.assign(count, 0);
    // Triangle sets only while they are small enough to merge; a parent consumes its children's.
    std::vector<std::vector<uint32_t>> sets(count);
    const std::vector<uint32_t> order = children_first_order(bvh);
    for (uint32_t node : order) {
        const BvhNode& n = bvh.nodes[node];
        std::vector<uint32_t>& set = sets[node];
        if (n.is_leaf()) {
            append_live_triangles(triangles, bvh, n, set);
            sort_unique(set);
            distinct_[node] = uint32_t(set.size());  // exact for a leaf: it stays a leaf whatever its size
        } else {
            std::vector<uint32_t>& left = sets[n.first];
            std::vector<uint32_t>& right = sets[n.first + 1];
            if (distinct_[n.first] <= cap && distinct_[n.first + 1] <= cap) {
                std::set_union(left.begin(), left.end(), right.begin(), right.end(), std::back_inserter(set));
                distinct_[node] = std::min<uint32_t>(uint32_t(set.size()), cap + 1);
            } else {
                distinct_[node] = cap + 1;
            }
            std::vector<uint32_t>().swap(left);
            std::vector<uint32_t>().swap(right);
        }
        if (distinct_[node] > cap) std::vector<uint32_t>().swap(set);
    }
    if (strategy_ != WideCollapse::sah_optimal) return;

    // The dynamic program of Ylitie et al., children before parents. Costs are areas times unit
    // costs; dividing by the root's area (cost()) only rescales them.
    const int w = width_;
    constexpr double kInfinite = std::numeric_limits<double>::infinity();
    best_.assign(count * size_t(w), kInfinite);
    used_.assign(count * size_t(w), 1);
    split_left_.assign(count * size_t(w), 0);
    single_is_leaf_.assign(count, 1);
    inner_split_.assign(count, 1);
    std::vector<double> distribute(size_t(w) + 1);
    std::vector<uint8_t> distribute_left(size_t(w) + 1);
    for (uint32_t node : order) {
        const BvhNode& n = bvh.nodes[node];
        double* best = &best_[size_t(node) * w];
        if (n.is_leaf()) {
            std::fill(best, best + w, leaf_cost(node));
            continue;
        }
        const double* left = &best_[size_t(n.first) * w];
        const double* right = &best_[size_t(n.first + 1) * w];
        // distribute[j]: both subtrees as j children in all, k of them from the left (ties: fewest).
        for (int j = 2; j <= w; ++j) {
            distribute[j] = kInfinite;
            for (int k = 1; k < j; ++k) {
                const double c = left[k - 1] + right[j - k - 1];
                if (c < distribute[j]) {
                    distribute[j] = c;
                    distribute_left[j] = uint8_t(k);
                }
            }
        }
        const double as_leaf = leaf_cost(node);
        const double as_inner = double(n.bounds.area()) * cost_.node + distribute[w];
        inner_split_[node] = distribute_left[w];
        single_is_leaf_[node] = as_leaf <= as_inner;
        best[0] = std::min(as_leaf, as_inner);
        uint8_t* used = &used_[size_t(node) * w];
        uint8_t* split_left = &split_left_[size_t(node) * w];
        used[0] = 1;
        split_left[0] = 0;
        for (int i = 2; i <= w; ++i) {
            split_left[i - 1] = distribute_left[i];
            if (distribute[i] < best[i - 2]) {
                best[i - 1] = distribute[i];
                used[i - 1] = uint8_t(i);
            } else {
                best[i - 1] = best[i - 2];
                used[i - 1] = used[i - 2];
            }
        }
    }
}

double CollapsePlan::leaf_cost(uint32_t node) const {
    const BvhNode& n = bvh_.nodes[node];
    if (!n.is_leaf() && distinct_[node] > cost_.max_merged_leaf) return std::numeric_limits<double>::infinity();
    const uint32_t packs = (distinct_[node] + 3) / 4;
    return double(n.bounds.area()) * cost_.pack * double(packs);
}

void CollapsePlan::expand(uint32_t node, int slots, std::vector<CollapseSlot>& out) const {
    const BvhNode& n = bvh_.nodes[node];
    const size_t at = size_t(node) * width_;
    const int used = n.is_leaf() ? 1 : used_[at + slots - 1];
    const int left = n.is_leaf() ? 0 : split_left_[at + used - 1];
    if (used == 1 || left == 0) {
        out.push_back({node, n.is_leaf() || single_is_leaf_[node] != 0});
        return;
    }
    expand(n.first, left, out);
    expand(n.first + 1, used - left, out);
}

std::vector<CollapseSlot> CollapsePlan::largest_area_slots(uint32_t node) const {
    std::vector<CollapseSlot> children;
    const BvhNode& n = bvh_.nodes[node];
    if (n.is_leaf()) return {{node, true}};
    children = {{n.first, bvh_.nodes[n.first].is_leaf()}, {n.first + 1, bvh_.nodes[n.first + 1].is_leaf()}};
    while (int(children.size()) < width_) {
        int widest = -1;
        float widest_area = -1.0f;
        for (int i = 0; i < int(children.size()); ++i) {
            const BvhNode& child = bvh_.nodes[children[i].node];
            if (!child.is_leaf() && child.bounds.area() > widest_area) {
                widest = i;
                widest_area = child.bounds.area();
            }
        }
        if (widest < 0) break;
        const uint32_t first = bvh_.nodes[children[widest].node].first;
        children[widest] = {first, bvh_.nodes[first].is_leaf()};
        children.insert(children.begin() + widest + 1, {first + 1, bvh_.nodes[first + 1].is_leaf()});
    }
    return children;
}

std::vector<CollapseSlot> CollapsePlan::slots(uint32_t node) const {
    const BvhNode& n = bvh_.nodes[node];
    if (n.is_leaf()) return {{node, true}};
    if (strategy_ == WideCollapse::largest_area) return largest_area_slots(node);
    std::vector<CollapseSlot> out;
    out.reserve(size_t(width_));
    const int left = inner_split_[node];
    expand(n.first, left, out);
    expand(n.first + 1, width_ - left, out);
    return out;
}

double CollapsePlan::cost() const {
    if (bvh_.empty()) return 0.0;
    double total = 0.0;
    std::vector<uint32_t> stack{0};
    while (!stack.empty()) {
        const uint32_t node = stack.back();
        stack.pop_back();
        total += double(bvh_.nodes[node].bounds.area()) * cost_.node;
        for (const CollapseSlot& slot : slots(node)) {
            if (slot.leaf)
                total += leaf_cost(slot.node);
            else
                stack.push_back(slot.node);
        }
    }
    const double root_area = double(bvh_.nodes[0].bounds.area());
    return root_area > 0.0 ? total / root_area : total;
}

}  // namespace spacebvh::trace
