// SPDX-License-Identifier: MIT
#include "builder_spec.hpp"

#include "spacebvh/presets.hpp"

namespace spacebvh::cli {

BuilderSpec parse_builder_spec(const std::string& text, const BuildCliOptions& defaults) {
    const size_t at = text.find('@');
    BuilderSpec spec{text, defaults.options(text.substr(0, at))};
    if (at != std::string::npos) {
        for (const std::string& setting : CLI::detail::split(text.substr(at + 1), ';')) {
            const size_t equals = setting.find('=');
            if (equals == std::string::npos) throw Error("builder '" + text + "': expected key=value after '@'");
            const std::string key = setting.substr(0, equals), value = setting.substr(equals + 1);
            if (key == "co")
                spec.options.cost.overlap_penalty = parse_float_or_inf(value, "co");
            else if (key == "ct")
                spec.options.cost.traversal_cost = parse_float_or_inf(value, "ct");
            else if (key == "ci")
                spec.options.cost.intersection_cost = parse_float_or_inf(value, "ci");
            else if (key == "leaf")
                spec.options.limits.max_leaf_size = parse_unsigned(value, "leaf");
            else if (key == "block")
                spec.options.cost.leaf_block = parse_unsigned(value, "block");
            else if (key == "budget")
                spec.options.limits.reference_budget = parse_float_or_inf(value, "budget");
            else if (key == "bins")
                spec.options.object.bins = parse_unsigned(value, "bins");
            else if (key == "spatialbins")
                spec.options.spatial.bins = parse_unsigned(value, "spatialbins");
            else if (key == "gate")
                spec.options.spatial.gate_alpha = parse_float_or_inf(value, "gate");
            else if (key == "search")
                spec.options.search_spaces = parse_search_spaces(value);
            else if (key == "grid")
                spec.options.grid.resolution = parse_float_or_inf(value, "grid");
            else if (key == "gridmax")
                spec.options.grid.max_cells = parse_unsigned(value, "gridmax");
            else if (key == "lookahead")
                spec.options.lookahead.depth = parse_unsigned(value, "lookahead");
            else if (key == "candidates")
                spec.options.lookahead.candidates = parse_unsigned(value, "candidates");
            else if (key == "top")
                spec.options.lookahead.top_share = parse_float_or_inf(value, "top");
            else if (key == "sweep")
                spec.options.spatial.exact_sweep = parse_unsigned(value, "sweep") != 0;
            else if (key == "samples")
                spec.options.spatial.sweep_interior_samples = parse_unsigned(value, "samples");
            else if (key == "optimize")
                spec.options.reinsertion.iterations = parse_unsigned(value, "optimize");
            else if (key == "trays")
                spec.options.termination_rays = parse_unsigned(value, "trays");
            else if (key == "tn0")
                spec.options.termination.shrinkage = parse_float_or_inf(value, "tn0");
            else if (key == "tcand")
                spec.options.termination.candidates = parse_unsigned(value, "tcand");
            else if (key == "tsplit")
                spec.options.termination.split_choice = parse_unsigned(value, "tsplit") != 0;
            else if (key == "topt")
                spec.options.termination.reinsertion_iterations = parse_unsigned(value, "topt");
            else if (key == "tprior")
                spec.options.termination.reinsertion_prior = parse_float_or_inf(value, "tprior");
            else
                throw Error(
                    "builder '" + text + "': unknown setting '" + key +
                    "' (co, ct, ci, leaf, block, budget, bins, spatialbins, gate, search, grid, gridmax, lookahead, "
                    "candidates, top, sweep, samples, optimize, trays, tn0, tcand, tsplit, topt, tprior)");
        }
        spec.options.validate();
        if (spec.options.termination.reinsertion_iterations > 0 && spec.options.termination_rays == 0)
            throw Error("builder '" + text + "': topt needs trays (the segments it prices nodes by)");
    }
    std::string name = text.substr(0, at);
    strip_optimize_suffix(name);
    spec.label = name + (spec.options.reinsertion.iterations > 0 ? "+opt" : "") +
                 (at == std::string::npos ? "" : text.substr(at));
    return spec;
}

}  // namespace spacebvh::cli
