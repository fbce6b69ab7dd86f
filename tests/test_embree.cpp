// SPDX-License-Identifier: MIT
// The Embree adapter against the exact arbiter of docs/rays.md.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "spacebvh/tools/embree_scene.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/verify.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;

namespace {

// A wavy height field (shared edges everywhere), a closed box floating above it, a few loose
// triangles and one degenerate triangle: about 1,200 triangles.
Scene hand_made_scene() {
    Scene scene;
    scene.name = "hand_made";
    const int n = 24;
    auto height = [](float x, float z) { return 0.3f * std::sin(3.0f * x) * std::cos(2.0f * z); };
    auto grid = [&](int i, int j) {
        const float x = -2.0f + 4.0f * float(i) / n, z = -2.0f + 4.0f * float(j) / n;
        return Vec3(x, height(x, z), z);
    };
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            scene.triangles.push_back({grid(i, j), grid(i + 1, j), grid(i + 1, j + 1)});
            scene.triangles.push_back({grid(i, j), grid(i + 1, j + 1), grid(i, j + 1)});
        }
    // Box [-0.5, 0.5] x [0.6, 1.4] x [-0.5, 0.5].
    const Vec3 lo{-0.5f, 0.6f, -0.5f}, hi{0.5f, 1.4f, 0.5f};
    auto corner = [&](int c) { return Vec3(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z); };
    const int faces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
    for (const auto& f : faces) {
        scene.triangles.push_back({corner(f[0]), corner(f[1]), corner(f[2])});
        scene.triangles.push_back({corner(f[0]), corner(f[2]), corner(f[3])});
    }
    SplitMix64 rng(99);
    for (int i = 0; i < 40; ++i) {
        const Vec3 c{4 * rng.uniform() - 2, 2 * rng.uniform(), 4 * rng.uniform() - 2};
        auto jitter = [&] { return Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f, rng.uniform() - 0.5f) * 0.6f; };
        scene.triangles.push_back({c + jitter(), c + jitter(), c + jitter()});
    }
    scene.triangles.push_back({{0, 1.8f, 0}, {1, 1.8f, 0}, {2, 1.8f, 0}});  // degenerate
    scene.degenerate_count = 1;
    return scene;
}

std::vector<HitRecord> records_of(std::span<const Hit> hits) {
    std::vector<HitRecord> out(hits.size());
    for (size_t i = 0; i < hits.size(); ++i) out[i] = to_record(hits[i]);
    return out;
}

void expect_same_hits(std::span<const Hit> a, std::span<const Hit> b, const char* what) {
    ASSERT_EQ(a.size(), b.size());
    size_t different = 0;
    for (size_t i = 0; i < a.size(); ++i)
        if (a[i].t != b[i].t || a[i].primitive != b[i].primitive) ++different;
    EXPECT_EQ(different, 0u) << what;
}

// Checks Embree at one quality on `rays`: closest hits against the arbiter on every ray, occlusion
// against the closest hit, and the batch and packet paths against single rays.
void check_embree_against_arbiter(const Scene& scene, std::span<const Ray> rays, EmbreeQuality quality) {
    SCOPED_TRACE(std::string("quality ") + to_string(quality));
    const EmbreeScene embree(scene, quality);
    EXPECT_GE(embree.build_milliseconds(), 0.0);

    std::vector<Hit> hits(rays.size());
    embree.intersect(rays, hits);
    std::vector<HitRecord> truth(rays.size());
    size_t hit_count = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        truth[i] = arbiter_closest_hit(scene, rays[i]);
        hit_count += truth[i].is_hit();
    }
    EXPECT_GT(hit_count, rays.size() / 10);
    EXPECT_LT(hit_count, rays.size());
    // The arbiter is the truth; Embree's non-watertight test may be wrong on a rare ray.
    const VerificationReport report = verify_against_reference(scene, rays, truth, records_of(hits), false);
    EXPECT_EQ(report.ours_wrong, 0u);
    EXPECT_LE(report.reference_wrong, rays.size() / 1000 + 1) << "Embree wrong more often than expected";

    for (const Hit& hit : hits)
        if (hit.is_hit()) {
            ASSERT_LT(hit.primitive, scene.triangles.size());
            ASSERT_FALSE(scene.triangles[hit.primitive].is_degenerate());
        }

    // Occlusion agrees with the closest hit, and nothing is in front of the closest hit.
    std::vector<uint8_t> occluded(rays.size());
    embree.occluded(rays, occluded);
    size_t inconsistent = 0, blocked_before_hit = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        if (bool(occluded[i]) != hits[i].is_hit()) ++inconsistent;
        if (!hits[i].is_hit()) continue;
        Ray shorter = rays[i];
        shorter.tmax = hits[i].t * 0.999f;
        if (embree.occluded(shorter)) ++blocked_before_hit;
    }
    EXPECT_EQ(inconsistent, 0u);
    EXPECT_EQ(blocked_before_hit, 0u);

    // Single, batch and 16-wide packets give the same answers.
    std::vector<Hit> single(rays.size()), packets(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) single[i] = embree.intersect(rays[i]);
    embree.intersect16(rays, packets);
    expect_same_hits(single, hits, "batch vs single");
    expect_same_hits(packets, hits, "intersect16 vs intersect1");
    std::vector<uint8_t> occluded16(rays.size());
    embree.occluded16(rays, occluded16);
    EXPECT_EQ(occluded16, occluded);
}

}  // namespace

TEST(Embree, QualityNames) {
    for (EmbreeQuality q : {EmbreeQuality::low, EmbreeQuality::medium, EmbreeQuality::high})
        EXPECT_EQ(parse_embree_quality(to_string(q)), q);
    EXPECT_THROW(parse_embree_quality("ultra"), Error);
}

TEST(Embree, AgreesWithTheArbiterOnAHandMadeScene) {
    const Scene scene = hand_made_scene();
    // 3,001 rays: not a multiple of 16 or 1024, so packet tails and short chunks are exercised.
    const std::vector<Ray> rays = generate_random_rays(scene.bounds(), 3001, 1);
    for (EmbreeQuality q : {EmbreeQuality::low, EmbreeQuality::medium, EmbreeQuality::high})
        check_embree_against_arbiter(scene, rays, q);
}

TEST(Embree, RespectsTheRaySegment) {
    const Scene scene = hand_made_scene();
    const EmbreeScene embree(scene, EmbreeQuality::medium);
    Ray ray;
    ray.org = {0.0f, 3.0f, 0.0f};
    ray.dir = {0.0f, -2.0f, 0.0f};  // t in units of |dir|: the box top (y = 1.4) is at t = 0.8
    Hit hit = embree.intersect(ray);
    ASSERT_TRUE(hit.is_hit());
    EXPECT_NEAR(hit.t, 0.8f, 1e-6f);
    ray.tmin = 0.85f;  // past the top: the box bottom (y = 0.6) at t = 1.2
    hit = embree.intersect(ray);
    ASSERT_TRUE(hit.is_hit());
    EXPECT_NEAR(hit.t, 1.2f, 1e-6f);
    ray.tmax = 1.1f;
    EXPECT_FALSE(embree.intersect(ray).is_hit());
    EXPECT_FALSE(embree.occluded(ray));
}

TEST(Embree, MemoryAndErrors) {
    const Scene scene = hand_made_scene();
    const EmbreeScene embree(scene, EmbreeQuality::high);
    EXPECT_GT(embree.memory_bytes(), 0u);
    EXPECT_GE(embree.buffer_bytes(), scene.triangles.size() * 48);
    EmbreeScene original(scene, EmbreeQuality::low);
    EmbreeScene moved(std::move(original));  // the shared buffers must survive the move
    Ray ray;
    ray.org = {0, 3, 0};
    ray.dir = {0, -1, 0};
    EXPECT_TRUE(moved.intersect(ray).is_hit());

    Scene empty;
    empty.name = "empty";
    EXPECT_THROW(EmbreeScene(empty, EmbreeQuality::medium), Error);
    std::vector<Hit> too_few(2);
    const std::vector<Ray> rays(3, ray);
    EXPECT_THROW(embree.intersect(rays, too_few), Error);
}

TEST(Embree, AgreesWithTheArbiterOnTheBunny) {
    const std::string path = std::string(SPACEBVH_SHARED_DIR) + "/scenes/bunny/bunny.obj";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared scene not found: " << path;
    const Scene scene = load_scene(path);
    ASSERT_EQ(scene.triangles.size(), 69451u);
    const std::vector<Ray> rays = generate_random_rays(scene.bounds(), 2000, 1);

    const EmbreeScene low(scene, EmbreeQuality::low);
    const EmbreeScene medium(scene, EmbreeQuality::medium);
    const EmbreeScene high(scene, EmbreeQuality::high);
    std::vector<Hit> h_low(rays.size()), h_medium(rays.size()), h_high(rays.size());
    low.intersect(rays, h_low);
    medium.intersect(rays, h_medium);
    high.intersect(rays, h_high);

    // The brute-force arbiter costs 69k exact tests a ray: check a sample of rays directly...
    size_t wrong = 0, hits = 0;
    for (size_t i = 0; i < rays.size(); i += 20) {
        const HitRecord truth = arbiter_closest_hit(scene, rays[i]);
        hits += truth.is_hit();
        if (!hits_agree(truth, to_record(h_medium[i]), rays[i], scene.diagonal())) ++wrong;
    }
    EXPECT_GT(hits, 10u);  // about 43 % of random rays hit the bunny
    EXPECT_LE(wrong, 1u);
    // ...and all rays across qualities, where only the disagreements go to the arbiter.
    const VerificationReport low_vs_high =
        verify_against_reference(scene, rays, records_of(h_low), records_of(h_high), false);
    const VerificationReport medium_vs_high =
        verify_against_reference(scene, rays, records_of(h_medium), records_of(h_high), false);
    EXPECT_LE(low_vs_high.disagreements, 2u);
    EXPECT_LE(medium_vs_high.disagreements, 2u);

    // Primary rays from the MANIFEST camera: packets equal single rays, occlusion equals hits.
    Camera camera;
    camera.eye = {-0.016f, 0.11f, 0.25f};
    camera.target = {-0.016f, 0.11f, 0.0f};
    camera.up = {0, 1, 0};
    camera.fovy_degrees = 45.0f;
    const std::vector<Ray> primary = generate_primary_rays(camera, 64, 48);
    std::vector<Hit> single(primary.size()), packets(primary.size());
    medium.intersect(primary, single);
    medium.intersect16(primary, packets);
    expect_same_hits(packets, single, "bunny primary: intersect16 vs intersect1");
    std::vector<uint8_t> occluded(primary.size());
    medium.occluded(primary, occluded);
    size_t primary_hits = 0, inconsistent = 0;
    for (size_t i = 0; i < primary.size(); ++i) {
        primary_hits += single[i].is_hit();
        inconsistent += bool(occluded[i]) != single[i].is_hit();
    }
    EXPECT_EQ(inconsistent, 0u);
    EXPECT_GT(primary_hits, primary.size() / 5);  // the MANIFEST lists 41 % at 1024 x 1024
}
