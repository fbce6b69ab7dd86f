// SPDX-License-Identifier: MIT
// The builders (include/spacebvh/bvh.hpp) on every builtin scene: tree invariants, answers of the
// binary tracer against Embree with the exact arbiter settling disagreements (docs/rays.md),
// determinism across thread counts, the build options, and edge-case scenes.
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "spacebvh/presets.hpp"
#include "spacebvh/tools/embree_scene.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/clip.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tools/verify.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;

namespace {

// Tree invariants (tree_violations), the arbiter check and byte-wise tree comparison: test_support.hpp.
using namespace testing_support;

// Every node's box is exactly the union of the triangle boxes below it (object partitioning keeps
// boxes tight).
std::string loose_boxes(const Scene& scene, const Bvh& bvh) {
    std::vector<AABB> computed(bvh.nodes.size());
    // Children come after parents, so a reverse sweep sees children first.
    for (size_t i = bvh.nodes.size(); i-- > 0;) {
        const BvhNode& node = bvh.nodes[i];
        AABB box;
        if (node.is_leaf()) {
            for (uint32_t p = node.first; p < node.first + node.reference_count; ++p)
                box.extend(scene.triangles[bvh.primitives[p]].bounds());
        } else {
            box = merge(computed[node.first], computed[node.first + 1]);
        }
        computed[i] = box;
        if (!(box == node.bounds)) return "node " + std::to_string(i) + " box is not tight";
    }
    return "";
}

// ---------------------------------------------------------------------------------------------------
// Builtin scenes with their rays and Embree's answers, loaded once per process.

struct SceneCase {
    std::string name;
    Scene scene;
    std::vector<Ray> rays[3];  // random, primary, diffuse
    std::vector<HitRecord> embree_closest[3], embree_occlusion[3];
};

const char* kKindNames[3] = {"random", "primary", "diffuse"};

const Scene& builtin(const std::string& name) { return testing_support::cached_builtin_scene(name); }

const SceneCase& scene_case(const std::string& name) {
    static std::mutex mutex;
    static std::map<std::string, std::unique_ptr<SceneCase>> cache;
    std::lock_guard lock(mutex);
    auto& slot = cache[name];
    if (slot) return *slot;
    auto c = std::make_unique<SceneCase>();
    c->name = name;
    c->scene = builtin(name);
    const EmbreeScene embree(c->scene, EmbreeQuality::medium);
    // >= 10k rays of each kind: 10,000 random, 128 x 80 = 10,240 primary, diffuse from Embree's primary hits.
    c->rays[0] = generate_random_rays(c->scene.bounds(), 10000, 1);
    const Camera camera = camera_for_scene(c->scene, "builtin:" + name, SceneTransform{});
    c->rays[1] = generate_primary_rays(camera, 128, 80);
    // Diffuse rays start at primary hits; where few primary rays hit (soup, organic), take them from a
    // finer image until there are >= 10k, then thin them evenly to at most 12k.
    for (uint32_t scale = 1; c->rays[2].size() < 10000 && scale <= 8; scale *= 2) {
        const std::vector<Ray> source = generate_primary_rays(camera, 128 * scale, 80 * scale);
        std::vector<Hit> primary_hits(source.size());
        embree.intersect(source, primary_hits);
        c->rays[2] = generate_diffuse_rays(c->scene, source, primary_hits, 1);
    }
    if (c->rays[2].size() > 12000) {
        std::vector<Ray> thinned;
        const double step = double(c->rays[2].size()) / 12000.0;
        for (size_t i = 0; i < 12000; ++i) thinned.push_back(c->rays[2][size_t(double(i) * step)]);
        c->rays[2] = std::move(thinned);
    }
    for (int k = 0; k < 3; ++k) {
        std::vector<Hit> hits(c->rays[k].size());
        std::vector<uint8_t> occluded(c->rays[k].size());
        embree.intersect(c->rays[k], hits);
        embree.occluded(c->rays[k], occluded);
        c->embree_closest[k].resize(hits.size());
        c->embree_occlusion[k].resize(hits.size());
        for (size_t i = 0; i < hits.size(); ++i) {
            c->embree_closest[k][i] = to_record(hits[i]);
            c->embree_occlusion[k][i] = occlusion_record(occluded[i]);
        }
    }
    slot = std::move(c);
    return *slot;
}

// Our answers on the case's rays against Embree's; every disagreement goes to the arbiter. Expects
// none of ours wrong and reports Embree's wrong count.
void expect_agrees_with_embree(const SceneCase& c, const Tracer& tracer, const std::string& label) {
    for (int k = 0; k < 3; ++k) {
        SCOPED_TRACE(label + ", " + kKindNames[k] + " rays");
        const auto& rays = c.rays[k];
        ASSERT_GE(rays.size(), 10000u);
        const VerificationReport closest =
            verify_against_reference(c.scene, rays, closest_records(tracer, rays), c.embree_closest[k], false);
        const VerificationReport occlusion =
            verify_against_reference(c.scene, rays, occlusion_records(tracer, rays), c.embree_occlusion[k], true);
        EXPECT_EQ(closest.ours_wrong, 0u)
            << "closest hit; first wrong ray " << (closest.wrong_rays.empty() ? 0 : closest.wrong_rays.front());
        EXPECT_EQ(occlusion.ours_wrong, 0u)
            << "occlusion; first wrong ray " << (occlusion.wrong_rays.empty() ? 0 : occlusion.wrong_rays.front());
        ::testing::Test::RecordProperty(label + "_" + kKindNames[k] + "_embree_wrong",
                                        std::to_string(closest.reference_wrong + occlusion.reference_wrong));
        if (closest.reference_wrong + occlusion.reference_wrong > 0)
            std::printf("[ info ] %s %s rays: Embree medium wrong on %zu closest, %zu occlusion of %zu\n",
                        label.c_str(), kKindNames[k], closest.reference_wrong, occlusion.reference_wrong, rays.size());
    }
}

std::string param_name(std::string text) {
    for (char& c : text)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    return text;
}

// ---------------------------------------------------------------------------------------------------
// Parameterised over (builder, builtin scene).

class BuilderOnScene : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {
protected:
    const std::string& builder() const { return std::get<0>(GetParam()); }
    const std::string& scene_name() const { return std::get<1>(GetParam()); }
};

std::string builder_scene_name(const ::testing::TestParamInfo<std::tuple<std::string, std::string>>& info) {
    return param_name(std::get<0>(info.param) + "_" + std::get<1>(info.param));
}

}  // namespace

// Structure (reachability, containment, leaf ranges and sizes, depth, node count, tight boxes);
// closest hit and occlusion against Embree, or the arbiter where they differ, on >= 10k rays per
// kind; and the same tree byte for byte when built with 1 thread instead of 2. (One test, so that the
// slow builders build each scene only twice.) "NAME+opt": the tree optimised by reinsertion.
TEST_P(BuilderOnScene, TreeIsValidAgreesWithEmbreeAndIsDeterministic) {
    const SceneCase& c = scene_case(scene_name());
    const BuildConfig options = options_for_tree(builder());
    const Bvh bvh = build_in_arena(2, c.scene, options);
    EXPECT_EQ(bvh.builder, builder());
    uint32_t depth = 0;
    EXPECT_EQ(tree_violations(c.scene, bvh, options, &depth), "");
    if (partitions_objects(to_string(options.preset))) {
        EXPECT_EQ(loose_boxes(c.scene, bvh), "");
    }
    EXPECT_GT(depth, 5u);  // tens of thousands of triangles need a real tree
    const TreeStats stats = compute_tree_stats(c.scene, bvh, options.cost, false);
    EXPECT_EQ(stats.distinct_primitives, c.scene.triangles.size());
    EXPECT_EQ(stats.max_depth, depth);

    {
        const Tracer tracer(c.scene, bvh, Kernel::binary);
        expect_agrees_with_embree(c, tracer, builder() + "_" + scene_name());
    }

    const Bvh one_thread = build_in_arena(1, c.scene, options);
    EXPECT_EQ(first_difference(one_thread, bvh), "") << "1 vs 2 threads";
}

INSTANTIATE_TEST_SUITE_P(Builtin, BuilderOnScene,
                         ::testing::Combine(::testing::ValuesIn(builder_names()),
                                            ::testing::ValuesIn(builtin_scene_names())),
                         builder_scene_name);

// The reinsertion optimiser (src/builders/optimize/reinsertion_optimizer.hpp) on the classical builder everywhere,
// and on spatial-split trees (leaves holding clipped references) where splits matter most.
INSTANTIATE_TEST_SUITE_P(Optimized, BuilderOnScene,
                         ::testing::Values(std::make_tuple("binned+opt", "interior"),
                                           std::make_tuple("binned+opt", "interior-rotated"),
                                           std::make_tuple("binned+opt", "organic"),
                                           std::make_tuple("binned+opt", "soup"),
                                           std::make_tuple("spatial+opt", "interior-rotated")),
                         builder_scene_name);

// The exact spatial sweep (BuildConfig::exact_spatial_sweep) in the presets with spatial search:
// valid trees, answers equal to the arbiter's, the same tree with 1 and 2 threads.
TEST(ExactSpatialSweep, TreesAreValidAnswerLikeTheArbiterAndAreDeterministic) {
    for (const char* scene_name : {"soup", "interior"}) {
        const Scene& scene = builtin(scene_name);
        const std::vector<Ray> rays = generate_random_rays(scene.bounds(), 300, 1);
        for (const char* builder : {"kdbvh", "spatial"}) {
            SCOPED_TRACE(std::string(builder) + " on " + scene_name);
            BuildConfig options = config_for(builder);
            options.spatial.exact_sweep = true;
            const Bvh bvh = build_in_arena(2, scene, options);
            EXPECT_EQ(tree_violations(scene, bvh, options), "");
            EXPECT_EQ(first_difference(build_in_arena(1, scene, options), bvh), "") << "1 vs 2 threads";
            EXPECT_EQ(wrong_against_arbiter(scene, Tracer(scene, bvh, Kernel::binary), rays), "");
        }
    }
}

namespace {

class PerBuiltinScene : public ::testing::TestWithParam<std::string> {};
class PerBuilder : public ::testing::TestWithParam<std::string> {};
class ObjectBuilder : public ::testing::TestWithParam<std::string> {};

std::string plain_name(const ::testing::TestParamInfo<std::string>& info) { return param_name(info.param); }

}  // namespace

// The exact sweep (cbvh) never gives a worse tree SAH than the binned approximation.
TEST_P(PerBuiltinScene, CbvhTreeSahIsAtMostBinned) {
    const Scene& scene = builtin(GetParam());
    const BuildConfig sweep = config_for("cbvh"), binned = config_for("binned");
    const double sah_cbvh = tree_sah(spacebvh::build(scene, sweep), sweep.cost);
    const double sah_binned = tree_sah(spacebvh::build(scene, binned), binned.cost);
    RecordProperty("sah_cbvh", std::to_string(sah_cbvh));
    RecordProperty("sah_binned", std::to_string(sah_binned));
    EXPECT_GT(sah_cbvh, 0.0);
    EXPECT_LE(sah_cbvh, sah_binned) << GetParam();
}

INSTANTIATE_TEST_SUITE_P(Builtin, PerBuiltinScene, ::testing::ValuesIn(builtin_scene_names()), plain_name);

// Brute force (no Embree): our answers equal the arbiter's on 300 rays of each kind on the soup.
TEST_P(PerBuilder, AnswersEqualTheArbiterOnTheSoup) {
    const Scene& scene = builtin("soup");
    const Bvh bvh = spacebvh::build(scene, config_for(GetParam()));
    const Tracer tracer(scene, bvh, Kernel::binary);
    const std::vector<Ray> random = generate_random_rays(scene.bounds(), 300, 1);
    // 20 x 15 = 300 primary rays.
    const std::vector<Ray> primary = generate_primary_rays(camera_for_scene(scene, "builtin:soup", {}), 20, 15);
    // Diffuse rays from many more primary rays, cut to 300.
    const std::vector<Ray> more_primary = generate_primary_rays(camera_for_scene(scene, "builtin:soup", {}), 64, 48);
    std::vector<Hit> hits(more_primary.size());
    tracer.intersect(more_primary, hits);
    std::vector<Ray> diffuse = generate_diffuse_rays(scene, more_primary, hits, 1);
    ASSERT_GE(diffuse.size(), 300u);
    diffuse.resize(300);
    EXPECT_EQ(wrong_against_arbiter(scene, tracer, random), "") << "random";
    EXPECT_EQ(wrong_against_arbiter(scene, tracer, primary), "") << "primary";
    EXPECT_EQ(wrong_against_arbiter(scene, tracer, diffuse), "") << "diffuse";
}

namespace {

// Small random scenes with features that stress partitioning: clusters, duplicates, degenerate
// triangles, axis-aligned and coplanar triangles, long slivers.
Scene small_random_scene(uint64_t seed, size_t count) {
    SplitMix64 rng(seed);
    Scene scene;
    scene.name = "small_" + std::to_string(seed);
    auto point = [&](float scale) {
        return Vec3(scale * (2 * rng.uniform() - 1), scale * (2 * rng.uniform() - 1), scale * (2 * rng.uniform() - 1));
    };
    while (scene.triangles.size() < count) {
        const float choice = rng.uniform();
        const Vec3 c = point(10.0f);
        if (choice < 0.4f) {
            scene.triangles.push_back({c + point(1.0f), c + point(1.0f), c + point(1.0f)});
        } else if (choice < 0.5f && !scene.triangles.empty()) {
            scene.triangles.push_back(scene.triangles[size_t(rng.uniform() * float(scene.triangles.size()))]);
        } else if (choice < 0.6f) {
            const Vec3 d = point(1.0f);
            scene.triangles.push_back({c, c + d, c + d * 2.0f});  // degenerate (collinear)
        } else if (choice < 0.75f) {
            const float z = std::round(c.z);  // axis-aligned, on shared integer planes
            scene.triangles.push_back({{std::round(c.x), std::round(c.y), z},
                                       {std::round(c.x) + 1, std::round(c.y), z},
                                       {std::round(c.x), std::round(c.y) + 1, z}});
        } else if (choice < 0.85f) {
            scene.triangles.push_back({c, c + Vec3(15.0f, 0.1f, 0.0f), c + Vec3(0.0f, 0.2f, 0.05f)});  // sliver
        } else {
            // A small cluster around one point.
            for (int i = 0; i < 4; ++i)
                scene.triangles.push_back({c + point(0.05f), c + point(0.05f), c + point(0.05f)});
        }
    }
    for (const Triangle& t : scene.triangles) scene.degenerate_count += t.is_degenerate();
    return scene;
}

}  // namespace

// Many small scenes and option combinations: invariants hold and every answer equals the arbiter's.
TEST_P(PerBuilder, SmallScenesWithManyOptionsMatchTheArbiter) {
    struct Variant {
        uint32_t max_leaf, max_depth, bins;
        float c_o;
        uint32_t leaf_block = 1;
    };
    const Variant variants[] = {{8, 64, 32, 0.0f},         {1, 64, 2, 0.0f},     {2, 64, 256, 1.0f},
                                {4, 3, 16, kInfinity},     {1, 1024, 7, 0.0f},   {3, 64, 32, kInfinity},
                                {16, 2, 32, 0.5f},         {8, 64, 32, 0.0f, 4}, {2, 64, 16, 1.0f, 8},
                                {16, 64, 32, kInfinity, 4}};
    uint64_t seed = 11;
    for (const size_t count : {1, 2, 3, 9, 40, 150, 700}) {
        for (const Variant& v : variants) {
            const Scene scene = small_random_scene(++seed, count);
            BuildConfig options = config_for(GetParam());
            options.limits.max_leaf_size = v.max_leaf;
            options.limits.max_depth = v.max_depth;
            options.object.bins = v.bins;
            options.cost.overlap_penalty = v.c_o;
            options.cost.leaf_block = v.leaf_block;
            SCOPED_TRACE(scene.name + " (" + std::to_string(scene.triangles.size()) + " triangles), max leaf " +
                         std::to_string(v.max_leaf) + ", max depth " + std::to_string(v.max_depth) + ", bins " +
                         std::to_string(v.bins) + ", C_o " + std::to_string(v.c_o) + ", leaf block " +
                         std::to_string(v.leaf_block));
            const Bvh bvh = spacebvh::build(scene, options);
            ASSERT_EQ(tree_violations(scene, bvh, options), "");
            const Tracer tracer(scene, bvh, Kernel::binary);
            EXPECT_EQ(wrong_against_arbiter(scene, tracer, probing_rays(scene, 300, seed)), "");
        }
    }
}

// max_leaf_size bounds every leaf (no leaf reaches max_depth here, so none is exempt).
TEST_P(PerBuilder, MaxLeafSizeIsRespected) {
    const Scene scene = soup_prefix(6000);
    for (uint32_t max_leaf : {1u, 3u, 16u}) {
        BuildConfig options = config_for(GetParam());
        options.limits.max_leaf_size = max_leaf;
        const Bvh bvh = spacebvh::build(scene, options);
        uint32_t depth = 0;
        EXPECT_EQ(tree_violations(scene, bvh, options, &depth), "") << "max leaf " << max_leaf;
        EXPECT_LT(depth, options.limits.max_depth);
        uint32_t largest = 0;
        for (const BvhNode& node : bvh.nodes) largest = std::max(largest, node.reference_count);
        EXPECT_LE(largest, max_leaf);
        if (max_leaf == 1) {
            EXPECT_EQ(bvh.nodes.size(), 2 * bvh.primitives.size() - 1);
        }
    }
}

// max_depth bounds the depth; the deepest leaves then hold more than max_leaf_size, and answers stay right.
TEST_P(PerBuilder, MaxDepthIsRespected) {
    const SceneCase& c = scene_case("interior");
    for (uint32_t max_depth : {1u, 4u, 10u}) {
        BuildConfig options = config_for(GetParam());
        options.limits.max_depth = max_depth;
        const Bvh bvh = spacebvh::build(c.scene, options);
        uint32_t depth = 0;
        EXPECT_EQ(tree_violations(c.scene, bvh, options, &depth), "") << "max depth " << max_depth;
        EXPECT_EQ(depth, max_depth);
        uint32_t largest = 0;
        for (const BvhNode& node : bvh.nodes) largest = std::max(largest, node.reference_count);
        EXPECT_GT(largest, options.limits.max_leaf_size);
        if (max_depth == 1) {
            EXPECT_EQ(bvh.nodes.size(), 3u);
        }
        if (max_depth == 10)
            expect_agrees_with_embree(c, Tracer(c.scene, bvh, Kernel::binary), GetParam() + "_depth10");
    }
}

// C_o = inf (disjoint children only) with an object builder still builds a valid tree (the median
// fallback splits where no object split is disjoint) that answers correctly. (Finite C_o: see
// SmallScenesWithManyOptionsMatchTheArbiter.)
TEST_P(ObjectBuilder, InfiniteOverlapPenaltyBuildsValidCorrectTrees) {
    for (const char* name : {"soup", "interior-rotated"}) {
        const SceneCase& c = scene_case(name);
        BuildConfig options = config_for(GetParam());
        options.cost.overlap_penalty = kInfinity;
        const Bvh bvh = spacebvh::build(c.scene, options);
        EXPECT_EQ(bvh.cost.overlap_penalty, kInfinity);
        EXPECT_EQ(tree_violations(c.scene, bvh, options), "") << name;
        expect_agrees_with_embree(c, Tracer(c.scene, bvh, Kernel::binary), GetParam() + "_" + name + "_co_inf");
    }
}

// One triangle: a single leaf root that is hit where expected.
TEST_P(PerBuilder, OneTriangleScene) {
    Scene scene;
    scene.name = "one";
    scene.triangles = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}};
    const BuildConfig options = config_for(GetParam());
    const Bvh bvh = spacebvh::build(scene, options);
    ASSERT_EQ(bvh.nodes.size(), 1u);
    EXPECT_TRUE(bvh.root().is_leaf());
    EXPECT_EQ(bvh.root().reference_count, 1u);
    EXPECT_EQ(bvh.primitives, std::vector<uint32_t>{0});
    EXPECT_EQ(bvh.root().bounds, scene.triangles[0].bounds());
    const Tracer tracer(scene, bvh, Kernel::binary);
    Ray ray;
    ray.org = {0.25f, 0.25f, 2.0f};
    ray.dir = {0, 0, -1};
    const Hit hit = tracer.intersect(ray);
    EXPECT_EQ(hit.primitive, 0u);
    EXPECT_EQ(hit.t, 2.0f);
    EXPECT_TRUE(tracer.occluded(ray));
    ray.org = {0.75f, 0.75f, 2.0f};
    EXPECT_FALSE(tracer.intersect(ray).is_hit());
    EXPECT_FALSE(tracer.occluded(ray));
}

// Many identical triangles (all centroids equal, far more than max_leaf_size): split anyway, traced right.
TEST_P(PerBuilder, IdenticalTrianglesAreSplitAndTraced) {
    Scene scene;
    scene.name = "identical";
    const Triangle t{{-1, -1, 3}, {2, -1, 3}, {-1, 2, 3}};
    scene.triangles.assign(100, t);
    const BuildConfig options = config_for(GetParam());
    const Bvh bvh = spacebvh::build(scene, options);
    uint32_t depth = 0;
    EXPECT_EQ(tree_violations(scene, bvh, options, &depth), "");
    EXPECT_LE(depth, 10u);  // halving: about log2(100 / 8) + 1 levels
    const Tracer tracer(scene, bvh, Kernel::binary);
    EXPECT_EQ(wrong_against_arbiter(scene, tracer, probing_rays(scene, 500, 3)), "");
    Ray ray;
    ray.org = {0, 0, 0};
    ray.dir = {0, 0, 1};
    const Hit hit = tracer.intersect(ray);
    ASSERT_TRUE(hit.is_hit());
    EXPECT_EQ(hit.t, 3.0f);
    EXPECT_LT(hit.primitive, 100u);
}

// Different triangles that share one centroid (no centroid cut separates them) and nested sizes.
TEST_P(PerBuilder, TrianglesWithOneCommonCentroidAreSplitAndTraced) {
    Scene scene;
    scene.name = "common_centroid";
    const Vec3 c{0.5f, -0.25f, 2.0f};
    for (int i = 1; i <= 60; ++i) {
        const float s = 0.0625f * float(i);  // exact, so c - s and c + s average to c exactly
        switch (i % 3) {
            case 0:
                scene.triangles.push_back({c + Vec3(-s, -s, 0), c + Vec3(s, -s, 0), c + Vec3(0, s, 0)});
                break;
            case 1:
                scene.triangles.push_back({c + Vec3(0, -s, -s), c + Vec3(0, s, -s), c + Vec3(0, 0, s)});
                break;
            default:
                scene.triangles.push_back({c + Vec3(-s, 0, -s), c + Vec3(s, 0, s), c + Vec3(-s, 0, s)});
                break;
        }
    }
    for (const Triangle& t : scene.triangles) ASSERT_EQ(t.bounds().center(), c);
    const BuildConfig options = config_for(GetParam());
    const Bvh bvh = spacebvh::build(scene, options);
    EXPECT_EQ(tree_violations(scene, bvh, options), "");
    const Tracer tracer(scene, bvh, Kernel::binary);
    EXPECT_EQ(wrong_against_arbiter(scene, tracer, probing_rays(scene, 1000, 5)), "");
}

// A scene with degenerate triangles only (and a line of them): builds, and nothing is ever hit.
TEST_P(PerBuilder, DegenerateOnlySceneBuildsAndIsNeverHit) {
    Scene scene;
    scene.name = "degenerate";
    for (int i = 0; i < 50; ++i) {
        const float x = float(i);
        scene.triangles.push_back({{x, 0, 0}, {x + 0.5f, 0, 0}, {x + 1.0f, 0, 0}});  // collinear
        scene.triangles.push_back({{x, 1, 1}, {x, 1, 1}, {x, 1, 1}});                // a point
        scene.triangles.push_back({{x, 2, 0}, {x + 1, 2.5f, 0}, {x + 1, 2.5f, 0}});  // repeated vertex
    }
    const BuildConfig options = config_for(GetParam());
    const Bvh bvh = spacebvh::build(scene, options);
    EXPECT_EQ(tree_violations(scene, bvh, options), "");
    const Tracer tracer(scene, bvh, Kernel::binary);
    size_t hits = 0;
    for (const Ray& ray : probing_rays(scene, 500, 9)) hits += tracer.intersect(ray).is_hit() + tracer.occluded(ray);
    EXPECT_EQ(hits, 0u);
}

// Invalid options and an empty scene throw Error (never build).
TEST(BuildConfig, InvalidOptionsAndEmptySceneThrow) {
    Scene scene;
    scene.name = "tiny";
    scene.triangles = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{2, 0, 0}, {3, 0, 0}, {2, 1, 0}}};
    auto with = [](auto change) {
        BuildConfig options;
        change(options);
        return options;
    };
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.preset = Preset(99); })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.preset = Preset(8); })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.object.bins = 1; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.object.bins = 0; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.object.bins = 257; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.object.bins = 100000; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.limits.max_leaf_size = 0; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.limits.max_depth = 0; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.limits.max_depth = 1025; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.cost.traversal_cost = -1.0f; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.cost.intersection_cost = 0.0f; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.cost.overlap_penalty = -1.0f; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.cost.overlap_penalty = std::nanf(""); })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.spatial.bins = 1; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.spatial.bins = 1025; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.limits.reference_budget = 0.5f; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.limits.reference_budget = 5.0f; })), Error);
    EXPECT_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.limits.reference_budget = std::nanf(""); })),
                 Error);
    EXPECT_THROW(config_for("no-such-builder"), Error);
    EXPECT_NO_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.object.bins = 2; })));
    EXPECT_NO_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.object.bins = 256; })));
    EXPECT_NO_THROW(spacebvh::build(scene, with([](BuildConfig& o) { o.limits.max_depth = 1024; })));

    try {
        (void)config_for("nope");
        FAIL() << "no exception";
    } catch (const Error& e) {
        // The message names the bad builder and the known ones.
        EXPECT_NE(std::string(e.what()).find("nope"), std::string::npos) << e.what();
        for (const std::string& name : builder_names())
            EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }

    Scene empty;
    empty.name = "empty";
    for (const std::string& name : builder_names())
        EXPECT_THROW(spacebvh::build(empty, config_for(name)), Error) << name;
}

// Counting references in blocks of four makes leaves of up to four triangles as cheap as one: the
// trees of every builder get fewer, fuller leaves than with the plain SAH, on the organic mesh.
TEST(BuildConfig, LeafBlocksGiveFullerLeaves) {
    const Scene& scene = builtin("organic");
    for (const char* builder : {"cbvh", "binned", "spatial"}) {
        BuildConfig options = config_for(builder);
        auto leaves = [&](uint32_t block) {
            options.cost.leaf_block = block;
            const Bvh bvh = spacebvh::build(scene, options);
            EXPECT_EQ(bvh.cost.leaf_block, block);
            size_t count = 0;
            for (const BvhNode& node : bvh.nodes) count += node.is_leaf();
            return count;
        };
        const size_t plain = leaves(1), blocks = leaves(4);
        EXPECT_LT(double(blocks), 0.6 * double(plain))
            << builder << ": " << blocks << " leaves with B = 4, " << plain << " with B = 1";
    }
}

// builder_names() lists cbvh and binned, each with a description; the tree records builder and cost.
TEST(BuildConfig, BuilderNamesDescriptionsAndRecordedSettings) {
    const std::vector<std::string> names = builder_names();
    EXPECT_NE(std::find(names.begin(), names.end(), "cbvh"), names.end());
    EXPECT_NE(std::find(names.begin(), names.end(), "binned"), names.end());
    for (const std::string& name : names) EXPECT_FALSE(describe_builder(name).empty()) << name;
    EXPECT_TRUE(describe_builder("no-such-builder").empty());

    Scene scene;
    scene.name = "two";
    scene.triangles = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{5, 0, 0}, {6, 0, 0}, {5, 1, 0}}};
    BuildConfig options = config_for("cbvh");
    options.cost.traversal_cost = 0.5f;
    options.cost.overlap_penalty = 2.0f;
    const Bvh bvh = spacebvh::build(scene, options);
    EXPECT_EQ(bvh.builder, "cbvh");
    EXPECT_EQ(bvh.cost.traversal_cost, 0.5f);
    EXPECT_EQ(bvh.cost.overlap_penalty, 2.0f);
    EXPECT_EQ(bvh.cost.intersection_cost, 1.0f);
}

// Repeated builds with 2 threads, and with 4 threads on 2 cores (oversubscription reorders tasks
// even more), give the same tree byte for byte as a 1-thread build.
TEST_P(PerBuilder, RepeatedAndOversubscribedBuildsAreIdentical) {
    const Scene scene = soup_prefix(12000);
    const BuildConfig options = config_for(GetParam());
    const Bvh one = build_in_arena(1, scene, options);
    const Bvh two = build_in_arena(2, scene, options);
    const Bvh two_again = build_in_arena(2, scene, options);
    EXPECT_EQ(first_difference(one, two), "") << "1 vs 2 threads";
    EXPECT_EQ(first_difference(two, two_again), "") << "2 threads twice";
    tbb::global_control allow(tbb::global_control::max_allowed_parallelism, 4);
    const Bvh four = build_in_arena(4, scene, options);
    EXPECT_EQ(first_difference(one, four), "") << "1 vs 4 threads";
}

// The progress callback reports fractions in [0, 1] and finishes with 1.
TEST_P(PerBuilder, ProgressReportsFractionsUpToOne) {
    const Scene scene = soup_prefix(6000);
    BuildConfig options = config_for(GetParam());
    ProgressLog log;
    options.hooks.progress = log.callback();
    EXPECT_FALSE(spacebvh::build(scene, options).empty());
    EXPECT_EQ(log.problems(), "");
    EXPECT_GT(log.reports.size(), 2u);
}

// With max_depth up to 1024 allowed, a builder may make trees far deeper than 64 levels; tracing such a
// tree must still work. Collinear degenerate triangles have SA(N) = 0, where every split costs the same,
// so the binned builder peels one bin per level (about 150 levels, both children inner nodes) and cbvh
// one reference per level (down to max_depth).
TEST_P(PerBuilder, VeryDeepTreesAreTracedCorrectly) {
    Scene scene;
    scene.name = "line";
    for (int i = 0; i < 20000; ++i) {
        const float x = float(i);
        scene.triangles.push_back({{x, 0, 0}, {x + 0.5f, 0, 0}, {x + 1.0f, 0, 0}});
    }
    scene.triangles.push_back({{-2, -1, -1}, {-2, 1, -1}, {-2, 0, 1}});  // one real triangle at the far end
    BuildConfig options = config_for(GetParam());
    options.limits.max_leaf_size = 1;
    options.limits.max_depth = 1024;
    const Bvh bvh = spacebvh::build(scene, options);
    uint32_t depth = 0;
    EXPECT_EQ(tree_violations(scene, bvh, options, &depth), "");
    RecordProperty("depth", std::to_string(depth));
    // The point of the scene: the binned builder makes a tree deeper than 128 levels here.
    if (GetParam() == "binned") {
        EXPECT_GT(depth, 128u) << "the scene no longer makes a deep tree";
    }
    const Tracer tracer(scene, bvh, Kernel::binary);
    // Along the line of degenerate triangles (inside every node box) to the real triangle.
    Ray ray;
    ray.org = {20005.0f, 0.0f, 0.0f};
    ray.dir = {-1.0f, 0.0f, 0.0f};
    const Hit hit = tracer.intersect(ray);
    EXPECT_EQ(hit.primitive, 20000u);
    EXPECT_EQ(hit.t, 20007.0f);
    EXPECT_TRUE(tracer.occluded(ray));
}

INSTANTIATE_TEST_SUITE_P(All, PerBuilder, ::testing::ValuesIn(builder_names()), plain_name);
INSTANTIATE_TEST_SUITE_P(Object, ObjectBuilder, ::testing::Values("cbvh", "binned"), plain_name);

// ---------------------------------------------------------------------------------------------------
// Recursive cost evaluation (BuildConfig::lookahead_depth; the choice itself is tested in
// test_lookahead.cpp): the trees it builds are valid, answer as the arbiter does, and are the same
// byte for byte with 1 and 2 threads.

namespace {

class LookaheadBuilder : public ::testing::TestWithParam<std::tuple<std::string, uint32_t>> {};

std::string lookahead_name(const ::testing::TestParamInfo<std::tuple<std::string, uint32_t>>& info) {
    return param_name(std::get<0>(info.param) + "_lookahead" + std::to_string(std::get<1>(info.param)));
}

}  // namespace

TEST_P(LookaheadBuilder, TreesAreValidCorrectAndDeterministic) {
    const auto& [builder, depth] = GetParam();
    // cbvh: big enough for the parallel paths (subtrees and candidate pricing from 4096 references);
    // spatial (10x slower): clipping and the budget in the priced subtrees.
    const Scene scene = soup_prefix(builder == "cbvh" ? 6000 : 2000);
    BuildConfig options = config_for(builder);
    options.lookahead.depth = depth;
    const Bvh bvh = build_in_arena(2, scene, options);
    EXPECT_EQ(tree_violations(scene, bvh, options), "");
    const Tracer tracer(scene, bvh, Kernel::binary);
    EXPECT_EQ(wrong_against_arbiter(scene, tracer, probing_rays(scene, 1500, 11)), "");
    EXPECT_EQ(first_difference(build_in_arena(1, scene, options), bvh), "") << "1 vs 2 threads";
    RecordProperty("sah", std::to_string(tree_sah(bvh, options.cost)));
}

INSTANTIATE_TEST_SUITE_P(Lookahead, LookaheadBuilder,
                         ::testing::Values(std::make_tuple("cbvh", 1u), std::make_tuple("cbvh", 2u),
                                           std::make_tuple("spatial", 1u)),
                         lookahead_name);

// Recursive cost evaluation to the leaves at the top of the tree (BuildConfig::lookahead_top_share;
// the pricing is tested in test_lookahead.cpp): valid trees that answer as the arbiter does, the same
// for 1 and 2 threads, and never above the greedy tree's SAH. On the interior (a room around dense
// objects, as living_room_3) the greedy step's top choices are not the best: the SAH must drop.
TEST(LookaheadTop, TreesAreValidCorrectDeterministicAndNoWorseThanGreedy) {
    const Scene soup = soup_prefix(6000);  // big enough for the parallel paths of the pricing (4096 references)
    BuildConfig options = config_for("spatial");
    options.lookahead.top_share = 0.1f;
    const Bvh bvh = build_in_arena(2, soup, options);
    EXPECT_EQ(tree_violations(soup, bvh, options), "");
    const Tracer tracer(soup, bvh, Kernel::binary);
    EXPECT_EQ(wrong_against_arbiter(soup, tracer, probing_rays(soup, 1500, 13)), "");
    EXPECT_EQ(first_difference(build_in_arena(1, soup, options), bvh), "") << "1 vs 2 threads";

    const Scene& interior = cached_builtin_scene("interior");
    BuildConfig greedy = config_for("spatial");
    const double greedy_sah = tree_sah(spacebvh::build(interior, greedy), greedy.cost);
    const double looked_ahead_sah = tree_sah(spacebvh::build(interior, options), options.cost);
    EXPECT_LT(looked_ahead_sah, 0.99 * greedy_sah);
    RecordProperty("interior_sah", std::to_string(greedy_sah) + " -> " + std::to_string(looked_ahead_sah));

    // One search space (cbvh): nothing to choose between, the greedy tree.
    BuildConfig object_only = config_for("cbvh");
    const Bvh greedy_cbvh = spacebvh::build(soup, object_only);
    object_only.lookahead.top_share = 0.1f;
    EXPECT_EQ(first_difference(spacebvh::build(soup, object_only), greedy_cbvh), "");
}
