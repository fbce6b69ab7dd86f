// SPDX-License-Identifier: MIT
// The reinsertion optimiser (src/builders/optimize/reinsertion_optimizer.hpp, ReinsertionConfig::iterations,
// optimize): the tree SAH never rises and falls where there is something to gain, the gains are
// priced exactly, the trees stay valid (depth cap included) and answer like the arbiter, the result
// does not depend on the thread count, and bad options, tiny trees and cancellation are handled.
// (Optimised trees on the builtin scenes against Embree and the arbiter: test_builders.cpp, suite
// Optimized/BuilderOnScene.)
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <tbb/global_control.h>

#include <atomic>
#include <cmath>
#include <string>
#include <vector>

#include "builders/optimize/reinsertion_optimizer.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tools/embree_builder.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/trace.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;
using namespace spacebvh::testing_support;

namespace {

BuildConfig optimized(BuildConfig options, uint32_t iterations = kDefaultReinsertionIterations) {
    options.reinsertion.iterations = iterations;
    return options;
}

uint32_t tree_depth(const Bvh& bvh) {
    uint32_t deepest = 0;
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};
    while (!stack.empty()) {
        const auto [index, depth] = stack.back();
        stack.pop_back();
        deepest = std::max(deepest, depth);
        const BvhNode& node = bvh.nodes[index];
        if (!node.is_leaf()) stack.insert(stack.end(), {{node.first, depth + 1}, {node.first + 1, depth + 1}});
    }
    return deepest;
}

}  // namespace

// The classical builder leaves much to gain on every builtin scene; the optimised tree keeps every
// triangle and its SAH is lower (Bittner et al. report 10-30 % for SAH builders).
TEST(Reinsertion, LowersTheSahOfBinnedTreesOnEveryBuiltinScene) {
    for (const std::string& name : builtin_scene_names()) {
        SCOPED_TRACE(name);
        const Scene& scene = cached_builtin_scene(name);
        const BuildConfig options = config_for("binned");
        const Bvh plain = spacebvh::build(scene, options);
        const Bvh better = spacebvh::build(scene, optimized(options));
        EXPECT_EQ(better.builder, "binned+opt");
        const double before = tree_sah(plain, options.cost), after = tree_sah(better, options.cost);
        RecordProperty("sah_" + name, std::to_string(before) + " -> " + std::to_string(after));
        EXPECT_LT(after, before * 0.995);
        EXPECT_EQ(better.nodes.size(), plain.nodes.size());
        EXPECT_EQ(tree_violations(scene, better, options), "");
    }
}

// Every preset, several cost models (C_T large and zero, C_o > 0 and inf): the SAH never rises, and
// C_T = 0 (inner nodes cost nothing) leaves the tree as built.
TEST(Reinsertion, NeverRaisesTheSahOfAnyBuilder) {
    const Scene scene = soup_prefix(2500);
    for (const std::string& builder : builder_names()) {
        for (float traversal_cost : {1.0f, 4.0f, 0.0f}) {
            SCOPED_TRACE(builder + ", C_T = " + std::to_string(traversal_cost));
            BuildConfig options = config_for(builder);
            options.cost.traversal_cost = traversal_cost;
            const Bvh plain = spacebvh::build(scene, options);
            const Bvh better = spacebvh::build(scene, optimized(options));
            const double before = tree_sah(plain, options.cost), after = tree_sah(better, options.cost);
            EXPECT_LE(after, before);
            if (traversal_cost == 0.0f) {
                EXPECT_EQ(first_difference(plain, better), "");
            } else {
                EXPECT_LT(after, before);  // a soup always has somewhere better to put a subtree
            }
            EXPECT_EQ(tree_violations(scene, better, options), "");
        }
    }
}

// The gain of each move is exact: the priced gains add up to the change of the inner nodes' area,
// and the tree SAH changes by C_T / SA(root) times that (leaves and SA(root) stay).
TEST(Reinsertion, GainsArePricedExactly) {
    const Scene& scene = cached_builtin_scene("interior");
    BuildConfig options = config_for("binned");
    options.cost.traversal_cost = 2.0f;
    Bvh bvh = spacebvh::build(scene, options);
    const double sah_before = tree_sah(bvh, options.cost);
    const AABB root_box = bvh.root().bounds;
    builders::ReinsertionOptions reinsertion;
    reinsertion.iterations = kDefaultReinsertionIterations;
    const builders::ReinsertionReport report = builders::optimize_by_reinsertion(bvh, reinsertion);
    EXPECT_GT(report.moves, 10u);
    EXPECT_GE(report.iterations, 2u);
    EXPECT_EQ(bvh.root().bounds, root_box);
    EXPECT_LE(report.inner_area_refitted, report.inner_area_before);
    EXPECT_GT(report.applied_gain, 0.0);
    EXPECT_NEAR(report.inner_area_refitted - report.inner_area_after, report.applied_gain,
                1e-9 * report.inner_area_before);
    const double root_area = double(root_box.area());
    const double predicted =
        sah_before - options.cost.traversal_cost * (report.inner_area_before - report.inner_area_after) / root_area;
    EXPECT_NEAR(tree_sah(bvh, options.cost), predicted, 1e-6 * sah_before);
}

// Small random scenes, small leaves and several builders: valid trees whose answers equal the
// arbiter's; the depth cap holds even where the optimiser would otherwise go deeper.
TEST(Reinsertion, SmallScenesStayValidAndAnswerLikeTheArbiter) {
    const Scene scene = soup_prefix(1500);
    const std::vector<Ray> rays = probing_rays(scene, 600, 5);
    for (const char* builder : {"binned", "spatial", "kdbvh"}) {
        for (uint32_t leaf : {1u, 4u}) {
            SCOPED_TRACE(std::string(builder) + ", max leaf " + std::to_string(leaf));
            BuildConfig options = config_for(builder);
            options.limits.max_leaf_size = leaf;
            const Bvh bvh = spacebvh::build(scene, optimized(options));
            EXPECT_EQ(tree_violations(scene, bvh, options), "");
            EXPECT_EQ(wrong_against_arbiter(scene, Tracer(scene, bvh, Kernel::binary), rays), "");
        }
    }
}

TEST(Reinsertion, DepthCapIsRespected) {
    const Scene scene = soup_prefix(3000);
    BuildConfig options = config_for("binned");
    options.limits.max_leaf_size = 1;
    const Bvh plain = spacebvh::build(scene, options);
    const uint32_t built_depth = tree_depth(plain);
    // Uncapped (64), the optimiser deepens this tree...
    const Bvh deeper = spacebvh::build(scene, optimized(options));
    ASSERT_GT(tree_depth(deeper), built_depth) << "the scene no longer tests the cap";
    // ...capped at the built depth (the same tree: no node reached the cap), it may not.
    options.limits.max_depth = built_depth;
    ASSERT_EQ(first_difference(spacebvh::build(scene, options), plain), "");
    const Bvh capped = spacebvh::build(scene, optimized(options));
    EXPECT_LE(tree_depth(capped), built_depth);
    EXPECT_LT(tree_sah(capped, options.cost), tree_sah(plain, options.cost));
    EXPECT_EQ(tree_violations(scene, capped, options), "");
    // A tree already deeper than the cap keeps its own depth as the cap.
    Bvh too_deep = plain;
    BuildConfig shallow = optimized(options);
    shallow.limits.max_depth = built_depth / 2;
    optimize(too_deep, shallow.reinsertion, shallow.limits.max_depth, shallow.hooks);
    EXPECT_LE(tree_depth(too_deep), built_depth);
    EXPECT_LE(tree_sah(too_deep, options.cost), tree_sah(plain, options.cost));
}

// The same tree byte for byte with 1, 2 and 4 threads (4 on 2 cores reorders the searches further).
TEST(Reinsertion, SameTreeForAnyThreadCount) {
    const Scene scene = soup_prefix(12000);
    for (const char* builder : {"binned", "spatial"}) {
        SCOPED_TRACE(builder);
        const BuildConfig options = optimized(config_for(builder));
        const Bvh one = build_in_arena(1, scene, options);
        EXPECT_EQ(first_difference(one, build_in_arena(2, scene, options)), "") << "1 vs 2 threads";
        tbb::global_control allow(tbb::global_control::max_allowed_parallelism, 4);
        EXPECT_EQ(first_difference(one, build_in_arena(4, scene, options)), "") << "1 vs 4 threads";
    }
}

// Embree's imported trees are binary trees like ours: optimize improves them too.
TEST(Reinsertion, OptimizesEmbreeTrees) {
    const Scene& scene = cached_builtin_scene("interior-rotated");
    const BuildConfig options = optimized(config_for("binned"));
    const Bvh embree = build_bvh_with_embree(scene, EmbreeQuality::high, options);
    Bvh better = embree;
    optimize(better, options.reinsertion, options.limits.max_depth, options.hooks);
    EXPECT_EQ(better.builder, "embree-high+opt");
    EXPECT_LT(tree_sah(better, options.cost), tree_sah(embree, options.cost));
    BuildConfig check = options;
    check.preset = Preset::spatial;  // Embree's high-quality trees split references (no object-partition checks)
    check.limits.reference_budget = 4.0f;
    EXPECT_EQ(tree_violations(scene, better, check), "");
}

TEST(Reinsertion, BadIterationCountsAreRejected) {
    BuildConfig options = config_for("binned");
    options.reinsertion.iterations = kMaxReinsertionIterations + 1;
    try {
        options.validate();
        FAIL() << "no error for " << options.reinsertion.iterations << " iterations";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("reinsertion iterations"), std::string::npos) << error.what();
        EXPECT_NE(std::string(error.what()).find("1001"), std::string::npos) << error.what();
    }
    EXPECT_THROW(spacebvh::build(two_floors(), options), Error);
    options.reinsertion.iterations = kMaxReinsertionIterations;
    EXPECT_NO_THROW(options.validate());
}

// Trees with nothing to move (1 leaf; 2 leaves; 3 leaves only if a subtree can change place) and the
// empty tree; an empty scene still throws as for any build.
TEST(Reinsertion, TinyAndEmptyTrees) {
    Scene scene = two_floors();
    for (size_t triangles : {1u, 2u, 3u, 4u}) {
        SCOPED_TRACE(std::to_string(triangles) + " triangles");
        Scene part = scene;
        part.triangles.resize(triangles);
        BuildConfig options = config_for("binned");
        options.limits.max_leaf_size = 1;
        const Bvh plain = spacebvh::build(part, options);
        const Bvh better = spacebvh::build(part, optimized(options));
        EXPECT_EQ(better.builder, "binned+opt");
        EXPECT_EQ(better.nodes.size(), 2 * triangles - 1);
        if (triangles <= 2) {
            EXPECT_EQ(first_difference(plain, better), "");
        }
        EXPECT_LE(tree_sah(better, options.cost), tree_sah(plain, options.cost));
        EXPECT_EQ(tree_violations(part, better, options), "");
    }
    Bvh empty;
    optimize(empty, optimized(config_for("binned")).reinsertion);
    EXPECT_TRUE(empty.empty());
    Scene nothing;
    nothing.name = "nothing";
    EXPECT_THROW(spacebvh::build(nothing, optimized(config_for("binned"))), Error);
}

// A set cancel flag stops the optimisation with Cancelled and leaves the tree as it was; progress
// reports run from the build's half to 1.
TEST(Reinsertion, CancelAndProgress) {
    const Scene scene = soup_prefix(6000);
    BuildConfig options = optimized(config_for("binned"));
    const Bvh plain = spacebvh::build(scene, config_for("binned"));
    std::atomic<bool> cancel{true};
    options.hooks.cancel = &cancel;
    Bvh tree = plain;
    EXPECT_THROW(optimize(tree, options.reinsertion, options.limits.max_depth, options.hooks), Cancelled);
    EXPECT_EQ(first_difference(tree, plain), "");
    EXPECT_EQ(tree.builder, "binned");
    EXPECT_THROW(spacebvh::build(scene, options), Cancelled);

    options.hooks.cancel = nullptr;
    ProgressLog log;
    options.hooks.progress = log.callback();
    EXPECT_FALSE(spacebvh::build(scene, options).empty());
    EXPECT_EQ(log.problems(), "");
    // The optimiser's share: past the build's half, before the end.
    EXPECT_GT(std::count_if(log.reports.begin(), log.reports.end(), [](double f) { return f > 0.5 && f < 1.0; }), 0);
}
