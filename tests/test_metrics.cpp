// SPDX-License-Identifier: MIT
// Tree metrics (src/tools/metrics/tree_metrics.cpp) on hand-built trees whose SAH and EPO are computed by
// hand, plus a randomized comparison of EPO against a brute-force evaluation of its definition.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include <tbb/global_control.h>

#include "spacebvh/clip.hpp"
#include "spacebvh/tools/metrics.hpp"

namespace spacebvh {

using namespace spacebvh::tools;
namespace {

BvhNode inner(AABB bounds, uint32_t first_child) { return {bounds, first_child, 0}; }
BvhNode leaf(AABB bounds, uint32_t first, uint32_t count) { return {bounds, first, count}; }

// Two triangles side by side in z = 0, touching along x = 1; the right leaf lists its triangle twice.
// Root box [0,2]x[0,1]x[0,0] has area 4, each leaf [0,1]x[0,1] area 2.
struct TwoLeaves {
    Scene scene;
    Bvh bvh;
    TwoLeaves() {
        scene.triangles = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{1, 0, 0}, {2, 0, 0}, {1, 1, 0}}};
        bvh.nodes = {inner({{0, 0, 0}, {2, 1, 0}}, 1), leaf({{0, 0, 0}, {1, 1, 0}}, 0, 1),
                     leaf({{1, 0, 0}, {2, 1, 0}}, 1, 2)};
        bvh.primitives = {0, 1, 1};
    }
};

TEST(Metrics, TreeSahMatchesHandComputation) {
    TwoLeaves t;
    CostModel cost;
    cost.traversal_cost = 1.0f;
    cost.intersection_cost = 2.0f;
    // C_T*4/4 + C_I*1*2/4 + C_I*1*2/4 (the duplicate counts once) = 1 + 1 + 1.
    EXPECT_DOUBLE_EQ(tree_sah(t.bvh, cost), 3.0);
    cost.traversal_cost = 0.5f;
    EXPECT_DOUBLE_EQ(tree_sah(t.bvh, cost), 2.5);
}

TEST(Metrics, EpoIsZeroWhenBoxesHoldOnlyTheirOwnTriangles) {
    // The triangles touch along x = 1, inside the other leaf's box only as a segment (area 0).
    TwoLeaves t;
    EXPECT_EQ(tree_epo(t.scene, t.bvh, CostModel{}), 0.0);
}

// Three triangles of area 2 each (A(S) = 6):
//   T0 in z = 0 and T2 in z = 0.5, both with corners (0,0), (2,0), (0,2) in x, y;
//   T1 in the plane x = 1 with (y, z) corners (0,-1), (0,1), (2,0).
// Tree: root -> [N, B]; N -> [A, C]; A = {T0} (flat box z = 0), C = {T2} (flat box z = 0.5),
//   N box [0,2]x[0,2]x[0,0.5], B = {T1} with a loose box [0.5,1]x[0,2]x[-1,1].
// Overlaps:
//   N contains the part of T1 with z in [0, 0.5]: integral of 2(1 - z) dz over [0, 0.5] = 0.75.
//   B contains the parts of T0 and T2 with x in [0.5, 1]: integral of (2 - x) dx = 0.625 each.
//   A and C meet T1 only in segments (area 0); the root holds everything in its subtree.
// EPO = (C_T * 0.75 + C_I * 1 * 1.25) / 6.
struct Overlapping {
    Scene scene;
    Bvh bvh;
    Overlapping() {
        scene.triangles = {{{0, 0, 0}, {2, 0, 0}, {0, 2, 0}},
                           {{1, 0, -1}, {1, 0, 1}, {1, 2, 0}},
                           {{0, 0, 0.5f}, {2, 0, 0.5f}, {0, 2, 0.5f}}};
        bvh.nodes = {inner({{0, 0, -1}, {2, 2, 1}}, 1),          // 0 root
                     inner({{0, 0, 0}, {2, 2, 0.5f}}, 3),        // 1 N
                     leaf({{0.5f, 0, -1}, {1, 2, 1}}, 0, 1),     // 2 B = {T1}
                     leaf({{0, 0, 0}, {2, 2, 0}}, 1, 1),         // 3 A = {T0}
                     leaf({{0, 0, 0.5f}, {2, 2, 0.5f}}, 2, 1)};  // 4 C = {T2}
        bvh.primitives = {1, 0, 2};
    }
};

TEST(Metrics, EpoMatchesHandComputationForOverlappingBoxes) {
    Overlapping t;
    CostModel cost;
    cost.traversal_cost = 1.5f;
    cost.intersection_cost = 2.0f;
    EXPECT_NEAR(tree_epo(t.scene, t.bvh, cost), (1.5 * 0.75 + 2.0 * 1.25) / 6.0, 1e-12);
}

TEST(Metrics, EpoIgnoresTrianglesAlsoReferencedInsideTheSubtree) {
    // As a spatial split would: T1 is referenced by B and also by leaf A under N, so it is in Q(N)
    // and Q(A). Only B's overlap with T0 and T2 remains: C_I * 1 * 1.25 / 6.
    Overlapping t;
    t.bvh.nodes[3] = leaf({{0, 0, -1}, {2, 2, 0}}, 1, 2);  // A = {T0, T1}
    t.bvh.nodes[4] = leaf({{0, 0, 0.5f}, {2, 2, 0.5f}}, 3, 1);
    t.bvh.primitives = {1, 0, 1, 2};
    CostModel cost;
    cost.traversal_cost = 1.5f;
    cost.intersection_cost = 2.0f;
    EXPECT_NEAR(tree_epo(t.scene, t.bvh, cost), 2.0 * 1.25 / 6.0, 1e-12);
}

// A median-split tree over random triangles, children adjacent as in Bvh, leaves of up to 4.
Bvh median_tree(const Scene& scene) {
    Bvh bvh;
    std::vector<uint32_t> ids(scene.triangles.size());
    std::iota(ids.begin(), ids.end(), 0u);
    bvh.nodes.emplace_back();
    struct Task {
        uint32_t node, begin, end;
    };
    std::vector<Task> tasks{{0, 0, uint32_t(ids.size())}};
    std::vector<std::pair<uint32_t, std::vector<uint32_t>>> leaves;
    while (!tasks.empty()) {
        Task task = tasks.back();
        tasks.pop_back();
        AABB bounds;
        for (uint32_t i = task.begin; i < task.end; ++i) bounds.extend(scene.triangles[ids[i]].bounds());
        bvh.nodes[task.node].bounds = bounds;
        if (task.end - task.begin <= 4) {
            bvh.nodes[task.node].first = uint32_t(bvh.primitives.size());
            bvh.nodes[task.node].reference_count = task.end - task.begin;
            for (uint32_t i = task.begin; i < task.end; ++i) bvh.primitives.push_back(ids[i]);
            continue;
        }
        int axis = bounds.largest_axis();
        uint32_t middle = (task.begin + task.end) / 2;
        std::nth_element(
            ids.begin() + task.begin, ids.begin() + middle, ids.begin() + task.end, [&](uint32_t a, uint32_t b) {
                return scene.triangles[a].bounds().centroid(axis) < scene.triangles[b].bounds().centroid(axis);
            });
        uint32_t first = uint32_t(bvh.nodes.size());
        bvh.nodes[task.node].first = first;
        bvh.nodes.emplace_back();
        bvh.nodes.emplace_back();
        tasks.push_back({first + 1, middle, task.end});
        tasks.push_back({first, task.begin, middle});
    }
    return bvh;
}

Scene random_scene(size_t count, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> position(0.0f, 10.0f), offset(-1.5f, 1.5f);
    Scene scene;
    for (size_t i = 0; i < count; ++i) {
        Vec3 c{position(rng), position(rng), position(rng)};
        scene.triangles.push_back({c + Vec3(offset(rng), offset(rng), offset(rng)),
                                   c + Vec3(offset(rng), offset(rng), offset(rng)),
                                   c + Vec3(offset(rng), offset(rng), offset(rng))});
    }
    return scene;
}

// EPO straight from the definition: every node against every triangle not in its subtree.
double brute_force_epo(const Scene& scene, const Bvh& bvh, const CostModel& cost) {
    double total = 0.0;
    for (const Triangle& t : scene.triangles) total += clipped_triangle_area(t, t.bounds());
    double epo = 0.0;
    for (size_t n = 0; n < bvh.nodes.size(); ++n) {
        std::vector<uint8_t> in_subtree(scene.triangles.size(), 0);
        std::vector<uint32_t> stack{uint32_t(n)};
        while (!stack.empty()) {
            const BvhNode& m = bvh.nodes[stack.back()];
            stack.pop_back();
            if (m.is_leaf()) {
                for (uint32_t k = 0; k < m.reference_count; ++k) in_subtree[bvh.primitives[m.first + k]] = 1;
            } else {
                stack.push_back(m.first);
                stack.push_back(m.first + 1);
            }
        }
        double area = 0.0;
        for (size_t t = 0; t < scene.triangles.size(); ++t) {
            if (!in_subtree[t]) area += clipped_triangle_area(scene.triangles[t], bvh.nodes[n].bounds);
        }
        const BvhNode& node = bvh.nodes[n];
        epo += (node.is_leaf() ? cost.intersection_cost * node.reference_count : cost.traversal_cost) * area;
    }
    return epo / total;
}

TEST(Metrics, EpoMatchesBruteForceAndIsDeterministic) {
    Scene scene = random_scene(600, 99);
    Bvh bvh = median_tree(scene);
    CostModel cost;
    cost.traversal_cost = 1.2f;
    double expected = brute_force_epo(scene, bvh, cost);
    double parallel = tree_epo(scene, bvh, cost);
    EXPECT_GT(expected, 0.0);
    EXPECT_NEAR(parallel, expected, 1e-9 * expected);
    {
        tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
        EXPECT_EQ(tree_epo(scene, bvh, cost), parallel);  // bit for bit, whatever the thread count
    }
}

TEST(Metrics, TreeStats) {
    Overlapping t;
    CostModel cost;
    TreeStats stats = compute_tree_stats(t.scene, t.bvh, cost);
    EXPECT_EQ(stats.nodes, 5u);
    EXPECT_EQ(stats.inner_nodes, 2u);
    EXPECT_EQ(stats.leaves, 3u);
    EXPECT_EQ(stats.max_depth, 2u);
    EXPECT_DOUBLE_EQ(stats.mean_leaf_depth, (1.0 + 2.0 + 2.0) / 3.0);
    EXPECT_EQ(stats.references, 3u);
    EXPECT_EQ(stats.distinct_primitives, 3u);
    EXPECT_EQ(stats.bytes, 5 * sizeof(BvhNode) + 3 * sizeof(uint32_t));
    EXPECT_DOUBLE_EQ(stats.sah, tree_sah(t.bvh, cost));
    EXPECT_NEAR(stats.epo, (0.75 + 1.25) / 6.0, 1e-12);
    EXPECT_EQ(compute_tree_stats(t.scene, t.bvh, cost, false).epo, 0.0);

    TwoLeaves two;
    TreeStats dup = compute_tree_stats(two.scene, two.bvh, cost);
    EXPECT_EQ(dup.references, 3u);
    EXPECT_EQ(dup.distinct_primitives, 2u);
}

TEST(Metrics, EmptyTree) {
    Scene scene;
    Bvh bvh;
    EXPECT_EQ(tree_sah(bvh, CostModel{}), 0.0);
    EXPECT_EQ(tree_epo(scene, bvh, CostModel{}), 0.0);
    EXPECT_EQ(compute_tree_stats(scene, bvh, CostModel{}).nodes, 0u);
}

}  // namespace
}  // namespace spacebvh
