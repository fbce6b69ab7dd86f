// SPDX-License-Identifier: MIT
// One scene of `compare`, in its stages: our rows (every builder under every kernel), Embree's rows,
// the round-robin measurement with the answers checked, and the report (the table, the scene's JSON).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "compare_plan.hpp"
#include "compare_rows.hpp"
#include "instanced_input.hpp"
#include "spacebvh/tools/embree_instances.hpp"
#include "ray_sets.hpp"

namespace spacebvh::cli::compare {

// What the stages of one scene share. The rows' measurements point into `rows` and `ray_sets` and
// call the tracers and Embree scenes kept here.
struct SceneComparison {
    std::string source;
    Scene scene;
    RaySetParameters parameters;
    std::vector<Ray> ray_sets[3];         // per RayKind; primary rays in `primary_order`
    std::vector<Ray> primary_row_major;   // the spec's order, which Embree's packets regroup
    std::vector<uint32_t> primary_order;  // row-major pixel of each primary ray
    std::vector<Row> rows;                // reserved for every row: measurements point into it
    std::vector<Measurement> measurements;
    std::vector<std::unique_ptr<Tracer>> tracers;
    std::vector<std::unique_ptr<EmbreeScene>> embree_scenes;
    // A spec naming an instanced scene (compare_instances.cpp): `scene` then stands in for its world
    // box only (cameras, random rays), and the rows trace these.
    std::unique_ptr<InstancedInput> instanced;
    std::vector<std::shared_ptr<RenderScene>> render_scenes;
    std::vector<std::unique_ptr<EmbreeInstancedScene>> embree_instanced;

    uint64_t triangle_count() const { return instanced ? instanced->instanced_triangles() : scene.triangles.size(); }
};

// The scene loaded, its camera and ray parameters set; no rows yet.
SceneComparison load_comparison(const ComparePlan& plan, const std::string& source);
// Builds every builder's tree (--build-runs times) and adds one row per kernel; the first tree also
// makes the ray sets.
void add_our_rows(const ComparePlan& plan, SceneComparison& comparison, Progress& progress);
// Builds Embree's scene per quality and adds its rows, single rays then 16-ray packets.
void add_embree_rows(const ComparePlan& plan, SceneComparison& comparison, Progress& progress);
// Times every row round robin, then checks the answers when the plan verifies.
void measure(const ComparePlan& plan, SceneComparison& comparison, Progress& progress);
// Prints the scene's table and returns its JSON.
nlohmann::json report(const ComparePlan& plan, const SceneComparison& comparison);

// The stages above for an instanced scene (compare_instances.cpp): its rows are RenderScenes (one per
// builder and kernel: the single-ray kernels only) and Embree's two-level scenes; the instanced
// scene's arbiter settles disagreements.
void load_instanced_comparison(const ComparePlan& plan, SceneComparison& comparison);
void add_our_instanced_rows(const ComparePlan& plan, SceneComparison& comparison, Progress& progress);

struct EmbreePacketOrder;
// One Embree row of an instanced scene: its two-level scene, single rays or 16-ray packets.
void add_embree_instanced_row(const ComparePlan& plan, SceneComparison& comparison, EmbreeQuality quality, bool packets,
                              const EmbreePacketOrder& packet_order);

// Shared by both kinds of scene.
Measurement& add_measurement(SceneComparison& comparison, KindResult& result, std::span<const Ray> rays,
                             std::function<void(std::span<const Ray>, std::span<Hit>)> intersect,
                             std::function<void(std::span<const Ray>, std::span<uint8_t>)> occluded);
void show_rows_built(const ComparePlan& plan, const SceneComparison& comparison, Progress& progress);
std::vector<Ray> gathered(const std::vector<Ray>& rays, const std::vector<uint32_t>& order);

// Where Embree's packets trace the primary rays: 4x4 tiles of the row-major image (none when --tile 0
// keeps our rays row-major too), their answers put back in our order.
struct EmbreePacketOrder {
    std::vector<uint32_t> tiles_of_16;
    std::vector<uint32_t> position_in_primary;  // row-major pixel -> our ray index

    EmbreePacketOrder(const ComparePlan& plan, const SceneComparison& comparison);
    // Gives `measurement` (of the primary rays) this order, when there is one.
    void apply(const SceneComparison& comparison, Measurement& measurement) const;
};

// The share of the progress bar that building the rows takes (the rest: measuring).
inline constexpr double kBuildShare = 0.3;

}  // namespace spacebvh::cli::compare
