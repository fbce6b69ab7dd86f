// SPDX-License-Identifier: MIT
// The exact arbiter and the agreement rule of docs/rays.md.
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <cmath>
#include <vector>

#include "core/exact_triangle.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/verify.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;

namespace {

const Triangle kUnit{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};  // in z = 0, right angle at the origin

Ray down_at(float x, float y, float z = 1.0f) {
    Ray ray;
    ray.org = {x, y, z};
    ray.dir = {0, 0, -1};
    return ray;
}

bool hits(const Ray& ray, const Triangle& tri) { return intersect_triangle_exact(ray, tri).has_value(); }

}  // namespace

TEST(ExactTriangle, HitsTheInteriorWithTheRightT) {
    const auto t = intersect_triangle_exact(down_at(0.25f, 0.25f), kUnit);
    ASSERT_TRUE(t);
    EXPECT_EQ(*t, 1.0);
    // From below (no back-face culling), and t in units of |dir|.
    Ray up = down_at(0.2f, 0.3f, -2.0f);
    up.dir = {0, 0, 4};
    ASSERT_TRUE(intersect_triangle_exact(up, kUnit));
    EXPECT_DOUBLE_EQ(*intersect_triangle_exact(up, kUnit), 0.5);
    // Oblique.
    Ray oblique;
    oblique.org = {-1, -1, 2};
    oblique.dir = {1.2f, 1.3f, -2};
    const auto to = intersect_triangle_exact(oblique, kUnit);
    ASSERT_TRUE(to);
    EXPECT_DOUBLE_EQ(*to, 1.0);
}

TEST(ExactTriangle, EdgesAndVerticesAreInside) {
    EXPECT_TRUE(hits(down_at(0.5f, 0.0f), kUnit));  // edge v0 v1
    EXPECT_TRUE(hits(down_at(0.0f, 0.5f), kUnit));  // edge v2 v0
    EXPECT_TRUE(hits(down_at(0.5f, 0.5f), kUnit));  // hypotenuse v1 v2
    EXPECT_TRUE(hits(down_at(0.25f, 0.75f), kUnit));
    EXPECT_TRUE(hits(down_at(0.0f, 0.0f), kUnit));  // vertices
    EXPECT_TRUE(hits(down_at(1.0f, 0.0f), kUnit));
    EXPECT_TRUE(hits(down_at(0.0f, 1.0f), kUnit));
}

TEST(ExactTriangle, MissesOutside) {
    EXPECT_FALSE(hits(down_at(0.6f, 0.6f), kUnit));
    EXPECT_FALSE(hits(down_at(-1e-7f, 0.5f), kUnit));
    EXPECT_FALSE(hits(down_at(0.5f, -1e-7f), kUnit));
    EXPECT_FALSE(hits(down_at(std::nextafter(0.5f, 1.0f), 0.5f), kUnit));
    EXPECT_FALSE(hits(down_at(2.0f, 2.0f), kUnit));
    EXPECT_FALSE(hits(down_at(1.0f + 1e-6f, 0.0f), kUnit));
    // Pointing away.
    Ray away = down_at(0.25f, 0.25f);
    away.dir = {0, 0, 1};
    EXPECT_FALSE(hits(away, kUnit));
}

TEST(ExactTriangle, DegenerateTrianglesAreNeverHit) {
    const Triangle segment{{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
    const Triangle point{{0.5f, 0, 0}, {0.5f, 0, 0}, {0.5f, 0, 0}};
    const Triangle repeated{{0, 0, 0}, {1, 0, 0}, {1, 0, 0}};
    for (const Triangle& tri : {segment, point, repeated}) {
        EXPECT_FALSE(hits(down_at(0.5f, 0.0f), tri));
        EXPECT_FALSE(hits(down_at(1.0f, 0.0f), tri));
        Ray sideways;  // along the segment
        sideways.org = {-1, 0, 0};
        sideways.dir = {1, 0, 0};
        EXPECT_FALSE(hits(sideways, tri));
    }
}

TEST(ExactTriangle, HonoursTminAndTmax) {
    Ray ray = down_at(0.25f, 0.25f);
    ray.tmax = 0.5f;
    EXPECT_FALSE(hits(ray, kUnit));
    ray.tmax = 1.0f;  // closed interval
    EXPECT_TRUE(hits(ray, kUnit));
    ray.tmin = 1.0f;
    EXPECT_TRUE(hits(ray, kUnit));
    ray.tmin = 1.5f;
    ray.tmax = kInfinity;
    EXPECT_FALSE(hits(ray, kUnit));
    // Origin on the surface, tmin = 0: t = 0 counts.
    Ray on_surface = down_at(0.25f, 0.25f, 0.0f);
    ASSERT_TRUE(intersect_triangle_exact(on_surface, kUnit));
    EXPECT_EQ(*intersect_triangle_exact(on_surface, kUnit), 0.0);
    // Behind the origin.
    EXPECT_FALSE(hits(down_at(0.25f, 0.25f, -1.0f), kUnit));
}

TEST(ExactTriangle, AxisParallelRays) {
    const Triangle yz{{3, 0, 0}, {3, 1, 0}, {3, 0, 1}};  // in the plane x = 3
    Ray along_x;
    along_x.org = {0, 0.25f, 0.25f};
    along_x.dir = {1, 0, 0};
    ASSERT_TRUE(intersect_triangle_exact(along_x, yz));
    EXPECT_EQ(*intersect_triangle_exact(along_x, yz), 3.0);
    along_x.org = {0, 0.5f, 0.5f};  // on the hypotenuse
    EXPECT_TRUE(hits(along_x, yz));
    along_x.org = {0, 0.5f, 0.51f};
    EXPECT_FALSE(hits(along_x, yz));

    const Triangle xz{{0, -2, 0}, {0, -2, 1}, {1, -2, 0}};  // in the plane y = -2
    Ray along_y;
    along_y.org = {0.1f, 5, 0.1f};
    along_y.dir = {0, -1, 0};
    ASSERT_TRUE(intersect_triangle_exact(along_y, xz));
    EXPECT_EQ(*intersect_triangle_exact(along_y, xz), 7.0);

    // A ray in the triangle's plane is not a hit.
    Ray in_plane;
    in_plane.org = {-1, 0.25f, 0};
    in_plane.dir = {1, 0, 0};
    EXPECT_FALSE(hits(in_plane, kUnit));
}

TEST(ExactTriangle, SharedEdgesAreWatertight) {
    // Two triangles sharing a diagonal of an irregular quad; rays aimed at points on and next to the
    // diagonal from oblique directions must hit at least one of them, and rays off the quad neither.
    const Vec3 a{0.1f, 0.2f, 0.3f}, b{1.7f, 0.1f, -0.2f}, c{1.9f, 1.3f, 0.4f}, d{0.2f, 1.1f, 0.1f};
    const Triangle left{a, b, c}, right{a, c, d};
    SplitMix64 rng(17);
    int misses = 0;
    for (int i = 0; i < 20000; ++i) {
        const float s = 0.02f + 0.96f * rng.uniform();
        const Vec3 target = a + (c - a) * s;  // on the diagonal, rounded to float
        Ray ray;
        ray.org = target + Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f, 1.0f + rng.uniform());
        ray.dir = target - ray.org;
        if (!hits(ray, left) && !hits(ray, right)) ++misses;
    }
    EXPECT_EQ(misses, 0);
}

TEST(HitsAgree, FollowsTheSpecRule) {
    Ray ray;
    ray.dir = {0, 0, 1};
    const HitRecord miss;
    EXPECT_TRUE(hits_agree(miss, miss, ray, 10.0f));
    EXPECT_FALSE(hits_agree({1.0f, 0}, miss, ray, 10.0f));
    EXPECT_FALSE(hits_agree(miss, {1.0f, 0}, ray, 10.0f));
    // Relative term 1e-4 * max(|tA|, |tB|) plus absolute 1e-6 * diagonal / |dir| (here 1e-5).
    EXPECT_TRUE(hits_agree({100.0f, 1}, {100.009f, 1}, ray, 10.0f));
    EXPECT_FALSE(hits_agree({100.0f, 1}, {100.012f, 1}, ray, 10.0f));
    EXPECT_TRUE(hits_agree({0.0f, 1}, {9e-6f, 1}, ray, 10.0f));
    EXPECT_FALSE(hits_agree({0.0f, 1}, {1.1e-5f, 1}, ray, 10.0f));
    // A longer direction shrinks the absolute term (t is in units of |dir|).
    ray.dir = {0, 0, 4};
    EXPECT_FALSE(hits_agree({0.0f, 1}, {9e-6f, 1}, ray, 10.0f));
    EXPECT_TRUE(hits_agree({0.0f, 1}, {2e-6f, 1}, ray, 10.0f));
    // Different primitives at the same t are not a disagreement.
    EXPECT_TRUE(hits_agree({2.0f, 1}, {2.0f, 7}, ray, 10.0f));
    // Occlusion records.
    EXPECT_TRUE(hits_agree(occlusion_record(true), occlusion_record(true), ray, 10.0f));
    EXPECT_FALSE(hits_agree(occlusion_record(true), occlusion_record(false), ray, 10.0f));
}

namespace {

// Two unit squares, at z = 0 (triangles 0, 1) and z = -1 (triangles 2, 3), a degenerate
// triangle (4) and a duplicate of triangle 0 (5).
Scene two_floors() {
    Scene scene = testing_support::two_floors();
    scene.triangles.push_back({{0, 0, 0.5f}, {1, 1, 0.5f}, {2, 2, 0.5f}});
    scene.triangles.push_back(scene.triangles[0]);
    scene.degenerate_count = 1;
    return scene;
}

}  // namespace

TEST(Arbiter, ClosestHitAndOcclusionOnATinyScene) {
    const Scene scene = two_floors();
    HitRecord r = arbiter_closest_hit(scene, down_at(0.7f, 0.2f));
    EXPECT_EQ(r.primitive, 0u);  // ties with its duplicate (5) go to the lower index
    EXPECT_EQ(r.t, 1.0f);
    r = arbiter_closest_hit(scene, down_at(0.2f, 0.7f));
    EXPECT_EQ(r.primitive, 1u);
    Ray from_below = down_at(0.2f, 0.7f, -3.0f);
    from_below.dir = {0, 0, 1};
    r = arbiter_closest_hit(scene, from_below);
    EXPECT_EQ(r.primitive, 3u);
    EXPECT_EQ(r.t, 2.0f);
    // The degenerate triangle is transparent, misses are misses.
    EXPECT_FALSE(arbiter_closest_hit(scene, down_at(1.5f, 1.5f)).is_hit());
    Ray between = down_at(0.5f, 0.5f, -0.5f);
    between.tmax = 0.25f;
    EXPECT_FALSE(arbiter_occlusion(scene, between).is_hit());
    between.tmax = 0.5f;
    EXPECT_TRUE(arbiter_occlusion(scene, between).is_hit());
    EXPECT_EQ(arbiter_occlusion(scene, between).t, 0.0f);
    EXPECT_EQ(arbiter_closest_hit(scene, between).primitive, 2u);  // on the shared diagonal: lowest index
}

TEST(Verify, CountsAndListsWrongAnswers) {
    const Scene scene = two_floors();
    std::vector<Ray> rays;
    for (int i = 0; i < 100; ++i) rays.push_back(down_at(0.005f + 0.01f * i, 0.3f));
    for (int i = 0; i < 100; ++i) rays.push_back(down_at(2.0f, 0.01f * i));  // all miss
    std::vector<HitRecord> truth(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) truth[i] = arbiter_closest_hit(scene, rays[i]);

    std::vector<HitRecord> ours = truth, reference = truth;
    // Equal t, other primitive: agreement.
    reference[3].primitive = 5;
    // Reference wrong on 2 rays.
    reference[10] = {};
    reference[150] = {0.5f, 1};
    // Ours wrong on 40 rays (more than are listed).
    for (size_t i = 199; i >= 120; i -= 2) ours[i] = {3.0f, 0};
    // Both wrong and disagreeing.
    ours[20].t = 1.5f;
    reference[20].t = 2.5f;

    const VerificationReport report = verify_against_reference(scene, rays, ours, reference, false);
    EXPECT_EQ(report.rays, rays.size());
    EXPECT_EQ(report.disagreements, 43u);  // ours 40, reference 2 (rays 10, 150), both 1 (ray 20)
    EXPECT_EQ(report.ours_wrong, 41u);
    EXPECT_EQ(report.reference_wrong, 3u);
    ASSERT_EQ(report.wrong_rays.size(), 32u);
    EXPECT_EQ(report.wrong_rays.front(), 20u);
    EXPECT_TRUE(std::is_sorted(report.wrong_rays.begin(), report.wrong_rays.end()));
    EXPECT_EQ(report.wrong_rays[1], 121u);

    // Occlusion mode uses the occlusion arbiter.
    std::vector<HitRecord> occ_ours(rays.size()), occ_ref(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) occ_ours[i] = occ_ref[i] = occlusion_record(truth[i].is_hit());
    occ_ref[0] = occlusion_record(false);
    const VerificationReport occ = verify_against_reference(scene, rays, occ_ours, occ_ref, true);
    EXPECT_EQ(occ.disagreements, 1u);
    EXPECT_EQ(occ.ours_wrong, 0u);
    EXPECT_EQ(occ.reference_wrong, 1u);
    EXPECT_TRUE(occ.wrong_rays.empty());

    EXPECT_THROW(verify_against_reference(scene, rays, std::span(ours).first(10), reference, false), Error);
}
