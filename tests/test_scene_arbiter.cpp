// SPDX-License-Identifier: MIT
// The instanced scene's arbiter (spacebvh/tools/scene_arbiter.hpp) against the tests' own reference
// (scene_test_support.hpp: every placement brute force, no culling) on two levels of rotated, mirrored,
// non-uniformly scaled and sheared instances, near the origin and far from it, with random rays and
// rays aimed at vertices and edges; and Embree's two-level scene (embree_instances.hpp) beside a
// RenderScene on the same rays, the arbiter settling every disagreement: ours are never wrong.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>

#include "scene_test_support.hpp"
#include "spacebvh/tools/embree_instances.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene_arbiter.hpp"
#include "test_support.hpp"

using namespace spacebvh;
using namespace spacebvh::scene_testing;

namespace {

Affine rotated(float degrees, Vec3 scale, Vec3 shift, bool mirror) {
    const double c = std::cos(degrees * M_PI / 180.0), s = std::sin(degrees * M_PI / 180.0);
    const double r[3][3] = {{c, -s, 0}, {s * 0.6, c * 0.6, 0.8}, {-s * 0.8, -c * 0.8, 0.6}};  // rotation
    Affine m;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) m.m[4 * i + j] = float(scale[i] * r[i][j] * (mirror && j == 0 ? -1.0 : 1.0));
        m.m[4 * i + 3] = shift[i];
    }
    return m;
}

struct Instanced {
    std::vector<Triangle> organic, soup;
    std::unique_ptr<Level> leaf, top;
    std::vector<tools::Scene> meshes;
    std::vector<tools::MeshPlacement> placements;
    std::vector<Placement> reference;
};

// Two levels: the leaf (organic and soup) placed three times in the top scene, the top also holding
// the soup itself; everything shifted by `far`.
Instanced make_instanced(const SceneConfig& config, float far) {
    Instanced s;
    s.organic = testing_support::cached_builtin_scene("organic").triangles;
    s.organic.resize(std::min<size_t>(s.organic.size(), 2000));
    s.soup = testing_support::cached_builtin_scene("soup").triangles;
    s.soup.resize(1000);
    const float size = length(bounds_of(s.organic).extent());
    s.leaf = std::make_unique<Level>(config, "leaf");
    s.leaf->mesh(s.organic);
    s.leaf->mesh(s.soup);
    s.leaf->scene->commit();
    s.top = std::make_unique<Level>(config, "top");
    s.top->mesh(s.soup);
    s.top->instance(*s.leaf, rotated(30.0f, {1, 1, 1}, {far, far, far}, false));
    s.top->instance(*s.leaf, rotated(-70.0f, {2.0f, 0.5f, 1.0f}, {far + size, far, far}, true));
    Affine sheared = rotated(200.0f, {0.7f, 1.5f, 1.0f}, {far, far + size, far - size}, false);
    sheared.m[1] += 0.3f;
    s.top->instance(*s.leaf, sheared);
    s.top->scene->commit();
    s.reference = placements(*s.top);
    std::map<const std::vector<Triangle>*, uint32_t> index;
    for (const auto* mesh : {&s.organic, &s.soup}) {
        index[mesh] = uint32_t(s.meshes.size());
        s.meshes.push_back(tools::Scene{"mesh", *mesh});
    }
    for (const Placement& p : s.reference)
        s.placements.push_back({index.at(p.triangles), p.forward, p.path, p.geometry, p.masks});
    return s;
}

// Random rays through the world box, and rays aimed at world vertices and edge midpoints.
std::vector<Ray> hostile_rays(const Instanced& s, const AABB& world) {
    std::vector<Ray> rays = tools::generate_random_rays(world, 300, 5);
    const std::vector<Ray> starts = tools::generate_random_rays(world, 300, 6);
    for (size_t k = 0; k < starts.size(); ++k) {
        const Placement& p = s.reference[k % s.reference.size()];
        const Triangle w = p.world((*p.triangles)[(k * 7919) % p.triangles->size()]);
        rays.push_back({starts[k].org, (k % 2 ? w.v0 : (w.v1 + w.v2) * 0.5f) - starts[k].org, 0.0f, kInfinity});
    }
    return rays;
}

}  // namespace

TEST(SceneArbiter, EqualsEveryPlacementBruteForceNearAndFar) {
    for (float far : {0.0f, 3.0e4f}) {
        SCOPED_TRACE(far);
        const Instanced s = make_instanced(SceneConfig{}, far);
        const tools::SceneArbiter arbiter(s.meshes, s.placements);
        const std::vector<Ray> rays = hostile_rays(s, s.top->scene->bounds());
        size_t different = 0, hits = 0;
        for (const Ray& ray : rays) {
            const Reference truth = closest_in_instances(s.reference, ray, 0xFFFFFFFFu);
            const tools::PlacedHit mine = arbiter.closest_hit(ray);
            hits += truth.is_hit();
            different += mine.placement != truth.placement || mine.hit.t != float(truth.t) ||
                         (truth.is_hit() && mine.hit.primitive != truth.primitive);
            different += arbiter.occluded(ray) != truth.is_hit();
        }
        EXPECT_EQ(different, 0u);
        EXPECT_GT(hits, rays.size() / 3);
    }
}

TEST(SceneArbiter, MasksAndBadPlacements) {
    Instanced s = make_instanced(SceneConfig{}, 0.0f);
    for (tools::MeshPlacement& p : s.placements) p.masks.back() = p.mesh == 1 ? 0x2u : 0x1u;  // soup: 0x2
    const tools::SceneArbiter arbiter(s.meshes, s.placements);
    for (const Ray& ray : tools::generate_random_rays(s.top->scene->bounds(), 200, 9)) {
        const tools::PlacedHit hit = arbiter.closest_hit(ray, 0x1u);
        if (hit.placement >= 0) {
            EXPECT_EQ(s.placements[size_t(hit.placement)].mesh, 0u);
        }
    }
    s.placements[1].mesh = 7;
    EXPECT_THROW(tools::SceneArbiter(s.meshes, s.placements), Error);
    s.placements[1].mesh = 0;
    s.placements[1].transforms[0].m[0] = NAN;
    EXPECT_THROW(tools::SceneArbiter(s.meshes, s.placements), Error);
}

// Embree's two-level scene (single rays and packets) beside ours: every disagreement settled by the
// arbiter finds ours right; Embree's answers name real placements.
TEST(SceneArbiter, SettlesRenderSceneAgainstEmbreesTwoLevelScene) {
    SceneConfig config;
    config.tracer.kernel = Kernel::bvh8;
    config.recipe = TreeRecipe::for_builder("spatial");
    const Instanced s = make_instanced(config, 0.0f);
    const tools::SceneArbiter arbiter(s.meshes, s.placements);
    const tools::EmbreeInstancedScene embree(s.meshes, s.placements, tools::EmbreeQuality::high);
    const std::vector<Ray> rays = hostile_rays(s, s.top->scene->bounds());
    std::vector<SceneHit> ours(rays.size()), single(rays.size()), packets(rays.size());
    s.top->scene->intersect(rays, ours);
    embree.intersect(rays, single);
    embree.intersect16(rays, packets);
    std::vector<tools::HitRecord> mine, theirs, theirs16;
    size_t misnamed = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        mine.push_back(record_of(ours[i]));
        theirs.push_back(record_of(single[i]));
        theirs16.push_back(record_of(packets[i]));
        bool named = !single[i].is_hit();
        for (const tools::MeshPlacement& p : s.placements)
            named = named || (p.path == single[i].instance && p.geometry == single[i].geometry);
        misnamed += !named;
    }
    const auto truth = [&](const Ray& ray) { return arbiter.closest_hit(ray).hit; };
    for (const auto* reference : {&theirs, &theirs16}) {
        const tools::VerificationReport report =
            tools::verify_with_arbiter(rays, mine, *reference, arbiter.diagonal(), truth);
        EXPECT_EQ(report.ours_wrong, 0u);
        EXPECT_LT(report.disagreements, rays.size() / 20);  // the two scenes answer alike
    }
    EXPECT_EQ(misnamed, 0u);
    EXPECT_GT(embree.memory_bytes(), 0u);
}
