// SPDX-License-Identifier: MIT
// Quantized 8-wide nodes (quantized_layout.hpp) and the bvh8q kernels over them: every decoded child
// box contains the exact float child box (boxes at every scale, far from the grid's origin, flat,
// points, near the float range's ends), empty slots are never marked used, and the kernels answer
// as the exact arbiter on scenes that stress the grid: flat, huge, tiny, far from the world's origin,
// small objects far apart; on random rays and on rays aimed at vertices and along edges.
// (test_kernels.cpp and test_tracer.cpp run the bvh8q kernels through their tests too: they take
// every kernel name.)
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene.hpp"
#include "spacebvh/tools/verify.hpp"
#include "spacebvh/trace.hpp"
#include "test_support.hpp"
#include "trace/layout/quantized_layout.hpp"
#include "trace/traversal/traversal_common.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;

namespace {

// A float node of `boxes` (at most 8; the other slots empty, as the collapse leaves them).
trace::WideNode<8> node_of(const std::vector<AABB>& boxes) {
    trace::WideNode<8> node;
    for (int slot = 0; slot < 8; ++slot) {
        const AABB box = slot < int(boxes.size()) ? boxes[slot] : AABB::empty();
        for (int axis = 0; axis < 3; ++axis) {
            node.planes[2 * axis][slot] = box.lo[axis];
            node.planes[2 * axis + 1][slot] = box.hi[axis];
        }
        node.child[slot] = uint32_t(100 + slot);
        node.count[slot] = uint32_t(slot % 3);
    }
    return node;
}

// Checks the encoder's invariant on one node: used slots as in the float node, every decoded box
// contains its child box, child and count kept. Returns the largest decoded slack on any plane in
// units of the node's grid cell, or of the float spacing at the plane where that is coarser (how
// loose the rounding is).
double check_node(const std::vector<AABB>& boxes) {
    const trace::WideNode<8> node = node_of(boxes);
    const trace::QuantizedNode8 q = trace::quantize_node(node);
    double slack = 0;
    for (int slot = 0; slot < 8; ++slot) {
        EXPECT_EQ(q.used(slot), node.used(slot)) << slot;
        if (!node.used(slot)) continue;
        EXPECT_EQ(q.child[slot], node.child[slot]);
        EXPECT_EQ(q.count[slot], node.count[slot]);
        const AABB decoded = trace::decoded_box(q, slot);
        for (int axis = 0; axis < 3; ++axis) {
            const float lo = node.planes[2 * axis][slot], hi = node.planes[2 * axis + 1][slot];
            EXPECT_LE(decoded.lo[axis], lo) << "slot " << slot << " axis " << axis;
            EXPECT_GE(decoded.hi[axis], hi) << "slot " << slot << " axis " << axis;
            EXPECT_GT(q.scale[axis], 0.0f);
            const float magnitude = std::max(std::fabs(lo), std::fabs(hi));
            const double unit =
                std::max(double(q.scale[axis]),
                         double(std::nextafter(magnitude, std::numeric_limits<float>::infinity()) - magnitude));
            if (std::isfinite(decoded.hi[axis]))
                slack = std::max({slack, (double(lo) - double(decoded.lo[axis])) / unit,
                                  (double(decoded.hi[axis]) - double(hi)) / unit});
        }
    }
    return slack;
}

AABB box(Vec3 lo, Vec3 hi) { return {lo, hi}; }

}  // namespace

// Random nodes at every scale and offset: centres from 0 to 1e30 away from the world's origin,
// children from 1e-30 to 1e30 across, some of them flat or points; every decoded box contains its
// child box, and the rounding stays within a grid cell or two of the box where nothing overflows.
TEST(QuantizedNodes, DecodedBoxesContainTheirChildBoxes) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_int_distribution<int> exponent(-30, 30), children(1, 8), kind(0, 5);
    double worst = 0;
    for (int n = 0; n < 20000; ++n) {
        const float centre_scale = std::pow(10.0f, float(exponent(rng))), size = std::pow(10.0f, float(exponent(rng)));
        const Vec3 centre{unit(rng) * centre_scale, unit(rng) * centre_scale, unit(rng) * centre_scale};
        std::vector<AABB> boxes;
        const int count = children(rng);
        for (int c = 0; c < count; ++c) {
            Vec3 lo, hi;
            for (int axis = 0; axis < 3; ++axis) {
                const float a = centre[axis] + unit(rng) * size, b = centre[axis] + unit(rng) * size;
                lo[axis] = std::min(a, b);
                hi[axis] = std::max(a, b);
            }
            const int k = kind(rng);
            if (k == 0) hi.z = lo.z;  // flat on z
            if (k == 1) hi = lo;      // a point
            if (k == 2) {             // a child far smaller than its siblings
                hi = lo;
                hi.x = std::nextafter(lo.x, std::numeric_limits<float>::infinity());
            }
            boxes.push_back(box(lo, hi));
        }
        worst = std::max(worst, check_node(boxes));
    }
    // Codes are the tightest on the grid: at most one cell (plus the rounding of the decode) out.
    EXPECT_LE(worst, 2.0);
}

// The degenerate grids: all children one point, all flat on one axis, children near the ends of the
// float range and around zero, subnormal coordinates, one tiny child far from its siblings.
TEST(QuantizedNodes, DegenerateGridsStillContainTheirBoxes) {
    const float big = std::numeric_limits<float>::max(), tiny = std::numeric_limits<float>::denorm_min();
    check_node({box({1, 2, 3}, {1, 2, 3})});
    check_node({box({1, 2, 3}, {1, 2, 3}), box({1, 2, 3}, {1, 2, 3})});
    check_node({box({0, 0, 5}, {1, 1, 5}), box({2, 2, 5}, {3, 3, 5})});
    check_node({box({-big, -big, -big}, {big, big, big}), box({0, 0, 0}, {tiny, tiny, tiny})});
    check_node({box({-big, 1, 1}, {-big, 2, 2}), box({big, 1, 1}, {big, 2, 2})});
    check_node({box({big, big, big}, {big, big, big})});
    check_node({box({-tiny, -tiny, -tiny}, {tiny, tiny, tiny}), box({0, 0, 0}, {0, 0, 0})});
    check_node({box({1e-40f, 2e-40f, 3e-40f}, {4e-40f, 5e-40f, 6e-40f})});
    check_node({box({1e7f, 1e7f, 1e7f}, {1e7f + 1, 1e7f + 1, 1e7f + 1}), box({-1e7f, 0, 0}, {-1e7f, 0, 0})});
    check_node({box({0, 0, 0}, {1, 1, 1}), box({1e5f, 1e5f, 1e5f}, {1e5f + 1e-3f, 1e5f + 1e-3f, 1e5f + 1e-3f})});
    check_node({box({-0.0f, -0.0f, -0.0f}, {0.0f, 0.0f, 0.0f})});
    // No child at all (the root of an empty scene): nothing used.
    const trace::QuantizedNode8 empty = trace::quantize_node(node_of({}));
    EXPECT_EQ(empty.used_mask, 0u);
}

// A leaf count beyond 16 bits is refused rather than truncated.
TEST(QuantizedNodes, RefusesLeafCountsBeyondSixteenBits) {
    trace::WideNode<8> node = node_of({box({0, 0, 0}, {1, 1, 1})});
    node.count[0] = 70000;
    EXPECT_THROW(trace::quantize_node(node), Error);
}

namespace {

// Rays of a scene that graze its geometry, `count` of each kind: random rays, rays from random points
// aimed exactly at vertices and at edge midpoints, rays along edges from beyond one end, and
// axis-parallel rays through vertices.
std::vector<Ray> grazing_rays(const Scene& scene, uint64_t seed, int count) {
    std::vector<Ray> rays = generate_random_rays(scene.bounds(), size_t(count), seed);
    std::mt19937 rng{uint32_t(seed)};
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    const AABB bounds = scene.bounds();
    const Vec3 extent = bounds.extent();
    auto random_point = [&] {
        return Vec3{bounds.lo.x - extent.x * 0.25f + extent.x * 1.5f * unit(rng),
                    bounds.lo.y - extent.y * 0.25f + extent.y * 1.5f * unit(rng),
                    bounds.lo.z - extent.z * 0.25f + extent.z * 1.5f * unit(rng)};
    };
    std::uniform_int_distribution<size_t> pick(0, scene.triangles.size() - 1);
    for (int i = 0; i < count; ++i) {
        const Triangle& t = scene.triangles[pick(rng)];
        const Vec3 corners[3] = {t.v0, t.v1, t.v2};
        const Vec3 a = corners[i % 3], b = corners[(i + 1) % 3];
        Ray ray;
        ray.org = random_point();
        ray.dir = (i % 2 ? a : (a + b) * 0.5f) - ray.org;
        if (ray.dir != Vec3(0.0f)) rays.push_back(ray);
        Ray along;
        along.org = a + (a - b);  // on the edge's line, beyond a
        along.dir = b - a;
        if (along.dir != Vec3(0.0f)) rays.push_back(along);
        Ray axis;
        axis.org = a;
        axis.org[i % 3] = bounds.lo[i % 3] - extent[i % 3];
        axis.dir = Vec3(0.0f);
        axis.dir[i % 3] = 1.0f;
        rays.push_back(axis);
    }
    return rays;
}

// Every bvh8q kernel against the binary reference kernel, every disagreement settled by the exact
// arbiter (closest hit and occlusion; batches, and single-ray calls against the batch): a description
// of the wrong answers.
std::string disagreements(const Scene& scene, uint64_t seed, int count = 300) {
    const Bvh bvh = spacebvh::build(scene, config_for("spatial"));
    const std::vector<Ray> rays = grazing_rays(scene, seed, count);
    const Tracer reference(scene, bvh, Kernel::binary);
    const std::vector<HitRecord> reference_closest = testing_support::closest_records(reference, rays);
    const std::vector<HitRecord> reference_occlusion = testing_support::occlusion_records(reference, rays);
    std::vector<std::string> kernels;
    for (const std::string& name : kernel_names())  // each node test once: the aliases left out
        if (name.rfind("bvh8q-", 0) == 0) kernels.push_back(name);
    EXPECT_GE(kernels.size(), 2u);
    std::string text;
    for (const std::string& kernel : kernels) {
        const std::unique_ptr<Tracer> tracer = make_tracer(kernel, scene, bvh);
        const std::vector<HitRecord> closest = testing_support::closest_records(*tracer, rays);
        const std::vector<HitRecord> occlusion = testing_support::occlusion_records(*tracer, rays);
        const VerificationReport c = verify_against_reference(scene, rays, closest, reference_closest, false);
        const VerificationReport o = verify_against_reference(scene, rays, occlusion, reference_occlusion, true);
        size_t single_differences = 0;
        for (size_t i = 0; i < rays.size(); i += 7) {
            const HitRecord single = to_record(tracer->intersect(rays[i]));
            single_differences += single.t != closest[i].t || single.primitive != closest[i].primitive ||
                                  tracer->occluded(rays[i]) != occlusion[i].is_hit();
        }
        if (c.ours_wrong + c.reference_wrong + o.ours_wrong + o.reference_wrong + single_differences)
            text += " " + kernel + ": " + std::to_string(c.ours_wrong) + " closest, " + std::to_string(o.ours_wrong) +
                    " occlusion wrong (reference " + std::to_string(c.reference_wrong + o.reference_wrong) + "), " +
                    std::to_string(single_differences) + " single-ray calls unlike the batch;";
    }
    return text;
}

Scene transformed(const std::string& name, float scale, Vec3 translate) {
    SceneTransform transform;
    transform.scale = scale;
    transform.translate = translate;
    return load_scene("builtin:" + name, transform);
}

}  // namespace

TEST(QuantizedKernels, AnswerAsTheArbiterOnBuiltinScenes) {
    for (const std::string& name : builtin_scene_names())
        EXPECT_EQ(disagreements(load_scene("builtin:" + name), 3), "") << name;
}

TEST(QuantizedKernels, AnswerAsTheArbiterOnHugeTinyAndFarScenes) {
    EXPECT_EQ(disagreements(transformed("interior", 1e15f, Vec3(0.0f)), 5), "") << "huge";
    EXPECT_EQ(disagreements(transformed("interior", 1e-9f, Vec3(0.0f)), 6), "") << "tiny";
    EXPECT_EQ(disagreements(transformed("organic", 1.0f, {3e4f, -2e4f, 1e4f}), 7), "") << "far from the origin";
    EXPECT_EQ(disagreements(transformed("interior-rotated", 1e-3f, {-700.0f, 50.0f, 1e3f}), 8), "") << "small and far";
}

// A flat scene (every box zero-extent on z) and small clusters far apart (each node's grid spans
// distant children, whose boxes round out to whole cells of it).
TEST(QuantizedKernels, AnswerAsTheArbiterOnFlatAndScatteredScenes) {
    Scene flat;
    flat.name = "flat";
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (int i = 0; i < 1000; ++i) {
        const Vec3 p{unit(rng) * 100, unit(rng) * 100, 0.0f};
        flat.triangles.push_back({p, p + Vec3(unit(rng), 0.0f, 0.0f), p + Vec3(0.0f, unit(rng), 0.0f)});
    }
    EXPECT_EQ(disagreements(flat, 9, 100), "") << "flat";

    Scene scattered;
    scattered.name = "scattered";
    const Scene organic = load_scene("builtin:organic");
    for (const Vec3 offset : {Vec3(0.0f), Vec3(1e5f, 0.0f, 0.0f), Vec3(0.0f, -3e5f, 2e3f), Vec3(7e4f, 7e4f, 7e4f)})
        for (size_t i = 0; i < organic.triangles.size(); i += 4) {
            const Triangle& t = organic.triangles[i];
            scattered.triangles.push_back({t.v0 * 0.01f + offset, t.v1 * 0.01f + offset, t.v2 * 0.01f + offset});
        }
    EXPECT_EQ(disagreements(scattered, 10, 100), "") << "scattered";
}

// The layout's figures: half the node bytes of bvh8 on the same tree, the same node count and leaves.
TEST(QuantizedKernels, HalveTheNodeBytes) {
    const Scene scene = load_scene("builtin:interior");
    const Bvh bvh = spacebvh::build(scene, config_for("spatial"));
    const std::unique_ptr<Tracer> full = make_tracer("bvh8", scene, bvh), quantized = make_tracer("bvh8q", scene, bvh);
    EXPECT_EQ(full->node_count(), quantized->node_count());
    EXPECT_EQ(full->memory_bytes() - quantized->memory_bytes(), full->node_count() * 128);
    EXPECT_EQ(quantized->config().node_format, NodeFormat::quantized);
    EXPECT_EQ(make_tracer("bvh8q-avx2+moller@area", scene, bvh)->config().collapse, WideCollapse::largest_area);
    EXPECT_THROW(make_tracer("bvh4q", scene, bvh), Error);
    EXPECT_THROW(Tracer(scene, bvh,
                        TracerConfig{Kernel::bvh4, NodeTest::best, WideCollapse::sah_optimal, 0, LeafTest::watertight,
                                     NodeFormat::quantized}),
                 Error);
    EXPECT_THROW(Tracer(scene, bvh,
                        TracerConfig{Kernel::packet8, NodeTest::best, WideCollapse::sah_optimal, 0,
                                     LeafTest::watertight, NodeFormat::quantized}),
                 Error);
}
