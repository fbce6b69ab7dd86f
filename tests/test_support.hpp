// SPDX-License-Identifier: MIT
// Helpers shared by the test files: our answers as hit-file records, ready for verify_against_reference;
// tree invariants; answers against the exact arbiter; byte-wise tree comparison and builds with a
// given thread count.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <functional>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "builders/driver/reference.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/clip.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tools/verify.hpp"

namespace spacebvh::testing_support {

using namespace spacebvh::tools;

// `builtin:NAME`, loaded once per test process (thread-safe).
inline const Scene& cached_builtin_scene(const std::string& name) {
    static std::mutex mutex;
    static std::map<std::string, std::unique_ptr<Scene>> cache;
    std::lock_guard lock(mutex);
    auto& slot = cache[name];
    if (!slot) slot = std::make_unique<Scene>(load_scene("builtin:" + name));
    return *slot;
}

// The first `count` triangles of the soup: big enough for the parallel build paths, quick to build.
inline Scene soup_prefix(size_t count) {
    Scene scene = cached_builtin_scene("soup");
    scene.triangles.resize(count);
    scene.name = "soup_" + std::to_string(count);
    return scene;
}

// Two unit squares at z = 0 (triangles 0, 1) and z = -1 (triangles 2, 3).
inline Scene two_floors() {
    Scene scene;
    scene.name = "two_floors";
    for (float z : {0.0f, -1.0f}) {
        scene.triangles.push_back({{0, 0, z}, {1, 0, z}, {1, 1, z}});
        scene.triangles.push_back({{0, 0, z}, {1, 1, z}, {0, 1, z}});
    }
    return scene;
}

// A node for testing split finders directly: its triangles, one reference per triangle (whole box),
// and their summary.
struct SmallNode {
    std::vector<Triangle> triangles;
    std::vector<builders::Reference> references;
    builders::ReferenceSummary summary;
};
inline SmallNode small_node(std::vector<Triangle> triangles) {
    SmallNode node;
    node.triangles = std::move(triangles);
    for (uint32_t i = 0; i < node.triangles.size(); ++i) node.references.push_back({node.triangles[i].bounds(), i});
    node.summary = builders::summarize(node.references);
    return node;
}

inline std::vector<HitRecord> closest_records(const Tracer& tracer, std::span<const Ray> rays) {
    std::vector<Hit> hits(rays.size());
    tracer.intersect(rays, hits);
    std::vector<HitRecord> records(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) records[i] = to_record(hits[i]);
    return records;
}

inline std::vector<HitRecord> occlusion_records(const Tracer& tracer, std::span<const Ray> rays) {
    std::vector<uint8_t> occluded(rays.size());
    tracer.occluded(rays, occluded);
    std::vector<HitRecord> records(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) records[i] = occlusion_record(occluded[i]);
    return records;
}

// ---------------------------------------------------------------------------------------------------
// Tree invariants.

// Object-partitioning builders put every triangle in exactly one leaf with its whole box; the others
// (spatial splits) may clip a triangle into several leaves.
inline bool partitions_objects(const std::string& builder) { return builder == "cbvh" || builder == "binned"; }

// Checks the structure of a built tree: every node reachable exactly once, children after their
// parent, boxes containing their children, leaves listing the primitives array in order without gaps
// and each triangle at most once, nodes = 2 * leaves - 1, depth <= max_depth, leaves no larger than
// max_leaf_size unless at max_depth, references within the budget, and every triangle in some leaf.
// Object partitioning: each triangle in exactly one leaf whose box contains the triangle's box.
// Spatial splits: each leaf box touches its triangles, and each vertex of a triangle lies in the box
// of a leaf that lists it. Returns "" when all hold, else a description of the first violations.
inline std::string tree_violations(const Scene& scene, const Bvh& bvh, const BuildConfig& options,
                                   uint32_t* depth_out = nullptr) {
    std::ostringstream problems;
    int reported = 0;
    auto problem = [&](const std::string& text) {
        if (reported++ < 8) problems << text << "; ";
    };
    if (bvh.nodes.empty()) return "no nodes";
    const bool strict = partitions_objects(to_string(options.preset));
    std::vector<uint8_t> reached(bvh.nodes.size(), 0);
    std::vector<uint32_t> seen(scene.triangles.size(), 0);
    std::vector<uint8_t> vertex_covered(scene.triangles.size(), 0);  // bit i: vertex i in a listing leaf's box
    size_t leaves = 0, next_primitive = 0;
    uint32_t max_depth = 0;
    // Depth-first, left child first: the order the builder emits nodes and leaf primitives in.
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};
    while (!stack.empty()) {
        const auto [index, depth] = stack.back();
        stack.pop_back();
        if (index >= bvh.nodes.size()) {
            problem("node index " + std::to_string(index) + " out of range");
            continue;
        }
        if (reached[index]++) {
            problem("node " + std::to_string(index) + " reached twice");
            continue;
        }
        max_depth = std::max(max_depth, depth);
        const BvhNode& node = bvh.nodes[index];
        if (node.bounds.is_empty()) problem("node " + std::to_string(index) + " has an empty box");
        if (!node.is_leaf()) {
            if (node.first <= index || size_t(node.first) + 1 >= bvh.nodes.size()) {
                problem("inner node " + std::to_string(index) + " has children at " + std::to_string(node.first));
                continue;
            }
            for (uint32_t c = node.first; c < node.first + 2; ++c)
                if (!node.bounds.contains(bvh.nodes[c].bounds))
                    problem("node " + std::to_string(index) + " does not contain its child " + std::to_string(c));
            stack.push_back({node.first + 1, depth + 1});  // right pushed first: left is visited first
            stack.push_back({node.first, depth + 1});
            continue;
        }
        ++leaves;
        if (node.first != next_primitive)
            problem("leaf " + std::to_string(index) + " starts at " + std::to_string(node.first) + ", expected " +
                    std::to_string(next_primitive));
        next_primitive = size_t(node.first) + node.reference_count;
        if (next_primitive > bvh.primitives.size()) {
            problem("leaf " + std::to_string(index) + " runs past the primitives array");
            continue;
        }
        if (node.reference_count > options.limits.max_leaf_size && depth < options.limits.max_depth)
            problem("leaf " + std::to_string(index) + " holds " + std::to_string(node.reference_count) +
                    " references at depth " + std::to_string(depth));
        std::vector<uint32_t> listed(bvh.primitives.begin() + node.first, bvh.primitives.begin() + next_primitive);
        std::sort(listed.begin(), listed.end());
        if (std::adjacent_find(listed.begin(), listed.end()) != listed.end())
            problem("leaf " + std::to_string(index) + " lists a triangle twice");
        for (const uint32_t primitive : listed) {
            if (primitive >= scene.triangles.size()) {
                problem("primitive " + std::to_string(primitive) + " out of range");
                continue;
            }
            ++seen[primitive];
            const Triangle& triangle = scene.triangles[primitive];
            if (strict) {
                if (!node.bounds.contains(triangle.bounds()))
                    problem("leaf " + std::to_string(index) + " does not contain triangle " +
                            std::to_string(primitive));
            } else if (clip_triangle_bounds(triangle, node.bounds).is_empty()) {
                problem("leaf " + std::to_string(index) + " box misses its triangle " + std::to_string(primitive));
            }
            for (int v = 0; v < 3; ++v)
                if (node.bounds.contains(triangle.vertex(v))) vertex_covered[primitive] |= uint8_t(1u << v);
        }
    }
    if (max_depth > options.limits.max_depth)
        problem("depth " + std::to_string(max_depth) + " exceeds max_depth " +
                std::to_string(options.limits.max_depth));
    for (size_t i = 0; i < reached.size(); ++i)
        if (!reached[i]) {
            problem("node " + std::to_string(i) + " unreachable");
            break;
        }
    if (next_primitive != bvh.primitives.size())
        problem("leaves cover " + std::to_string(next_primitive) + " of " + std::to_string(bvh.primitives.size()) +
                " primitive entries");
    const size_t budget = strict ? scene.triangles.size()
                                 : std::max(scene.triangles.size(), size_t(double(options.limits.reference_budget) *
                                                                           double(scene.triangles.size())));
    if (bvh.primitives.size() > budget)
        problem(std::to_string(bvh.primitives.size()) + " references exceed the budget of " + std::to_string(budget));
    for (size_t i = 0; i < seen.size(); ++i) {
        if (seen[i] == 0 || (strict && seen[i] != 1)) {
            problem("triangle " + std::to_string(i) + " appears in " + std::to_string(seen[i]) + " leaves");
            break;
        }
        if (vertex_covered[i] != 7) {
            problem("a vertex of triangle " + std::to_string(i) + " lies in no leaf box that lists it");
            break;
        }
    }
    if (bvh.nodes.size() != 2 * leaves - 1)
        problem(std::to_string(bvh.nodes.size()) + " nodes for " + std::to_string(leaves) + " leaves");
    if (depth_out) *depth_out = max_depth;
    return problems.str();
}

// A preset's options; "NAME+opt" adds the reinsertion optimisation with the CLI's default effort.
inline BuildConfig options_for_tree(const std::string& name) {
    constexpr std::string_view kSuffix = "+opt";
    if (!name.ends_with(kSuffix)) return config_for(name);
    BuildConfig options = config_for(name.substr(0, name.size() - kSuffix.size()));
    options.reinsertion.iterations = kDefaultReinsertionIterations;
    return options;
}

// ---------------------------------------------------------------------------------------------------
// Answers against the exact arbiter.

// Brute-force truth for a few rays, in parallel.
inline void arbiter_records(const Scene& scene, std::span<const Ray> rays, std::vector<HitRecord>& closest,
                            std::vector<HitRecord>& occlusion) {
    closest.assign(rays.size(), {});
    occlusion.assign(rays.size(), {});
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 8), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
            closest[i] = arbiter_closest_hit(scene, rays[i]);
            occlusion[i] = arbiter_occlusion(scene, rays[i]);
        }
    });
}

// Counts our answers that disagree with the arbiter's, listing a few.
inline std::string wrong_against_arbiter(const Scene& scene, const Tracer& tracer, std::span<const Ray> rays) {
    std::vector<HitRecord> truth_closest, truth_occlusion;
    arbiter_records(scene, rays, truth_closest, truth_occlusion);
    const std::vector<HitRecord> ours_closest = closest_records(tracer, rays);
    const std::vector<HitRecord> ours_occlusion = occlusion_records(tracer, rays);
    const float diagonal = scene.diagonal();
    size_t wrong = 0;
    std::ostringstream text;
    for (size_t i = 0; i < rays.size(); ++i) {
        const bool closest_ok = hits_agree(ours_closest[i], truth_closest[i], rays[i], diagonal);
        const bool occlusion_ok = ours_occlusion[i].is_hit() == truth_occlusion[i].is_hit();
        if (closest_ok && occlusion_ok) continue;
        if (wrong++ < 5)
            text << "ray " << i << ": ours t=" << ours_closest[i].t << " prim=" << ours_closest[i].primitive
                 << " occluded=" << ours_occlusion[i].is_hit() << ", arbiter t=" << truth_closest[i].t
                 << " prim=" << truth_closest[i].primitive << " occluded=" << truth_occlusion[i].is_hit() << "; ";
    }
    if (wrong == 0) return "";
    return std::to_string(wrong) + " of " + std::to_string(rays.size()) + " rays wrong: " + text.str();
}

// Rays for small hand-made scenes: random rays plus rays aimed exactly at vertices and edge midpoints.
inline std::vector<Ray> probing_rays(const Scene& scene, size_t random_count, uint64_t seed) {
    AABB bounds = scene.bounds();
    // Random origins in a box a little larger than the scene, so that rays also come from outside.
    const Vec3 pad = bounds.extent() * 0.25f + Vec3(0.01f);
    bounds = {bounds.lo - pad, bounds.hi + pad};
    std::vector<Ray> rays = generate_random_rays(bounds, random_count, seed);
    SplitMix64 rng(seed * 7919 + 1);
    const size_t aimed = std::min<size_t>(scene.triangles.size(), 400);
    for (size_t k = 0; k < aimed; ++k) {
        const Triangle& t = scene.triangles[(k * 7919) % scene.triangles.size()];
        for (const Vec3 target : {t.v0, t.v1, (t.v1 + t.v2) * 0.5f, (t.v0 + t.v1 + t.v2) * (1.0f / 3.0f)}) {
            Ray ray;
            ray.org = {bounds.lo.x + rng.uniform() * (bounds.hi.x - bounds.lo.x),
                       bounds.lo.y + rng.uniform() * (bounds.hi.y - bounds.lo.y),
                       bounds.lo.z + rng.uniform() * (bounds.hi.z - bounds.lo.z)};
            ray.dir = target - ray.org;
            if (ray.dir == Vec3(0.0f)) continue;
            rays.push_back(ray);
        }
    }
    return rays;
}

// BuildConfig::progress reports, collected from any thread.
struct ProgressLog {
    std::mutex mutex;
    std::vector<double> reports;
    std::function<void(double)> callback() {
        return [this](double fraction) {
            std::lock_guard lock(mutex);
            reports.push_back(fraction);
        };
    }
    // "" when there were reports, all in [0, 1], the last one 1; else what is wrong.
    std::string problems() const {
        if (reports.empty()) return "no progress reports";
        for (double fraction : reports)
            if (!(fraction >= 0.0 && fraction <= 1.0))
                return "fraction " + std::to_string(fraction) + " outside [0, 1]";
        if (reports.back() != 1.0) return "the last report is " + std::to_string(reports.back()) + ", not 1";
        return "";
    }
};

// ---------------------------------------------------------------------------------------------------
// Determinism.

// "" when the trees are the same byte for byte, else where they first differ.
inline std::string first_difference(const Bvh& a, const Bvh& b) {
    if (a.nodes.size() != b.nodes.size())
        return "node counts " + std::to_string(a.nodes.size()) + " vs " + std::to_string(b.nodes.size());
    if (a.primitives.size() != b.primitives.size())
        return "primitive counts " + std::to_string(a.primitives.size()) + " vs " + std::to_string(b.primitives.size());
    static_assert(sizeof(BvhNode) == 32, "BvhNode is compared byte for byte");
    for (size_t i = 0; i < a.nodes.size(); ++i)
        if (std::memcmp(&a.nodes[i], &b.nodes[i], sizeof(BvhNode)) != 0)
            return "node " + std::to_string(i) + " differs";
    if (std::memcmp(a.primitives.data(), b.primitives.data(), a.primitives.size() * sizeof(uint32_t)) != 0)
        return "primitive arrays differ";
    return "";
}

inline Bvh build_in_arena(int threads, const Scene& scene, const BuildConfig& options) {
    tbb::task_arena arena(threads);
    Bvh bvh;
    arena.execute([&] { bvh = spacebvh::build(scene, options); });
    return bvh;
}

}  // namespace spacebvh::testing_support
