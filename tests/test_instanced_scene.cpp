// SPDX-License-Identifier: MIT
// Instanced scenes of the tools (spacebvh/tools/instanced_scene.hpp): builtin:forest:N (deterministic
// placements with rotations, mirrors and non-uniform scales; its size limits), the RenderScene built
// from a description (each mesh once; answers against the exact arbiter per placement and on the
// flattened scene; masks; nesting), and the scene memory estimate against the measured size.
#include <gtest/gtest.h>

#include "instanced_test_support.hpp"
#include "spacebvh/memory_estimate.hpp"
#include "test_support.hpp"
#include "tools/scene/instanced_internal.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;
using namespace spacebvh::scene_testing;

namespace {

double determinant(const Affine& a) { return scene_detail::Affine64(a).determinant(); }

TEST(Forest, SpecsAndSizeLimits) {
    EXPECT_TRUE(is_instanced_scene_spec("builtin:forest:10"));
    EXPECT_TRUE(is_instanced_scene_spec("some/file.GLTF"));
    EXPECT_TRUE(is_instanced_scene_spec("x.glb"));
    EXPECT_FALSE(is_instanced_scene_spec("builtin:organic"));
    EXPECT_FALSE(is_instanced_scene_spec("bunny.obj"));
    for (const char* bad :
         {"builtin:forest", "builtin:forest:0", "builtin:forest:1000001", "builtin:forest:abc", "builtin:forest:-3",
          "builtin:forest:", "builtin:forest:12x", "builtin:forest:99999999999999999999999"}) {
        try {
            load_instanced_scene(bad);
            ADD_FAILURE() << bad << " loaded";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("builtin:forest:N"), std::string::npos) << e.what();
        }
    }
}

TEST(Forest, DeterministicPlacementsWithMirrorsAndNonUniformScales) {
    const InstancedScene a = load_instanced_scene("builtin:forest:500");
    const InstancedScene b = load_instanced_scene("builtin:forest:500");
    ASSERT_EQ(a.instances.size(), 500u);
    ASSERT_EQ(a.meshes.size(), 4u);
    EXPECT_EQ(a.depth(), 1u);
    size_t mirrored = 0;
    std::vector<size_t> per_mesh(a.meshes.size(), 0);
    for (size_t i = 0; i < a.instances.size(); ++i) {
        const SceneInstance& x = a.instances[i];
        EXPECT_EQ(x.transform.m, b.instances[i].transform.m);
        EXPECT_EQ(x.mesh, b.instances[i].mesh);
        EXPECT_EQ(x.mask, 1u << x.mesh);
        EXPECT_EQ(scene_detail::invalid_instance_transform(x.transform), "") << i;
        mirrored += determinant(x.transform) < 0;
        ++per_mesh.at(x.mesh);
        // Not a similarity: the columns' lengths differ (non-uniform scale).
        double column[3];
        for (int c = 0; c < 3; ++c)
            column[c] = std::hypot(x.transform.m[c], x.transform.m[4 + c], x.transform.m[8 + c]);
        EXPECT_GT(std::max({column[0], column[1], column[2]}) / std::min({column[0], column[1], column[2]}),
                  1.0 + 1e-6);
    }
    EXPECT_GT(mirrored, 60u);
    EXPECT_LT(mirrored, 200u);
    for (size_t count : per_mesh) EXPECT_GT(count, 50u);
    for (const Scene& mesh : a.meshes) EXPECT_GT(mesh.triangles.size(), 1000u) << mesh.name;
}

TEST(Forest, AMillionInstancesAreTenBillionTrianglesInLittleMemory) {
    const InstancedScene forest = load_instanced_scene("builtin:forest:1000000");
    EXPECT_EQ(forest.instances.size(), 1'000'000u);
    EXPECT_GT(forest.instanced_triangle_count(), uint64_t(10'000'000'000));
    EXPECT_LT(forest.unique_triangle_count(), 100'000u);
    // The description: the meshes once plus one record per instance.
    EXPECT_LE(sizeof(SceneInstance), 96u);
    const SceneMemoryEstimate estimate = estimate_scene_memory(forest, SceneConfig{});
    EXPECT_LT(estimate.total(), uint64_t(2) << 30) << format_bytes(estimate.total());
    EXPECT_GT(estimate.instance_bytes, 100'000'000u);  // the instances dominate, linearly
}

TEST(InstancedScene, ForestAnswersMatchTheArbiterPerPlacementAndFlattened) {
    for (Kernel kernel : {Kernel::binary, Kernel::bvh8}) {
        SceneConfig config;
        config.tracer.kernel = kernel;
        const InstancedScene forest = load_instanced_scene("builtin:forest:16");
        const std::shared_ptr<RenderScene> render = make_render_scene(forest, config);
        EXPECT_EQ(render->geometry_count(), 16u);
        EXPECT_EQ(render->depth(), 1u);
        const std::vector<Ray> rays = generate_random_rays(render->bounds(), 150, 91);
        const Check all = check_against_arbiter(*render, forest, rays);
        EXPECT_EQ(all.wrong, 0u) << all.first;
        EXPECT_EQ(all.misnamed, 0u) << all.first;
        EXPECT_EQ(all.flat_disagree, 0u);
        EXPECT_GT(all.hits, all.rays / 10);
        // Masks: the forest's masks name the mesh kind; rays that see conifers and rocks only.
        const Check some = check_against_arbiter(*render, forest, rays, 0b101);
        EXPECT_EQ(some.wrong, 0u) << some.first;
        EXPECT_LT(some.hits, all.hits);
    }
}

// The load transform is composed onto every instance (outer * instance, in double, rounded once).
TEST(InstancedScene, TheLoadTransformPlacesEveryInstance) {
    SceneTransform transform;
    transform.rotate_degrees = {30.0f, -20.0f, 75.0f};
    transform.scale = 2.5f;
    transform.translate = {4.0f, -1.0f, 7.0f};
    const InstancedScene plain = load_instanced_scene("builtin:forest:20");
    const InstancedScene moved = load_instanced_scene("builtin:forest:20", transform);
    ASSERT_EQ(moved.instances.size(), plain.instances.size());
    EXPECT_NE(moved.name, plain.name);
    for (size_t i = 0; i < plain.instances.size(); ++i) {
        const Vec3 corner = plain.meshes[plain.instances[i].mesh].triangles[7].v1;
        const Vec3 expected = transform.apply(plain.instances[i].transform.apply(corner));
        const Vec3 got = moved.instances[i].transform.apply(corner);
        EXPECT_LE(length(got - expected), 1e-5f * length(expected)) << i;
    }
    // A one-mesh spec is loaded by load_scene with the transform itself.
    const InstancedScene one = load_instanced_scene("builtin:soup", transform);
    EXPECT_EQ(one.meshes[0].name, load_scene("builtin:soup", transform).name);
    SceneTransform bad;
    bad.scale = 0.0f;
    EXPECT_THROW(load_instanced_scene("builtin:forest:2", bad), Error);
}

TEST(Forest, LoadsFlattenedAsOneMeshWithinTheCap) {
    const InstancedScene forest = load_instanced_scene("builtin:forest:3");
    const Scene flat = load_scene("builtin:forest:3");
    EXPECT_EQ(flat.triangles.size(), forest.instanced_triangle_count());
    EXPECT_EQ(flat.name, "forest:3");
    try {
        load_scene("builtin:forest:100000");
        ADD_FAILURE() << "flattened 10^9 triangles";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("more than the 50000000"), std::string::npos) << e.what();
    }
}

TEST(InstancedScene, OneMeshSpecsAreOneIdentityInstance) {
    const InstancedScene scene = load_instanced_scene("builtin:soup");
    ASSERT_EQ(scene.meshes.size(), 1u);
    ASSERT_EQ(scene.instances.size(), 1u);
    EXPECT_EQ(scene.instances[0].transform.m, Affine::identity().m);
    EXPECT_EQ(scene.instanced_triangle_count(), scene.meshes[0].triangles.size());
    const std::shared_ptr<RenderScene> render = make_render_scene(scene, SceneConfig{});
    const std::vector<Ray> rays = generate_random_rays(render->bounds(), 100, 5);
    const Check check = check_against_arbiter(*render, scene, rays);
    EXPECT_EQ(check.wrong, 0u) << check.first;
}

// A nested description: a "grove" of two forest meshes placed three times by the top scene.
TEST(InstancedScene, NestedScenesFlattenAndBuildEachSceneOnce) {
    auto grove = std::make_shared<InstancedScene>();
    const InstancedScene forest = load_instanced_scene("builtin:forest:2");
    grove->name = "grove";
    grove->meshes = forest.meshes;
    grove->instances = forest.instances;
    InstancedScene top;
    top.name = "top";
    top.meshes.push_back(forest.meshes[3]);
    for (int i = 0; i < 3; ++i) {
        SceneInstance instance;
        instance.scene = grove;
        instance.transform.m[3] = 20.0f * float(i);
        instance.transform.m[0] = i == 1 ? -1.0f : 1.0f;  // a mirrored grove
        top.instances.push_back(instance);
    }
    top.instances.push_back(SceneInstance{0, nullptr, Affine::identity(), 0xFFFFFFFFu});
    EXPECT_EQ(top.depth(), 2u);
    EXPECT_EQ(top.placement_count(), 7u);
    EXPECT_EQ(flatten_placements(top).size(), 7u);
    EXPECT_EQ(top.instanced_triangle_count(),
              3 * forest.instanced_triangle_count() + forest.meshes[3].triangles.size());
    const Scene flat = flatten_scene(top);
    EXPECT_EQ(flat.triangles.size(), top.instanced_triangle_count());
    const std::shared_ptr<RenderScene> render = make_render_scene(top, SceneConfig{});
    EXPECT_EQ(render->depth(), 2u);
    // Against the arbiter on the flattened copy: closest t per ray.
    const std::vector<Ray> rays = generate_random_rays(render->bounds(), 60, 17);
    size_t wrong = 0, hits = 0;
    for (const Ray& ray : rays) {
        const SceneHit hit = render->intersect(ray);
        hits += hit.is_hit();
        wrong += !hits_agree(record_of(hit), arbiter_closest_hit(flat, ray), ray, length(render->bounds().extent()));
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(hits, 6u);
    flatten_placements(top);  // within the default cap
    EXPECT_THROW(flatten_placements(top, 6), Error);
    EXPECT_THROW(flatten_scene(top, 1000), Error);
}

TEST(InstancedScene, BadDescriptionsAreRefused) {
    InstancedScene scene = load_instanced_scene("builtin:forest:3");
    scene.instances[1].mesh = 9;
    EXPECT_THROW(make_render_scene(scene, SceneConfig{}), Error);
    EXPECT_THROW(scene.instanced_triangle_count(), Error);
    scene.instances[1].mesh = 0;
    scene.instances[2].transform.m[5] = 0.0f;  // singular: RenderScene's own check names it
    scene.instances[2].transform.m[4] = 0.0f;
    scene.instances[2].transform.m[6] = 0.0f;
    EXPECT_THROW(make_render_scene(scene, SceneConfig{}), Error);
    EXPECT_NE(scene_detail::invalid_instance_transform(scene.instances[2].transform), "");
    Affine stretched;
    stretched.m[0] = 1e-6f;
    EXPECT_NE(scene_detail::invalid_instance_transform(stretched).find("condition"), std::string::npos);
    Affine nan;
    nan.m[7] = NAN;
    EXPECT_NE(scene_detail::invalid_instance_transform(nan).find("row 1, column 3"), std::string::npos);
    EXPECT_THROW(make_render_scene(std::shared_ptr<const InstancedScene>(), SceneConfig{}), Error);
}

// The estimate against RenderScene::memory_bytes() of the pieces make_render_scene builds: each mesh's
// scene once, and the top level.
TEST(SceneMemory, EstimateBoundsTheMeasuredSize) {
    for (const char* builder : {"binned", "spatial"}) {
        SceneConfig config;
        config.recipe = TreeRecipe::for_builder(builder);
        auto forest = std::make_shared<const InstancedScene>(load_instanced_scene("builtin:forest:3000"));
        uint64_t measured = 0;
        for (const Scene& mesh : forest->meshes) {
            RenderScene one(config, mesh.name);
            one.attach_mesh(mesh.mesh());
            one.commit();
            measured += one.memory_bytes();
        }
        const std::shared_ptr<RenderScene> render = make_render_scene(forest, config);
        measured += render->memory_bytes();
        const SceneMemoryEstimate estimate = estimate_scene_memory(*forest, config);
        const uint64_t kept = estimate.mesh_bytes + estimate.instance_bytes;
        // Stated factor: what is kept is estimated at 1x to 3x the measured size.
        EXPECT_GE(kept, measured) << builder;
        EXPECT_LE(kept, 3 * measured) << builder << ": " << format_bytes(kept) << " vs " << format_bytes(measured);
        EXPECT_GT(estimate.build_bytes, 0u);
    }
}

TEST(SceneMemory, ABuildBeyondTheLimitIsRefusedBeforeItStarts) {
    SceneConfig config;
    config.recipe.limits.memory_limit_bytes = 4 << 20;
    const InstancedScene forest = load_instanced_scene("builtin:forest:100");
    try {
        make_render_scene(forest, config);
        ADD_FAILURE() << "built";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("instanced scene 'forest:100' (100 placements"), std::string::npos)
            << e.what();
        EXPECT_NE(std::string(e.what()).find("the memory limit of 4.0 MiB"), std::string::npos) << e.what();
    }
}

}  // namespace
