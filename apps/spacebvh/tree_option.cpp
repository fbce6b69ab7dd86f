// SPDX-License-Identifier: MIT
#include "tree_option.hpp"

#include <sstream>

#include "cli_common.hpp"

namespace spacebvh::cli {

void TreeOption::add_to(CLI::App& command, const std::string& help) {
    CLI::Option* option = command.add_option("--tree", path, help);
    for (const char* name : {"--builder", "--quality"})
        if (CLI::Option* other = command.get_option_no_throw(name)) option->excludes(other);
}

Bvh tree_for(const TreeOption& tree, const Scene& scene, const TreeRecipe& options, double* milliseconds) {
    const auto start = std::chrono::steady_clock::now();
    Bvh bvh = build_tree(scene, tree.given() ? TreeRecipe::from_file(tree.path) : options);
    if (milliseconds) *milliseconds = milliseconds_since(start);
    return bvh;
}

std::string build_settings_text(const TreeRecipe& options) {
    std::ostringstream text;
    text << "builder=" << options.builder << " " << options.cost.describe()
         << " max_leaf=" << options.limits.max_leaf_size << " max_depth=" << options.limits.max_depth
         << " bins=" << options.object.bins << " spatial_bins=" << options.spatial.bins
         << " budget=" << options.limits.reference_budget << " unsplitting=" << options.spatial.unsplitting
         << " spatial_gate=" << options.spatial.gate_alpha
         << " search=" << (options.search_spaces ? search_space_names(options.search_spaces) : "preset")
         << " grid_resolution=" << options.grid.resolution << " grid_max=" << options.grid.max_cells
         << " grid_splitting=" << options.grid.splitting << " lookahead=" << options.lookahead.depth
         << " lookahead_candidates=" << options.lookahead.candidates << " lookahead_top=" << options.lookahead.top_share
         << " spatial_sweep=" << options.spatial.exact_sweep
         << " sweep_samples=" << options.spatial.sweep_interior_samples
         << " reinsertion_iterations=" << options.reinsertion.iterations;
    return text.str();
}

}  // namespace spacebvh::cli
