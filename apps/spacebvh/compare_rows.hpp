// SPDX-License-Identifier: MIT
// The rows of `compare`: what one builder under one kernel, or one Embree quality, measured per ray
// kind, and the round-robin timing that fills them in.
#pragma once

#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "spacebvh/cost_model.hpp"
#include "spacebvh/scene.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene_arbiter.hpp"
#include "spacebvh/trace.hpp"

namespace spacebvh::cli::compare {

using namespace spacebvh::tools;

inline constexpr RayKind kKinds[] = {RayKind::random, RayKind::primary, RayKind::diffuse};

struct KindResult {
    double closest_mrays = 0, occlusion_mrays = 0;
    // Work per ray of closest-hit and of occlusion queries (an occlusion ray stops at its first hit
    // found, so the two differ by what early termination saves); -1: not measured (Embree, or --runs 0).
    double nodes_per_ray = -1, triangles_per_ray = -1;
    double occlusion_nodes_per_ray = -1, occlusion_triangles_per_ray = -1;
    size_t wrong = 0;  // closest + occlusion answers the arbiter rejects
    std::vector<HitRecord> closest, occlusion;
    std::vector<double> closest_ms, occlusion_ms;  // every timed run, in round-robin order (spread of the median)
};

struct Row {
    std::string name;
    std::string kernel;      // the kernel column: one name, or the per-kind choice of "auto"
    std::string kernels[3];  // per ray kind
    double build_ms = 0;
    std::vector<double> build_ms_runs;
    std::optional<TreeStats> stats;
    std::optional<CostModel> cost;
    KindResult kinds[3];
    size_t peak_rss_bytes = 0;  // the process's peak resident set when the row was done
    // Nodes and leaf triangle data of the random rays' tracer (Embree: what its commit allocated) per
    // triangle of the scene; -1 if not known.
    double layout_bytes_per_triangle = -1;
};

// One timed measurement: a row's tracer (ours or Embree's) on one ray kind, closest hits and
// occlusion. `order`, when not empty, maps its rays back to the kind's ray set (Embree's packets trace
// the primary rays in 4x4 tiles): answer i belongs to ray order[i].
struct Measurement {
    KindResult* result;
    std::span<const Ray> rays;   // the kind's ray set, or `reordered`
    std::vector<Ray> reordered;  // its own order of the rays, when it has one (its buffer survives moves)
    std::vector<uint32_t> order;
    std::function<void(std::span<const Ray>, std::span<Hit>)> intersect;
    std::function<void(std::span<const Ray>, std::span<uint8_t>)> occluded;
    // In place of `intersect` for a scene of instances (RenderScene, Embree's two-level scene).
    std::function<void(std::span<const Ray>, std::span<SceneHit>)> intersect_scene;
};

// Times every measurement `runs` times, round robin: run 1 of every row, then run 2 of every row, and
// so on, after one warm-up run each (which also keeps the answers). The machines are shared and their
// speed drifts over seconds; interleaved, a drift slows every row alike instead of the rows measured
// during it, so the ratios between rows (ours / Embree) stay honest. Mrays/s = ray count / median time.
// runs == 0 is the answers-only pass of a soak: the one pass that keeps the answers is also the timed
// one. A measurement's answers become records right after its first pass, so the raw hits of only one
// measurement are alive at a time (at 10^7 rays a row's answers are what bounds memory).
void measure_round_robin(std::vector<Measurement>& measurements, int runs, const std::function<void(double)>& progress);

// The child boxes and triangles `tracer` tests per ray of `rays`, closest hits and occlusion, into
// `result` (an untimed pass with traversal statistics).
void count_work_per_ray(const Tracer& tracer, std::span<const Ray> rays, KindResult& result);

// Every row's answers against a reference row's: the first Embree row (at `first_embree_row`) for our
// rows, our first row for Embree's; the exact arbiter settles each disagreement, and the answers it
// rejects are the row's `wrong` count. The arbiter is the scene's: the mesh's, or with `instances`
// the instanced scene's (every placement's triangles, each for the ray in the placement's space).
void count_wrong_answers(const Scene& scene, const std::vector<Ray> (&ray_sets)[3], std::vector<Row>& rows,
                         size_t first_embree_row, const SceneArbiter* instances = nullptr);

}  // namespace spacebvh::cli::compare
