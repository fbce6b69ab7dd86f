// SPDX-License-Identifier: MIT
// BuildConfig: the presets' defaults, the quality levels, and the range of every setting.
#include <string>

#include "builders/search_spaces/binned_object_split_finder.hpp"
#include "builders/search_spaces/grid_split_finder.hpp"
#include "builders/preset_table.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh {
namespace {

constexpr uint32_t kKnownSearchSpaces = SearchSpace::object_sweep | SearchSpace::object_binned |
                                        SearchSpace::spatial_binned | SearchSpace::spatial_sweep |
                                        uint32_t(SearchSpace::grid);

constexpr bool presets_in_enum_order() {
    for (size_t i = 0; i < builders::kPresetCount; ++i)
        if (uint32_t(builders::kPresets[i].preset) != i) return false;
    return true;
}
static_assert(presets_in_enum_order(), "kPresets must list the presets in Preset order");

void require(bool ok, const std::string& message) {
    if (!ok) throw Error(message);
}

}  // namespace

const char* to_string(Preset preset) {
    return uint32_t(preset) < builders::kPresetCount ? builders::preset_of(preset).name : "?";
}

BuildConfig BuildConfig::for_preset(Preset preset) {
    BuildConfig config;
    config.preset = preset;
    require(uint32_t(preset) < builders::kPresetCount, "unknown preset " + std::to_string(uint32_t(preset)));
    config.cost.overlap_penalty = builders::preset_of(preset).overlap_penalty;
    return config;
}

BuildConfig BuildConfig::for_quality(Quality quality) {
    switch (quality) {
        case Quality::fast:
            return for_preset(Preset::binned);
        case Quality::balanced: {
            BuildConfig config = for_preset(Preset::spatial);
            config.search_spaces = SearchSpace::object_binned | SearchSpace::spatial_binned;
            return config;
        }
        case Quality::high: {
            BuildConfig config = for_preset(Preset::spatial);
            config.reinsertion.iterations = kDefaultReinsertionIterations;
            return config;
        }
    }
    throw Error("unknown quality level " + std::to_string(int(quality)));
}

void BuildConfig::validate() const {
    require(uint32_t(preset) < builders::kPresetCount, "unknown preset " + std::to_string(uint32_t(preset)));
    cost.validate();
    require(termination.shrinkage >= 0.0f && termination.shrinkage < kInfinity,
            "termination shrinkage must be finite and >= 0, got " + std::to_string(termination.shrinkage));
    require(
        termination.reinsertion_prior >= 0.0f && termination.reinsertion_prior < kInfinity,
        "termination reinsertion prior must be finite and >= 0, got " + std::to_string(termination.reinsertion_prior));
    require(termination.reinsertion_iterations <= kMaxReinsertionIterations,
            "termination reinsertion iterations must be in [0, " + std::to_string(kMaxReinsertionIterations) +
                "], got " + std::to_string(termination.reinsertion_iterations));
    require(termination.min_rays >= 1, "termination min rays must be at least 1");
    require(termination.candidates >= 1 && termination.candidates <= 16,
            "termination candidates must be in [1, 16], got " + std::to_string(termination.candidates));
    for (size_t i = 0; i < termination.segments.size(); ++i) {
        const Ray& segment = termination.segments[i];
        require(is_finite(segment.org) && is_finite(segment.dir) && !(segment.dir == Vec3(0.0f)) &&
                    segment.tmin >= 0.0f && !(segment.tmax < segment.tmin),
                "termination segment " + std::to_string(i) +
                    " has a non-finite origin or direction, a zero direction or an empty t range");
    }
    require(limits.max_leaf_size >= 1 && limits.max_leaf_size <= (1u << 20),
            "max leaf size must be in [1, 1048576], got " + std::to_string(limits.max_leaf_size));
    require(limits.max_depth >= 1 && limits.max_depth <= 1024,
            "max depth must be in [1, 1024], got " + std::to_string(limits.max_depth));
    require(limits.reference_budget >= 1.0f && limits.reference_budget <= 4.0f,
            "reference budget must be in [1, 4] (a multiple of the triangle count), got " +
                std::to_string(limits.reference_budget));
    require(!(search_spaces & ~kKnownSearchSpaces), "search spaces: unknown bits in " + std::to_string(search_spaces) +
                                                        " (known: object, binned, spatial, spatial-sweep, grid)");
    require(object.bins >= 2 && object.bins <= builders::kMaxObjectBins, "object bins must be in [2, " +
                                                                             std::to_string(builders::kMaxObjectBins) +
                                                                             "], got " + std::to_string(object.bins));
    require(spatial.bins >= 2 && spatial.bins <= 1024,
            "spatial bins must be in [2, 1024], got " + std::to_string(spatial.bins));
    require(spatial.gate_alpha < 0.0f || spatial.gate_alpha <= 1.0f,
            "spatial gate alpha must be in [0, 1] (or negative for the preset's own), got " +
                std::to_string(spatial.gate_alpha));
    require(spatial.sweep_interior_samples <= 64,
            "sweep interior samples must be in [0, 64], got " + std::to_string(spatial.sweep_interior_samples));
    require(grid.resolution > 0.0f && grid.resolution <= 64.0f,
            "grid resolution R must be in (0, 64], got " + std::to_string(grid.resolution));
    require(grid.max_cells >= 2 && grid.max_cells <= builders::kMaxGridCells,
            "grid max cells must be in [2, " + std::to_string(builders::kMaxGridCells) + "], got " +
                std::to_string(grid.max_cells));
    require(lookahead.depth <= kMaxLookaheadDepth, "lookahead depth must be in [0, " +
                                                       std::to_string(kMaxLookaheadDepth) + "], got " +
                                                       std::to_string(lookahead.depth));
    require(lookahead.candidates >= 1 && lookahead.candidates <= 16,
            "lookahead candidates (per axis and search space) must be in [1, 16], got " +
                std::to_string(lookahead.candidates));
    require(
        lookahead.top_share == 0.0f || (lookahead.top_share >= kMinLookaheadTopShare && lookahead.top_share <= 1.0f),
        "lookahead top share must be 0 (off) or in [" + std::to_string(kMinLookaheadTopShare) +
            ", 1] (a share of the root's references), got " + std::to_string(lookahead.top_share));
    require(reinsertion.iterations <= kMaxReinsertionIterations,
            "reinsertion iterations must be in [0, " + std::to_string(kMaxReinsertionIterations) +
                "] (0 = no optimisation), got " + std::to_string(reinsertion.iterations));
}

}  // namespace spacebvh
