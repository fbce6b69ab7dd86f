// SPDX-License-Identifier: MIT
// What `compare` is asked for (its options) and what it will do (the plan): the rows of every scene,
// validated before any scene is loaded.
#pragma once

#include <string>
#include <vector>

#include "builder_spec.hpp"
#include "cli_common.hpp"
#include "spacebvh/tools/embree_scene.hpp"
#include "tree_option.hpp"

namespace spacebvh::cli::compare {

using namespace spacebvh::tools;

struct CompareOptions {
    std::vector<std::string> sources;
    std::string builders = "cbvh,binned,kdbvh,spatial,sbvh";
    std::string embree = "low,medium,high";
    std::string kernels = "auto";
    std::string embree_packets = "high";
    uint32_t tile = 8;
    int runs = 5, build_runs = 3;
    size_t random_count = 1000000;
    uint64_t seed = 1;
    bool no_verify = false, no_epo = false;
    SceneOptions scene;
    BuildCliOptions build;
    CameraOptions camera;
    CommonOptions common;
    TreeOption tree;
};

// Per scene: our rows (one per builder and kernel, the first the ratio baseline), then Embree's (one
// per quality with single rays, then one per quality with 16-ray packets).
struct ComparePlan {
    const CompareOptions& options;
    std::vector<BuilderSpec> builders;  // a saved tree (--tree) first when given
    std::vector<std::string> kernels;   // --kernel names, "auto" among them
    std::vector<EmbreeQuality> embree_rows, embree_packet_rows;
    std::vector<std::string> sources;  // every built-in scene when none is named
    SceneTransform transform;

    explicit ComparePlan(const CompareOptions& compare_options) : options(compare_options) {}
    size_t our_row_count() const { return builders.size() * kernels.size(); }
    size_t row_count() const { return our_row_count() + embree_rows.size() + embree_packet_rows.size(); }
    // Our rows' answers are checked against the first Embree row, so there must be one.
    bool verifies() const { return !options.no_verify && !embree_rows.empty(); }
};

// Validates the options (throws Error naming the first one out of range). `builders_given`: --builders
// was given explicitly, so its rows follow a saved tree's rather than being replaced by it.
ComparePlan make_plan(const CompareOptions& options, bool builders_given);

// The first lines of the report: threads, cost model, runs and the ratio baseline.
void print_plan_header(const ComparePlan& plan);

}  // namespace spacebvh::cli::compare
