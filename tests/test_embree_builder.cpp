// SPDX-License-Identifier: MIT
// Embree's binary trees imported into our Bvh (spacebvh/tools/embree_builder.hpp): structure, the
// reference budget, answers of our tracer over them, and tree quality.
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "spacebvh/tools/embree_builder.hpp"
#include "spacebvh/tools/embree_scene.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tools/verify.hpp"

using namespace spacebvh;
using namespace spacebvh::tools;

namespace {

const char* kScenes[] = {"interior", "interior-rotated", "soup"};
const EmbreeQuality kQualities[] = {EmbreeQuality::medium, EmbreeQuality::high};

BuildConfig embree_options() {
    BuildConfig options;  // max leaf 8, C_T = C_I = 1, the costs Embree's own trees are measured under
    options.limits.reference_budget = 1.2f;
    return options;
}

const Scene& builtin_scene(const std::string& name) { return testing_support::cached_builtin_scene(name); }

// One tree per scene and quality, built once per process (Embree's HIGH build is the slow part).
const Bvh& embree_tree(const std::string& name, EmbreeQuality quality) {
    static std::mutex mutex;
    static std::map<std::string, std::unique_ptr<Bvh>> cache;
    const Scene& scene = builtin_scene(name);
    std::lock_guard lock(mutex);
    auto& slot = cache[name + "/" + to_string(quality)];
    if (!slot) slot = std::make_unique<Bvh>(build_bvh_with_embree(scene, quality, embree_options()));
    return *slot;
}

size_t reference_count(const Bvh& bvh) {
    size_t references = 0;
    for (const BvhNode& node : bvh.nodes) references += node.reference_count;
    return references;
}

// The tree's shape: every node reached exactly once from the root, children stored side by side
// after their parent, leaf ranges partitioning the primitive array, each triangle once per leaf and
// at least once in the tree, boxes containing their children, leaves within the size limit and
// touching each of their triangles. Returns "" or the first problem.
std::string check_structure(const Scene& scene, const Bvh& bvh, uint32_t max_leaf_size, bool split_references) {
    if (bvh.nodes.empty()) return "no nodes";
    std::vector<uint8_t> reached(bvh.nodes.size(), 0), triangle_seen(scene.triangles.size(), 0);
    std::vector<uint32_t> stack{0};
    size_t leaf_entries = 0;
    while (!stack.empty()) {
        const uint32_t index = stack.back();
        stack.pop_back();
        if (index >= bvh.nodes.size()) return "node index " + std::to_string(index) + " out of range";
        if (reached[index]++) return "node " + std::to_string(index) + " reached twice";
        const BvhNode& node = bvh.nodes[index];
        const std::string where = "node " + std::to_string(index);
        if (node.bounds.is_empty()) return where + " has an empty box";
        if (!node.is_leaf()) {
            if (node.first <= index || size_t(node.first) + 1 >= bvh.nodes.size())
                return where + ": children at " + std::to_string(node.first) + " do not follow it";
            for (uint32_t c = node.first; c <= node.first + 1; ++c)
                if (!node.bounds.contains(bvh.nodes[c].bounds))
                    return where + " does not contain child " + std::to_string(c);
            stack.push_back(node.first + 1);
            stack.push_back(node.first);
            continue;
        }
        if (node.reference_count > max_leaf_size)
            return where + " is a leaf of " + std::to_string(node.reference_count) + " > " +
                   std::to_string(max_leaf_size);
        if (size_t(node.first) + node.reference_count > bvh.primitives.size()) return where + ": range out of bounds";
        leaf_entries += node.reference_count;
        for (uint32_t k = node.first; k < node.first + node.reference_count; ++k) {
            const uint32_t id = bvh.primitives[k];
            if (id >= scene.triangles.size()) return where + " lists triangle " + std::to_string(id);
            if (k > node.first && bvh.primitives[k - 1] >= id) return where + " lists a triangle twice (or unsorted)";
            triangle_seen[id] = 1;
            const AABB triangle_box = scene.triangles[id].bounds();
            const bool ok = split_references ? !intersect(node.bounds, triangle_box).is_empty()
                                             : node.bounds.contains(triangle_box);
            if (!ok) return where + " does not hold its triangle " + std::to_string(id);
        }
    }
    for (size_t i = 0; i < reached.size(); ++i)
        if (!reached[i]) return "node " + std::to_string(i) + " unreachable";
    if (leaf_entries != bvh.primitives.size()) return "leaf ranges do not cover the primitive array exactly";
    for (size_t i = 0; i < triangle_seen.size(); ++i)
        if (!triangle_seen[i]) return "triangle " + std::to_string(i) + " unreachable";
    return "";
}

using testing_support::closest_records;
using testing_support::occlusion_records;

}  // namespace

TEST(EmbreeBuilder, TreesAreWellFormed) {
    const BuildConfig options = embree_options();
    for (const char* name : kScenes)
        for (EmbreeQuality quality : kQualities) {
            SCOPED_TRACE(std::string(name) + ", " + to_string(quality));
            const Scene& scene = builtin_scene(name);
            const Bvh& bvh = embree_tree(name, quality);
            EXPECT_EQ(bvh.builder, quality == EmbreeQuality::high ? "embree-high" : "embree-medium");
            EXPECT_EQ(check_structure(scene, bvh, options.limits.max_leaf_size, quality == EmbreeQuality::high), "");
            const size_t references = reference_count(bvh);
            EXPECT_GE(references, scene.triangles.size());
            if (quality == EmbreeQuality::medium) {
                EXPECT_EQ(references, scene.triangles.size());
            }
            std::printf("[ info ] %s embree-%s: %zu triangles, %zu nodes, %zu references, SAH %.3f\n", name,
                        to_string(quality), scene.triangles.size(), bvh.nodes.size(), references,
                        tree_sah(bvh, options.cost));
        }
}

TEST(EmbreeBuilder, HighSplitsWithinTheReferenceBudget) {
    const BuildConfig options = embree_options();
    for (const char* name : kScenes) {
        SCOPED_TRACE(name);
        const size_t triangles = builtin_scene(name).triangles.size();
        const size_t budget = size_t(double(options.limits.reference_budget) * double(triangles));
        EXPECT_LE(reference_count(embree_tree(name, EmbreeQuality::high)), budget);
    }
    // The rotated interior is full of long diagonal triangles: Embree does split there.
    EXPECT_GT(reference_count(embree_tree("interior-rotated", EmbreeQuality::high)),
              builtin_scene("interior-rotated").triangles.size());

    // A bigger budget is honoured too (and a budget of 1 allows no split at all).
    const Scene& rotated = builtin_scene("interior-rotated");
    BuildConfig tight = options;
    tight.limits.reference_budget = 1.0f;
    const Bvh unsplit = build_bvh_with_embree(rotated, EmbreeQuality::high, tight);
    EXPECT_EQ(reference_count(unsplit), rotated.triangles.size());
    EXPECT_EQ(check_structure(rotated, unsplit, tight.limits.max_leaf_size, true), "");
}

TEST(EmbreeBuilder, OurTracerOverEmbreeTreesAgreesWithEmbree) {
    for (const char* name : kScenes) {
        const Scene& scene = builtin_scene(name);
        const std::vector<Ray> rays = generate_random_rays(scene.bounds(), 10000, 1);
        for (EmbreeQuality quality : kQualities) {
            SCOPED_TRACE(std::string(name) + ", " + to_string(quality));
            const Tracer tracer(scene, embree_tree(name, quality), Kernel::binary);
            const EmbreeScene embree(scene, quality);
            std::vector<Hit> hits(rays.size());
            std::vector<uint8_t> occluded(rays.size());
            embree.intersect(rays, hits);
            embree.occluded(rays, occluded);
            std::vector<HitRecord> embree_closest(rays.size()), embree_occlusion(rays.size());
            size_t hit_count = 0;
            for (size_t i = 0; i < rays.size(); ++i) {
                embree_closest[i] = to_record(hits[i]);
                embree_occlusion[i] = occlusion_record(occluded[i]);
                hit_count += hits[i].is_hit();
            }
            EXPECT_GT(hit_count, rays.size() / 10);

            const VerificationReport closest =
                verify_against_reference(scene, rays, closest_records(tracer, rays), embree_closest, false);
            const VerificationReport occlusion =
                verify_against_reference(scene, rays, occlusion_records(tracer, rays), embree_occlusion, true);
            EXPECT_EQ(closest.ours_wrong, 0u)
                << "closest hit; first wrong ray " << (closest.wrong_rays.empty() ? 0 : closest.wrong_rays.front());
            EXPECT_EQ(occlusion.ours_wrong, 0u)
                << "occlusion; first wrong ray " << (occlusion.wrong_rays.empty() ? 0 : occlusion.wrong_rays.front());
            if (closest.reference_wrong + occlusion.reference_wrong > 0)
                std::printf("[ info ] %s %s: Embree wrong on %zu closest, %zu occlusion of %zu rays\n", name,
                            to_string(quality), closest.reference_wrong, occlusion.reference_wrong, rays.size());
        }
    }
}

TEST(EmbreeBuilder, SpatialSplitsLowerTheSahOnTheRotatedInterior) {
    const CostModel cost = embree_options().cost;
    const double medium = tree_sah(embree_tree("interior-rotated", EmbreeQuality::medium), cost);
    const double high = tree_sah(embree_tree("interior-rotated", EmbreeQuality::high), cost);
    EXPECT_LE(high, medium);
}

TEST(EmbreeBuilder, OptionsAndErrors) {
    const Scene& scene = builtin_scene("soup");
    BuildConfig options = embree_options();

    // Leaf size and costs reach Embree: leaves of at most 2, and the cost model is recorded.
    options.limits.max_leaf_size = 2;
    options.cost.traversal_cost = 1.5f;
    double last_progress = -1.0;
    size_t progress_calls = 0;
    std::mutex mutex;
    options.hooks.progress = [&](double f) {
        std::lock_guard lock(mutex);
        ++progress_calls;
        last_progress = f;
    };
    const Bvh small_leaves = build_bvh_with_embree(scene, EmbreeQuality::high, options);
    EXPECT_EQ(check_structure(scene, small_leaves, 2, true), "");
    EXPECT_EQ(small_leaves.cost.traversal_cost, 1.5f);
    EXPECT_GT(progress_calls, 0u);
    EXPECT_EQ(last_progress, 1.0);

    // An exception thrown by the progress callback cancels the build and comes back out.
    BuildConfig throwing = embree_options();
    throwing.hooks.progress = [](double) { throw std::runtime_error("stop"); };
    EXPECT_THROW(build_bvh_with_embree(scene, EmbreeQuality::medium, throwing), std::runtime_error);

    // The builder still works after a cancelled build.
    EXPECT_EQ(check_structure(scene, build_bvh_with_embree(scene, EmbreeQuality::medium, embree_options()),
                              embree_options().limits.max_leaf_size, false),
              "");

    Scene empty;
    empty.name = "empty";
    EXPECT_THROW(build_bvh_with_embree(empty, EmbreeQuality::medium, embree_options()), Error);
    EXPECT_THROW(build_bvh_with_embree(scene, EmbreeQuality::low, embree_options()), Error);
    BuildConfig too_big = embree_options();
    too_big.limits.max_leaf_size = 33;
    EXPECT_THROW(build_bvh_with_embree(scene, EmbreeQuality::medium, too_big), Error);
    BuildConfig bad_budget = embree_options();
    bad_budget.limits.reference_budget = 0.5f;
    EXPECT_THROW(build_bvh_with_embree(scene, EmbreeQuality::high, bad_budget), Error);

    // A tiny scene: one triangle is a leaf root.
    Scene one;
    one.name = "one";
    one.triangles.push_back({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
    const Bvh single = build_bvh_with_embree(one, EmbreeQuality::high, embree_options());
    ASSERT_EQ(single.nodes.size(), 1u);
    EXPECT_TRUE(single.root().is_leaf());
    EXPECT_EQ(single.primitives, std::vector<uint32_t>{0});
}
