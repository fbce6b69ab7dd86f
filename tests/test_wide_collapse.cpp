// SPDX-License-Identifier: MIT
// The collapse of binary trees into wide nodes (src/trace/layout/wide_collapse.hpp): the SAH-optimal plan
// against an exhaustive search over every way to cut small trees, against Embree's largest-area rule
// on the built-in scenes, the plan's coverage (every triangle of the tree in some reachable leaf), and
// the layout's slot order (wide_layout.cpp: decreasing subtree size, empty slots last).
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <map>
#include <set>
#include <vector>

#include "spacebvh/presets.hpp"
#include "spacebvh/build.hpp"
#include "test_support.hpp"
#include "trace/layout/wide_collapse.hpp"
#include "trace/layout/wide_layout.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;
using testing_support::cached_builtin_scene;
using trace::CollapsePlan;
using trace::CollapseSlot;

namespace {

// The wide SAH of the best cut, found by enumerating, for every wide node, every set of at most W
// descendants that covers its subtree (a "frontier"), each made a leaf (when small enough) or,
// recursively, a wide node. Exponential; for small trees only.
class ExhaustiveCollapse {
public:
    ExhaustiveCollapse(const Scene& scene, const Bvh& bvh, int width, const trace::WideCost& cost)
        : scene_(scene), bvh_(bvh), width_(width), cost_(cost) {}

    double cost() { return inner_cost(0) / double(bvh_.nodes[0].bounds.area()); }

private:
    using Frontier = std::vector<uint32_t>;

    // Every frontier of node's subtree with at most width_ nodes.
    const std::vector<Frontier>& frontiers(uint32_t node) {
        if (auto found = frontiers_.find(node); found != frontiers_.end()) return found->second;
        std::vector<Frontier> result{{node}};
        const BvhNode& n = bvh_.nodes[node];
        if (!n.is_leaf()) append_unions(frontiers(n.first), frontiers(n.first + 1), result);
        return frontiers_[node] = result;
    }
    void append_unions(const std::vector<Frontier>& left, const std::vector<Frontier>& right,
                       std::vector<Frontier>& out) {
        for (const Frontier& a : left)
            for (const Frontier& b : right)
                if (int(a.size() + b.size()) <= width_) {
                    Frontier both = a;
                    both.insert(both.end(), b.begin(), b.end());
                    out.push_back(both);
                }
    }
    double leaf_cost(uint32_t node) {
        const BvhNode& n = bvh_.nodes[node];
        const size_t triangles = trace::subtree_triangles(scene_.triangles, bvh_, node).size();
        if (!n.is_leaf() && triangles > cost_.max_merged_leaf) return std::numeric_limits<double>::infinity();
        return double(n.bounds.area()) * cost_.pack * double((triangles + 3) / 4);
    }
    double slot_cost(uint32_t node) {
        const double leaf = leaf_cost(node);
        return bvh_.nodes[node].is_leaf() ? leaf : std::min(leaf, inner_cost(node));
    }
    double inner_cost(uint32_t node) {
        if (auto found = inner_.find(node); found != inner_.end()) return found->second;
        const BvhNode& n = bvh_.nodes[node];
        double best = std::numeric_limits<double>::infinity();
        std::vector<Frontier> options;
        append_unions(frontiers(n.first), frontiers(n.first + 1), options);
        for (const Frontier& frontier : options) {
            double sum = 0.0;
            for (uint32_t slot : frontier) sum += slot_cost(slot);
            best = std::min(best, sum);
        }
        return inner_[node] = double(n.bounds.area()) * cost_.node + best;
    }

    const Scene& scene_;
    const Bvh& bvh_;
    int width_;
    trace::WideCost cost_;
    std::map<uint32_t, std::vector<Frontier>> frontiers_;
    std::map<uint32_t, double> inner_;
};

// The triangles in the leaves of the wide tree the plan makes, walking its wide nodes from the root,
// and a description of the first malformed wide node ("" if none).
std::string walk_plan(const Scene& scene, const Bvh& bvh, const CollapsePlan& plan, int width,
                      std::set<uint32_t>& triangles) {
    std::vector<uint32_t> stack{0};
    while (!stack.empty()) {
        const uint32_t node = stack.back();
        stack.pop_back();
        const std::vector<CollapseSlot> slots = plan.slots(node);
        if (slots.empty() || int(slots.size()) > width)
            return "wide node of binary node " + std::to_string(node) + " has " + std::to_string(slots.size()) +
                   " children";
        if (!bvh.nodes[node].is_leaf() && slots.size() < 2) return "inner wide node with one child";
        for (const CollapseSlot& slot : slots) {
            if (!bvh.nodes[node].bounds.contains(bvh.nodes[slot.node].bounds)) return "child box outside its parent's";
            if (slot.leaf) {
                for (uint32_t t : trace::subtree_triangles(scene.triangles, bvh, slot.node)) triangles.insert(t);
            } else if (bvh.nodes[slot.node].is_leaf()) {
                return "a binary leaf planned as an inner node";
            } else {
                stack.push_back(slot.node);
            }
        }
    }
    return "";
}

}  // namespace

// On small trees (a prefix of the soup, leaves of one or two triangles so merging matters) the
// dynamic program finds exactly the cost of the best cut the exhaustive search finds, for both widths
// and for pack costs that favour leaves or nodes.
TEST(WideCollapse, SahOptimalPlanEqualsExhaustiveSearchOnSmallTrees) {
    for (const size_t triangles : {9u, 23u, 40u}) {
        const Scene scene = testing_support::soup_prefix(triangles);
        BuildConfig options = config_for("cbvh");
        options.limits.max_leaf_size = 2;
        options.cost.intersection_cost = 0.3f;  // small leaves
        const Bvh bvh = spacebvh::build(scene, options);
        ASSERT_GT(bvh.nodes.size(), 5u);
        for (const int width : {4, 8}) {
            for (const double pack : {0.3, 1.0, 4.0}) {
                trace::WideCost cost;
                cost.pack = pack;
                cost.max_merged_leaf = 4;
                SCOPED_TRACE(std::to_string(triangles) + " triangles, width " + std::to_string(width) + ", pack " +
                             std::to_string(pack));
                const CollapsePlan plan(scene.triangles, bvh, width, WideCollapse::sah_optimal, cost);
                const double exhaustive = ExhaustiveCollapse(scene, bvh, width, cost).cost();
                EXPECT_NEAR(plan.cost(), exhaustive, 1e-9 * exhaustive);
                const CollapsePlan area(scene.triangles, bvh, width, WideCollapse::largest_area, cost);
                EXPECT_LE(exhaustive, area.cost() * (1 + 1e-12));
            }
        }
    }
}

// On the built-in scenes and several builders: the SAH-optimal plan never costs more than the
// largest-area one (and costs less on some tree), and both plans make well-formed wide nodes whose
// leaves hold every non-degenerate triangle of the tree.
TEST(WideCollapse, SahOptimalPlanBeatsLargestAreaAndCoversEveryTriangle) {
    size_t strictly_cheaper = 0;
    for (const std::string& scene_name : builtin_scene_names()) {
        const Scene& scene = cached_builtin_scene(scene_name);
        for (const char* builder : {"cbvh", "spatial"}) {
            const Bvh bvh = spacebvh::build(scene, config_for(builder));
            std::set<uint32_t> expected;
            for (const BvhNode& node : bvh.nodes)
                if (node.is_leaf())
                    for (uint32_t i = node.first; i < node.first + node.reference_count; ++i)
                        if (!scene.triangles[bvh.primitives[i]].is_degenerate()) expected.insert(bvh.primitives[i]);
            for (const int width : {4, 8}) {
                SCOPED_TRACE(scene_name + ", " + builder + ", width " + std::to_string(width));
                const CollapsePlan sah(scene.triangles, bvh, width, WideCollapse::sah_optimal);
                const CollapsePlan area(scene.triangles, bvh, width, WideCollapse::largest_area);
                EXPECT_LE(sah.cost(), area.cost() * (1 + 1e-12));
                strictly_cheaper += sah.cost() < area.cost() * (1 - 1e-3);
                for (const CollapsePlan* plan : {&sah, &area}) {
                    std::set<uint32_t> covered;
                    EXPECT_EQ(walk_plan(scene, bvh, *plan, width, covered), "");
                    EXPECT_EQ(covered, expected);
                }
            }
        }
    }
    EXPECT_GT(strictly_cheaper, 0u);
}

namespace {

// Triangle lanes under a wide node (leaf lanes summed over its subtree); checks on the way that each
// node's used slots come first, in non-increasing order of the lanes under them.
template <int W>
uint64_t lanes_checking_order(const trace::WideLayout<W>& layout, uint32_t index, size_t& misordered) {
    const trace::WideNode<W>& node = layout.nodes[index];
    uint64_t total = 0, previous = std::numeric_limits<uint64_t>::max();
    bool empty_seen = false;
    for (int slot = 0; slot < W; ++slot) {
        if (!node.used(slot)) {
            empty_seen = true;
            continue;
        }
        const uint64_t lanes =
            node.count[slot] ? node.count[slot] : lanes_checking_order(layout, node.child[slot], misordered);
        misordered += empty_seen || lanes > previous;
        previous = lanes;
        total += lanes;
    }
    return total;
}

template <int W>
void expect_slots_by_decreasing_size(const Scene& scene, const Bvh& bvh) {
    const trace::WideLayout<W> layout = trace::collapse_to_wide<W>(scene.triangles, bvh, WideCollapse::sah_optimal);
    size_t misordered = 0;
    const uint64_t lanes = lanes_checking_order(layout, 0, misordered);
    EXPECT_EQ(misordered, 0u);
    EXPECT_GE(lanes, bvh.primitives.empty() ? 0u : 1u);
}

}  // namespace

// The any-hit kernels pop a node's other entered children smallest subtree first because the layout
// orders each node's slots by decreasing size (wide_layout.cpp): check that order on every node.
TEST(WideLayout, SlotsComeInDecreasingSubtreeSizeWithEmptySlotsLast) {
    for (const std::string& scene_name : builtin_scene_names()) {
        const Scene& scene = cached_builtin_scene(scene_name);
        for (const char* builder : {"cbvh", "spatial"}) {
            SCOPED_TRACE(scene_name + ", " + builder);
            const Bvh bvh = spacebvh::build(scene, config_for(builder));
            expect_slots_by_decreasing_size<4>(scene, bvh);
            expect_slots_by_decreasing_size<8>(scene, bvh);
        }
    }
}
