// SPDX-License-Identifier: MIT
// Tracer::refit: after the vertices move and the tree's boxes are recomputed (same topology), every
// kernel answers as the exact arbiter on the moved triangles, the wide float layouts updated in place
// and the others made again; a triangle that becomes (or stops being) degenerate forces a new layout
// and is still answered exactly.
#include <gtest/gtest.h>

#include <cmath>

#include <tbb/task_arena.h>

#include "core/exact_triangle.hpp"
#include "scene_test_support.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/recipe.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/verify.hpp"
#include "test_support.hpp"

using namespace spacebvh;
using spacebvh::scene_testing::organic;

namespace {

// rotating: about z; bending: y += x^2 / size; exploding: each triangle pushed out from the centre.
std::vector<Triangle> moved(std::vector<Triangle> triangles, const std::string& kind, float size) {
    for (Triangle& t : triangles) {
        const Vec3 centroid = (t.v0 + t.v1 + t.v2) / 3.0f;
        for (Vec3* p : {&t.v0, &t.v1, &t.v2}) {
            if (kind == "rotating") {
                *p = Vec3{0.8f * p->x - 0.6f * p->y, 0.6f * p->x + 0.8f * p->y, p->z};
            } else if (kind == "bending") {
                p->y += p->x * p->x / size;
            } else {
                *p = *p + centroid * 0.5f;
            }
        }
    }
    return triangles;
}

struct Truth {
    double t = INFINITY;
    uint32_t primitive = kInvalidIndex;
};
Truth arbiter(const std::vector<Triangle>& triangles, const Ray& ray) {
    Truth best;
    for (uint32_t i = 0; i < triangles.size(); ++i)
        if (const auto t = intersect_triangle_exact(ray, triangles[i]); t && *t < best.t) best = {*t, i};
    return best;
}

// Wrong answers of `tracer` against the arbiter on `triangles`, closest hit and occlusion.
size_t wrong_answers(const Tracer& tracer, const std::vector<Triangle>& triangles, const std::vector<Ray>& rays,
                     float size, size_t* hits = nullptr) {
    size_t wrong = 0;
    for (const Ray& ray : rays) {
        const Truth truth = arbiter(triangles, ray);
        const Hit hit = tracer.intersect(ray);
        const tools::HitRecord expected =
            truth.primitive == kInvalidIndex ? tools::HitRecord{} : tools::HitRecord{float(truth.t), truth.primitive};
        wrong += !tools::hits_agree({hit.t, hit.primitive}, expected, ray, size);
        wrong += tracer.occluded(ray) != (truth.primitive != kInvalidIndex);
        if (hits) *hits += hit.is_hit();
    }
    return wrong;
}

class TracerRefit : public ::testing::TestWithParam<std::tuple<std::string, std::string, std::string>> {};

TEST_P(TracerRefit, RefittedLayoutAnswersAsTheArbiterOnTheMovedMesh) {
    const auto& [builder, kernel, kind] = GetParam();
    const std::vector<Triangle> before = organic(1500);
    const float size = length(bounds_of(before).extent());
    Bvh bvh = build(MeshView(before), TreeRecipe::for_builder(builder));
    TracerConfig refittable = parse_kernel(kernel);
    refittable.keep_refit_map = true;
    Tracer tracer(MeshView(before), bvh, refittable);
    Tracer plain(MeshView(before), bvh, parse_kernel(kernel));  // no refit map: refit lays it out again
    const bool float_wide = kernel.rfind("bvh", 0) == 0 && kernel.rfind("bvh8q", 0) != 0;
    if (float_wide) {
        EXPECT_GT(tracer.memory_bytes(), plain.memory_bytes()) << "the map is counted";
    }
    const std::vector<Triangle> after = moved(before, kind, size);
    refit_boxes(bvh, after);
    const bool in_place = tracer.refit(MeshView(after), bvh);
    EXPECT_EQ(in_place, float_wide) << kernel;
    EXPECT_FALSE(plain.refit(MeshView(after), bvh)) << kernel;
    const std::vector<Ray> rays = tools::generate_random_rays(bounds_of(after), 250, 4);
    size_t hits = 0;
    EXPECT_EQ(wrong_answers(tracer, after, rays, size, &hits), 0u);
    EXPECT_EQ(wrong_answers(plain, after, rays, size), 0u);
    EXPECT_GT(hits, 20u);
}

INSTANTIATE_TEST_SUITE_P(Kernels, TracerRefit,
                         ::testing::Combine(::testing::Values("binned", "spatial"),
                                            ::testing::Values("binary", "bvh4", "bvh8", "bvh8+moller", "bvh8q"),
                                            ::testing::Values("rotating", "bending", "exploding")));

// A triangle that becomes degenerate, and a degenerate one that opens up: the layout is made anew, and
// the answers stay exact (a degenerate triangle is never hit, an opened one is).
TEST(TracerRefit, DegeneracyChangesMakeANewLayout) {
    std::vector<Triangle> before = organic(800);
    const float size = length(bounds_of(before).extent());
    before[7] = {before[7].v0, before[7].v0, before[7].v1};  // degenerate at build: no layout stores it
    Bvh bvh = build(MeshView(before), TreeRecipe::for_builder("spatial"));
    TracerConfig refittable = parse_kernel("bvh8");
    refittable.keep_refit_map = true;
    Tracer tracer(MeshView(before), bvh, refittable);
    std::vector<Triangle> after = before;
    after[7].v1 = organic(800)[7].v1;  // opens up
    after[3] = {after[3].v0, after[3].v0, after[3].v0};
    refit_boxes(bvh, after);
    EXPECT_FALSE(tracer.refit(MeshView(after), bvh));
    std::vector<Ray> rays = tools::generate_random_rays(bounds_of(after), 150, 11);
    for (int k : {3, 7}) {                   // aimed at both changed triangles
        const Triangle t = organic(800)[k];  // a copy: the vector is a temporary
        const Vec3 target = (t.v0 + t.v1 + t.v2) / 3.0f;
        rays.push_back(Ray{rays[k].org, target - rays[k].org, 0.0f, kInfinity});
    }
    EXPECT_EQ(wrong_answers(tracer, after, rays, size), 0u);
    // Moving the same mesh again keeps the (new) layout in place.
    const std::vector<Triangle> again = moved(after, "rotating", size);
    refit_boxes(bvh, again);
    EXPECT_TRUE(tracer.refit(MeshView(again), bvh));
    EXPECT_EQ(wrong_answers(tracer, again, tools::generate_random_rays(bounds_of(again), 150, 12), size), 0u);
}

TEST(TracerRefit, ATreeOfOtherGeometryIsRefused) {
    const std::vector<Triangle> mesh = organic(300);
    Bvh bvh = build(MeshView(mesh), TreeRecipe::for_builder("binned"));
    Tracer tracer(MeshView(mesh), bvh, parse_kernel("bvh8"));
    const std::vector<Triangle> fewer(mesh.begin(), mesh.begin() + 100);
    EXPECT_THROW(tracer.refit(MeshView(fewer), bvh), Error);
}

}  // namespace

// Refit runs across the thread's arena (the tree's leaves, the layout's packs and nodes, the scene's
// copy of the triangles): one thread and four give the same boxes and the same answers, which are
// the arbiter's on the moved mesh.
TEST(TracerRefit, TheSameForAnyThreadCount) {
    const std::vector<Triangle> before = organic(30000);
    const float size = length(bounds_of(before).extent());
    const std::vector<Triangle> after = moved(before, "bending", size);
    const Bvh built = build(MeshView(before), TreeRecipe::for_builder("spatial"));
    Bvh one = built, four = built;
    tbb::task_arena(1).execute([&] { refit_boxes(one, after); });
    tbb::task_arena(4).execute([&] { refit_boxes(four, after); });
    ASSERT_EQ(one.nodes.size(), four.nodes.size());
    for (size_t n = 0; n < one.nodes.size(); ++n) {
        EXPECT_EQ(one.nodes[n].bounds.lo, four.nodes[n].bounds.lo) << n;
        EXPECT_EQ(one.nodes[n].bounds.hi, four.nodes[n].bounds.hi) << n;
    }
    EXPECT_FALSE(one.nodes[0].bounds.lo == built.nodes[0].bounds.lo &&
                 one.nodes[0].bounds.hi == built.nodes[0].bounds.hi);

    SceneConfig config;
    config.recipe = TreeRecipe::for_builder("spatial");
    std::vector<Triangle> a = before, b = before;  // the callers' buffers, moved before the refit
    RenderScene scene_a(config), scene_b(config);
    scene_a.attach_mesh(MeshView(a));
    scene_b.attach_mesh(MeshView(b));
    scene_a.commit();
    scene_b.commit();
    a = after;
    b = after;
    tbb::task_arena(1).execute([&] { scene_a.refit(0); });
    tbb::task_arena(4).execute([&] { scene_b.refit(0); });
    const std::vector<Ray> rays = tools::generate_random_rays(bounds_of(after), 300, 9);
    size_t wrong = 0, hits = 0;
    for (const Ray& ray : rays) {
        const SceneHit ha = scene_a.intersect(ray), hb = scene_b.intersect(ray);
        EXPECT_EQ(ha.t, hb.t);
        EXPECT_EQ(ha.primitive, hb.primitive);
        const Truth truth = arbiter(after, ray);
        const tools::HitRecord expected =
            truth.primitive == kInvalidIndex ? tools::HitRecord{} : tools::HitRecord{float(truth.t), truth.primitive};
        wrong += !tools::hits_agree({ha.t, ha.primitive}, expected, ray, size);
        hits += ha.is_hit();
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(hits, 20u);
}
