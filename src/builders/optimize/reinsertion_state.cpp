// SPDX-License-Identifier: MIT
#include "builders/optimize/reinsertion_state.hpp"

#include <algorithm>
#include <numeric>

#include "spacebvh/error.hpp"

namespace spacebvh::builders::reinsertion {

Optimizer::Optimizer(const Bvh& bvh, uint32_t max_depth, std::span<const Ray> segments, float area_prior)
    : bounds_(bvh.nodes.size()),
      parent_(bvh.nodes.size(), kNone),
      children_(bvh.nodes.size(), {kNone, kNone}),
      height_(bvh.nodes.size(), 0),
      depth_(bvh.nodes.size(), 0),
      settled_(bvh.nodes.size(), 0),
      sampled_(!segments.empty()),
      lists_(segments.empty() ? 0 : bvh.nodes.size()),
      price_(bvh.nodes.size(), 0.0),
      stamp_(bvh.nodes.size(), 0),
      level_(bvh.nodes.size(), 0) {
    for (uint32_t i = 0; i < bvh.nodes.size(); ++i) {
        const BvhNode& node = bvh.nodes[i];
        bounds_[i] = node.bounds;
        if (node.is_leaf()) continue;
        children_[i] = {node.first, node.first + 1};
        parent_[node.first] = parent_[node.first + 1] = i;
    }
    // Children come after their parents: a backward sweep sees children first.
    for (uint32_t i = uint32_t(bvh.nodes.size()); i-- > 0;)
        if (!is_leaf(i)) height_[i] = 1 + std::max(height_[children_[i][0]], height_[children_[i][1]]);
    max_depth_ = std::max(max_depth, height_[kRoot]);
    if (sampled_) {
        segments_.reserve(segments.size());
        for (const Ray& ray : segments) segments_.push_back(SampleSegment::of(ray));
        const double root_area = area_in_double(bounds_[kRoot]);
        area_weight_ = root_area > 0.0 ? double(area_prior) / root_area : 0.0;
    }
    price_all();
    minimum_gain_ = kMinimumMoveGain * price_[kRoot];
}

void Optimizer::price_all() {
    std::vector<uint32_t> stack{kRoot};
    if (sampled_) {
        std::vector<uint32_t> all(segments_.size());
        std::iota(all.begin(), all.end(), 0u);
        lists_[kRoot].clear();
        price_among(bounds_[kRoot], all, {}, &lists_[kRoot]);
    }
    while (!stack.empty()) {
        const uint32_t node = stack.back();
        stack.pop_back();
        set_price(node);
        if (is_leaf(node)) continue;
        for (uint32_t child : children_[node]) {
            if (sampled_) {
                lists_[child].clear();
                price_among(bounds_[child], lists_[node], {}, &lists_[child]);
            }
            stack.push_back(child);
        }
    }
    changed_.clear();
}

void Optimizer::reprice_changed() {
    if (!sampled_) {
        for (uint32_t node : changed_) set_price(node);
        changed_.clear();
        return;
    }
    // A list is filtered from its parent's, which must be current: shallower nodes first.
    std::vector<std::pair<uint32_t, uint32_t>> by_depth;
    for (uint32_t node : changed_) {
        uint32_t depth = 0;
        for (uint32_t up = node; up != kRoot; up = parent_[up]) ++depth;
        by_depth.push_back({depth, node});
    }
    std::sort(by_depth.begin(), by_depth.end());
    by_depth.erase(std::unique(by_depth.begin(), by_depth.end()), by_depth.end());
    std::vector<uint32_t> meeting;
    for (const auto& [depth, node] : by_depth) {
        meeting.clear();
        price_among(bounds_[node], lists_[parent_[node]], {}, &meeting);
        lists_[node].swap(meeting);
        set_price(node);
    }
    changed_.clear();
}

void Optimizer::refit_all() {
    for (uint32_t i = uint32_t(bounds_.size()); i-- > 1;)
        if (!is_leaf(i)) bounds_[i] = merge(bounds_[children_[i][0]], bounds_[children_[i][1]]);
    price_all();
}

void Optimizer::refit_upwards(uint32_t node) {
    for (; node != kNone; node = parent_[node]) {
        settled_[node] = 0;  // its box or its subtree changed
        const auto [left, right] = children_[node];
        if (node != kRoot) {  // the root's box is kept
            const AABB box = merge(bounds_[left], bounds_[right]);
            if (!(box == bounds_[node])) {
                bounds_[node] = box;
                changed_.push_back(node);
            }
        }
        height_[node] = 1 + std::max(height_[left], height_[right]);
    }
}

void Optimizer::compute_depths() {
    std::vector<uint32_t> stack{kRoot};
    depth_[kRoot] = 0;
    while (!stack.empty()) {
        const uint32_t node = stack.back();
        stack.pop_back();
        if (is_leaf(node)) continue;
        for (uint32_t child : children_[node]) {
            depth_[child] = depth_[node] + 1;
            stack.push_back(child);
        }
    }
}

double Optimizer::inner_price() const {
    double sum = 0.0;
    for (uint32_t i = 0; i < bounds_.size(); ++i)
        if (!is_leaf(i)) sum += price_[i];
    return sum;
}

std::vector<uint32_t> Optimizer::select_candidates(size_t count) const {
    std::vector<std::pair<double, uint32_t>> eligible;
    for (uint32_t i = 0; i < bounds_.size(); ++i)
        if (depth_[i] >= 2 && !settled_[i]) eligible.push_back({price_[i], i});
    count = std::min(count, eligible.size());
    auto larger_first = [](const auto& a, const auto& b) {
        return a.first > b.first || (a.first == b.first && a.second < b.second);
    };
    std::nth_element(eligible.begin(), eligible.begin() + count, eligible.end(), larger_first);
    std::sort(eligible.begin(), eligible.begin() + count, larger_first);
    std::vector<uint32_t> candidates(count);
    for (size_t i = 0; i < count; ++i) candidates[i] = eligible[i].second;
    return candidates;
}

void Optimizer::apply(uint32_t node, uint32_t destination) {
    const uint32_t parent = parent_[node];
    const uint32_t grandparent = parent_[parent];
    const uint32_t old_sibling = sibling(node);
    // These have new parents, so their own best places may have changed (the refits below unsettle
    // the nodes whose boxes change).
    settled_[node] = settled_[old_sibling] = settled_[destination] = 0;
    // Out: N's sibling takes P's place.
    replace_child(grandparent, parent, old_sibling);
    // In: P, with children the destination and N, takes the destination's place.
    replace_child(parent_[destination], destination, parent);
    children_[parent] = {destination, node};
    parent_[destination] = parent_[node] = parent;
    refit_upwards(grandparent);
    refit_upwards(parent);
    reprice_changed();
}

// Depth-first, left first, the two children of a node side by side (as the builders emit), leaves
// listing their triangles in that order.
void Optimizer::emit_node(uint32_t node, uint32_t out_index, const Bvh& source, Bvh& out) const {
    out.nodes[out_index].bounds = bounds_[node];
    if (is_leaf(node)) {
        const BvhNode& leaf = source.nodes[node];
        out.nodes[out_index].first = uint32_t(out.primitives.size());
        out.nodes[out_index].reference_count = leaf.reference_count;
        out.primitives.insert(out.primitives.end(), source.primitives.begin() + leaf.first,
                              source.primitives.begin() + leaf.first + leaf.reference_count);
        return;
    }
    const uint32_t first_child = uint32_t(out.nodes.size());
    out.nodes.resize(out.nodes.size() + 2);
    out.nodes[out_index].first = first_child;
    out.nodes[out_index].reference_count = 0;
    emit_node(children_[node][0], first_child, source, out);
    emit_node(children_[node][1], first_child + 1, source, out);
}

Bvh Optimizer::emit(const Bvh& source) const {
    Bvh out;
    out.builder = source.builder;
    out.cost = source.cost;
    out.nodes.reserve(source.nodes.size());
    out.primitives.reserve(source.primitives.size());
    out.nodes.resize(1);
    emit_node(kRoot, 0, source, out);
    return out;
}

}  // namespace spacebvh::builders::reinsertion
