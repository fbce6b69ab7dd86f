// SPDX-License-Identifier: MIT
// The wide (BVH4/BVH8) and packet kernels (wide_tracer.hpp, packet_tracer.hpp) against the binary
// reference kernel and the exact arbiter: every kernel on every built-in scene for random, primary
// (row-major and in 8x8 / 16x16 tiles), diffuse rays, rays starting on surfaces and cut-off segments;
// packets with partially inactive lanes and lost coherence; the caller's flush-to-zero mode; errors.
// (test_tracer.cpp runs its watertightness and edge-case tests over the kernels too.)
#include <gtest/gtest.h>
#include <xmmintrin.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <numeric>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "spacebvh/presets.hpp"
#include "spacebvh/queries.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tools/verify.hpp"
#include "spacebvh/trace.hpp"
#include "test_support.hpp"
#include "trace/traversal/traversal_common.hpp"
#include "trace/leaf_tests/triangle_pack.hpp"
#include "trace/traversal/visit_order.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;
using testing_support::cached_builtin_scene;
using testing_support::closest_records;
using testing_support::occlusion_records;
using testing_support::wrong_against_arbiter;

namespace {

// Every kernel by its full name (the +moller leaf test included), and the widest node test of each
// family also over Embree's largest-area collapse ("@area"; the others use the SAH-optimal one).
std::vector<std::string> explicit_kernels() {
    std::vector<std::string> kernels;
    for (const std::string& name : kernel_names())
        if (name.find('-') != std::string::npos) kernels.push_back(name);
    for (const std::string family : {"bvh4-", "bvh8-", "packet8-", "packet16-"}) {
        std::string widest;
        for (const std::string& name : kernel_names())
            if (name.rfind(family, 0) == 0 && name.find('+') == std::string::npos) widest = name;
        if (!widest.empty()) kernels.push_back(widest + "@area");
    }
    return kernels;
}

// Ray sets of a scene: random, primary in tile order, diffuse from the primary hits, rays leaving the
// surface points of those hits towards random points (they start on a triangle: t = 0 must not count
// beyond tmin), and random rays cut to [tmax / 4, tmax / 2] of their closest hit.
std::vector<std::pair<std::string, std::vector<Ray>>> ray_sets(const Scene& scene, const Tracer& reference) {
    std::vector<std::pair<std::string, std::vector<Ray>>> sets;
    sets.emplace_back("random", generate_random_rays(scene.bounds(), 3000, 11));
    const uint32_t width = 64, height = 48;
    const std::vector<Ray> row_major = generate_primary_rays(default_camera(scene), width, height);
    std::vector<Ray> tiled;
    for (uint32_t i : tile_order(width, height, 8)) tiled.push_back(row_major[i]);
    sets.emplace_back("primary (8x8 tiles)", tiled);
    std::vector<Hit> hits(row_major.size());
    reference.intersect(row_major, hits);
    sets.emplace_back("diffuse", generate_diffuse_rays(scene, row_major, hits, 3));
    std::vector<Ray> from_surface;
    SplitMix64 rng(5);
    const AABB box = scene.bounds();
    for (size_t i = 0; i < row_major.size(); ++i) {
        if (!hits[i].is_hit()) continue;
        Ray ray;
        ray.org = row_major[i].org + row_major[i].dir * hits[i].t;
        const Vec3 target{box.lo.x + (box.hi.x - box.lo.x) * float(rng.uniform()),
                          box.lo.y + (box.hi.y - box.lo.y) * float(rng.uniform()),
                          box.lo.z + (box.hi.z - box.lo.z) * float(rng.uniform())};
        ray.dir = target - ray.org;
        if (ray.dir == Vec3(0.0f)) continue;
        from_surface.push_back(ray);
    }
    sets.emplace_back("from surfaces", from_surface);
    std::vector<Ray> cut = sets[0].second;
    for (Ray& ray : cut) {
        const Hit hit = reference.intersect(ray);
        if (hit.is_hit()) {
            ray.tmin = hit.t / 4;
            ray.tmax = hit.t / 2;
        }
    }
    sets.emplace_back("cut segments", cut);
    return sets;
}

class KernelsOnScene : public ::testing::TestWithParam<std::string> {};

}  // namespace

// Closest hits and occlusion answers of every kernel equal the binary kernel's, any disagreement settled
// by the arbiter, on cbvh and spatial trees. Trees, rays and reference answers are made once per scene.
TEST_P(KernelsOnScene, AnswersEqualTheReferenceKernel) {
    const Scene& scene = cached_builtin_scene(GetParam());
    for (const char* builder : {"cbvh", "spatial"}) {
        const Bvh bvh = spacebvh::build(scene, config_for(builder));
        const Tracer reference(scene, bvh, Kernel::binary);
        const auto sets = ray_sets(scene, reference);
        std::vector<std::vector<HitRecord>> reference_closest, reference_occlusion;
        for (const auto& [set_name, rays] : sets) {
            ASSERT_GT(rays.size(), 100u) << set_name;
            reference_closest.push_back(closest_records(reference, rays));
            reference_occlusion.push_back(occlusion_records(reference, rays));
        }
        for (const std::string& kernel : explicit_kernels()) {
            const std::unique_ptr<Tracer> tracer = make_tracer(kernel, scene, bvh);
            EXPECT_EQ(tracer->name(), kernel);
            for (size_t set = 0; set < sets.size(); ++set) {
                const auto& [set_name, rays] = sets[set];
                SCOPED_TRACE(std::string(builder) + ", " + kernel + ", " + set_name);
                const auto closest = verify_against_reference(scene, rays, closest_records(*tracer, rays),
                                                              reference_closest[set], false);
                EXPECT_EQ(closest.ours_wrong, 0u);
                EXPECT_EQ(closest.reference_wrong, 0u);
                // Occlusion has no ties: the answers are identical.
                const auto occlusion = occlusion_records(*tracer, rays);
                size_t occlusion_differences = 0;
                for (size_t i = 0; i < rays.size(); ++i)
                    occlusion_differences += occlusion[i].is_hit() != reference_occlusion[set][i].is_hit();
                EXPECT_EQ(occlusion_differences, 0u);
                // Single-ray calls answer like the batch.
                for (size_t i = 0; i < rays.size(); i += 97) {
                    const HitRecord single = to_record(tracer->intersect(rays[i]));
                    EXPECT_TRUE(hits_agree(single, reference_closest[set][i], rays[i], scene.diagonal())) << i;
                    EXPECT_EQ(tracer->occluded(rays[i]), reference_occlusion[set][i].is_hit()) << i;
                }
            }
        }
    }
}

INSTANTIATE_TEST_SUITE_P(All, KernelsOnScene, ::testing::ValuesIn(builtin_scene_names()), [](const auto& info) {
    std::string name = info.param;
    for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    return name;
});

// Packets whose lanes are partly inactive: a short last packet, empty segments (tmax < tmin), rays
// already settled by a zero-length segment, and packets mixing direction signs (coherence lost).
TEST(Packets, PartlyInactiveAndIncoherentPacketsMatchTheArbiter) {
    const Scene& scene = cached_builtin_scene("interior");
    const Bvh bvh = spacebvh::build(scene, config_for("cbvh"));
    std::vector<Ray> rays = generate_primary_rays(default_camera(scene), 20, 10);  // 200 rays
    for (size_t i = 0; i < rays.size(); i += 7) rays[i].tmax = -1.0f;              // empty segment
    for (size_t i = 3; i < rays.size(); i += 11) rays[i].tmax = rays[i].tmin;      // a point
    for (size_t i = 150; i < 180; ++i) rays[i].dir = -rays[i].dir;                 // mixed signs
    for (uint32_t size : {1u, 7u, 64u, 256u}) {
        for (NodeTest test : supported_node_tests(8)) {
            if (test == NodeTest::sse) continue;
            SCOPED_TRACE(std::to_string(size) + " rays per packet, " + to_string(test));
            const Tracer tracer(scene, bvh, TracerConfig{Kernel::packet8, test, WideCollapse::sah_optimal, size});
            const auto closest = closest_records(tracer, rays);
            const auto occlusion = occlusion_records(tracer, rays);
            size_t wrong = 0;
            for (size_t i = 0; i < rays.size(); ++i) {
                wrong += !hits_agree(closest[i], arbiter_closest_hit(scene, rays[i]), rays[i], scene.diagonal());
                wrong += occlusion[i].is_hit() != arbiter_occlusion(scene, rays[i]).is_hit();
                if (rays[i].tmax < rays[i].tmin) {
                    EXPECT_FALSE(closest[i].is_hit()) << i;
                }
            }
            EXPECT_EQ(wrong, 0u);
        }
    }
}

// A caller that set flush-to-zero and denormals-are-zero (as renderers do) gets the same answers, on a
// scene so small that its edge functions are denormal, and gets its mode back.
TEST(Kernels, CallerFlushToZeroModeChangesNoAnswer) {
    Scene scene = load_scene("builtin:organic");
    for (Triangle& t : scene.triangles)
        for (Vec3* v : {&t.v0, &t.v1, &t.v2}) *v = *v * 1e-20f;
    const Bvh bvh = spacebvh::build(scene, config_for("binned"));
    const std::vector<Ray> rays = generate_random_rays(scene.bounds(), 400, 3);
    std::vector<HitRecord> truth;
    for (const Ray& ray : rays) truth.push_back(arbiter_closest_hit(scene, ray));
    size_t truth_hits = 0;
    for (const HitRecord& record : truth) truth_hits += record.is_hit();
    EXPECT_GT(truth_hits, 50u);
    for (const std::string& kernel :
         {std::string("binary"), std::string("bvh4"), std::string("bvh8"), std::string("packet8")}) {
        const std::unique_ptr<Tracer> tracer = make_tracer(kernel, scene, bvh);
        std::vector<HitRecord> single;
        const unsigned saved = _mm_getcsr();
        _mm_setcsr(saved | 0x8040);  // FTZ | DAZ
        for (const Ray& ray : rays) single.push_back(to_record(tracer->intersect(ray)));
        const auto batch = closest_records(*tracer, rays);
        const unsigned after = _mm_getcsr();
        _mm_setcsr(saved);  // the comparisons below need the standard mode too
        EXPECT_EQ(after & 0x8040u, 0x8040u) << kernel << " did not restore the caller's mode";
        size_t wrong = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            wrong += !hits_agree(single[i], truth[i], rays[i], scene.diagonal());
            wrong += !hits_agree(batch[i], truth[i], rays[i], scene.diagonal());
        }
        EXPECT_EQ(wrong, 0u) << kernel;
    }
}

// The statistics count work: single-ray totals equal the batch's, and a wide node tests all its
// children at once, so 8-wide nodes are fetched less often than binary ones on the same tree.
TEST(Kernels, StatisticsAreConsistentAcrossKernels) {
    const Scene& scene = cached_builtin_scene("interior");
    const Bvh bvh = spacebvh::build(scene, config_for("cbvh"));
    const std::vector<Ray> rays = generate_random_rays(scene.bounds(), 2000, 9);
    for (const std::string& kernel : {std::string("binary"), std::string("bvh4"), std::string("bvh8")}) {
        const std::unique_ptr<Tracer> tracer = make_tracer(kernel, scene, bvh);
        TraversalStats singles, batch;
        for (const Ray& ray : rays) tracer->intersect(ray, singles);
        std::vector<Hit> hits(rays.size());
        tracer->intersect(rays, hits, &batch);
        EXPECT_EQ(singles.nodes_visited, batch.nodes_visited) << kernel;
        EXPECT_EQ(singles.triangles_tested, batch.triangles_tested) << kernel;
        EXPECT_GT(batch.nodes_visited, rays.size()) << kernel;
    }
    const Tracer four(scene, bvh, Kernel::bvh4), eight(scene, bvh, Kernel::bvh8);
    EXPECT_LT(eight.node_count(), four.node_count());
    EXPECT_LT(four.node_count(), bvh.nodes.size() / 2);
}

TEST(Kernels, TileOrderGroupsTilesAndIsAPermutation) {
    const std::vector<uint32_t> order = tile_order(10, 7, 4);
    ASSERT_EQ(order.size(), 70u);
    std::vector<uint32_t> sorted = order;
    std::sort(sorted.begin(), sorted.end());
    std::vector<uint32_t> identity(70);
    std::iota(identity.begin(), identity.end(), 0u);
    EXPECT_EQ(sorted, identity);
    // The first tile is pixels x, y in [0, 4): 16 rays, then the next tile starts at x = 4.
    for (int k = 0; k < 16; ++k) EXPECT_EQ(order[k], uint32_t((k / 4) * 10 + k % 4)) << k;
    EXPECT_EQ(order[16], 4u);
    EXPECT_THROW(tile_order(4, 4, 0), Error);
}

TEST(Kernels, BadChoicesAreClearErrors) {
    const Scene& scene = cached_builtin_scene("soup");
    const Bvh bvh = spacebvh::build(scene, config_for("binned"));
    EXPECT_THROW(make_tracer("bvh16", scene, bvh), Error);
    EXPECT_THROW(make_tracer("bvh8-sse", scene, bvh), Error);  // SSE tests 4 lanes
    EXPECT_THROW(make_tracer("bvh4-avx2", scene, bvh), Error);
    EXPECT_THROW(Tracer(scene, bvh, TracerConfig{Kernel::bvh4, NodeTest::avx2}), Error);
    EXPECT_THROW(Tracer(scene, bvh, TracerConfig{Kernel::packet8, NodeTest::sse}), Error);
    EXPECT_THROW(Tracer(scene, bvh, TracerConfig{Kernel::packet8, NodeTest::best, WideCollapse::sah_optimal, 257}),
                 Error);
    EXPECT_THROW(Tracer(scene, bvh, TracerConfig{Kernel::bvh8, NodeTest::best, WideCollapse::sah_optimal, 64}), Error);
    // The moller leaf test: single-ray bvh4 and bvh8 kernels only.
    EXPECT_THROW(make_tracer("packet8+moller", scene, bvh), Error);
    EXPECT_THROW(make_tracer("binary+moller", scene, bvh), Error);
    EXPECT_THROW(make_tracer("bvh8-scalar+moller", scene, bvh), Error);
    EXPECT_THROW(make_tracer("bvh8+woop", scene, bvh), Error);
    EXPECT_THROW(Tracer(scene, bvh,
                        TracerConfig{Kernel::packet16, NodeTest::best, WideCollapse::sah_optimal, 0, LeafTest::moller}),
                 Error);
    EXPECT_EQ(make_tracer("bvh8+moller@area", scene, bvh)->config().leaf_test, LeafTest::moller);
    try {
        make_tracer("warp", scene, bvh);
        FAIL() << "no error";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("bvh8"), std::string::npos) << "the message lists the kernels";
    }
    for (const std::string& name : kernel_names()) EXPECT_NO_THROW(make_tracer(name, scene, bvh)) << name;
}

// Empty trees and a root that is a leaf.
TEST(Kernels, EmptyAndSingleLeafTrees) {
    const Scene scene = testing_support::two_floors();
    Bvh leaf_root;  // all four triangles in the root leaf
    leaf_root.nodes.push_back({scene.bounds(), 0, 4});
    leaf_root.primitives = {0, 1, 2, 3};
    Ray down;
    down.org = {0.25f, 0.5f, 1.0f};
    down.dir = {0.0f, 0.0f, -1.0f};
    for (const std::string& kernel : explicit_kernels()) {
        const std::unique_ptr<Tracer> empty = make_tracer(kernel, scene, Bvh{});
        EXPECT_FALSE(empty->intersect(down).is_hit()) << kernel;
        EXPECT_FALSE(empty->occluded(down)) << kernel;
        const std::unique_ptr<Tracer> tracer = make_tracer(kernel, scene, leaf_root);
        const Hit hit = tracer->intersect(down);
        EXPECT_EQ(hit.primitive, 1u) << kernel;
        EXPECT_FLOAT_EQ(hit.t, 1.0f) << kernel;
        EXPECT_TRUE(tracer->occluded(down)) << kernel;
    }
}

// A scene spanning more than the float range: coordinates up to +-3e38, so a vertex minus a ray
// origin overflows, and node extents are infinite. Every builder builds it (a binning finder once
// took a bin index from inf * 0), and every leaf test answers as the arbiter, for rays along an
// axis too (a shear of 0 times an infinite depth is NaN).
TEST(Kernels, SceneBeyondTheFloatRangeBuildsAndAnswersExactly) {
    Scene scene;
    scene.name = "beyond the float range";
    SplitMix64 rng(17);
    const auto coordinate = [&] { return float((rng.uniform() * 2.0 - 1.0) * 3e38); };
    const auto point = [&] { return Vec3{coordinate(), coordinate(), coordinate()}; };
    for (int i = 0; i < 200; ++i) scene.triangles.push_back(Triangle{point(), point(), point()});
    std::vector<Ray> rays;
    for (int i = 0; i < 1500; ++i) {
        Ray ray;
        ray.org = point();
        if (i % 2 == 0) {
            const float sign = rng.uniform() < 0.5 ? -1.0f : 1.0f;
            ray.dir = Vec3(0.0f);
            ray.dir[i / 2 % 3] = sign;
        } else {
            ray.dir = Vec3{float(rng.uniform() - 0.5), float(rng.uniform() - 0.5), float(rng.uniform() - 0.5)};
        }
        rays.push_back(ray);
    }
    size_t occluded = 0;
    std::vector<uint8_t> truth(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) occluded += truth[i] = arbiter_occlusion(scene, rays[i]).is_hit();
    EXPECT_GT(occluded, rays.size() / 10);  // not vacuous: many rays hit
    EXPECT_LT(occluded, rays.size());
    for (const std::string& builder : builder_names()) {
        SCOPED_TRACE(builder);
        const Bvh bvh = spacebvh::build(scene, config_for(builder));
        for (const char* kernel : {"binary", "bvh4", "bvh8", "bvh8+moller", "bvh8q", "packet8"}) {
            const std::unique_ptr<Tracer> tracer = make_tracer(kernel, scene, bvh);
            EXPECT_EQ(wrong_against_arbiter(scene, *tracer, rays), "") << kernel;
        }
        // The exact queries walk the same wide nodes.
        const RayQueries queries(scene.triangles, bvh);
        size_t query_differences = 0;
        for (size_t i = 0; i < rays.size(); ++i) query_differences += queries.any_hit(rays[i]) != bool(truth[i]);
        EXPECT_EQ(query_differences, 0u);
    }
}

// A grid of unit cubes with gaps (voxel-like: every face on a node plane) and rays along the axes,
// as voxelisation casts them: origins on vertex coordinates, on faces, in gaps and at random, moving
// along one axis (the other components +0 or -0). Such rays take the kernels' subtract-multiply box
// test (wide_kernel.inl, RayBoxes; binary_kernel.cpp, SlabRay) and the queries' double slabs: a ray
// lying in the plane of a box face must still enter it (boxes are closed), which the operand order of
// min and max keeps for the NaN of 0 * inf. Every kernel answers as the arbiter, the exact queries as
// their brute force.
TEST(Kernels, AxisAlignedRaysAnswerAsTheArbiter) {
    Scene scene;
    scene.name = "cube grid";
    const auto add_cube = [&](Vec3 lo, Vec3 hi) {
        const Vec3 c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {lo.x, hi.y, lo.z}, {hi.x, hi.y, lo.z},
                           {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {lo.x, hi.y, hi.z}, {hi.x, hi.y, hi.z}};
        const int quads[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
        for (const auto& q : quads) {
            scene.triangles.push_back(Triangle{c[q[0]], c[q[1]], c[q[2]]});
            scene.triangles.push_back(Triangle{c[q[0]], c[q[2]], c[q[3]]});
        }
    };
    for (int x = 0; x < 6; ++x)
        for (int y = 0; y < 6; ++y)
            for (int z = 0; z < 6; ++z)
                if ((x * 7 + y * 3 + z * 5) % 4 != 0)
                    add_cube(Vec3(2.0f * x, 2.0f * y, 2.0f * z), Vec3(2.0f * x + 1, 2.0f * y + 1, 2.0f * z + 1));
    SplitMix64 rng(23);
    // Coordinates on vertices and faces (integers), in the gaps (x.5) and at random.
    const auto coordinate = [&] {
        const double pick = rng.uniform();
        const float cell = float(int(rng.uniform() * 12.0));
        if (pick < 0.4) return cell;
        if (pick < 0.7) return cell + 0.5f;
        return float(rng.uniform() * 14.0 - 1.0);
    };
    std::vector<Ray> rays;
    for (int i = 0; i < 1500; ++i) {
        Ray ray;
        const int axis = i % 3;
        ray.org = Vec3{coordinate(), coordinate(), coordinate()};
        const bool negative = rng.uniform() < 0.5;
        if (i % 4 == 0) ray.org[axis] = negative ? 15.0f : -4.0f;  // from outside the grid
        ray.dir = Vec3(rng.uniform() < 0.5 ? 0.0f : -0.0f);
        ray.dir[axis] = negative ? -1.0f : 1.0f;
        if (i % 5 == 0) ray.tmax = float(rng.uniform() * 8.0);
        rays.push_back(ray);
    }
    std::vector<HitRecord> truth_closest, truth_occlusion;
    testing_support::arbiter_records(scene, rays, truth_closest, truth_occlusion);
    std::vector<uint8_t> truth(rays.size());
    size_t occluded = 0;
    for (size_t i = 0; i < rays.size(); ++i) occluded += truth[i] = truth_occlusion[i].is_hit();
    EXPECT_GT(occluded, rays.size() / 4);  // not vacuous: many rays hit, many on edges and faces
    EXPECT_LT(occluded, rays.size() - rays.size() / 10);
    for (const char* builder : {"spatial", "binned"}) {
        SCOPED_TRACE(builder);
        const Bvh bvh = spacebvh::build(scene, config_for(builder));
        for (const std::string& kernel : explicit_kernels()) {
            const std::unique_ptr<Tracer> tracer = make_tracer(kernel, scene, bvh);
            const std::vector<HitRecord> closest = closest_records(*tracer, rays);
            const std::vector<HitRecord> occlusion = occlusion_records(*tracer, rays);
            size_t wrong = 0;
            for (size_t i = 0; i < rays.size(); ++i)
                wrong += !hits_agree(closest[i], truth_closest[i], rays[i], scene.diagonal()) ||
                         occlusion[i].is_hit() != truth_occlusion[i].is_hit();
            EXPECT_EQ(wrong, 0u) << kernel;
        }
        // The queries decide edges and vertices by symbolic perturbation: their brute force.
        const RayQueries queries(scene.triangles, bvh);
        size_t query_differences = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            std::optional<QueryHit> expected;
            for (uint32_t t = 0; t < scene.triangles.size(); ++t) {
                const std::optional<QueryHit> crossing = intersect_triangle_perturbed(rays[i], scene.triangles[t], t);
                if (crossing && (!expected || crossing->t < expected->t)) expected = crossing;
            }
            const std::optional<QueryHit> first = queries.first_hit(rays[i]);
            query_differences += queries.any_hit(rays[i]) != expected.has_value() ||
                                 first.has_value() != expected.has_value() || (first && first->t != expected->t);
        }
        EXPECT_EQ(query_differences, 0u);
    }
}

// The shared leaf packing (LeafPacker): every leaf's lanes hold all its non-degenerate triangles, each
// lane a real triangle of the scene, no leaf's lanes reach past the filled lanes, and sharing packs
// between neighbouring leaves stores fewer packs than one pack per started four triangles.
TEST(Kernels, LeafPackerCoversEveryLeafAndSharesPacks) {
    for (const std::string builder : {"cbvh", "spatial"}) {
        const Scene& scene = cached_builtin_scene("interior");
        const Bvh bvh = spacebvh::build(scene, config_for(builder));
        trace::TrianglePacks packs;
        trace::LeafPacker packer(scene.triangles, bvh, packs);
        std::vector<std::pair<uint32_t, uint32_t>> placed;
        size_t leaves = 0, packs_one_per_leaf = 0;
        for (const BvhNode& node : bvh.nodes) {
            if (!node.is_leaf()) continue;
            ++leaves;
            size_t live = 0;
            for (uint32_t i = node.first; i < node.first + node.reference_count; ++i)
                live += scene.triangles[bvh.primitives[i]].is_degenerate() ? 0 : 1;
            packs_one_per_leaf += (live + 3) / 4;
            const auto [first, count] = packer.add(node);
            ASSERT_EQ(count == 0, live == 0) << builder;
            placed.emplace_back(first, count);
        }
        size_t index = 0;
        for (const BvhNode& node : bvh.nodes) {
            if (!node.is_leaf()) continue;
            const auto [first, count] = placed[index++];
            std::set<uint32_t> lanes;
            for (uint32_t lane = 0; lane < count; ++lane) {
                ASSERT_LT(first + lane / 4, packs.size()) << builder;
                const trace::TrianglePack& pack = packs[first + lane / 4];
                const uint32_t primitive = pack.primitive[lane % 4];
                ASSERT_LT(primitive, scene.triangles.size()) << builder;
                Vec3 vertex[3];
                trace::pack_triangle(pack, int(lane % 4), vertex);
                const Triangle& triangle = scene.triangles[primitive];
                EXPECT_TRUE(vertex[0] == triangle.v0 && vertex[1] == triangle.v1 && vertex[2] == triangle.v2)
                    << builder;
                lanes.insert(primitive);
            }
            for (uint32_t i = node.first; i < node.first + node.reference_count; ++i)
                if (!scene.triangles[bvh.primitives[i]].is_degenerate()) {
                    EXPECT_TRUE(lanes.count(bvh.primitives[i]))
                        << builder << ": leaf misses triangle " << bvh.primitives[i];
                }
        }
        EXPECT_GT(leaves, 100u) << builder;
        EXPECT_LT(packs.size(), packs_one_per_leaf * 9 / 10) << builder << ": packs are not shared";
    }
}

// Packets test a leaf's triangles over eight rays at once when all rays of the packet shear along the
// same axes (the dominant direction component), else ray by ray. Both must give exactly the answers
// of the single-ray kernel: a fan of rays from one origin whose dominant axis is x for some rays and y
// for others (same direction signs, so the packet stays coherent), next to a fan whose rays all have
// x dominant; closest hits compared field by field, occlusion answers, and the arbiter.
TEST(Packets, TrianglesOverRaysMatchTheSingleRayKernel) {
    const Scene& scene = cached_builtin_scene("interior");
    const Bvh bvh = spacebvh::build(scene, config_for("cbvh"));
    const AABB box = scene.bounds();
    const Vec3 origin = box.lo + (box.hi - box.lo) * 0.3f;
    for (const float spread : {0.05f, 0.6f}) {  // 0.6: y overtakes x for part of the fan
        std::vector<Ray> rays;
        for (int i = 0; i < 256; ++i) {
            Ray ray;
            ray.org = origin;
            ray.dir = {1.0f, 0.7f + spread * float(i % 16) / 15.0f, 0.2f + 0.3f * float(i / 16) / 15.0f};
            rays.push_back(ray);
        }
        const std::unique_ptr<Tracer> single = make_tracer("bvh8", scene, bvh);
        std::vector<Hit> expected(rays.size());
        single->intersect(rays, expected);
        std::vector<uint8_t> expected_occluded(rays.size());
        single->occluded(rays, expected_occluded);
        for (uint32_t size : {8u, 64u, 256u}) {
            for (NodeTest test : supported_node_tests(8)) {
                if (test == NodeTest::sse) continue;
                SCOPED_TRACE("spread " + std::to_string(spread) + ", " + std::to_string(size) + " rays per packet, " +
                             to_string(test));
                const Tracer tracer(scene, bvh, TracerConfig{Kernel::packet8, test, WideCollapse::sah_optimal, size});
                std::vector<Hit> hits(rays.size());
                tracer.intersect(rays, hits);
                std::vector<uint8_t> occluded(rays.size());
                tracer.occluded(rays, occluded);
                size_t hit_count = 0;
                for (size_t i = 0; i < rays.size(); ++i) {
                    EXPECT_EQ(hits[i].t, expected[i].t) << i;
                    EXPECT_EQ(hits[i].primitive, expected[i].primitive) << i;
                    EXPECT_EQ(hits[i].u, expected[i].u) << i;
                    EXPECT_EQ(occluded[i], expected_occluded[i]) << i;
                    EXPECT_TRUE(hits_agree(closest_records(tracer, std::span(&rays[i], 1))[0],
                                           arbiter_closest_hit(scene, rays[i]), rays[i], scene.diagonal()))
                        << i;
                    hit_count += hits[i].is_hit();
                }
                EXPECT_GT(hit_count, rays.size() / 2);
            }
        }
    }
}

// Occlusion packets drop each ray once it is blocked and end once all are. A near wall of small
// triangles covers the left half (x < 0) of a far wall; rays go from z = 0 towards +z (one shear axis,
// one direction sign: the packet stays coherent). Packets of: every ray blocked by the near wall
// (the packet must end early), rays blocked by the near wall next to rays that pass it and are
// blocked by the far wall or miss it, the same with the first ray free or blocked (a blocked first
// ray hands its place on), segments that end before either wall, and packets whose rays disagree in
// direction signs. Occlusion answers must equal the
// arbiter's and the single-ray kernel's; closest hits the arbiter's.
TEST(Packets, OcclusionWithRaysBlockedEarlyAndLateMatchesTheArbiter) {
    Scene scene;
    scene.name = "walls";
    const auto add_wall = [&](float x0, float x1, float z, int columns, int rows) {
        for (int i = 0; i < columns; ++i)
            for (int j = 0; j < rows; ++j) {
                const float xa = x0 + (x1 - x0) * float(i) / float(columns),
                            xb = x0 + (x1 - x0) * float(i + 1) / float(columns);
                const float ya = -5.0f + 10.0f * float(j) / float(rows),
                            yb = -5.0f + 10.0f * float(j + 1) / float(rows);
                scene.triangles.push_back({{xa, ya, z}, {xb, ya, z}, {xb, yb, z}});
                scene.triangles.push_back({{xa, ya, z}, {xb, yb, z}, {xa, yb, z}});
            }
    };
    add_wall(-5.0f, 0.0f, 2.0f, 20, 40);   // near wall, left half
    add_wall(-5.0f, 5.0f, 10.0f, 40, 40);  // far wall
    const Bvh bvh = spacebvh::build(scene, config_for("spatial"));

    // 16 x 16 rays per group; `x_of(i, j)` places ray (i, j) of a group.
    std::vector<Ray> rays;
    const auto add_group = [&](auto x_of, float tmax, float dir_x0 = 0.02f, float dir_y0 = 0.05f) {
        for (int j = 0; j < 16; ++j)
            for (int i = 0; i < 16; ++i) {
                Ray ray;
                ray.org = {x_of(i, j), -3.0f + 0.37f * float(j), 0.0f};
                ray.dir = {dir_x0 + 0.01f * float(i), dir_y0 + 0.003f * float(j), 1.0f};
                ray.tmax = tmax;
                rays.push_back(ray);
            }
    };
    add_group([](int i, int) { return -4.5f + 0.2f * float(i); }, kInfinity);  // all blocked by the near wall
    add_group([](int i, int) { return i % 2 ? 0.5f + 0.25f * float(i) : -4.0f + 0.1f * float(i); },
              kInfinity);  // alternate near / far
    add_group([](int i, int j) { return (i + j) % 3 ? -3.0f : 1.0f + 0.3f * float(i); },
              kInfinity);  // first ray blocked late
    add_group([](int i, int j) { return (i + j) % 3 ? 4.0f + 0.1f * float(i) : -2.0f; },
              kInfinity);                                                 // first ray misses the far wall
    add_group([](int i, int) { return -4.5f + 0.6f * float(i); }, 1.5f);  // segments end before both walls
    add_group([](int i, int) { return -4.5f + 0.6f * float(i); }, 5.0f);  // only the near wall is in reach
    // Direction y changes sign within the packets (a tile across the horizon: one packet per sign
    // octant), and also direction x is 0 for a column (those rays cannot join a packet).
    add_group([](int i, int) { return i % 2 ? 0.5f + 0.25f * float(i) : -4.0f + 0.1f * float(i); }, kInfinity, 0.02f,
              -0.02f);
    add_group([](int i, int) { return i % 2 ? 0.5f + 0.25f * float(i) : -4.0f + 0.1f * float(i); }, kInfinity, 0.0f,
              -0.02f);

    std::vector<uint8_t> expected(rays.size());
    make_tracer("bvh8", scene, bvh)->occluded(rays, expected);
    size_t blocked = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        ASSERT_EQ(bool(expected[i]), arbiter_occlusion(scene, rays[i]).is_hit()) << i;
        blocked += expected[i];
    }
    // The groups really mix blocked and free rays: all 256 of the first blocked, none of the fifth.
    EXPECT_EQ(std::count(expected.begin(), expected.begin() + 256, 1), 256);
    EXPECT_EQ(std::count(expected.begin() + 1024, expected.begin() + 1280, 1), 0);
    EXPECT_GT(blocked, rays.size() / 3);
    EXPECT_LT(blocked, rays.size() - rays.size() / 4);

    std::vector<HitRecord> expected_closest(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) expected_closest[i] = arbiter_closest_hit(scene, rays[i]);
    for (uint32_t size : {1u, 8u, 13u, 64u, 256u}) {
        for (NodeTest test : supported_node_tests(8)) {
            if (test == NodeTest::sse) continue;
            SCOPED_TRACE(std::to_string(size) + " rays per packet, " + to_string(test));
            const Tracer tracer(scene, bvh, TracerConfig{Kernel::packet8, test, WideCollapse::sah_optimal, size});
            const auto occlusion = occlusion_records(tracer, rays);
            const auto closest = closest_records(tracer, rays);
            size_t wrong = 0, wrong_closest = 0;
            for (size_t i = 0; i < rays.size(); ++i) {
                wrong += occlusion[i].is_hit() != bool(expected[i]);
                wrong_closest += !hits_agree(closest[i], expected_closest[i], rays[i], scene.diagonal());
            }
            EXPECT_EQ(wrong, 0u);
            EXPECT_EQ(wrong_closest, 0u);
            // A fully blocked packet ends once its rays are blocked: a leaf or two per ray, not the
            // whole wall the frustum spans.
            std::vector<uint8_t> occluded(256);
            TraversalStats stats;
            tracer.occluded(std::span(rays.data(), 256), occluded, &stats);
            EXPECT_EQ(std::count(occluded.begin(), occluded.end(), 1), 256);
            EXPECT_LE(stats.triangles_tested, 256u * 8u);
        }
    }
}

// The single-ray kernels order three or more entered children by sorting integer visit keys
// (trace/traversal/visit_order.hpp): the order must be visits_after's, nearest first and, at equal distances,
// the later slot first (-0 just before +0), for every count the 4- and 8-wide nodes produce.
template <int W>
void check_visit_key_order(std::mt19937& random) {
    const float distances[] = {-2.5f, -0.0f, 0.0f, 1e-30f, 0.5f, 0.5f, 3.0f, 1e30f};
    std::uniform_int_distribution<int> pick(0, 7);
    for (int trial = 0; trial < 2000; ++trial) {
        const int n = 3 + trial % (W - 2);
        std::vector<uint32_t> slots(W);
        std::iota(slots.begin(), slots.end(), 0u);
        std::shuffle(slots.begin(), slots.end(), random);
        slots.resize(size_t(n));
        float entry[W] = {};
        for (uint32_t slot : slots) entry[slot] = distances[pick(random)];
        uint64_t key[W];
        for (int i = 0; i < n; ++i) key[i] = trace::visit_key(entry[slots[size_t(i)]], slots[size_t(i)]);
        trace::sort_visit_keys<W>(key, n);

        std::vector<uint32_t> expected = slots;
        std::sort(expected.begin(), expected.end(), [&](uint32_t a, uint32_t b) {
            if (entry[a] != entry[b]) return entry[a] < entry[b];
            if (std::signbit(entry[a]) != std::signbit(entry[b])) return std::signbit(entry[a]);
            return a > b;
        });
        for (int i = 0; i < n; ++i)
            ASSERT_EQ(trace::visit_key_slot(key[i]), expected[size_t(i)])
                << "W " << W << ", trial " << trial << ", position " << i;
    }
}

TEST(Kernels, VisitKeysSortInTheClosestHitVisitOrder) {
    std::mt19937 random(7);
    check_visit_key_order<4>(random);
    check_visit_key_order<8>(random);
}

// The fused slab constants, made for three axes at once in vector instructions, are bit for bit the
// formula of traversal_common.hpp computed one axis at a time: rays of every magnitude, axis-parallel
// ones (+0 and -0), directions so small that 1/d overflows, and origins at 0 on an axis, whose offsets
// must not be subnormal (every fused test would take them as an operand, in microcode on x86).
TEST(FusedSlabs, AreTheScalarFormulaBitForBit) {
    std::mt19937 random(5);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), exponent(-30.0f, 30.0f);
    auto value = [&] { return unit(random) * std::exp2(exponent(random)); };
    std::vector<Ray> rays;
    for (int i = 0; i < 2000; ++i) rays.push_back({{value(), value(), value()}, {value(), value(), value()}});
    for (float special : {0.0f, -0.0f, 1e-40f, -1e-40f, 3e38f})
        for (int axis = 0; axis < 3; ++axis) {
            Ray ray{{value(), 1e30f, -2.5f}, {value(), value(), value()}};
            ray.dir[axis] = special;
            rays.push_back(ray);
        }
    for (float zero : {0.0f, -0.0f})
        for (int axis = 0; axis < 3; ++axis) {
            Ray ray{{value(), value(), value()}, {value(), value(), value()}};
            ray.org[axis] = zero;
            rays.push_back(ray);
        }
    auto bits = [](float x) { return std::bit_cast<uint32_t>(x); };
    for (const Ray& ray : rays) {
        const trace::FusedSlabs slabs(ray);
        for (int axis = 0; axis < 3; ++axis) {
            const float org = ray.org[axis], inv = 1.0f / ray.dir[axis];
            const float exit_inv = inv * (1.0f + 0x1p-21f);
            const float scaled_org = org * inv, exit_scaled_org = org * exit_inv;
            float entry_scale = 0.0f, exit_scale = 0.0f, entry_offset = kInfinity, exit_offset = -kInfinity;
            if (std::isfinite(exit_inv) && std::isfinite(exit_scaled_org)) {
                entry_scale = inv;
                entry_offset = scaled_org + (std::fabs(scaled_org) * 0x1p-21f + 0x1p-126f);
                exit_scale = exit_inv;
                exit_offset = exit_scaled_org - (std::fabs(exit_scaled_org) * 0x1p-21f + 0x1p-126f);
            }
            if (ray.org[axis] == 0.0f) {
                EXPECT_NE(std::fpclassify(trace::FusedSlabs::lane(slabs.entry_offset, axis)), FP_SUBNORMAL) << axis;
                EXPECT_NE(std::fpclassify(trace::FusedSlabs::lane(slabs.exit_offset, axis)), FP_SUBNORMAL) << axis;
            }
            EXPECT_EQ(bits(trace::FusedSlabs::lane(slabs.entry_scale, axis)), bits(entry_scale)) << axis;
            EXPECT_EQ(bits(trace::FusedSlabs::lane(slabs.entry_offset, axis)), bits(entry_offset)) << axis;
            EXPECT_EQ(bits(trace::FusedSlabs::lane(slabs.exit_scale, axis)), bits(exit_scale)) << axis;
            EXPECT_EQ(bits(trace::FusedSlabs::lane(slabs.exit_offset, axis)), bits(exit_offset)) << axis;
            EXPECT_EQ(((slabs.negative >> axis) & 1u) != 0, std::signbit(inv)) << axis;
        }
    }
}
