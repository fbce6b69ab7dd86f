// SPDX-License-Identifier: MIT
#include "builders/search_spaces/search_spaces.hpp"

#include "builders/search_spaces/binned_object_split_finder.hpp"
#include "builders/search_spaces/binned_spatial_split_finder.hpp"
#include "builders/search_spaces/grid_split_finder.hpp"
#include "builders/search_spaces/object_sweep_split_finder.hpp"
#include "builders/search_spaces/spatial_sweep_split_finder.hpp"

namespace spacebvh::builders {

std::vector<std::unique_ptr<SplitFinder>> make_search_spaces(uint32_t spaces, std::span<const Triangle> triangles,
                                                             const BuildConfig& config, bool allow_unsplitting,
                                                             float spatial_gate_alpha) {
    std::vector<std::unique_ptr<SplitFinder>> finders;
    if (spaces & uint32_t(SearchSpace::object_sweep)) finders.push_back(std::make_unique<ObjectSweepSplitFinder>());
    if (spaces & uint32_t(SearchSpace::object_binned))
        finders.push_back(std::make_unique<BinnedObjectSplitFinder>(config.object.bins));
    if (spaces & uint32_t(SearchSpace::spatial_binned)) {
        SpatialSearchOptions spatial;
        spatial.bins = config.spatial.bins;
        spatial.unsplit = config.spatial.unsplitting && allow_unsplitting;
        spatial.gate_alpha = spatial_gate_alpha;
        finders.push_back(std::make_unique<BinnedSpatialSplitFinder>(triangles, spatial));
    }
    if (spaces & uint32_t(SearchSpace::spatial_sweep)) {
        SpatialSweepOptions sweep;
        sweep.unsplit = config.spatial.unsplitting && allow_unsplitting;
        sweep.interior_samples = config.spatial.sweep_interior_samples;
        sweep.gate_alpha = spatial_gate_alpha;
        finders.push_back(std::make_unique<SpatialSweepSplitFinder>(triangles, sweep));
    }
    if (spaces & uint32_t(SearchSpace::grid)) {
        GridSearchOptions grid;
        grid.resolution = config.grid.resolution;
        grid.max_cells = config.grid.max_cells;
        grid.split_primitives = config.grid.splitting;
        finders.push_back(std::make_unique<GridSplitFinder>(triangles, grid));
    }
    return finders;
}

uint32_t effective_search_spaces(const BuilderPreset& preset, const BuildConfig& config) {
    uint32_t spaces = config.search_spaces ? config.search_spaces : preset.search_spaces;
    // The exact sweep instead of bins: the same planes' rule, every event a candidate.
    if (config.spatial.exact_sweep && (spaces & uint32_t(SearchSpace::spatial_binned)))
        spaces = (spaces & ~uint32_t(SearchSpace::spatial_binned)) | uint32_t(SearchSpace::spatial_sweep);
    return spaces;
}

bool splits_references(uint32_t spaces, const BuildConfig& config) {
    return (spaces & (SearchSpace::spatial_binned | SearchSpace::spatial_sweep)) ||
           ((spaces & uint32_t(SearchSpace::grid)) && config.grid.splitting);
}

}  // namespace spacebvh::builders
