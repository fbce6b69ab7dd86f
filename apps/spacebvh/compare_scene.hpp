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

// The share of the progress bar that building the rows takes (the rest: measuring).
inline constexpr double kBuildShare = 0.3;

}  // namespace spacebvh::cli::compare
