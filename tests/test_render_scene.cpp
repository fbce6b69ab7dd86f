// SPDX-License-Identifier: MIT
// RenderScene (include/spacebvh/scene.hpp): meshes and two levels of instances placed by rotations,
// mirrors, non-uniform scales and shears, traced by every kernel that takes instances, against the
// exact arbiter per instance (the ray in the instance's space) and on the flattened scene; ids, instance
// paths and masks; shared meshes when ../shared is present.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>

#include "scene_test_support.hpp"
#include "spacebvh/tools/rays.hpp"
#include "test_support.hpp"

using namespace spacebvh;
using namespace spacebvh::scene_testing;

namespace {

// parent = scale * R(axis, degrees) (mirrored in x when `mirror`) * local + shift.
Affine placed(Vec3 axis, float degrees, Vec3 scale, Vec3 shift, bool mirror = false) {
    const Vec3 a = normalize(axis);
    const double c = std::cos(degrees * M_PI / 180.0), s = std::sin(degrees * M_PI / 180.0);
    const double r[3][3] = {{c + a.x * a.x * (1 - c), a.x * a.y * (1 - c) - a.z * s, a.x * a.z * (1 - c) + a.y * s},
                            {a.y * a.x * (1 - c) + a.z * s, c + a.y * a.y * (1 - c), a.y * a.z * (1 - c) - a.x * s},
                            {a.z * a.x * (1 - c) - a.y * s, a.z * a.y * (1 - c) + a.x * s, c + a.z * a.z * (1 - c)}};
    Affine m;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) m.m[4 * i + j] = float(scale[i] * r[i][j] * (mirror && j == 0 ? -1.0 : 1.0));
        m.m[4 * i + 3] = shift[i];
    }
    return m;
}

std::vector<Triangle> prefix_of(const std::string& builtin, size_t count) {
    std::vector<Triangle> t = testing_support::cached_builtin_scene(builtin).triangles;
    if (t.size() > count) t.resize(count);
    return t;
}

struct TwoLevels {
    std::vector<Triangle> organic, soup;
    std::unique_ptr<Level> leaf, middle, top;
};

// top: the organic mesh itself, the leaf scene (organic + soup) mirrored and scaled, and the middle
// scene (three placements of the leaf scene, plus the soup) twice: rotated, sheared-scaled.
TwoLevels two_levels(const SceneConfig& config, uint32_t soup_mask = 0xFFFFFFFFu, uint32_t mirror_mask = 0xFFFFFFFFu) {
    TwoLevels s;
    s.organic = prefix_of("organic", 3000);
    s.soup = prefix_of("soup", 1500);
    const AABB box = bounds_of(s.organic);
    const float size = length(box.extent());
    s.leaf = std::make_unique<Level>(config, "leaf");
    s.leaf->mesh(s.organic);
    s.leaf->mesh(s.soup, soup_mask);
    s.leaf->scene->commit();
    s.middle = std::make_unique<Level>(config, "middle");
    s.middle->instance(*s.leaf, placed({1, 2, 3}, 37.0f, {1, 1, 1}, {size, 0, 0}));
    s.middle->instance(*s.leaf, placed({0, 1, 0}, 90.0f, {2.0f, 0.5f, 1.0f}, {0, size, 0}), 0x2);
    s.middle->instance(*s.leaf, placed({1, 0, 0}, -20.0f, {0.7f, 0.7f, 0.7f}, {0, 0, size}, true));
    s.middle->mesh(s.soup);
    s.middle->scene->commit();
    s.top = std::make_unique<Level>(config, "top");
    s.top->mesh(s.organic);
    s.top->instance(*s.leaf, placed({0, 0, 1}, 15.0f, {1.5f, 1.0f, 0.6f}, {-size, 0, 0}, true), mirror_mask);
    s.top->instance(*s.middle, placed({1, 1, 0}, 60.0f, {0.5f, 0.5f, 0.5f}, {0, -size, 0}));
    Affine sheared = placed({0, 1, 1}, 200.0f, {1.0f, 3.0f, 1.0f}, {size, size, -size});
    sheared.m[1] += 0.3f;
    s.top->instance(*s.middle, sheared);
    s.top->scene->commit();
    return s;
}

struct Tally {
    size_t rays = 0, hits = 0, wrong = 0, flat_disagree = 0, misnamed = 0;
    std::ostringstream text;
};

// Every ray: our closest hit and occlusion against the per-instance arbiter (t within the agreement
// rule; ids and path naming a real crossing) and against the flattened scene's arbiter.
void check_rays(const RenderScene& scene, const std::vector<Placement>& all, const Flattened& flat,
                std::span<const Ray> rays, uint32_t mask, Tally& tally, const TraceContext& base = {}) {
    const float diagonal = length(scene.bounds().extent());
    TraceContext context = base;
    context.mask = mask;
    std::vector<SceneHit> hits(rays.size());
    std::vector<uint8_t> blocked(rays.size());
    scene.intersect(rays, hits, context);
    scene.occluded(rays, blocked, context);
    for (size_t i = 0; i < rays.size(); ++i) {
        const Reference truth = closest_in_instances(all, rays[i], mask);
        const Reference flat_truth = closest_flattened(all, flat, rays[i], mask);
        ++tally.rays;
        tally.hits += hits[i].is_hit();
        const bool agrees = tools::hits_agree(record_of(hits[i]), record_of(truth), rays[i], diagonal);
        if (!agrees || bool(blocked[i]) != truth.is_hit()) {
            if (tally.wrong++ < 4)
                tally.text << "ray " << i << ": t " << hits[i].t << " vs " << truth.t << ", occluded "
                           << int(blocked[i]) << "; ";
        }
        if (hits[i].is_hit() && !not_a_crossing(all, hits[i], rays[i], diagonal).empty()) {
            if (tally.misnamed++ < 4)
                tally.text << "ray " << i << ": " << not_a_crossing(all, hits[i], rays[i], diagonal);
        }
        tally.flat_disagree += !tools::hits_agree(record_of(hits[i]), record_of(flat_truth), rays[i], diagonal);
    }
}

class SceneKernels : public ::testing::TestWithParam<std::tuple<Kernel, std::string>> {};

TEST_P(SceneKernels, TwoLevelsMatchTheArbiterPerInstanceAndFlattened) {
    SceneConfig config;
    config.tracer.kernel = std::get<0>(GetParam());
    config.recipe = TreeRecipe::for_builder(std::get<1>(GetParam()));
    const TwoLevels s = two_levels(config);
    EXPECT_EQ(s.top->scene->depth(), 2u);
    const std::vector<Placement> all = placements(*s.top);
    ASSERT_EQ(all.size(), 1u + 2u + 2u * (3u * 2u + 1u));
    const Flattened flat = flatten(all);
    AABB world = s.top->scene->bounds();
    const std::vector<Ray> rays = tools::generate_random_rays(world, 400, 47);
    Tally tally;
    check_rays(*s.top->scene, all, flat, rays, 0xFFFFFFFFu, tally);
    EXPECT_EQ(tally.wrong, 0u) << tally.text.str();
    EXPECT_EQ(tally.misnamed, 0u) << tally.text.str();
    EXPECT_EQ(tally.flat_disagree, 0u);
    EXPECT_GT(tally.hits, tally.rays / 8);  // the rays do meet the instances
}

INSTANTIATE_TEST_SUITE_P(Kernels, SceneKernels,
                         ::testing::Combine(::testing::Values(Kernel::binary, Kernel::bvh4, Kernel::bvh8),
                                            ::testing::Values("binned", "spatial")));

TEST(RenderScene, MasksHideGeometriesAndInstances) {
    SceneConfig config;
    const TwoLevels s = two_levels(config, /*soup_mask=*/0x4, /*mirror_mask=*/0x8);
    const std::vector<Placement> all = placements(*s.top);
    const Flattened flat = flatten(all);
    const std::vector<Ray> rays = tools::generate_random_rays(s.top->scene->bounds(), 150, 7);
    for (uint32_t mask : {0x1u, 0x2u, 0x4u, 0x8u, 0xCu, 0xFFFFFFFFu}) {
        Tally tally;
        check_rays(*s.top->scene, all, flat, rays, mask, tally);
        EXPECT_EQ(tally.wrong + tally.misnamed, 0u) << "mask " << mask << ": " << tally.text.str();
        EXPECT_EQ(tally.flat_disagree, 0u) << "mask " << mask;
    }
    // Mask 0 sees nothing.
    TraceContext none;
    none.mask = 0;
    for (const Ray& ray : rays) {
        EXPECT_FALSE(s.top->scene->intersect(ray, none).is_hit());
        EXPECT_FALSE(s.top->scene->occluded(ray, none));
    }
}

TEST(RenderScene, PerRayMasksAndSingleCallsMatchTheBatch) {
    const TwoLevels s = two_levels(SceneConfig{}, 0x4, 0x8);
    const std::vector<Ray> rays = tools::generate_random_rays(s.top->scene->bounds(), 200, 3);
    std::vector<uint32_t> masks(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) masks[i] = uint32_t(1u << (i % 4));
    std::vector<SceneHit> hits(rays.size());
    s.top->scene->intersect(rays, hits, {}, masks);
    for (size_t i = 0; i < rays.size(); ++i) {
        TraceContext context;
        context.mask = masks[i];
        const SceneHit one = s.top->scene->intersect(rays[i], context);
        EXPECT_EQ(one.t, hits[i].t);
        EXPECT_EQ(one.primitive, hits[i].primitive);
        EXPECT_EQ(one.geometry, hits[i].geometry);
        EXPECT_EQ(one.instance, hits[i].instance);
    }
}

TEST(RenderScene, SameAnswersForAnyThreadCount) {
    const TwoLevels s = two_levels(SceneConfig{});
    const std::vector<Ray> rays = tools::generate_random_rays(s.top->scene->bounds(), 2000, 5);
    std::vector<SceneHit> one(rays.size()), four(rays.size());
    tbb::task_arena(1).execute([&] { s.top->scene->intersect(rays, one); });
    tbb::task_arena(4).execute([&] { s.top->scene->intersect(rays, four); });
    for (size_t i = 0; i < rays.size(); ++i) {
        EXPECT_EQ(one[i].t, four[i].t);
        EXPECT_EQ(one[i].primitive, four[i].primitive);
        EXPECT_EQ(one[i].instance, four[i].instance);
    }
}

// Rays aimed exactly at world-space vertices and edge midpoints of the placements, where triangles of
// one mesh meet: each answer is the per-instance arbiter's (the flattened scene may differ here by a
// rounding, docs/scenes.md, so it is not the reference).
TEST(RenderScene, RaysAtVerticesAndEdgesMatchTheArbiterPerInstance) {
    for (Kernel kernel : {Kernel::binary, Kernel::bvh8}) {
        SceneConfig config;
        config.tracer.kernel = kernel;
        const TwoLevels s = two_levels(config);
        const std::vector<Placement> all = placements(*s.top);
        const std::vector<Ray> random = tools::generate_random_rays(s.top->scene->bounds(), 300, 13);
        std::vector<Ray> rays;
        for (size_t k = 0; k < random.size(); ++k) {
            const Placement& p = all[k % all.size()];
            const Triangle w = p.world((*p.triangles)[(k * 7919) % p.triangles->size()]);
            const Vec3 target = k % 2 ? w.v0 : (w.v1 + w.v2) * 0.5f;
            rays.push_back({random[k].org, target - random[k].org, 0.0f, kInfinity});
        }
        const float diagonal = length(s.top->scene->bounds().extent());
        size_t wrong = 0, hits = 0;
        for (const Ray& ray : rays) {
            const SceneHit hit = s.top->scene->intersect(ray);
            const Reference truth = closest_in_instances(all, ray, 0xFFFFFFFFu);
            hits += hit.is_hit();
            wrong += !tools::hits_agree(record_of(hit), record_of(truth), ray, diagonal);
            wrong += s.top->scene->occluded(ray) != truth.is_hit();
            wrong += hit.is_hit() && !not_a_crossing(all, hit, ray, diagonal).empty();
        }
        EXPECT_EQ(wrong, 0u) << to_string(kernel);
        EXPECT_GT(hits, rays.size() / 2) << to_string(kernel);
    }
}

// Many instances in the same place (equal boxes, which no split separates) and a one-instance scene:
// the closest hit is that of the mesh itself, named by one of the instances.
TEST(RenderScene, CoincidentInstancesAndASingleInstance) {
    const std::vector<Triangle> mesh = prefix_of("organic", 2000);
    Level leaf(SceneConfig{}, "leaf");
    leaf.mesh(mesh);
    leaf.scene->commit();
    Level many(SceneConfig{}, "many"), one(SceneConfig{}, "one");
    for (int k = 0; k < 40; ++k) many.instance(leaf, Affine::identity(), k == 7 ? 0x2 : 0x1);
    one.instance(leaf, Affine::identity());
    many.scene->commit();
    one.scene->commit();
    const std::vector<Ray> rays = tools::generate_random_rays(leaf.scene->bounds(), 300, 17);
    size_t hits = 0;
    for (const Ray& ray : rays) {
        const SceneHit direct = leaf.scene->intersect(ray), a = many.scene->intersect(ray),
                       b = one.scene->intersect(ray);
        hits += direct.is_hit();
        EXPECT_EQ(a.t, direct.t);
        EXPECT_EQ(b.t, direct.t);
        EXPECT_EQ(b.primitive, direct.primitive);
        if (a.is_hit()) {
            EXPECT_TRUE(a.instance[0] < 40u && a.instance[1] == kInvalidIndex);
        }
        EXPECT_EQ(many.scene->occluded(ray), direct.is_hit());
        TraceContext only7;
        only7.mask = 0x2;
        const SceneHit c = many.scene->intersect(ray, only7);
        EXPECT_EQ(c.t, direct.t);
        if (c.is_hit()) {
            EXPECT_EQ(c.instance[0], 7u);
        }
    }
    EXPECT_GT(hits, 50u);
}

// A shared mesh (the bunny) instanced by rotations, a mirror and a non-uniform scale, when present.
TEST(RenderScene, SharedMeshInstancedMatchesTheArbiter) {
    const std::filesystem::path dir = std::filesystem::path(SPACEBVH_SHARED_DIR) / "scenes" / "bunny";
    std::filesystem::path file;
    if (std::filesystem::exists(dir))
        for (const auto& entry : std::filesystem::directory_iterator(dir))
            if (entry.path().extension() == ".obj" || entry.path().extension() == ".ply") file = entry.path();
    if (file.empty()) GTEST_SKIP() << "no shared bunny under " << dir;
    const tools::Scene bunny = tools::load_scene(file.string());
    SceneConfig config;
    config.recipe = TreeRecipe::for_builder("spatial");
    Level leaf(config, "bunny");
    leaf.mesh(bunny.triangles);
    leaf.scene->commit();
    const float size = bunny.diagonal();
    Level top(config, "bunnies");
    top.instance(leaf, placed({1, 2, 3}, 33.0f, {1, 1, 1}, {0, 0, 0}));
    top.instance(leaf, placed({0, 1, 0}, 120.0f, {1.0f, 2.0f, 0.5f}, {size, 0, 0}, true));
    top.instance(leaf, placed({1, 0, 0}, -70.0f, {0.5f, 0.5f, 0.5f}, {0, size, 0}));
    top.scene->commit();
    const std::vector<Placement> all = placements(top);
    const Flattened flat = flatten(all);
    const std::vector<Ray> rays = tools::generate_random_rays(top.scene->bounds(), 120, 11);
    Tally tally;
    check_rays(*top.scene, all, flat, rays, 0xFFFFFFFFu, tally);
    EXPECT_EQ(tally.wrong + tally.misnamed, 0u) << tally.text.str();
    EXPECT_EQ(tally.flat_disagree, 0u);
}

// Masks changed after commit (set_mask) reach every path a walk takes: a mesh of the traced scene,
// an instance, and the mesh of a one-mesh scene that an instance enters directly (its kernel called
// from the parent's top level), for each kernel.
class SceneMaskUpdates : public ::testing::TestWithParam<Kernel> {};

TEST_P(SceneMaskUpdates, SetMaskAfterCommitReachesEveryPath) {
    SceneConfig config;
    config.tracer.kernel = GetParam();
    const std::vector<Triangle> mesh = prefix_of("organic", 2000), soup = prefix_of("soup", 800);
    const float size = length(bounds_of(mesh).extent());
    Level one(config, "one");
    const uint32_t only = one.mesh(mesh);
    one.scene->commit();
    Level top(config, "top");
    const uint32_t floor = top.mesh(soup);
    const uint32_t first = top.instance(one, placed({1, 2, 3}, 40.0f, {1.0f, 0.6f, 1.3f}, {0, 0, 0}));
    top.instance(one, placed({0, 1, 0}, 110.0f, {0.8f, 0.8f, 0.8f}, {0.5f * size, 0, 0}, true));
    top.scene->commit();
    const std::vector<Ray> rays = tools::generate_random_rays(top.scene->bounds(), 300, 21);
    const auto check = [&](const char* step) {
        const std::vector<Placement> all = placements(top);
        const Flattened flat = flatten(all);
        for (uint32_t mask : {0x1u, 0x2u, 0x4u, 0x8u, 0xFFFFFFFFu}) {
            Tally tally;
            check_rays(*top.scene, all, flat, rays, mask, tally);
            EXPECT_EQ(tally.wrong + tally.misnamed, 0u) << step << ", mask " << mask << ": " << tally.text.str();
            EXPECT_EQ(tally.flat_disagree, 0u) << step << ", mask " << mask;
        }
    };
    const auto hits_with = [&](uint32_t mask) {
        TraceContext context;
        context.mask = mask;
        size_t n = 0;
        for (const Ray& ray : rays) n += top.scene->intersect(ray, context).is_hit();
        return n;
    };
    check("as committed");
    const size_t all_hits = hits_with(0x1);
    ASSERT_GT(all_hits, rays.size() / 8);
    top.scene->set_mask(first, 0x2);  // an instance of the traced scene
    top.instances[0].mask = 0x2;
    check("instance mask");
    one.scene->set_mask(only, 0x3);  // the instanced one-mesh scene's mesh, after the parent committed
    one.meshes[0].mask = 0x3;
    check("instanced mesh mask");
    top.scene->set_mask(floor, 0x4);  // a mesh of the traced scene
    top.meshes[0].mask = 0x4;
    check("mesh mask");
    EXPECT_LT(hits_with(0x1), all_hits);  // the masks did hide something
    EXPECT_EQ(hits_with(0x8), 0u);
}

INSTANTIATE_TEST_SUITE_P(Kernels, SceneMaskUpdates, ::testing::Values(Kernel::binary, Kernel::bvh4, Kernel::bvh8));

// A kernel whose layout is made again at refit (binary, quantized bvh8) still answers through the
// instances that enter it: a refitted then traced scene matches the arbiter on the moved mesh.
TEST(RenderScene, RefitOfALayoutMadeAgainIsTracedThroughInstances) {
    for (NodeFormat format : {NodeFormat::full, NodeFormat::quantized})
        for (Kernel kernel : {Kernel::binary, Kernel::bvh8}) {
            if (kernel == Kernel::binary && format == NodeFormat::quantized) continue;
            SceneConfig config;
            config.tracer.kernel = kernel;
            config.tracer.node_format = format;
            std::vector<Triangle> mesh = prefix_of("organic", 2000);
            const float size = length(bounds_of(mesh).extent());
            Level leaf(config, "leaf");
            leaf.mesh(mesh);
            leaf.scene->commit();
            Level top(config, "top");
            top.instance(leaf, placed({1, 1, 0}, 30.0f, {1, 1, 1}, {0, 0, 0}));
            top.instance(leaf, placed({0, 0, 1}, -75.0f, {0.7f, 1.2f, 1.0f}, {size, 0, 0}, true));
            top.scene->commit();
            for (Triangle& t : mesh)
                for (Vec3* v : {&t.v0, &t.v1, &t.v2}) v->y += 0.3f * v->x * v->x / size;
            leaf.scene->refit(0);
            top.scene->refit();
            const std::vector<Placement> all = placements(top);
            const Flattened flat = flatten(all);
            Tally tally;
            check_rays(*top.scene, all, flat, tools::generate_random_rays(top.scene->bounds(), 500, 5), 0xFFFFFFFFu,
                       tally);
            EXPECT_EQ(tally.wrong + tally.misnamed, 0u) << to_string(kernel) << ": " << tally.text.str();
            EXPECT_EQ(tally.flat_disagree, 0u) << to_string(kernel);
            EXPECT_GE(tally.hits, 12u);  // the moved mesh is in the rays' way
        }
}

// The walks' vectorised ray transform (scene::RayTransform) gives the documented ray of
// scene::to_instance bit for bit: rotations, mirrors, scales and shears, on rays from tiny to huge
// coordinates, negative zeros and coordinates whose sums round differently in each order.
TEST(RenderScene, VectorisedRayTransformIsTheDocumentedOneBitForBit) {
    uint64_t state = 99;
    const auto next = [&] {  // splitmix64 in [0, 1)
        uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return double((z ^ (z >> 31)) >> 11) * 0x1p-53;
    };
    const AABB box{{-1, -1, -1}, {1, 1, 1}};
    size_t compared = 0, rounded_differently = 0;
    for (int k = 0; k < 200; ++k) {
        Affine a = placed({float(next() - 0.5), float(next() - 0.5), float(next() + 0.1)}, float(360 * next()),
                          {float(0.3 + 3 * next()), float(0.3 + 3 * next()), float(0.3 + 3 * next())},
                          {float(1e4 * (next() - 0.5)), float(next() - 0.5), float(1e-3 * next())}, k % 3 == 0);
        if (k % 5 == 0) a.m[1] += 0.25f;  // a shear
        const scene::InstanceTransform xf = scene::make_instance_transform(a, box, {}, "test");
        const scene::RayTransform vectorised(xf);
        for (int r = 0; r < 50; ++r) {
            const float scale = std::ldexp(1.0f, int(60 * next()) - 30);
            Ray ray;
            for (int i = 0; i < 3; ++i) {
                ray.org[i] = float(scale * (next() - 0.5));
                ray.dir[i] = float(next() - 0.5);
            }
            if (r % 7 == 0) ray.dir.y = -0.0f;
            const Ray want = scene::to_instance(xf, ray), got = vectorised.apply(ray);
            for (int i = 0; i < 3; ++i) {
                EXPECT_EQ(std::bit_cast<uint32_t>(got.org[i]), std::bit_cast<uint32_t>(want.org[i])) << k << " " << r;
                EXPECT_EQ(std::bit_cast<uint32_t>(got.dir[i]), std::bit_cast<uint32_t>(want.dir[i])) << k << " " << r;
                // Where a float sum would round differently, the double one is being exercised.
                const float f = xf.inverse[3 * i] * ray.org.x + xf.inverse[3 * i + 1] * ray.org.y +
                                xf.inverse[3 * i + 2] * ray.org.z + xf.inverse_shift[i];
                rounded_differently += f != want.org[i];
            }
            EXPECT_EQ(got.tmin, ray.tmin);
            EXPECT_EQ(got.tmax, ray.tmax);
            ++compared;
        }
    }
    EXPECT_EQ(compared, 10000u);
    EXPECT_GT(rounded_differently, 1000u);
}

}  // namespace

namespace {

// The walks' finiteness check of the transformed ray (RayTransform::apply_finite) against
// is_finite_ray of the documented ray, on rays whose image overflows float on some coordinates
// (origins up to FLT_MAX taken through scales that enlarge), the rest compared bit for bit.
TEST(RenderScene, RayTransformSaysWhereTheRayOverflows) {
    const AABB box{{-1, -1, -1}, {1, 1, 1}};
    size_t finite = 0, overflowed = 0;
    for (int k = 0; k < 40; ++k) {
        const float shrink = 0.05f + 0.02f * float(k);  // the inverse scales rays by 1 / shrink
        const Affine a = placed({1.0f, float(k), 2.0f}, float(9 * k), {shrink, 2.0f * shrink, shrink},
                                {0.0f, 1e30f * float(k % 3), 0.0f}, k % 2 == 0);
        const scene::InstanceTransform xf = scene::make_instance_transform(a, box, {}, "test");
        const scene::RayTransform vectorised(xf);
        for (int r = 0; r < 200; ++r) {
            Ray ray;
            const float big = std::ldexp(1.0f, 100 + r % 28) * (1.0f + float(r) / 256.0f);
            ray.org =
                Vec3(r % 2 ? big : -big, float(r) - 100.0f, r % 5 == 0 ? std::numeric_limits<float>::max() : 1.0f);
            ray.dir = Vec3(1.0f, r % 3 == 0 ? big : 0.5f, -0.0f);
            const Ray want = scene::to_instance(xf, ray);
            Ray got;
            const bool ok = vectorised.apply_finite(ray, got);
            EXPECT_EQ(ok, scene::is_finite_ray(want)) << k << " " << r;
            for (int i = 0; i < 3; ++i) {
                EXPECT_EQ(std::bit_cast<uint32_t>(got.org[i]), std::bit_cast<uint32_t>(want.org[i])) << k << " " << r;
                EXPECT_EQ(std::bit_cast<uint32_t>(got.dir[i]), std::bit_cast<uint32_t>(want.dir[i])) << k << " " << r;
            }
            (ok ? finite : overflowed) += 1;
        }
    }
    EXPECT_GT(finite, 1000u);
    EXPECT_GT(overflowed, 1000u);
}

}  // namespace
