// SPDX-License-Identifier: MIT
// One kernel, ours or Embree HIGH's own, tracing ray files once each: the program valgrind runs in
// bench/work_per_ray.sh to count what each kernel executes per ray (instructions, simulated cache
// misses, branch mispredictions). All the tracing happens inside trace_rays, and only there does
// callgrind count (--toggle-collect; --dump-after=trace_rays gives one profile per ray file), so
// loading, building and the Embree commit are left out.
// Usage: spacebvh_work_per_ray SCENE ROTATION|- TREE_FILE|embree KERNEL RAY_FILE:closest|occlusion...
//   ROTATION: "x:45,y:45,z:45" or "-"; TREE_FILE: a tree saved by `spacebvh build --save` over the
//   rotated scene, or "embree" for Embree HIGH's own scene and kernel (KERNEL is then ignored).
//   Prints "N rays, M hit|occluded" per ray file, in order.
#include <tbb/global_control.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "spacebvh/error.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tree_file.hpp"
#include "spacebvh/tools/embree_scene.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene.hpp"

using namespace spacebvh;

static size_t trace(const tools::EmbreeScene* embree, const Tracer* ours, const std::vector<Ray>* rays,
                    bool occlusion) {
    size_t hits = 0;
    if (occlusion) {
        std::vector<uint8_t> blocked(rays->size());
        if (embree)
            embree->occluded(*rays, blocked);
        else
            ours->occluded(*rays, blocked);
        for (uint8_t b : blocked) hits += b != 0;
    } else {
        std::vector<Hit> closest(rays->size());
        if (embree)
            embree->intersect(*rays, closest);
        else
            ours->intersect(*rays, closest);
        for (const Hit& h : closest) hits += h.is_hit();
    }
    return hits;
}

// The counted call: out of line (and extern "C", so its name is plain) for callgrind's
// --toggle-collect=trace_rays.
extern "C" __attribute__((noinline)) size_t trace_rays(const tools::EmbreeScene* embree, const Tracer* ours,
                                                       const std::vector<Ray>* rays, bool occlusion) {
    return trace(embree, ours, rays, occlusion);
}

int main(int argc, char** argv) {
    if (argc < 6) {
        std::fprintf(stderr, "usage: %s SCENE ROTATION|- TREE_FILE|embree KERNEL RAY_FILE:closest|occlusion...\n",
                     argv[0]);
        return 2;
    }
    // One thread: callgrind counts a thread's work only while trace_rays is on that thread's stack.
    const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    try {
        // The jobs first, so a malformed one fails before the scene is loaded and built.
        struct Job {
            std::vector<Ray> rays;
            bool occlusion;
        };
        std::vector<Job> jobs;
        for (int i = 5; i < argc; ++i) {
            const std::string job = argv[i];
            const size_t colon = job.rfind(':');
            const std::string query = colon == std::string::npos ? "" : job.substr(colon + 1);
            if (query != "closest" && query != "occlusion")
                throw Error("expected RAY_FILE:closest or RAY_FILE:occlusion, got '" + job + "'");
            jobs.push_back({tools::read_ray_file(job.substr(0, colon)), query == "occlusion"});
        }
        tools::SceneTransform transform;
        if (std::string(argv[2]) != "-") transform.rotate_degrees = tools::SceneTransform::parse_rotation(argv[2]);
        const tools::Scene scene = tools::load_scene(argv[1], transform);
        std::unique_ptr<tools::EmbreeScene> embree;
        std::unique_ptr<Tracer> ours;
        if (std::string(argv[3]) == "embree") {
            embree = std::make_unique<tools::EmbreeScene>(scene, tools::EmbreeQuality::high);
        } else {
            const Bvh bvh = load_bvh(argv[3], scene.triangles);
            ours = make_tracer(argv[4], scene, bvh);
        }
        // A warm-up pass, not counted: first-call costs (thread pools, lazy setup) and cold caches
        // stay out of the per-ray figures.
        trace(embree.get(), ours.get(), &jobs.front().rays, false);
        for (const Job& job : jobs) {
            const size_t hits = trace_rays(embree.get(), ours.get(), &job.rays, job.occlusion);
            std::printf("%zu rays, %zu %s\n", job.rays.size(), hits, job.occlusion ? "occluded" : "hit");
        }
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
}
