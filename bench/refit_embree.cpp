// SPDX-License-Identifier: MIT
// Refit of one mesh, ours against its build and against Embree's RTC_BUILD_QUALITY_REFIT, and when a
// rebuild pays: the mesh is moved (rotating, bending, exploding, each by growing amounts), its tree
// refitted, and the refitted tree's SAH and bvh8 trace time on random rays compared with a fresh
// spatial build's on the moved mesh, in one process (medians of RUNS, interleaved). Speeds are
// measurements, never asserted (bench/README.md).
// Usage: spacebvh_refit_bench SCENE RAYS [RUNS]   (SCENE: a file or builtin:NAME; RAYS 0: refit times only)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "spacebvh/build.hpp"
#include "spacebvh/recipe.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/tools/embree_scene.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/tools/rays.hpp"

#include "bench_timing.hpp"

using namespace spacebvh;

namespace {

using bench::median_ms;
using bench::ms_since;

// The mesh moved by `amount` (0 = not moved): rotating turns it about z by amount * 90 degrees;
// bending adds amount * x^2 / size to y; exploding pushes each triangle out by amount * its centroid.
std::vector<Triangle> moved(const std::vector<Triangle>& mesh, const std::string& kind, double amount, float size,
                            Vec3 centre) {
    std::vector<Triangle> out = mesh;
    const double angle = amount * M_PI / 2, c = std::cos(angle), s = std::sin(angle);
    for (Triangle& t : out) {
        const Vec3 centroid = (t.v0 + t.v1 + t.v2) / 3.0f - centre;
        for (Vec3* p : {&t.v0, &t.v1, &t.v2}) {
            const Vec3 q = *p - centre;
            if (kind == "rotating")
                *p = centre + Vec3{float(c * q.x - s * q.y), float(s * q.x + c * q.y), q.z};
            else if (kind == "bending")
                p->y += float(amount * q.x * q.x / size);
            else
                *p = *p + centroid * float(amount);
        }
    }
    return out;
}

// Embree's refit: a dynamic scene whose one triangle geometry has RTC_BUILD_QUALITY_REFIT, over our
// vertex buffer; after the vertices change, rtcUpdateGeometryBuffer, rtcCommitGeometry and
// rtcCommitScene refit it. Embree reads a geometry's build quality only in a scene of build quality
// LOW (its two-level structure, rtcSetGeometryBuildQuality(3)); in any other scene REFIT is ignored
// and every commit rebuilds, so the scene is set to LOW here.
struct EmbreeRefit {
    RTCDevice device = tools::embree_device();
    RTCScene scene = rtcNewScene(device);
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    std::vector<float> xyz;  // 4 floats per vertex (Embree reads 16 bytes), three vertices per triangle
    std::vector<uint32_t> index;
    double build_ms = 0.0;

    explicit EmbreeRefit(const std::vector<Triangle>& mesh) : xyz(12 * mesh.size() + 4), index(3 * mesh.size()) {
        for (uint32_t i = 0; i < index.size(); ++i) index[i] = i;
        put(mesh);
        rtcSetSceneFlags(scene, RTC_SCENE_FLAG_DYNAMIC);
        rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_LOW);
        rtcSetGeometryBuildQuality(geometry, RTC_BUILD_QUALITY_REFIT);
        rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, xyz.data(), 0,
                                   4 * sizeof(float), 3 * mesh.size());
        rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, index.data(), 0,
                                   3 * sizeof(uint32_t), mesh.size());
        rtcCommitGeometry(geometry);
        rtcAttachGeometry(scene, geometry);
        const auto start = std::chrono::steady_clock::now();
        rtcCommitScene(scene);
        build_ms = ms_since(start);
        tools::check_embree(device, "the refit scene");
    }
    ~EmbreeRefit() {
        rtcReleaseGeometry(geometry);
        rtcReleaseScene(scene);
    }
    void put(const std::vector<Triangle>& mesh) {
        for (size_t t = 0; t < mesh.size(); ++t)
            for (int v = 0; v < 3; ++v)
                for (int axis = 0; axis < 3; ++axis) xyz[4 * (3 * t + v) + axis] = mesh[t].vertex(v)[axis];
    }
    void refit() {
        rtcUpdateGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0);
        rtcCommitGeometry(geometry);
        rtcCommitScene(scene);
    }
};

void refit_times(const tools::Scene& mesh, int runs) {
    std::vector<Triangle> current = mesh.triangles;
    SceneConfig config;
    config.recipe = TreeRecipe::for_builder("spatial");
    config.tracer.kernel = Kernel::bvh8;
    RenderScene scene(config, "refit");
    scene.attach_mesh(MeshView(current));
    const double spatial_ms =
        median_ms(runs, [&] { (void)build(MeshView(current), TreeRecipe::for_builder("spatial")); });
    const double binned_ms =
        median_ms(runs, [&] { (void)build(MeshView(current), TreeRecipe::for_builder("binned")); });
    scene.commit();
    const float size = length(bounds_of(current).extent());
    const Vec3 centre = bounds_of(current).center();
    const std::vector<Triangle> turned = moved(mesh.triangles, "rotating", 0.1, size, centre);
    // Alternate between two poses, so every refit sees moved vertices.
    int pose = 0;
    const double ours_ms = median_ms(runs, [&] {
        current = (++pose % 2) ? turned : mesh.triangles;
        scene.refit(0);
    });
    EmbreeRefit embree(mesh.triangles);
    pose = 0;
    const double embree_ms = median_ms(runs, [&] {
        embree.put((++pose % 2) ? turned : mesh.triangles);
        embree.refit();
    });
    // The vertex updates alone (each side writes its own buffer layout), so that the refits can also be
    // compared without them.
    const double ours_update_ms = median_ms(runs, [&] { current = (++pose % 2) ? turned : mesh.triangles; });
    const double embree_update_ms = median_ms(runs, [&] { embree.put((++pose % 2) ? turned : mesh.triangles); });
    std::printf(
        "refit of %zu triangles (vertices moved each time; ours: tree boxes, wide layout in place, top level):\n"
        "| ours refit ms | spatial build ms | binned build ms | refit/spatial | refit/binned | Embree refit ms | "
        "Embree first build ms | ours/Embree refit |\n| %.2f | %.1f | %.1f | %.3f | %.3f | %.2f | %.1f | %.2f |\n",
        mesh.triangles.size(), ours_ms, spatial_ms, binned_ms, ours_ms / spatial_ms, ours_ms / binned_ms, embree_ms,
        embree.build_ms, ours_ms / embree_ms);
    std::printf(
        "the same without the vertex updates (medians taken apart, so only a guide):\n"
        "| ours update ms | Embree update ms | ours refit only ms | Embree refit only ms | ours/Embree |\n"
        "| %.2f | %.2f | %.2f | %.2f | %.2f |\n",
        ours_update_ms, embree_update_ms, ours_ms - ours_update_ms, embree_ms - embree_update_ms,
        (ours_ms - ours_update_ms) / (embree_ms - embree_update_ms));
}

// The refitted tree against a fresh build on the moved mesh: SAH ratio and bvh8 trace-time ratio.
void growth(const tools::Scene& mesh, size_t ray_count, int runs) {
    const Bvh original = build(mesh.mesh(), TreeRecipe::for_builder("spatial"));
    const CostModel cost = original.cost;
    const float size = length(bounds_of(mesh.triangles).extent());
    const Vec3 centre = bounds_of(mesh.triangles).center();
    std::printf(
        "SAH growth of the refitted spatial tree (bvh8, random rays, closest hit; ratios refitted/fresh):\n"
        "| motion | amount | SAH refitted/fresh | trace refitted/fresh | refitted ms | fresh ms | fresh build ms |\n");
    for (const char* kind : {"rotating", "bending", "exploding"})
        for (double amount : {0.0, 0.05, 0.2, 0.5, 1.0, 2.0}) {
            const std::vector<Triangle> now = moved(mesh.triangles, kind, amount, size, centre);
            Bvh refitted = original;
            refit_boxes(refitted, now);
            const auto start = std::chrono::steady_clock::now();
            const Bvh fresh = build(MeshView(now), TreeRecipe::for_builder("spatial"));
            const double fresh_build_ms = ms_since(start);
            const Tracer a(MeshView(now), refitted, Kernel::bvh8), b(MeshView(now), fresh, Kernel::bvh8);
            const std::vector<Ray> rays = tools::generate_random_rays(bounds_of(now), ray_count, 3);
            std::vector<Hit> hits(rays.size());
            std::vector<double> ta, tb;
            for (int r = 0; r < runs; ++r) {  // interleaved
                ta.push_back(median_ms(1, [&] { a.intersect(rays, hits); }));
                tb.push_back(median_ms(1, [&] { b.intersect(rays, hits); }));
            }
            const double ma = bench::median_of(ta), mb = bench::median_of(tb);
            std::printf("| %s | %.2f | %.2f | %.2f | %.1f | %.1f | %.0f |\n", kind, amount,
                        tools::tree_sah(refitted, cost) / tools::tree_sah(fresh, cost), ma / mb, ma, mb,
                        fresh_build_ms);
        }
}

}  // namespace

int main(int argc, char** argv) try {
    if (argc < 3) {
        std::fprintf(stderr, "usage: %s SCENE RAYS [RUNS]\n", argv[0]);
        return 2;
    }
    const tools::Scene mesh = tools::load_scene(argv[1]);
    const size_t ray_count = std::stoul(argv[2]);
    const int runs = argc > 3 ? std::stoi(argv[3]) : 5;
    std::printf("%s: %zu triangles, %zu rays, median of %d runs\n", mesh.name.c_str(), mesh.triangles.size(), ray_count,
                runs);
    refit_times(mesh, runs);
    if (ray_count > 0) growth(mesh, ray_count, runs);
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
}
