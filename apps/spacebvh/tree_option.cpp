#include "tree_option.hpp"

#include <sstream>

#include "cli_common.hpp"
#include "spacebvh/tree_file.hpp"

namespace spacebvh::cli {

void TreeOption::add_to(CLI::App& command, const std::string& help) {
    CLI::Option* option = command.add_option("--tree", path, help);
    if (CLI::Option* builder = command.get_option_no_throw("--builder")) option->excludes(builder);
}

Bvh tree_for(const TreeOption& tree, const Scene& scene, const BuildOptions& options, double* milliseconds) {
    const auto start = std::chrono::steady_clock::now();
    Bvh bvh = tree.given() ? load_bvh(tree.path, scene.triangles) : build_tree(scene, options);
    if (milliseconds) *milliseconds = milliseconds_since(start);
    return bvh;
}

std::string build_settings_text(const BuildOptions& options) {
    std::ostringstream text;
    text << "builder=" << options.builder << " " << options.cost.describe() << " max_leaf=" << options.max_leaf_size
         << " max_depth=" << options.max_depth << " bins=" << options.object_bins
         << " spatial_bins=" << options.spatial_bins << " budget=" << options.reference_budget
         << " unsplitting=" << options.unsplitting << " spatial_gate=" << options.spatial_gate_alpha
         << " search=" << (options.search_spaces ? search_space_names(options.search_spaces) : "preset")
         << " grid_resolution=" << options.grid_resolution << " grid_max=" << options.grid_max_cells
         << " grid_splitting=" << options.grid_splitting << " lookahead=" << options.lookahead_depth
         << " lookahead_candidates=" << options.lookahead_candidates << " lookahead_top=" << options.lookahead_top_share
         << " spatial_sweep=" << options.exact_spatial_sweep << " sweep_samples=" << options.sweep_interior_samples
         << " reinsertion_iterations=" << options.reinsertion_iterations;
    return text.str();
}

}  // namespace spacebvh::cli
