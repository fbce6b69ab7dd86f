// SPDX-License-Identifier: MIT
// The exhaustive optimum (src/builders/search_spaces/exhaustive_split.hpp): equal to a naive enumeration, and never
// beaten by an object-partitioning search space (object sweep, binned object, grid without
// splitting) under the same cost model, for plain SAH, a finite overlap penalty and C_o = inf.
#include <gtest/gtest.h>

#include <bit>
#include <random>
#include <vector>

#include "builders/search_spaces/binned_object_split_finder.hpp"
#include "builders/search_spaces/exhaustive_split.hpp"
#include "builders/search_spaces/grid_split_finder.hpp"
#include "builders/search_spaces/object_sweep_split_finder.hpp"
#include "spacebvh/error.hpp"
#include "test_support.hpp"

namespace spacebvh::builders {

using namespace spacebvh::tools;
namespace {

using Node = testing_support::SmallNode;

// Random triangles of very different sizes in [0, 10]^3 (long slivers included: where centroids
// mislead the object sweep).
Node random_node(std::mt19937& random, uint32_t count) {
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::vector<Triangle> triangles;
    for (uint32_t i = 0; i < count; ++i) {
        const Vec3 a{10 * unit(random), 10 * unit(random), 10 * unit(random)};
        const float size = i % 3 == 0 ? 8.0f : 0.5f;
        auto near = [&] { return a + Vec3{size * unit(random), size * unit(random), size * unit(random)}; };
        triangles.push_back({a, near(), near()});
    }
    return testing_support::small_node(std::move(triangles));
}

float naive_optimum(const Node& node, const CostModel& cost) {
    const uint32_t count = uint32_t(node.references.size());
    float best = kInfinity;
    for (uint32_t mask = 1; mask + 1 < (1u << count); ++mask) {
        AABB left, right;
        for (uint32_t i = 0; i < count; ++i) (mask >> i & 1 ? left : right).extend(node.references[i].bounds);
        const uint32_t left_count = uint32_t(std::popcount(mask));
        best = std::min(best, cost.split_cost(node.summary.bounds, left, left_count, right, count - left_count));
    }
    return best;
}

CostModel cost_with(float overlap_penalty) {
    CostModel cost;
    cost.overlap_penalty = overlap_penalty;
    return cost;
}

TEST(Exhaustive, EqualsANaiveEnumerationOfEveryPartition) {
    std::mt19937 random(1);
    for (int trial = 0; trial < 30; ++trial) {
        const Node node = random_node(random, 2 + trial % 11);
        const CostModel cost = cost_with(std::array{0.0f, 0.5f, kInfinity}[trial % 3]);
        const ExhaustiveSplit best = exhaustive_split(node.references, node.summary.bounds, cost);
        EXPECT_EQ(best.cost, naive_optimum(node, cost)) << "trial " << trial;
        if (best.cost < kInfinity) {
            // The reported partition has the reported boxes, counts and cost.
            AABB left, right;
            for (uint32_t i = 0; i < node.references.size(); ++i)
                (best.left_mask >> i & 1 ? left : right).extend(node.references[i].bounds);
            EXPECT_EQ(left, best.left_bounds);
            EXPECT_EQ(right, best.right_bounds);
            EXPECT_EQ(best.left_count + best.right_count, node.references.size());
            EXPECT_EQ(cost.split_cost(node.summary.bounds, left, best.left_count, right, best.right_count), best.cost);
        }
    }
}

// The validator: on random small nodes (up to 16 references) no object-partitioning search space
// finds a split cheaper than the optimum. The object sweep is strictly above it on some nodes (the
// slides' point: centroids are not enough).
TEST(Exhaustive, NoObjectPartitioningSearchSpaceBeatsTheOptimum) {
    std::mt19937 random(7);
    int sweep_above_optimum = 0, compared = 0;
    for (int trial = 0; trial < 60; ++trial) {
        Node node = random_node(random, 3 + trial % 14);
        const CostModel cost = cost_with(std::array{0.0f, 1.0f, kInfinity}[trial % 3]);
        const ExhaustiveSplit optimum = exhaustive_split(node.references, node.summary.bounds, cost);
        GridSearchOptions grid;
        grid.resolution = 4.0f;
        grid.split_primitives = false;
        const ObjectSweepSplitFinder sweep;
        const BinnedObjectSplitFinder binned(16);
        const GridSplitFinder grid_finder(node.triangles, grid);
        const Split none;
        for (const SplitFinder* finder :
             {static_cast<const SplitFinder*>(&sweep), static_cast<const SplitFinder*>(&binned),
              static_cast<const SplitFinder*>(&grid_finder)}) {
            const NodeContext context{node.references, node.summary, node.references.size(), node.summary.bounds.area(),
                                      none};
            const Split split = finder->find(context, cost);
            EXPECT_GE(split.cost, optimum.cost) << finder->name() << ", trial " << trial;
            if (finder == &sweep) sweep_above_optimum += split.cost > optimum.cost;
            ++compared;
        }
    }
    EXPECT_EQ(compared, 180);
    EXPECT_GT(sweep_above_optimum, 5);
}

TEST(Exhaustive, RefusesLargeNodes) {
    std::mt19937 random(2);
    const Node node = random_node(random, uint32_t(kMaxExhaustiveReferences + 1));
    EXPECT_THROW(exhaustive_split(node.references, node.summary.bounds, CostModel{}), Error);
    EXPECT_FALSE(exhaustive_split(std::span(node.references).first(1), node.summary.bounds, CostModel{}).cost <
                 kInfinity);
}

}  // namespace
}  // namespace spacebvh::builders
