// SPDX-License-Identifier: MIT
// The entry points: a preset's references (plain or pre-split) and search spaces handed to the
// generic top-down driver, then the optional reinsertion optimisation.
#include "builders/memory_estimate.hpp"
#include "builders/preset_table.hpp"
#include "builders/presplit/presplit.hpp"
#include "builders/optimize/reinsertion_optimizer.hpp"
#include "builders/search_spaces/search_spaces.hpp"
#include "builders/driver/top_down_builder.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh {
void optimize(Bvh& bvh, const ReinsertionConfig& reinsertion, uint32_t max_depth, const BuildHooks& hooks) {
    if (reinsertion.iterations > kMaxReinsertionIterations)
        throw Error("reinsertion iterations must be in [0, " + std::to_string(kMaxReinsertionIterations) + "], got " +
                    std::to_string(reinsertion.iterations));
    if (reinsertion.iterations == 0) return;
    builders::ReinsertionOptions options;
    options.iterations = reinsertion.iterations;
    options.max_depth = max_depth;
    options.progress = hooks.progress;
    options.cancel = hooks.cancel;
    builders::optimize_by_reinsertion(bvh, options);
    bvh.builder += "+opt";
}

void optimize_for_termination(Bvh& bvh, const TerminationConfig& termination, uint32_t max_depth,
                              const BuildHooks& hooks) {
    if (termination.reinsertion_iterations > kMaxReinsertionIterations)
        throw Error("termination reinsertion iterations must be in [0, " + std::to_string(kMaxReinsertionIterations) +
                    "], got " + std::to_string(termination.reinsertion_iterations));
    if (termination.reinsertion_iterations == 0 || termination.segments.empty()) return;
    builders::ReinsertionOptions options;
    options.iterations = termination.reinsertion_iterations;
    options.max_depth = max_depth;
    options.progress = hooks.progress;
    options.cancel = hooks.cancel;
    options.segments = termination.segments;
    options.area_prior = termination.reinsertion_prior;
    builders::optimize_by_reinsertion(bvh, options);
    bvh.builder += "+topt";
}

Bvh build(const MeshView& mesh, const BuildConfig& config) {
    config.validate();
    builders::check_build_memory(mesh, config);
    const TriangleStore store(mesh);
    const std::span<const Triangle> triangles = store.triangles();
    if (triangles.empty()) throw Error("mesh '" + mesh.name() + "' has no triangles to build a BVH over");
    if (triangles.size() >= (size_t(1) << 31))
        throw Error("mesh '" + mesh.name() + "' has too many triangles (at most 2^31 - 1)");
    const builders::BuilderPreset& preset = builders::preset_of(config.preset);
    const uint32_t spaces = builders::effective_search_spaces(preset, config);
    builders::DriverOptions driver;
    driver.lookahead_depth = config.lookahead.depth;
    driver.lookahead_candidates = config.lookahead.candidates;
    driver.lookahead_top_share = config.lookahead.top_share;
    // With the optimisation, the build reports the first half of the progress and the optimiser the rest.
    const bool sampled_optimizing =
        config.termination.reinsertion_iterations > 0 && !config.termination.segments.empty();
    const bool optimizing = config.reinsertion.iterations > 0 || sampled_optimizing;
    const auto& progress = config.hooks.progress;
    driver.progress = progress;
    if (optimizing && progress) driver.progress = [progress](double fraction) { progress(0.5 * fraction); };
    driver.cancel = config.hooks.cancel;
    if (!config.termination.segments.empty() && config.termination.split_choice)
        driver.termination = &config.termination;
    const float gate = config.spatial.gate_alpha >= 0.0f ? config.spatial.gate_alpha : preset.spatial_gate_alpha;
    builders::TopDownBuilder builder(
        config.cost, {config.limits.max_leaf_size, config.limits.max_depth},
        builders::make_search_spaces(spaces, triangles, config, preset.allow_unsplitting, gate), triangles,
        std::move(driver));
    // References: one per triangle, or the pre-split pieces (within the budget).
    std::vector<builders::Reference> references;
    builders::PresplitOptions presplit;
    presplit.reference_budget = config.limits.reference_budget;
    switch (preset.presplit) {
        case builders::Presplit::none:
            references = builders::make_references(triangles);
            break;
        case builders::Presplit::early_split_clipping:
            references = builders::early_split_clipping(triangles, presplit);
            break;
        case builders::Presplit::edge_volume_heuristic:
            references = builders::edge_volume_heuristic(triangles, presplit);
            break;
    }
    // Spatial and grid splits may grow the references up to the budget; object splits never do.
    const size_t capacity = builders::splits_references(spaces, config)
                                ? size_t(double(config.limits.reference_budget) * double(triangles.size()))
                                : references.size();
    Bvh bvh = builder.build(std::move(references), capacity);
    bvh.builder = preset.name;
    if (optimizing) {
        BuildHooks hooks = config.hooks;
        if (progress) hooks.progress = [progress](double fraction) { progress(0.5 + 0.5 * fraction); };
        optimize(bvh, config.reinsertion, config.limits.max_depth, hooks);
        if (sampled_optimizing)
            optimize_for_termination(bvh, config.termination, config.limits.max_depth, {{}, hooks.cancel});
        if (progress) progress(1.0);
    }
    return bvh;
}

}  // namespace spacebvh
