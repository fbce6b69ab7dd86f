// SPDX-License-Identifier: MIT
// RenderScene's intersection filters (each candidate reaches the filter at most once, spatial splits
// included; the answer is the arbiter's on the accepted triangles; masks come first) and refit (moved
// meshes traced after refit answer as a fresh build, and as the arbiter).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <tuple>

#include "scene_test_support.hpp"
#include "spacebvh/tools/rays.hpp"
#include "test_support.hpp"

using namespace spacebvh;
using namespace spacebvh::scene_testing;

namespace {

Affine turned(float degrees, float sx, Vec3 shift, bool mirror) {
    const double c = std::cos(degrees * M_PI / 180.0), s = std::sin(degrees * M_PI / 180.0);
    Affine a;
    a.m = {float(sx * c * (mirror ? -1 : 1)),
           float(-s),
           0,
           shift.x,
           float(sx * s * (mirror ? -1 : 1)),
           float(c),
           0,
           shift.y,
           0,
           0,
           1.3f,
           shift.z};
    return a;
}

// Counts every offer per (instance path, geometry, primitive) and rejects odd primitives.
struct Offers {
    std::map<std::tuple<std::array<uint32_t, kMaxInstanceLevels>, uint32_t, uint32_t>, int> count;
    uint32_t hidden_geometry = kInvalidIndex;
    int hidden_offers = 0;
};
bool reject_odd(const FilterCandidate& candidate, void* user) {
    Offers& offers = *static_cast<Offers*>(user);
    ++offers.count[{candidate.hit.instance, candidate.hit.geometry, candidate.hit.primitive}];
    if (candidate.hit.geometry == offers.hidden_geometry && candidate.hit.instance[0] == kInvalidIndex)
        ++offers.hidden_offers;
    return candidate.hit.primitive % 2 == 0;
}

// Which primitives of `triangles` the spatial builder puts into more than one leaf.
std::vector<bool> split_primitives(const std::vector<Triangle>& triangles) {
    const Bvh bvh = build(MeshView(triangles), TreeRecipe::for_builder("spatial"));
    std::vector<int> leaves(triangles.size(), 0);
    for (const BvhNode& node : bvh.nodes)
        for (uint32_t k = 0; node.is_leaf() && k < node.reference_count; ++k) ++leaves[bvh.primitives[node.first + k]];
    std::vector<bool> split(triangles.size());
    for (size_t i = 0; i < triangles.size(); ++i) split[i] = leaves[i] > 1;
    return split;
}

TEST(SceneFilter, EachCandidateOnceAndTheArbitersAnswerOnTheAcceptedOnes) {
    const std::vector<Triangle> mesh = organic(3000), hidden = organic(500);
    SceneConfig config;
    config.recipe = TreeRecipe::for_builder("spatial");
    Level leaf(config, "leaf");
    leaf.mesh(mesh);
    leaf.scene->commit();
    Level top(config, "top");
    top.mesh(mesh);
    const uint32_t hidden_id = top.mesh(hidden, 0x2);  // the rays' mask 0x1 never sees it
    const float size = length(bounds_of(mesh).extent());
    top.instance(leaf, turned(40.0f, 1.5f, {size * 0.5f, 0, 0}, true));
    top.instance(leaf, turned(-75.0f, 0.8f, {0, size * 0.4f, 0}, false));
    top.scene->commit();
    const std::vector<Placement> all = placements(top);
    const std::vector<bool> split = split_primitives(mesh);
    ASSERT_GT(std::count(split.begin(), split.end(), true), 0);
    const std::vector<Ray> rays = tools::generate_random_rays(top.scene->bounds(), 300, 21);
    const Accept even = [](const Placement&, uint32_t primitive) { return primitive % 2 == 0; };
    Offers offers;
    offers.hidden_geometry = hidden_id;
    TraceContext context{0x1u, reject_odd, &offers};
    size_t repeated = 0, split_offers = 0, wrong = 0, hits = 0;
    for (const Ray& ray : rays) {
        for (bool occlusion : {false, true}) {
            offers.count.clear();
            const Reference truth = closest_in_instances(all, ray, 0x1u, even);
            if (occlusion) {
                wrong += top.scene->occluded(ray, context) != truth.is_hit();
            } else {
                const SceneHit hit = top.scene->intersect(ray, context);
                hits += hit.is_hit();
                wrong += !tools::hits_agree(record_of(hit), record_of(truth), ray, size);
                wrong += hit.is_hit() && hit.primitive % 2 != 0;
            }
            for (const auto& [key, n] : offers.count) {
                repeated += n > 1;
                split_offers += split[std::get<2>(key) % split.size()] && std::get<1>(key) != hidden_id;
            }
        }
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_EQ(repeated, 0u);
    EXPECT_GT(split_offers, 0u);  // candidates that spatial splits put in several leaves did reach the filter
    EXPECT_GT(hits, 0u);
    EXPECT_EQ(offers.hidden_offers, 0);  // masks are tested before the filter
}

bool reject_all(const FilterCandidate& candidate, void* user) {
    ++(*static_cast<std::map<uint32_t, int>*>(user))[candidate.hit.primitive];
    return false;
}

// Rays aimed at the centroids of the triangles that spatial splits put into several leaves, under a
// filter that rejects everything (so the walk goes on through every leaf on the ray): each such
// triangle is met in several leaves and must still be offered once.
TEST(SceneFilter, SplitTrianglesReachTheFilterOnce) {
    const std::vector<Triangle> mesh = organic(3000);
    const std::vector<bool> split = split_primitives(mesh);
    SceneConfig config;
    config.recipe = TreeRecipe::for_builder("spatial");
    RenderScene scene(config, "split");
    scene.attach_mesh(MeshView(mesh));
    scene.commit();
    const AABB box = scene.bounds();
    const std::vector<Ray> random = tools::generate_random_rays(box, 2000, 3);
    std::map<uint32_t, int> offers;
    const TraceContext context{0xFFFFFFFFu, reject_all, &offers};
    size_t aimed = 0, repeated = 0, split_offered = 0;
    for (uint32_t i = 0; i < mesh.size() && aimed < random.size(); ++i) {
        if (!split[i]) continue;
        const Vec3 target = (mesh[i].v0 + mesh[i].v1 + mesh[i].v2) / 3.0f;
        const Ray& r = random[aimed++];
        for (const Ray& ray :
             {Ray{r.org, target - r.org, 0.0f, kInfinity}, Ray{target - r.dir, r.dir, 0.0f, kInfinity}}) {
            offers.clear();
            EXPECT_FALSE(scene.intersect(ray, context).is_hit());
            for (const auto& [primitive, n] : offers) {
                repeated += n > 1;
                split_offered += split[primitive];
            }
            offers.clear();
            EXPECT_FALSE(scene.occluded(ray, context));
            for (const auto& [primitive, n] : offers) repeated += n > 1;
        }
    }
    EXPECT_GT(split_offered, aimed);  // the aimed-at triangles (and more) reached the filter
    EXPECT_EQ(repeated, 0u);
}

bool accept_all(const FilterCandidate&, void*) { return true; }

TEST(SceneFilter, AcceptingEveryCandidateGivesTheUnfilteredAnswers) {
    const std::vector<Triangle> mesh = organic(2000);
    Level leaf(SceneConfig{}, "leaf");
    leaf.mesh(mesh);
    leaf.scene->commit();
    Level top(SceneConfig{}, "top");
    top.instance(leaf, turned(10.0f, 2.0f, {0, 0, 0}, true));
    top.mesh(mesh);
    top.scene->commit();
    const std::vector<Ray> rays = tools::generate_random_rays(top.scene->bounds(), 500, 2);
    const TraceContext filtered{0xFFFFFFFFu, accept_all, nullptr};
    for (const Ray& ray : rays) {
        const SceneHit a = top.scene->intersect(ray), b = top.scene->intersect(ray, filtered);
        EXPECT_EQ(a.is_hit(), b.is_hit());
        if (a.is_hit() && b.is_hit()) {
            EXPECT_TRUE(tools::hits_agree(record_of(a), record_of(b), ray, 1.0f));
        }
        EXPECT_EQ(top.scene->occluded(ray), top.scene->occluded(ray, filtered));
    }
}

// An indexed mesh whose vertices the test moves: each triangle has its own three vertices.
struct MovingMesh {
    std::vector<float> xyz;
    std::vector<uint32_t> index;
    explicit MovingMesh(const std::vector<Triangle>& triangles) {
        for (const Triangle& t : triangles)
            for (int k = 0; k < 3; ++k) {
                index.push_back(uint32_t(xyz.size() / 3));
                for (int i = 0; i < 3; ++i) xyz.push_back(t.vertex(k)[i]);
            }
    }
    MeshView view() const { return MeshView(std::span<const float>(xyz), std::span<const uint32_t>(index)); }
    std::vector<Triangle> triangles() const {
        const TriangleStore store(view());
        return {store.triangles().begin(), store.triangles().end()};
    }
};

// rotating: about z; bending: y += x^2 / size; exploding: each triangle pushed out from the centre.
void move(MovingMesh& m, const std::string& kind, float size) {
    for (size_t t = 0; t < m.xyz.size() / 9; ++t) {
        float* v = &m.xyz[9 * t];
        const Vec3 centroid = (Vec3{v[0], v[1], v[2]} + Vec3{v[3], v[4], v[5]} + Vec3{v[6], v[7], v[8]}) / 3.0f;
        for (int k = 0; k < 3; ++k) {
            float* p = v + 3 * k;
            if (kind == "rotating") {
                const float x = p[0], y = p[1];
                p[0] = 0.8f * x - 0.6f * y;
                p[1] = 0.6f * x + 0.8f * y;
            } else if (kind == "bending") {
                p[1] += p[0] * p[0] / size;
            } else {
                for (int i = 0; i < 3; ++i) p[i] += 0.5f * centroid[i];
            }
        }
    }
}

class SceneRefit : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {};

TEST_P(SceneRefit, RefitThenTraceAnswersAsAFreshBuild) {
    const auto& [builder, kind] = GetParam();
    SceneConfig config;
    config.recipe = TreeRecipe::for_builder(builder);
    MovingMesh moving(organic(2500));
    const float size = length(bounds_of(moving.triangles()).extent());
    auto build_scene = [&](const MovingMesh& m, std::unique_ptr<Level>& leaf, std::unique_ptr<Level>& top) {
        leaf = std::make_unique<Level>(config, "leaf");
        leaf->scene->attach_mesh(m.view());
        leaf->scene->commit();
        top = std::make_unique<Level>(config, "top");
        top->instance(*leaf, turned(30.0f, 1.0f, {0, 0, 0}, false));
        top->instance(*leaf, turned(-100.0f, 0.7f, {size, 0, 0}, true));
        top->scene->commit();
    };
    std::unique_ptr<Level> leaf, top;
    build_scene(moving, leaf, top);
    move(moving, kind, size);
    leaf->scene->refit(0);
    top->scene->refit();
    MovingMesh copy = moving;
    std::unique_ptr<Level> fresh_leaf, fresh_top;
    build_scene(copy, fresh_leaf, fresh_top);
    const std::vector<Triangle> moved = moving.triangles();
    leaf->meshes.push_back({0, 0xFFFFFFFFu, &moved});
    const std::vector<Placement> all = placements(*top);
    const std::vector<Ray> rays = tools::generate_random_rays(fresh_top->scene->bounds(), 300, 9);
    size_t wrong = 0, differ = 0, hits = 0;
    for (const Ray& ray : rays) {
        const SceneHit ours = top->scene->intersect(ray), fresh = fresh_top->scene->intersect(ray);
        const Reference truth = closest_in_instances(all, ray, 0xFFFFFFFFu);
        hits += ours.is_hit();
        wrong += !tools::hits_agree(record_of(ours), record_of(truth), ray, size);
        wrong += top->scene->occluded(ray) != truth.is_hit();
        differ += !tools::hits_agree(record_of(ours), record_of(fresh), ray, size) || ours.instance != fresh.instance;
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_EQ(differ, 0u);
    EXPECT_GE(hits, 10u);  // the moved meshes are in the rays' way
}

INSTANTIATE_TEST_SUITE_P(Moves, SceneRefit,
                         ::testing::Combine(::testing::Values("binned", "spatial"),
                                            ::testing::Values("rotating", "bending", "exploding")));

}  // namespace
