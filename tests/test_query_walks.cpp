// SPDX-License-Identifier: MIT
// RayQueries' walks per instruction set (src/trace/queries/query_walks.cpp): on a CPU with AVX2 and
// FMA a layout holds eight-wide nodes and takes the walks compiled for AVX2; the same layout without
// them walks the binary nodes only, as on a CPU without AVX2 (in a portable build, by the baseline's
// copy of the walks). Both must give
// the answers of every triangle tested by brute force (intersect_triangle_perturbed), bit for bit, on
// random rays, rays through vertices and edge midpoints, rays with tmin < 0 and axis-aligned rays.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "spacebvh/presets.hpp"
#include "spacebvh/queries.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene.hpp"
#include "trace/kernels/kernels.hpp"
#include "trace/queries/query_layout.hpp"
#include "trace/queries/query_walks.hpp"

namespace spacebvh {
namespace {

using namespace spacebvh::tools;
using Layout = RayQueries::Layout;

// Random rays, then rays from random points through vertices and edge midpoints, some starting
// before their origin (tmin < 0), then axis-aligned rays through vertices.
std::vector<Ray> hostile_rays(const Scene& scene, size_t count, uint64_t seed) {
    const AABB bounds = scene.bounds();
    std::vector<Ray> rays = generate_random_rays(bounds, count, seed);
    std::mt19937_64 random(seed);
    std::uniform_real_distribution<float> unit(-0.5f, 1.5f);
    std::uniform_int_distribution<size_t> pick(0, scene.triangles.size() - 1);
    for (size_t i = 0; i < count; ++i) {
        const Triangle& tri = scene.triangles[pick(random)];
        const int k = int(i % 3);
        const Vec3 target = i % 2 ? tri.vertex(k) : (tri.vertex(k) + tri.vertex((k + 1) % 3)) * 0.5f;
        Vec3 origin;
        for (int a = 0; a < 3; ++a) origin[a] = bounds.lo[a] + unit(random) * (bounds.hi[a] - bounds.lo[a]);
        Ray ray{origin, target - origin};
        if (i % 4 == 0) ray.tmin = -0.5f;
        rays.push_back(ray);
        Ray axis{target, Vec3{0.0f, 0.0f, 0.0f}};
        axis.dir[k] = i % 2 ? 1.0f : -1.0f;
        axis.org[k] -= axis.dir[k] * (bounds.hi[k] - bounds.lo[k]);
        rays.push_back(axis);
    }
    return rays;
}

bool same(const QueryHit& a, const QueryHit& b) {
    return a.primitive == b.primitive && a.t == b.t && a.u == b.u && a.v == b.v && a.point == b.point;
}

// Every query of one layout against the brute force; returns the number of rays answered wrongly.
size_t wrong_answers(const Layout& layout, const Scene& scene, const std::vector<Ray>& rays) {
    size_t wrong = 0;
    std::vector<QueryHit> hits;
    std::vector<uint32_t> scratch;
    for (const Ray& ray : rays) {
        std::vector<QueryHit> expected;
        for (uint32_t i = 0; i < scene.triangles.size(); ++i)
            if (const auto hit = intersect_triangle_perturbed(ray, scene.triangles[i], i)) expected.push_back(*hit);
        std::sort(expected.begin(), expected.end(), [](const QueryHit& a, const QueryHit& b) {
            return a.t < b.t || (a.t == b.t && a.primitive < b.primitive);
        });
        trace::queries::collect_hits(layout, ray, hits, kNoHitLimit);
        bool ok = hits.size() == expected.size() && std::equal(hits.begin(), hits.end(), expected.begin(), same);
        ok = ok && trace::queries::count_crossings(layout, ray, scratch) == expected.size();
        ok = ok && trace::queries::any_crossing(layout, ray) == !expected.empty();
        QueryHit first;
        trace::queries::nearest_crossing(layout, ray, first);
        ok = ok && (expected.empty() ? !first.is_hit() : same(first, expected[0]));
        ok = ok && trace::queries::nearest_crossing_id(layout, ray) == first.primitive;
        wrong += !ok;
    }
    return wrong;
}

TEST(QueryWalks, EveryInstructionSetAnswersAsBruteForce) {
    for (const std::string name : {"organic", "interior-rotated"}) {
        const Scene scene = load_scene("builtin:" + name);
        for (const std::string builder : {"binned", "spatial"}) {
            const Bvh bvh = spacebvh::build(scene, config_for(builder));
            Layout dispatched(scene.triangles, bvh);
            EXPECT_EQ(dispatched.has_wide, trace::cpu_has(NodeTest::avx2)) << name;
            Layout baseline(scene.triangles, bvh);
            baseline.wide = {};
            baseline.has_wide = false;
            const std::vector<Ray> rays = hostile_rays(scene, 100, 7);
            EXPECT_EQ(wrong_answers(dispatched, scene, rays), 0u) << name << " " << builder << ", dispatched";
            EXPECT_EQ(wrong_answers(baseline, scene, rays), 0u) << name << " " << builder << ", baseline";
        }
    }
}

}  // namespace
}  // namespace spacebvh
