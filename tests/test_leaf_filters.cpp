// SPDX-License-Identifier: MIT
// The float filters of both leaf tests (docs/leaf-test.md): the watertight test's four-wide edge
// functions (triangle_pack.hpp, pack_edges) and the moller test's edges and distances
// (moller_filter.hpp). Every decision either calls certain is checked, lane by lane, against the
// exact arbiter (intersect_triangle_exact), for rays aimed at vertices, at points on edges, into
// interiors, at grazing angles, from points on the surface, and with tmin / tmax on the hit
// distance; on the built-in scenes and a shared scene when present. Then the +moller kernels against
// the watertight kernel on the same rays: identical answers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/exact_triangle.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene.hpp"
#include "spacebvh/trace.hpp"
#include "test_support.hpp"
#include "trace/leaf_tests/moller_filter.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Four consecutive live triangles of the scene (file order: mostly neighbours sharing edges).
std::vector<trace::TrianglePack> packs_of(const Scene& scene, size_t max_packs) {
    std::vector<trace::TrianglePack> packs;
    trace::TrianglePack pack{};
    int lane = 0;
    const size_t stride = std::max<size_t>(1, scene.triangles.size() / (4 * max_packs));
    for (size_t i = 0; i < scene.triangles.size() && packs.size() < max_packs; ++i) {
        if ((i / 4) % stride != 0) continue;
        const Triangle& t = scene.triangles[i];
        if (t.is_degenerate()) continue;
        const Vec3 v[3] = {t.v0, t.v1, t.v2};
        for (int k = 0; k < 3; ++k)
            for (int axis = 0; axis < 3; ++axis) pack.vertex[k][axis][lane] = v[k][axis];
        pack.primitive[lane] = uint32_t(i);
        if (++lane == 4) {
            packs.push_back(pack);
            pack = trace::TrianglePack{};
            lane = 0;
        }
    }
    return packs;
}

Triangle lane_triangle(const trace::TrianglePack& pack, int lane) {
    Vec3 v[3];
    trace::pack_triangle(pack, lane, v);
    return Triangle{v[0], v[1], v[2]};
}

struct Tally {
    size_t lanes = 0, certain_edges = 0, certain_within = 0, certain_rejected = 0;
    size_t watertight_certain = 0;  // lanes the watertight edges called certainly inside or outside
};

// Checks every certain decision of both filters on `pack` for `ray` (its tmax the running tmax).
void check_decisions(const trace::TrianglePack& pack, const trace::PackPlanes& planes, const Ray& ray, Tally& tally,
                     const std::string& what) {
    trace::MollerDecision decision;
    trace::moller_pack(pack, planes, trace::MollerRay(ray), ray.tmax, decision);
    trace::PackEdges edges;
    trace::pack_edges(pack, trace::PackRay(trace::WatertightRay(ray)), edges);
    Ray line = ray;
    line.tmin = -kInf;
    line.tmax = kInf;
    for (int lane = 0; lane < 4; ++lane) {
        const Triangle triangle = lane_triangle(pack, lane);
        const bool crosses_line = intersect_triangle_exact(line, triangle).has_value();
        const bool hit = intersect_triangle_exact(ray, triangle).has_value();
        const bool inside = (decision.inside >> lane) & 1, rejected = (decision.rejected >> lane) & 1;
        const bool within = (decision.within >> lane) & 1;
        ++tally.lanes;
        tally.certain_edges += inside || (rejected && !inside);
        tally.certain_within += within;
        tally.certain_rejected += rejected;
        SCOPED_TRACE(what + ", triangle " + std::to_string(pack.primitive[lane]));
        if (inside) {
            EXPECT_TRUE(crosses_line) << "certainly inside, but the arbiter's line misses";
        }
        if (rejected && !inside) {
            EXPECT_FALSE(crosses_line) << "certainly outside, but the arbiter's line crosses";
        }
        if (rejected) {
            EXPECT_FALSE(hit) << "rejected, but the arbiter hits in [tmin, tmax]";
        }
        if (within) {
            EXPECT_TRUE(hit) << "certain hit, but the arbiter misses";
        }
        EXPECT_FALSE(within && rejected);
        // The watertight edges decide the line only; the distance is always taken in double.
        const bool watertight_inside = (edges.inside >> lane) & 1, watertight_outside = (edges.outside >> lane) & 1;
        tally.watertight_certain += watertight_inside || watertight_outside;
        if (watertight_inside) {
            EXPECT_TRUE(crosses_line) << "watertight: certainly inside, but the arbiter's line misses";
        }
        if (watertight_outside) {
            EXPECT_FALSE(crosses_line) << "watertight: certainly outside, but the arbiter's line crosses";
        }
        EXPECT_FALSE(watertight_inside && watertight_outside);
    }
}

// The rays of one pack's lane: at its vertices, at points on its edges, into its interior, at
// grazing angles, from its surface; each also with tmin / tmax moved onto its exact hit distance.
std::vector<Ray> probe_rays(const Triangle& tri, const AABB& box, SplitMix64& rng) {
    std::vector<Ray> rays;
    const auto uniform = [&] { return float(rng.uniform()); };
    const auto point_in_box = [&] {
        const Vec3 e = box.extent();
        return Vec3{box.lo.x - e.x * 0.5f + 2.0f * e.x * uniform(), box.lo.y - e.y * 0.5f + 2.0f * e.y * uniform(),
                    box.lo.z - e.z * 0.5f + 2.0f * e.z * uniform()};
    };
    const auto aim = [&](Vec3 org, Vec3 target) {
        if (target == org) return;
        Ray ray;
        ray.org = org;
        ray.dir = target - org;
        rays.push_back(ray);
    };
    const Vec3 v[3] = {tri.v0, tri.v1, tri.v2};
    for (int k = 0; k < 3; ++k) {
        aim(point_in_box(), v[k]);  // at a vertex: two edge functions exactly or nearly zero
        const Vec3 a = v[k], b = v[(k + 1) % 3];
        aim(point_in_box(), a + (b - a) * uniform());  // at an edge point (rounded: within ulps)
        aim(point_in_box(), a + (b - a) * 0.5f);
    }
    const float s = uniform(), r = uniform() * (1.0f - s);
    aim(point_in_box(), tri.v0 + (tri.v1 - tri.v0) * s + (tri.v2 - tri.v0) * r);  // interior
    // Grazing: from beside the triangle, nearly along an edge, tilted by a tiny angle off its plane.
    const Vec3 e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
    const Vec3 n = cross(e1, e2);
    const float n_length = length(n);
    if (n_length > 0.0f && std::isfinite(n_length)) {
        const Vec3 unit_n = n * (1.0f / n_length);
        const Vec3 centre = (tri.v0 + tri.v1 + tri.v2) * (1.0f / 3.0f);
        for (float tilt : {1e-2f, 1e-4f, 1e-6f, 1e-8f, 0.0f}) {
            Ray ray;
            ray.org = centre - e1 * 2.0f + unit_n * (tilt * length(e1));
            ray.dir = e1 - unit_n * (tilt * length(e1) * 0.5f);
            rays.push_back(ray);
        }
        // From a surface point (the hit of a primary ray, as diffuse rays start): t near 0.
        Ray leaving;
        leaving.org = centre;
        leaving.dir = point_in_box() - centre;
        if (!(leaving.dir == Vec3(0.0f))) rays.push_back(leaving);
    }
    // The same rays with the range ending or starting on the exact hit distance, and one just past it.
    const size_t plain = rays.size();
    for (size_t i = 0; i < plain; ++i) {
        const auto t = intersect_triangle_exact(rays[i], tri);
        if (!t || !(*t > 0.0)) continue;
        const float ft = float(*t);
        for (float bound : {ft, std::nextafter(ft, 0.0f), std::nextafter(ft, kInf)}) {
            Ray cut = rays[i];
            cut.tmax = bound;
            rays.push_back(cut);
            cut.tmax = kInf;
            cut.tmin = bound;
            rays.push_back(cut);
        }
        Ray behind = rays[i];
        behind.tmin = -1.0f;  // distance decisions gated off: every inside lane takes the double path
        behind.tmax = ft * 0.5f;
        rays.push_back(behind);
    }
    return rays;
}

// expect_decisions: most lanes decided in float (not where every value lies below the bound's
// absolute underflow term, as on a scene of tiny coordinates: there the exact test decides all).
void check_scene(const Scene& scene, size_t max_packs, uint64_t seed, bool expect_decisions = true) {
    const std::vector<trace::TrianglePack> packs = packs_of(scene, max_packs);
    ASSERT_FALSE(packs.empty());
    const trace::PackPlanesList planes = trace::make_pack_planes(packs);
    SplitMix64 rng(seed);
    Tally tally;
    std::vector<Ray> all_rays;
    for (size_t p = 0; p < packs.size(); ++p) {
        for (int lane = 0; lane < 4; ++lane) {
            const std::vector<Ray> rays = probe_rays(lane_triangle(packs[p], lane), scene.bounds(), rng);
            for (const Ray& ray : rays) check_decisions(packs[p], planes[p], ray, tally, scene.name);
            if (p % 8 == 0) all_rays.insert(all_rays.end(), rays.begin(), rays.end());
            if (::testing::Test::HasFailure()) return;
        }
    }
    std::printf(
        "%s: %zu lanes; moller: edges certain %.4f, hits certain %.4f, rejected %.4f; watertight: edges certain %.4f\n",
        scene.name.c_str(), tally.lanes, double(tally.certain_edges) / tally.lanes,
        double(tally.certain_within) / tally.lanes, double(tally.certain_rejected) / tally.lanes,
        double(tally.watertight_certain) / tally.lanes);
    // Not vacuous: most lanes are decided by the filters.
    if (expect_decisions) {
        EXPECT_GT(tally.watertight_certain, tally.lanes / 2) << scene.name;
        EXPECT_GT(tally.certain_edges, tally.lanes / 2) << scene.name;
        EXPECT_GT(tally.certain_within, 0u) << scene.name;
        EXPECT_GT(tally.certain_rejected, tally.lanes / 4) << scene.name;
    }

    // Through the kernels: the +moller kernels answer exactly as the watertight ones.
    const Bvh bvh = spacebvh::build(scene, config_for("spatial"));
    for (const char* kernel : {"bvh8", "bvh4"}) {
        const std::unique_ptr<Tracer> watertight = make_tracer(kernel, scene, bvh);
        const std::unique_ptr<Tracer> moller = make_tracer(std::string(kernel) + "+moller", scene, bvh);
        std::vector<Hit> expected(all_rays.size()), hits(all_rays.size());
        std::vector<uint8_t> expected_occluded(all_rays.size()), occluded(all_rays.size());
        watertight->intersect(all_rays, expected);
        moller->intersect(all_rays, hits);
        watertight->occluded(all_rays, expected_occluded);
        moller->occluded(all_rays, occluded);
        size_t different = 0;
        for (size_t i = 0; i < all_rays.size(); ++i)
            different += std::memcmp(&hits[i].t, &expected[i].t, sizeof(float)) != 0 ||
                         hits[i].primitive != expected[i].primitive || occluded[i] != expected_occluded[i];
        EXPECT_EQ(different, 0u) << scene.name << ", " << kernel << ", " << all_rays.size() << " rays";
    }
}

}  // namespace

TEST(LeafFilters, EveryCertainDecisionMatchesTheArbiterOnBuiltinScenes) {
    uint64_t seed = 1;
    for (const std::string& name : builtin_scene_names()) {
        SCOPED_TRACE(name);
        check_scene(testing_support::cached_builtin_scene(name), 400, seed++);
    }
}

TEST(LeafFilters, EveryCertainDecisionMatchesTheArbiterOnASharedScene) {
    const std::string path = std::string(SPACEBVH_SHARED_DIR) + "/scenes/sibenik/sibenik.obj";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "no shared scene at " << path;
    SceneTransform rotated;
    rotated.rotate_degrees = SceneTransform::parse_rotation("x:45,y:45,z:45");
    check_scene(load_scene(path), 600, 7);
    check_scene(load_scene(path, rotated), 300, 8);
}

// A scene far from the origin and one of tiny coordinates (subnormal products): still exact.
TEST(LeafFilters, FarAndTinyScenesMatchTheArbiter) {
    const Scene& soup = testing_support::cached_builtin_scene("soup");
    // 1e-17: products of edge components near 1e-36, where float products reach the subnormal range.
    for (float scale : {1e-17f, 1e6f}) {
        Scene scene = soup;
        scene.name = scale < 1.0f ? "tiny soup" : "far soup";
        for (Triangle& t : scene.triangles)
            for (Vec3* v : {&t.v0, &t.v1, &t.v2}) *v = *v * scale + Vec3(scale > 1.0f ? 3e7f : 0.0f);
        SCOPED_TRACE(scene.name);
        check_scene(scene, 200, 3, scale > 1.0f);
    }
}
