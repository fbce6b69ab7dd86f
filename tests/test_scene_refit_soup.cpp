// SPDX-License-Identifier: MIT
// Refit of a scene's soup mesh, which reads the caller's triangles once, in the walk that refits the
// tree and the kernel's layout together (and checks the coordinates as it goes): after each refit
// every answer is the exact arbiter's on the moved triangles and a fresh build's, for each kernel and
// layout a scene takes and both builders; a coordinate that is not finite changes nothing; triangles
// that become or stop being degenerate; the same answers for any thread count.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <tuple>

#include <tbb/task_arena.h>

#include "scene_test_support.hpp"
#include "spacebvh/tools/rays.hpp"
#include "test_support.hpp"

using namespace spacebvh;
using namespace spacebvh::scene_testing;

namespace {

// rotating: about z; bending: y += x^2 / size; exploding: each triangle pushed out from the origin.
void move(std::vector<Triangle>& mesh, const std::string& kind, float size) {
    for (Triangle& t : mesh) {
        const Vec3 centroid = (t.v0 + t.v1 + t.v2) / 3.0f;
        for (Vec3* p : {&t.v0, &t.v1, &t.v2}) {
            if (kind == "rotating")
                *p = Vec3{0.8f * p->x - 0.6f * p->y, 0.6f * p->x + 0.8f * p->y, p->z};
            else if (kind == "bending")
                p->y += p->x * p->x / size;
            else
                *p = *p + centroid * 0.5f;
        }
    }
}

SceneConfig config_of(Kernel kernel, const std::string& builder, LeafTest leaf_test = LeafTest::watertight) {
    SceneConfig config;
    config.recipe = TreeRecipe::for_builder(builder);
    config.tracer.kernel = kernel;
    config.tracer.leaf_test = leaf_test;
    return config;
}

struct Tally {
    size_t wrong = 0, differ = 0, hits = 0;
};

// `level`'s answers against the exact arbiter on its triangles and against a fresh scene of them.
Tally check(const Level& level, const SceneConfig& config, size_t ray_count) {
    const std::vector<Triangle> now = *level.meshes[0].triangles;
    Level fresh(config, "fresh");
    fresh.mesh(now);
    fresh.scene->commit();
    const std::vector<Placement> all = placements(level);
    const float size = length(fresh.scene->bounds().extent());
    Tally tally;
    for (const Ray& ray : tools::generate_random_rays(fresh.scene->bounds(), ray_count, 5)) {
        const SceneHit ours = level.scene->intersect(ray), again = fresh.scene->intersect(ray);
        const Reference truth = closest_in_instances(all, ray, 0xFFFFFFFFu);
        tally.hits += ours.is_hit();
        tally.wrong += !tools::hits_agree(record_of(ours), record_of(truth), ray, size);
        tally.wrong += level.scene->occluded(ray) != truth.is_hit();
        tally.differ += !tools::hits_agree(record_of(ours), record_of(again), ray, size);
    }
    return tally;
}

class SoupRefit : public ::testing::TestWithParam<std::tuple<Kernel, std::string, std::string>> {};

TEST_P(SoupRefit, EachRefitAnswersAsTheArbiterAndAFreshBuild) {
    const auto& [kernel, builder, kind] = GetParam();
    const SceneConfig config = config_of(kernel, builder);
    std::vector<Triangle> mesh = organic(2000);
    const float size = length(bounds_of(mesh).extent());
    Level level(config, "soup");
    level.mesh(mesh);
    level.scene->commit();
    // Twice: the first refit also makes the layout's map of which reference rewrites which lane.
    for (int round = 0; round < 2; ++round) {
        move(mesh, kind, size);
        level.scene->refit(0);
        const Tally tally = check(level, config, 300);
        EXPECT_EQ(tally.wrong, 0u) << "round " << round;
        EXPECT_EQ(tally.differ, 0u) << "round " << round;
        EXPECT_GE(tally.hits, 10u);
    }
}

INSTANTIATE_TEST_SUITE_P(KernelsBuildersMoves, SoupRefit,
                         ::testing::Combine(::testing::Values(Kernel::binary, Kernel::bvh4, Kernel::bvh8),
                                            ::testing::Values("binned", "spatial"),
                                            ::testing::Values("rotating", "bending", "exploding")));

TEST(SoupRefitMoller, PlanesFollowTheMovedTriangles) {
    const SceneConfig config = config_of(Kernel::bvh8, "spatial", LeafTest::moller);
    std::vector<Triangle> mesh = organic(2000);
    Level level(config, "soup");
    level.mesh(mesh);
    level.scene->commit();
    move(mesh, "bending", length(bounds_of(mesh).extent()));
    level.scene->refit(0);
    const Tally tally = check(level, config, 300);
    EXPECT_EQ(tally.wrong, 0u);
    EXPECT_EQ(tally.differ, 0u);
}

TEST(SoupRefitErrors, ACoordinateNotFiniteChangesNothing) {
    for (const Kernel kernel : {Kernel::binary, Kernel::bvh4, Kernel::bvh8}) {
        const SceneConfig config = config_of(kernel, "spatial");
        std::vector<Triangle> mesh = organic(2000);
        const std::vector<Triangle> before = mesh;
        Level level(config, "soup");
        level.mesh(mesh);
        level.scene->commit();
        const std::vector<Ray> rays = tools::generate_random_rays(level.scene->bounds(), 300, 7);
        std::vector<SceneHit> expected;
        for (const Ray& ray : rays) expected.push_back(level.scene->intersect(ray));
        // Every triangle moved, and one in the middle is not finite: the walk has rewritten much of the
        // tree and the packs by the time it meets it.
        move(mesh, "rotating", 1.0f);
        mesh[1234].v1.y = std::numeric_limits<float>::quiet_NaN();
        try {
            level.scene->refit(0);
            ADD_FAILURE() << "a NaN coordinate was accepted";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("triangle 1234"), std::string::npos) << e.what();
        }
        size_t changed = 0;
        for (size_t r = 0; r < rays.size(); ++r) {
            const SceneHit now = level.scene->intersect(rays[r]);
            changed += now.t != expected[r].t || now.primitive != expected[r].primitive;
        }
        EXPECT_EQ(changed, 0u) << to_string(kernel);
        // The tree and the layout still hold the triangles of before: refitting to them answers alike.
        mesh = before;
        level.scene->refit(0);
        EXPECT_EQ(check(level, config, 200).wrong, 0u);
    }
}

TEST(SoupRefit, TrianglesBecomingOrStoppingBeingDegenerate) {
    for (const Kernel kernel : {Kernel::bvh4, Kernel::bvh8}) {
        const SceneConfig config = config_of(kernel, "spatial");
        std::vector<Triangle> mesh = organic(2000);
        const Triangle whole = mesh[7];
        mesh[7].v2 = mesh[7].v0;  // degenerate when built: no layout stores it
        Level level(config, "soup");
        level.mesh(mesh);
        level.scene->commit();
        mesh[7] = whole;          // now it can be hit
        mesh[9].v1 = mesh[9].v0;  // and this one cannot
        level.scene->refit(0);
        const Tally tally = check(level, config, 300);
        EXPECT_EQ(tally.wrong, 0u);
        EXPECT_EQ(tally.differ, 0u);
        // A ray straight at the revived triangle's centroid hits it (or a triangle in front of it).
        const Vec3 centroid = (whole.v0 + whole.v1 + whole.v2) / 3.0f;
        const Vec3 normal = normalize(cross(whole.v1 - whole.v0, whole.v2 - whole.v0));
        const Ray ray{centroid + normal * 1e-3f, normal * -1.0f};
        const Reference truth = closest_in_instances(placements(level), ray, 0xFFFFFFFFu);
        ASSERT_TRUE(truth.is_hit());
        EXPECT_EQ(level.scene->intersect(ray).primitive, truth.primitive);
    }
}

TEST(SoupRefit, SameBoxesAndAnswersForAnyThreadCount) {
    const SceneConfig config = config_of(Kernel::bvh8, "spatial");
    std::vector<Triangle> mesh = organic(4000);
    Level one(config, "one"), two(config, "two");
    one.mesh(mesh);
    two.mesh(mesh);
    one.scene->commit();
    two.scene->commit();
    move(mesh, "bending", length(bounds_of(mesh).extent()));
    tbb::task_arena(1).execute([&] { one.scene->refit(0); });
    tbb::task_arena(2).execute([&] { two.scene->refit(0); });
    EXPECT_EQ(one.scene->bounds().lo, two.scene->bounds().lo);
    EXPECT_EQ(one.scene->bounds().hi, two.scene->bounds().hi);
    size_t differ = 0;
    for (const Ray& ray : tools::generate_random_rays(one.scene->bounds(), 500, 11)) {
        const SceneHit a = one.scene->intersect(ray), b = two.scene->intersect(ray);
        differ += a.t != b.t || a.primitive != b.primitive || a.u != b.u || a.v != b.v;
    }
    EXPECT_EQ(differ, 0u);
}

}  // namespace
