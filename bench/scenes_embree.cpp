// SPDX-License-Identifier: MIT
// Instanced scenes, ours against Embree HIGH's two-level scene (instance geometries over one mesh
// scene), on the same rays, in one process: N instances of one mesh placed by deterministic random
// rotations, mirrors and non-uniform scales. Prints, side by side with ratios (medians of RUNS):
// top-level build times; closest-hit and occlusion times on random, primary and diffuse rays (ours with each
// single-ray kernel, Embree rtcIntersect1/rtcOccluded1) with every answer checked against Embree's
// (disagreements counted, not settled: instanced answers may differ at instance seams); the same
// scene flattened into one spatial-split mesh where it fits; and the mesh's refit against its build.
// Speeds are measurements, never asserted (bench/README.md).
// Diffuse rays bounce once from the primary hits. With MAX_TOP (>= 1000), top-level build times for
// 10^3 .. MAX_TOP instances follow; with RAYS 0, only they are measured.
// Usage: spacebvh_scenes_bench SCENE INSTANCES RAYS [RUNS [MAX_TOP]]   (SCENE: a file or builtin:NAME)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "spacebvh/build.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/tools/embree_instances.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/verify.hpp"

#include "bench_timing.hpp"

using namespace spacebvh;

namespace {

using bench::median_ms;
using bench::median_of;
using bench::ms_since;

// splitmix64 (docs/rays.md), for the placements.
struct Random {
    uint64_t state;
    double next() {
        uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return double((z ^ (z >> 31)) >> 11) * 0x1p-53;
    }
};

// Instance k: a random rotation (axis, angle), scales in [0.5, 2] per axis, every third mirrored, on
// a grid of cells `spacing` apart.
std::vector<Affine> placements(size_t count, float spacing) {
    Random random{47};
    std::vector<Affine> out;
    const size_t side = size_t(std::ceil(std::cbrt(double(count))));
    for (size_t k = 0; k < count; ++k) {
        const Vec3 axis =
            normalize(Vec3(float(random.next() - 0.5), float(random.next() - 0.5), float(random.next() + 0.1)));
        const double angle = random.next() * 2.0 * M_PI, c = std::cos(angle), s = std::sin(angle);
        const double r[3][3] = {{c + axis.x * axis.x * (1 - c), axis.x * axis.y * (1 - c) - axis.z * s,
                                 axis.x * axis.z * (1 - c) + axis.y * s},
                                {axis.y * axis.x * (1 - c) + axis.z * s, c + axis.y * axis.y * (1 - c),
                                 axis.y * axis.z * (1 - c) - axis.x * s},
                                {axis.z * axis.x * (1 - c) - axis.y * s, axis.z * axis.y * (1 - c) + axis.x * s,
                                 c + axis.z * axis.z * (1 - c)}};
        const double scale[3] = {0.5 + 1.5 * random.next(), 0.5 + 1.5 * random.next(), 0.5 + 1.5 * random.next()};
        const size_t cell[3] = {k % side, (k / side) % side, k / (side * side)};
        Affine a;
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j)
                a.m[4 * i + j] = float(scale[i] * r[i][j] * (k % 3 == 0 && j == 0 ? -1.0 : 1.0));
            a.m[4 * i + 3] = float(cell[i]) * spacing;
        }
        out.push_back(a);
    }
    return out;
}

// Embree's two-level scene of `placed` instances of the mesh (already built: only the top level is
// committed here).
std::unique_ptr<tools::EmbreeInstancedScene> embree_instances(const std::shared_ptr<const tools::EmbreeScene>& mesh,
                                                              const std::vector<Affine>& placed) {
    std::vector<tools::MeshPlacement> placements(placed.size());
    for (size_t k = 0; k < placed.size(); ++k) {
        placements[k].transforms = {placed[k]};
        placements[k].path[0] = uint32_t(k);
    }
    return std::make_unique<tools::EmbreeInstancedScene>(std::vector{mesh}, placements);
}

// Ours (RenderScene) or Embree's (EmbreeInstancedScene): the t of each answer, 0 for occluded.
template <class Traced>
void trace_t(const Traced& scene, std::span<const Ray> rays, std::span<float> t, bool occlusion) {
    if (occlusion) {
        std::vector<uint8_t> blocked(rays.size());
        scene.occluded(rays, blocked);
        for (size_t i = 0; i < rays.size(); ++i) t[i] = blocked[i] ? 0.0f : kInfinity;
        return;
    }
    std::vector<SceneHit> hits(rays.size());
    scene.intersect(rays, hits);
    for (size_t i = 0; i < rays.size(); ++i) t[i] = hits[i].t;
}

size_t disagreements(std::span<const Ray> rays, std::span<const float> a, std::span<const float> b, float diagonal) {
    size_t n = 0;
    for (size_t i = 0; i < rays.size(); ++i)
        n += !tools::hits_agree({a[i], a[i] == kInfinity ? kInvalidIndex : 0},
                                {b[i], b[i] == kInfinity ? kInvalidIndex : 0}, rays[i], diagonal);
    return n;
}

// The same scene as one mesh (each instance's triangles taken to world space), built by the spatial
// builder and traced by bvh8, against the two-level scene's bvh8 times, where it fits.
using RayKinds = std::vector<std::pair<const char*, const std::vector<Ray>*>>;

void flattened(const tools::Scene& mesh, const std::vector<Affine>& placed, const RayKinds& kinds,
               const std::vector<double>& two_level_ms, int runs) {
    const size_t triangles = placed.size() * mesh.triangles.size();
    if (triangles > 4'000'000) {
        std::printf("flattened: %zu triangles, not built (over 4M)\n", triangles);
        return;
    }
    tools::Scene flat;
    flat.name = "flattened";
    for (const Affine& a : placed)
        for (const Triangle& t : mesh.triangles)
            flat.triangles.push_back({a.apply(t.v0), a.apply(t.v1), a.apply(t.v2)});
    const auto start = std::chrono::steady_clock::now();
    const Bvh bvh = build(flat.mesh(), TreeRecipe::for_builder("spatial"));
    const double build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    const Tracer tracer(flat.mesh(), bvh, Kernel::bvh8);
    const tools::EmbreeScene embree_flat(flat, tools::EmbreeQuality::high);
    std::printf(
        "flattened: %zu triangles, spatial build %.0f ms\n| rays | query | flattened bvh8 ms | two-level bvh8 ms "
        "| flattened/two-level | Embree flattened ms | Embree flattened/ours flattened |\n",
        triangles, build_ms);
    size_t k = 0;
    for (const auto& [kind, kind_rays] : kinds) {
        const auto* const rays = kind_rays;  // a variable: clang before 16 captures no structured binding
        for (bool occlusion : {false, true}) {
            std::vector<Hit> hits(rays->size());
            std::vector<uint8_t> blocked(rays->size());
            const double ms = median_ms(runs, [&] {
                if (occlusion)
                    tracer.occluded(*rays, blocked);
                else
                    tracer.intersect(*rays, hits);
            });
            const double embree_ms = median_ms(runs, [&] {
                if (occlusion)
                    embree_flat.occluded(*rays, blocked);
                else
                    embree_flat.intersect(*rays, hits);
            });
            std::printf("| %s | %s | %.1f | %.1f | %.2f | %.1f | %.2f |\n", kind, occlusion ? "occluded" : "closest",
                        ms, two_level_ms[k], ms / two_level_ms[k], embree_ms, embree_ms / ms);
            ++k;
        }
    }
}

// The two-level scene: `leaf` placed by each transform (instance id k is placed[k]).
std::unique_ptr<RenderScene> instanced(const SceneConfig& config, const std::shared_ptr<RenderScene>& leaf,
                                       const std::vector<Affine>& placed) {
    auto top = std::make_unique<RenderScene>(config, "instances");
    for (const Affine& a : placed) top->attach_instance(leaf, a);
    top->commit();
    return top;
}

// One diffuse bounce per primary hit (docs/rays.md), from the hit triangle taken to world space.
std::vector<Ray> diffuse_rays(const RenderScene& scene, const tools::Scene& mesh, const std::vector<Affine>& placed,
                              const std::vector<Ray>& primary, float diagonal) {
    std::vector<SceneHit> hits(primary.size());
    scene.intersect(primary, hits);
    tools::Scene at;  // one world triangle per hit
    std::vector<Ray> from;
    std::vector<Hit> hit;
    for (size_t i = 0; i < primary.size(); ++i) {
        if (!hits[i].is_hit()) continue;
        const Affine& a = placed[hits[i].instance[0]];
        const Triangle& t = mesh.triangles[hits[i].primitive];
        at.triangles.push_back({a.apply(t.v0), a.apply(t.v1), a.apply(t.v2)});
        from.push_back(primary[i]);
        hit.push_back({hits[i].t, uint32_t(at.triangles.size() - 1), hits[i].u, hits[i].v});
    }
    return tools::generate_diffuse_rays(at, from, hit, 7, 1e-4f * diagonal);
}

// The mesh alone, ours (spatial tree, bvh8) against Embree HIGH on random rays in its box: the
// single-mesh ratio the instanced cells are held to.
void single_mesh(const tools::Scene& mesh, const tools::EmbreeScene& embree_mesh, size_t ray_count, int runs) {
    const Bvh bvh = build(mesh.mesh(), TreeRecipe::for_builder("spatial"));
    const Tracer tracer(mesh.mesh(), bvh, Kernel::bvh8);
    const std::vector<Ray> rays = tools::generate_random_rays(bounds_of(mesh.triangles), ray_count, 2);
    std::vector<Hit> hits(rays.size());
    std::vector<uint8_t> blocked(rays.size());
    for (bool occlusion : {false, true}) {
        const double ours = median_ms(runs, [&] {
            if (occlusion)
                tracer.occluded(rays, blocked);
            else
                tracer.intersect(rays, hits);
        });
        const double theirs = median_ms(runs, [&] {
            if (occlusion)
                embree_mesh.occluded(rays, blocked);
            else
                embree_mesh.intersect(rays, hits);
        });
        std::printf("single mesh, random %s, bvh8: ours %.1f ms, Embree %.1f ms, Embree/ours %.2f\n",
                    occlusion ? "occluded" : "closest", ours, theirs, theirs / ours);
    }
}

// Top-level build of 10^3 .. max instances of `leaf`, timed over the same work on both sides: the
// instances' setup (ours: attach_instance per instance, and one attach_instances call; Embree:
// rtcNewGeometry + rtcSetGeometryInstancedScene + rtcSetGeometryTransform + rtcCommitGeometry +
// rtcAttachGeometryByID) and the top level's build (ours: commit after the batch; Embree:
// rtcCommitScene), each the median of `runs`.
void top_level_scaling(const SceneConfig& config, const std::shared_ptr<RenderScene>& leaf,
                       const std::shared_ptr<const tools::EmbreeScene>& embree_mesh, size_t max, float diagonal,
                       int runs) {
    std::printf(
        "top level over the same work: setup = ours attach_instance each (single) or attach_instances once "
        "(batch), Embree instance geometry creation + transform + attach; commit = ours commit, Embree "
        "rtcCommitScene\n");
    std::printf(
        "| instances | ours single ms | ours batch ms | ours commit ms | Embree setup ms | Embree commit ms | "
        "commit ours/Embree | single+commit ours/Embree | batch+commit ours/Embree |\n");
    const std::vector<std::shared_ptr<const RenderScene>> scenes{leaf};
    for (size_t count = 1000; count <= max; count *= 10) {
        const std::vector<Affine> placed = placements(count, 1.5f * diagonal);
        std::vector<InstancePlacement> batch(count);
        for (size_t k = 0; k < count; ++k) batch[k].transform = placed[k];
        std::vector<double> single, batched, commit, setup, embree_commit;
        for (int run = 0; run < runs; ++run) {
            auto start = std::chrono::steady_clock::now();
            {
                RenderScene ours(config, "instances");
                for (const Affine& a : placed) ours.attach_instance(leaf, a);
                single.push_back(ms_since(start));
            }
            start = std::chrono::steady_clock::now();
            RenderScene ours(config, "instances");
            ours.attach_instances(scenes, batch);
            batched.push_back(ms_since(start));
            start = std::chrono::steady_clock::now();
            ours.commit();
            commit.push_back(ms_since(start));
            const auto theirs = embree_instances(embree_mesh, placed);
            setup.push_back(theirs->top_setup_milliseconds());
            embree_commit.push_back(theirs->top_build_milliseconds());
        }
        const double a = median_of(single), b = median_of(batched), c = median_of(commit);
        const double s = median_of(setup), e = median_of(embree_commit);
        std::printf("| %zu | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |\n", count, a, b, c, s, e, c / e,
                    (a + c) / (s + e), (b + c) / (s + e));
    }
}

}  // namespace

int main(int argc, char** argv) try {
    if (argc < 4) {
        std::fprintf(stderr, "usage: %s SCENE INSTANCES RAYS [RUNS [MAX_TOP]]\n", argv[0]);
        return 2;
    }
    const tools::Scene mesh = tools::load_scene(argv[1]);
    const size_t instances = std::stoul(argv[2]), ray_count = std::stoul(argv[3]);
    const int runs = argc > 4 ? std::stoi(argv[4]) : 5;
    const size_t max_top = argc > 5 ? std::stoul(argv[5]) : 0;
    const std::vector<Affine> placed = placements(instances, 1.5f * mesh.diagonal());
    std::printf("%s: %zu triangles, %zu instances (%.3g instanced triangles), %zu rays, median of %d runs\n",
                mesh.name.c_str(), mesh.triangles.size(), instances, double(instances) * double(mesh.triangles.size()),
                ray_count, runs);

    const auto embree_mesh = std::make_shared<const tools::EmbreeScene>(mesh, tools::EmbreeQuality::high);
    SceneConfig config;
    config.recipe = TreeRecipe::for_builder("spatial");
    auto leaf = std::make_shared<RenderScene>(config, "mesh");
    const uint32_t mesh_id = leaf->attach_mesh(mesh.mesh());
    leaf->commit();
    if (ray_count == 0) {  // the top level's build times alone
        top_level_scaling(config, leaf, embree_mesh, std::max<size_t>(max_top, 1000), mesh.diagonal(), runs);
        return 0;
    }
    std::unique_ptr<tools::EmbreeInstancedScene> embree;
    std::vector<double> embree_top;  // instance geometries' setup + rtcCommitScene, as ours attach + commit
    median_ms(runs, [&] {
        embree.reset();
        embree = embree_instances(embree_mesh, placed);
        embree_top.push_back(embree->top_setup_milliseconds() + embree->top_build_milliseconds());
    });
    const double embree_top_ms = median_of(embree_top);
    std::unique_ptr<RenderScene> ours;
    const double ours_top_ms = median_ms(runs, [&] { ours = instanced(config, leaf, placed); });
    std::printf("top level (setup + commit on both sides): ours %.2f ms, Embree %.2f ms, ours/Embree %.2f\n",
                ours_top_ms, embree_top_ms, ours_top_ms / embree_top_ms);

    const AABB world = ours->bounds();
    const float diagonal = length(world.extent());
    tools::Scene box_scene;
    box_scene.triangles = {{world.lo, world.hi, world.lo}};
    const std::vector<Ray> random = tools::generate_random_rays(world, ray_count, 1);
    const uint32_t side = uint32_t(std::sqrt(double(ray_count)));
    const std::vector<Ray> primary = tools::generate_primary_rays(tools::default_camera(box_scene), side, side);
    const std::vector<Ray> diffuse = diffuse_rays(*ours, mesh, placed, primary, diagonal);
    const RayKinds kinds = {{"random", &random}, {"primary", &primary}, {"diffuse", &diffuse}};
    std::printf("diffuse: %zu rays (one per primary hit)\n", diffuse.size());
    // One two-level scene per kernel, built once.
    std::vector<std::pair<Kernel, std::unique_ptr<RenderScene>>> traced;
    for (Kernel kernel : {Kernel::binary, Kernel::bvh4, Kernel::bvh8}) {
        SceneConfig c = config;
        c.tracer.kernel = kernel;
        auto kleaf = std::make_shared<RenderScene>(c, "mesh");
        kleaf->attach_mesh(mesh.mesh());
        kleaf->commit();
        traced.emplace_back(kernel, instanced(c, kleaf, placed));
    }
    std::printf("| rays | query | kernel | ours ms | Embree ms | Embree/ours | disagreements |\n");
    std::vector<double> bvh8_ms;  // per ray kind and query, in the loop's order
    for (const auto& [kind, kind_rays] : kinds) {
        const auto* const rays = kind_rays;  // a variable: clang before 16 captures no structured binding
        for (bool occlusion : {false, true}) {
            std::vector<float> theirs(rays->size()), mine(rays->size());
            const double embree_ms = median_ms(runs, [&] { trace_t(*embree, *rays, theirs, occlusion); });
            for (const auto& [kernel, kernel_scene] : traced) {
                const auto& top = kernel_scene;
                const double ours_ms = median_ms(runs, [&] { trace_t(*top, *rays, mine, occlusion); });
                if (kernel == Kernel::bvh8) bvh8_ms.push_back(ours_ms);
                std::printf("| %s | %s | %s | %.1f | %.1f | %.2f | %zu |\n", kind, occlusion ? "occluded" : "closest",
                            to_string(kernel), ours_ms, embree_ms, embree_ms / ours_ms,
                            disagreements(*rays, mine, theirs, diagonal));
            }
        }
    }

    single_mesh(mesh, *embree_mesh, ray_count, runs);
    flattened(mesh, placed, kinds, bvh8_ms, runs);
    if (max_top >= 1000) top_level_scaling(config, leaf, embree_mesh, max_top, mesh.diagonal(), runs);

    // Refit: the mesh's tree after its vertices moved (here: none moved, the cost is the same), against
    // building it again.
    const double refit_ms = median_ms(runs, [&] { leaf->refit(mesh_id); });
    const double build_ms = median_ms(runs, [&] { (void)build(mesh.mesh(), TreeRecipe::for_builder("spatial")); });
    std::printf("mesh refit %.2f ms (tree boxes and layout), spatial build %.2f ms, refit/build %.3f\n", refit_ms,
                build_ms, refit_ms / build_ms);
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
}
