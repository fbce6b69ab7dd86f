// SPDX-License-Identifier: MIT
// Mrays/s of Tracer64 (float64 mesh and rays, exact) against Tracer (float32, binary and automatic
// kernels) on the same tree: the tree built over local_frame_mesh(mesh), traced by both; the same
// random rays (docs/rays.md "random"), as float32 rays in the local frame and as float64 rays.
// Usage: spacebvh_float64_bench [SCENE (builtin:NAME or a path; default builtin:organic)] [RAYS] [RUNS]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "spacebvh/float64.hpp"
#include "spacebvh/trace.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene.hpp"

using namespace spacebvh;

template <typename Trace>
double best_mrays(size_t rays, int runs, Trace trace) {
    double best = 0.0;
    for (int run = 0; run < runs; ++run) {
        const auto start = std::chrono::steady_clock::now();
        trace();
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        best = std::max(best, double(rays) / seconds * 1e-6);
    }
    return best;
}

int main(int argc, char** argv) {
    const std::string source = argc > 1 ? argv[1] : "builtin:organic";
    const size_t count = argc > 2 ? std::stoul(argv[2]) : 200000;
    const int runs = argc > 3 ? std::stoi(argv[3]) : 3;
    const tools::Scene scene = tools::load_scene(source);
    // The scene's float coordinates widened to float64: the same mesh in both precisions.
    std::vector<double> xyz;
    for (const Triangle& t : scene.triangles)
        for (Vec3 v : {t.v0, t.v1, t.v2}) xyz.insert(xyz.end(), {double(v.x), double(v.y), double(v.z)});
    std::vector<uint32_t> indices(xyz.size() / 3);
    for (size_t i = 0; i < indices.size(); ++i) indices[i] = uint32_t(i);
    const MeshView mesh64 = MeshView(xyz, indices).named(scene.name);

    const LocalFrameMesh local = local_frame_mesh(mesh64);
    const Bvh bvh = build(MeshView(local.triangles), BuildConfig::for_quality(Quality::balanced));
    const std::vector<Ray> rays32 = tools::generate_random_rays(bounds_of(local.triangles), count, 1);
    std::vector<Ray64> rays64(rays32.size());
    for (size_t i = 0; i < rays32.size(); ++i) {
        const Ray& r = rays32[i];
        for (int a = 0; a < 3; ++a) {
            rays64[i].org[a] = double(r.org[a]) + local.origin[a];  // the same ray, global float64
            rays64[i].dir[a] = r.dir[a];
        }
    }

    std::vector<Hit> hits32(count);
    std::vector<Hit64> hits64(count);
    std::printf("scene %s, %zu triangles, %zu random rays, best of %d runs, closest hit\n", scene.name.c_str(),
                scene.triangles.size(), count, runs);
    for (Kernel kernel : {Kernel::binary, Kernel::automatic}) {
        const Tracer tracer(MeshView(local.triangles), bvh, kernel);
        const double mrays = best_mrays(count, runs, [&] { tracer.intersect(rays32, hits32); });
        std::printf("  float32 %-8s %8.2f Mrays/s\n", tracer.name().c_str(), mrays);
    }
    const Tracer64 tracer64(mesh64, bvh);
    const double mrays64 = best_mrays(count, runs, [&] { tracer64.intersect(rays64, hits64); });
    std::printf("  float64 exact    %8.2f Mrays/s (binary walk)\n", mrays64);
    size_t differ = 0;
    for (size_t i = 0; i < count; ++i) differ += hits32[i].primitive != hits64[i].primitive;
    // The float32 tracer sees the stand-ins (vertices rounded in the local frame): near edges and
    // between coplanar duplicates its triangle may differ.
    std::printf("  hit triangle differs from the float32 stand-ins' on %zu rays\n", differ);
    return 0;
}
