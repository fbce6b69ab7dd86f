// SPDX-License-Identifier: MIT
#include "compare_plan.hpp"

#include <cstdio>

#include "spacebvh/presets.hpp"

namespace spacebvh::cli::compare {
namespace {

// The non-empty names of a comma-separated list.
std::vector<std::string> names_in(const std::string& list) {
    std::vector<std::string> names;
    for (const auto& name : CLI::detail::split(list, ','))
        if (!name.empty()) names.push_back(name);
    return names;
}

// Embree qualities of a comma-separated list, or none for "none".
std::vector<EmbreeQuality> qualities_in(const std::string& list) {
    std::vector<EmbreeQuality> qualities;
    if (list != "none")
        for (const auto& name : names_in(list)) qualities.push_back(parse_embree_quality(name));
    return qualities;
}

}  // namespace

ComparePlan make_plan(const CompareOptions& options, bool builders_given) {
    if (options.runs < 0 || options.runs > 1000) throw Error("--runs must be in [0, 1000]");
    if (options.build_runs < 1 || options.build_runs > 1000) throw Error("--build-runs must be in [1, 1000]");
    if (options.random_count == 0 || options.random_count > (size_t(1) << 31))
        throw Error("--random must be in [1, 2^31]");
    ComparePlan plan(options);
    for (const auto& name : names_in(options.builders))
        plan.builders.push_back(parse_builder_spec(name, options.build));  // validates each
    if (options.tree.given()) {
        if (!builders_given) plan.builders.clear();
        plan.builders.insert(plan.builders.begin(),
                             BuilderSpec{options.tree.path, options.build.options("binned"), true});
        if (options.sources.size() != 1) throw Error("--tree: name the one scene the tree was built over");
    }
    if (plan.builders.empty()) throw Error("--builders names no builder");
    plan.kernels = names_in(options.kernels);
    if (plan.kernels.empty()) throw Error("--kernel names no kernel");
    if (options.tile > 1024) throw Error("--tile must be in [0, 1024]");
    plan.embree_packet_rows = qualities_in(options.embree_packets);
    plan.embree_rows = qualities_in(options.embree);
    plan.sources = options.sources;
    if (plan.sources.empty())
        for (const auto& name : builtin_scene_names()) plan.sources.push_back("builtin:" + name);
    plan.transform = options.scene.transform();
    return plan;
}

void print_plan_header(const ComparePlan& plan) {
    const CostModel& cost = plan.builders.front().options.cost;
    std::printf(
        "# spacebvh compare: %u threads, C_T=%g C_I=%g (C_o per row), max leaf %u; Mrays/s = median of %d "
        "runs; ratios to %s\n\n",
        plan.options.common.effective_threads(), cost.traversal_cost, cost.intersection_cost,
        plan.builders.front().options.limits.max_leaf_size, plan.options.runs, plan.builders.front().label.c_str());
}

}  // namespace spacebvh::cli::compare
