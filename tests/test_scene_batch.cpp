// SPDX-License-Identifier: MIT
// RenderScene::attach_instances against attach_instance one by one (the same ids, the same answers
// bit for bit, checked on rays through the instances), its errors (the first bad scene or placement
// by index, the scene unchanged), and the top level's build: valid (each item in one leaf of its
// own, boxes exact unions, at most 64 levels) and the same tree for any thread count.
#include <gtest/gtest.h>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "scene_test_support.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/tools/rays.hpp"
#include "trace/scene/top_level.hpp"

using namespace spacebvh;

namespace {

using Random = tools::SplitMix64;

// A rotation about a random axis, scales in [0.5, 2], every third mirrored, on a grid `spacing` apart.
Affine placement(Random& random, size_t k, float spacing) {
    const double ax = double(random.uniform()) - 0.5, ay = double(random.uniform()) - 0.5,
                 az = double(random.uniform()) + 0.1;
    const double norm = std::sqrt(ax * ax + ay * ay + az * az), x = ax / norm, y = ay / norm, z = az / norm;
    const double angle = double(random.uniform()) * 6.283185307179586, c = std::cos(angle), s = std::sin(angle);
    const double r[3][3] = {{c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s},
                            {y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s},
                            {z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)}};
    Affine a;
    for (int i = 0; i < 3; ++i) {
        const double scale = 0.5 + 1.5 * double(random.uniform());
        for (int j = 0; j < 3; ++j) a.m[4 * i + j] = float(scale * r[i][j] * (k % 3 == 0 && j == 0 ? -1.0 : 1.0));
    }
    a.m[3] = float(k % 8) * spacing, a.m[7] = float(k / 8 % 8) * spacing, a.m[11] = float(k / 64) * spacing;
    return a;
}

std::shared_ptr<RenderScene> mesh_scene(const std::vector<Triangle>& triangles, const std::string& name) {
    auto s = std::make_shared<RenderScene>(SceneConfig{}, name);
    s->attach_mesh(MeshView(triangles));
    s->commit();
    return s;
}

const std::vector<Triangle>& square() {
    static const std::vector<Triangle> t = {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}}, {{0, 0, 0}, {1, 1, 0}, {0, 1, 0}}};
    return t;
}

using scene_testing::expect_error;

TEST(SceneBatch, AttachInstancesMatchesAttachingOneByOne) {
    const std::vector<Triangle> organic = scene_testing::organic(400);
    const std::vector<std::shared_ptr<const RenderScene>> scenes{mesh_scene(organic, "organic"),
                                                                 mesh_scene(square(), "square")};
    Random random{7};
    std::vector<InstancePlacement> batch(600);
    for (size_t k = 0; k < batch.size(); ++k)
        batch[k] = {uint32_t(k % 5 == 0), placement(random, k, 2.0f), k % 7 == 3 ? 0x2u : 0xFFFFFFFFu};
    RenderScene one_by_one(SceneConfig{}, "single"), batched(SceneConfig{}, "batch");
    one_by_one.attach_mesh(MeshView(square()));
    batched.attach_mesh(MeshView(square()));
    for (size_t k = 0; k < batch.size(); ++k)
        EXPECT_EQ(one_by_one.attach_instance(scenes[batch[k].scene], batch[k].transform, batch[k].mask), k + 1);
    EXPECT_EQ(batched.attach_instances(scenes, batch), 1u);
    EXPECT_EQ(batched.attach_instances(scenes, {}), 1u + batch.size());  // nothing: the next id
    one_by_one.commit();
    batched.commit();
    ASSERT_EQ(batched.geometry_count(), one_by_one.geometry_count());
    EXPECT_EQ(batched.bounds().lo, one_by_one.bounds().lo);
    EXPECT_EQ(batched.bounds().hi, one_by_one.bounds().hi);
    const std::vector<Ray> rays = tools::generate_random_rays(one_by_one.bounds(), 20000, 3);
    size_t hits = 0;
    for (const uint32_t mask : {0xFFFFFFFFu, 0x2u}) {
        const TraceContext context{mask};
        std::vector<SceneHit> a(rays.size()), b(rays.size());
        std::vector<uint8_t> oa(rays.size()), ob(rays.size());
        one_by_one.intersect(rays, a, context);
        batched.intersect(rays, b, context);
        one_by_one.occluded(rays, oa, context);
        batched.occluded(rays, ob, context);
        for (size_t i = 0; i < rays.size(); ++i) {
            hits += a[i].is_hit();
            ASSERT_EQ(a[i].t, b[i].t) << "ray " << i;
            ASSERT_EQ(a[i].u, b[i].u) << "ray " << i;
            ASSERT_EQ(a[i].v, b[i].v) << "ray " << i;
            ASSERT_EQ(a[i].primitive, b[i].primitive) << "ray " << i;
            ASSERT_EQ(a[i].geometry, b[i].geometry) << "ray " << i;
            ASSERT_EQ(a[i].instance, b[i].instance) << "ray " << i;
            ASSERT_EQ(oa[i], ob[i]) << "ray " << i;
            ASSERT_EQ(oa[i] != 0, a[i].is_hit()) << "ray " << i;
        }
    }
    EXPECT_GT(hits, rays.size() / 20);  // the rays do reach the instances
}

TEST(SceneBatch, ErrorsNameTheFirstBadEntryAndLeaveTheSceneUnchanged) {
    const auto square_scene = mesh_scene(square(), "square");
    RenderScene top(SceneConfig{}, "top");
    top.attach_instance(square_scene, Affine::identity());
    top.commit();
    std::vector<InstancePlacement> batch(5000);
    Random random{11};
    for (size_t k = 0; k < batch.size(); ++k) batch[k].transform = placement(random, k, 2.0f);
    const std::vector<std::shared_ptr<const RenderScene>> scenes{square_scene};
    // Bad entries far apart: whichever thread meets which first, the lowest is named.
    batch[4100].transform.m[5] = 0.0f;  // with m[4], m[6] below: the second row is zero
    batch[4100].transform.m[4] = batch[4100].transform.m[6] = 0.0f;
    batch[3000].transform.m[7] = std::nanf("");
    batch[2500].scene = 1;
    tbb::global_control allow(tbb::global_control::max_allowed_parallelism, 4);  // more threads than cores
    for (const int threads : {1, 2, 3}) {
        tbb::task_arena arena(threads);
        arena.execute([&] {
            expect_error([&] { top.attach_instances(scenes, batch); }, "placements[2500] (would be geometry 2501)");
            expect_error([&] { top.attach_instances(scenes, batch); }, "scene index 1, but 1 scene(s) given");
        });
    }
    batch[2500].scene = 0;
    expect_error([&] { top.attach_instances(scenes, batch); }, "placements[3000] (would be geometry 3001)");
    expect_error([&] { top.attach_instances(scenes, batch); }, "entry (1, 3) is not finite");
    batch[3000].transform.m[7] = 1.0f;
    expect_error([&] { top.attach_instances(scenes, batch); },
                 "placements[4100] (would be geometry 4101): transform is singular");
    auto open = std::make_shared<RenderScene>(SceneConfig{}, "open");
    open->attach_mesh(MeshView(square()));
    const std::vector<std::shared_ptr<const RenderScene>> with_open{square_scene, open}, with_null{square_scene, {}};
    expect_error([&] { top.attach_instances(with_open, {}); }, "scenes[1]: scene 'open' is not committed");
    expect_error([&] { top.attach_instances(with_null, {}); }, "attach_instances: scenes[1]: no scene given");
    // Nothing half-built: still one geometry, still committed, still traceable; nothing holds the
    // child but that one instance (it could not be changed otherwise).
    EXPECT_EQ(top.geometry_count(), 1u);
    EXPECT_TRUE(top.committed());
    EXPECT_TRUE(top.intersect(Ray{{0.5f, 0.25f, 1}, {0, 0, -1}}).is_hit());
    batch[4100].transform = Affine::identity();
    EXPECT_EQ(top.attach_instances(scenes, batch), 1u);
    EXPECT_EQ(top.geometry_count(), 1u + batch.size());
    expect_error([&] { square_scene->commit(); }, std::to_string(1 + batch.size()) + " instance(s)");
}

// Checks the subtree at `index` of the top level over `items`: each item in one leaf of its own
// (counted in `seen`), every box the exact union of its children's (a leaf's: its item's), children
// after their parent (refit's order); returns its deepest level below `depth`.
uint32_t check_subtree(const Bvh& bvh, const std::vector<scene::TopLevelItem>& items, uint32_t index, uint32_t depth,
                       std::vector<uint8_t>& seen) {
    const BvhNode& node = bvh.nodes[index];
    AABB box;
    uint32_t deepest = depth;
    if (node.is_leaf()) {
        EXPECT_EQ(node.reference_count, 1u);
        const uint32_t item = bvh.primitives[node.first];
        EXPECT_EQ(seen[item]++, 0) << "item " << item;
        box = items[item].box;
    } else {
        EXPECT_GT(node.first, index);
        box = merge(bvh.nodes[node.first].bounds, bvh.nodes[node.first + 1].bounds);
        for (uint32_t child : {node.first, node.first + 1})
            deepest = std::max(deepest, check_subtree(bvh, items, child, depth + 1, seen));
    }
    EXPECT_EQ(node.bounds.lo, box.lo) << "node " << index;
    EXPECT_EQ(node.bounds.hi, box.hi) << "node " << index;
    return deepest;
}

// The whole top level as check_subtree says, every item seen once, at most 64 levels; its depth.
uint32_t check_top_level(const scene::TopLevel& top, const std::vector<scene::TopLevelItem>& items) {
    EXPECT_EQ(top.bvh.nodes.size(), 2 * items.size() - 1);
    std::vector<uint8_t> seen(items.size(), 0);
    const uint32_t deepest = check_subtree(top.bvh, items, 0, 0, seen);
    for (size_t i = 0; i < items.size(); ++i) EXPECT_EQ(seen[i], 1) << "item " << i;
    EXPECT_LE(deepest, 64u);
    return deepest;
}

TEST(SceneBatch, TopLevelBuildIsValidAndTheSameForAnyThreadCount) {
    Random random{5};
    std::vector<scene::TopLevelItem> items(100000);
    for (size_t i = 0; i < items.size(); ++i) {
        // Clustered and spread boxes, some identical, some far out, a few flat.
        const double scale = i % 10 == 0 ? 1e6 : 100.0;
        const Vec3 lo(float(scale * double(random.uniform())), float(scale * double(random.uniform())),
                      float(100 * double(random.uniform())));
        const Vec3 size(float(double(random.uniform())), float(double(random.uniform())),
                        i % 13 == 0 ? 0.0f : float(double(random.uniform())));
        items[i].box = i % 7 == 0 && i > 0 ? items[i - 1].box : AABB{lo, lo + size};
    }
    tbb::global_control allow(tbb::global_control::max_allowed_parallelism, 4);  // more threads than cores
    scene::TopLevel reference;
    tbb::task_arena(1).execute([&] { reference = scene::build_top_level(items); });
    check_top_level(reference, items);
    for (const int threads : {2, 3, 4}) {
        scene::TopLevel top;
        tbb::task_arena(threads).execute([&] { top = scene::build_top_level(items); });
        ASSERT_EQ(top.bvh.nodes.size(), reference.bvh.nodes.size());
        for (size_t n = 0; n < top.bvh.nodes.size(); ++n) {
            ASSERT_EQ(top.bvh.nodes[n].first, reference.bvh.nodes[n].first) << threads << " threads, node " << n;
            ASSERT_EQ(top.bvh.nodes[n].reference_count, reference.bvh.nodes[n].reference_count) << n;
            ASSERT_EQ(top.bvh.nodes[n].bounds.lo, reference.bvh.nodes[n].bounds.lo) << n;
            ASSERT_EQ(top.bvh.nodes[n].bounds.hi, reference.bvh.nodes[n].bounds.hi) << n;
        }
        ASSERT_EQ(top.bvh.primitives, reference.bvh.primitives) << threads << " threads";
    }
}

TEST(SceneBatch, TopLevelOverCoincidentBoxesStaysWithin64Levels) {
    // Identical boxes leave the SAH nothing to split: halving keeps the depth at log2 of the count.
    std::vector<scene::TopLevelItem> items(70000, scene::TopLevelItem{AABB{{1, 2, 3}, {4, 5, 6}}, {}});
    EXPECT_LE(check_top_level(scene::build_top_level(items), items), 17u);
    // Boxes shrinking towards one point: the SAH splits off one at a time until the depth guard halves.
    items.resize(5000);
    for (size_t i = 0; i < items.size(); ++i) {
        const float r = std::ldexp(1.0f, -int(i % 120));
        items[i].box = AABB{{-r, -r, -r}, {r, r, r}};
    }
    check_top_level(scene::build_top_level(items), items);
    items.resize(1);
    EXPECT_EQ(scene::build_top_level(items).bvh.nodes.size(), 1u);
}

}  // namespace
