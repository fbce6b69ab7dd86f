// SPDX-License-Identifier: MIT
// Every build setting once: its three spellings, type, range (as validate() enforces it), an example
// value, one line of help, and its field of the recipe. The command line lists them in this order.
#include "builders/settings_table.hpp"

#include <limits>

#include "builders/driver/split.hpp"
#include "builders/search_spaces/grid_split_finder.hpp"

namespace spacebvh::builders {
namespace {

constexpr double kUnbounded = std::numeric_limits<double>::infinity();
constexpr double kMaxWhole = double(std::numeric_limits<uint32_t>::max());
constexpr double kMaxBytes = double(std::numeric_limits<uint64_t>::max());

using T = SettingType;

// The cost model, the limits and the bins.
std::vector<SettingEntry> cost_and_limit_entries() {
    return {
        {{.name = "traversal_cost",
          .flag = "--ct",
          .row_key = "ct",
          .type = T::number,
          .max = kUnbounded,
          .example = "2",
          .help = "C_T, cost of a traversal step"},
         FloatField{[](TreeRecipe& r) -> float& { return r.cost.traversal_cost; }}},
        {{.name = "intersection_cost",
          .flag = "--ci",
          .row_key = "ci",
          .type = T::number,
          .max = kUnbounded,
          .min_exclusive = true,
          .example = "2",
          .help = "C_I, cost of a triangle test"},
         FloatField{[](TreeRecipe& r) -> float& { return r.cost.intersection_cost; }}},
        {{.name = "leaf_block",
          .flag = "--leaf-block",
          .row_key = "block",
          .type = T::whole,
          .min = 1,
          .max = 64,
          .range_note = "a power of two",
          .example = "4",
          .help =
              "B: the SAH counts references in whole blocks of B (a power of two; 4 = the kernels' packs of four, as "
              "Embree's SAH; 1 = plain SAH)"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.cost.leaf_block; }}},
        {{.name = "overlap_penalty",
          .flag = "--co",
          .row_key = "co",
          .type = T::number,
          .max = kUnbounded,
          .allows_infinity = true,
          .builder_default = true,
          .example = "0.5",
          .help = "C_o, overlap penalty (0 = plain SAH, inf = disjoint children only)"},
         FloatField{[](TreeRecipe& r) -> float& { return r.cost.overlap_penalty; }}},
        {{.name = "max_leaf_size",
          .flag = "--max-leaf",
          .row_key = "leaf",
          .type = T::whole,
          .min = 1,
          .max = 1 << 20,
          .example = "4",
          .help = "largest leaf (nodes with more references are split)"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.limits.max_leaf_size; }}},
        {{.name = "max_depth",
          .flag = "--max-depth",
          .row_key = "maxdepth",
          .type = T::whole,
          .min = 1,
          .max = 1024,
          .example = "32",
          .help = "deepest level; nodes there become leaves"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.limits.max_depth; }}},
        {{.name = "object_bins",
          .flag = "--bins",
          .row_key = "bins",
          .type = T::whole,
          .min = 2,
          .max = kMaxObjectBins,
          .example = "16",
          .help = "bins per axis of the binned object search space"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.object.bins; }}},
        {{.name = "spatial_bins",
          .flag = "--spatial-bins",
          .row_key = "spatialbins",
          .type = T::whole,
          .min = 2,
          .max = 1024,
          .example = "16",
          .help = "bins per axis of the spatial search space"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.spatial.bins; }}},
        {{.name = "reference_budget",
          .flag = "--budget",
          .row_key = "budget",
          .type = T::number,
          .min = 1,
          .max = 4,
          .example = "1.5",
          .help = "reference budget of spatial splits and pre-splitting, x triangles"},
         FloatField{[](TreeRecipe& r) -> float& { return r.limits.reference_budget; }}},
    };
}

// The memory limit, and how the spatial and grid search spaces search.
std::vector<SettingEntry> search_entries() {
    return {
        {{.name = "memory_limit",
          .flag = "--memory-limit",
          .row_key = "memory",
          .type = T::bytes,
          .max = kMaxBytes,
          .example = "64G",
          .help = "refuse, before starting, a build whose estimated peak memory exceeds this many bytes (0 = the "
                  "memory available, MemAvailable)"},
         BytesField{[](TreeRecipe& r) -> uint64_t& { return r.limits.memory_limit_bytes; }}},
        {{.name = "spatial_gate",
          .flag = "--spatial-gate",
          .row_key = "gate",
          .type = T::number,
          .max = 1,
          .range_note = "negative: the builder's own",
          .builder_default = true,
          .ours_only = true,
          .example = "0.001",
          .help = "try spatial planes only where the best object split's children overlap by at least this "
                  "fraction of the root's surface area (0 = everywhere)"},
         FloatField{[](TreeRecipe& r) -> float& { return r.spatial.gate_alpha; }}},
        {{.name = "unsplitting",
          .flag = "--no-unsplitting",
          .row_key = "unsplitting",
          .type = T::flag,
          .example = "0",
          .help = "reference unsplitting in spatial splits (off: every straddling reference is clipped into "
                  "both children)"},
         FlagField{[](TreeRecipe& r) -> bool& { return r.spatial.unsplitting; }}},
        {{.name = "search",
          .flag = "--search",
          .row_key = "search",
          .type = T::search_spaces,
          .builder_default = true,
          .ours_only = true,
          .example = "binned+spatial",
          .help = "search spaces combined at every node, any union of: object (exact SAH sweep), binned (binned "
                  "object SAH), spatial (kd planes, clipping), spatial-sweep (kd planes at every event), grid "
                  "(child boxes on a grid); e.g. object,spatial,grid"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.search_spaces; }}},
        {{.name = "grid_resolution",
          .flag = "--grid-resolution",
          .row_key = "grid",
          .type = T::number,
          .max = 64,
          .min_exclusive = true,
          .example = "2",
          .help = "R of the grid search space: G = ceil(R * N^(1/6)) cells per axis for a node of N references"},
         FloatField{[](TreeRecipe& r) -> float& { return r.grid.resolution; }}},
        {{.name = "grid_max_cells",
          .flag = "--grid-max",
          .row_key = "gridmax",
          .type = T::whole,
          .min = 2,
          .max = kMaxGridCells,
          .example = "4",
          .help = "largest G of the grid search space (work per node ~26 G^6)"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.grid.max_cells; }}},
        {{.name = "grid_splitting",
          .flag = "--no-grid-splitting",
          .row_key = "gridsplitting",
          .type = T::flag,
          .example = "0",
          .help = "primitive splitting in the grid search space (off: a reference in neither child box is "
                  "infeasible)"},
         FlagField{[](TreeRecipe& r) -> bool& { return r.grid.splitting; }}},
    };
}

// Recursive cost evaluation, and the spatial sweep.
std::vector<SettingEntry> lookahead_and_sweep_entries() {
    return {
        {{.name = "lookahead_depth",
          .flag = "--lookahead",
          .row_key = "lookahead",
          .type = T::whole,
          .max = kMaxLookaheadDepth,
          .ours_only = true,
          .example = "1",
          .help = "recursive cost evaluation: choose each split by the SAH of the subtree built this many levels "
                  "below it (0 = greedy; slower, about 1 + depth x candidates times the search)"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.lookahead.depth; }}},
        {{.name = "lookahead_candidates",
          .flag = "--lookahead-candidates",
          .row_key = "candidates",
          .type = T::whole,
          .min = 1,
          .max = 16,
          .example = "3",
          .help = "candidates the lookahead compares: the cheapest splits per axis and search space"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.lookahead.candidates; }}},
        {{.name = "lookahead_top",
          .flag = "--lookahead-top",
          .row_key = "top",
          .type = T::number,
          .max = 1,
          .range_note = "0 = off, else at least 0.01",
          .ours_only = true,
          .example = "0.25",
          .help = "recursive cost evaluation to the leaves at the top of the tree: nodes holding at least this "
                  "share of the root's references take the search space whose cheapest split leads to the subtree "
                  "of lowest SAH, each built out greedily (0 = off; about one build per search space and level of "
                  "such nodes)"},
         FloatField{[](TreeRecipe& r) -> float& { return r.lookahead.top_share; }}},
        {{.name = "spatial_sweep",
          .flag = "--spatial-sweep",
          .row_key = "sweep",
          .type = T::flag,
          .example = "1",
          .help = "kd planes at every reference bound with exact child boxes (the sweep) instead of on "
                  "{spatial_bins} bins"},
         FlagField{[](TreeRecipe& r) -> bool& { return r.spatial.exact_sweep; }}},
        {{.name = "sweep_samples",
          .flag = "--sweep-samples",
          .row_key = "samples",
          .type = T::whole,
          .max = 64,
          .example = "4",
          .help = "spatial sweep: positions sampled inside the intervals next to the best event planes (0 = events "
                  "only)"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.spatial.sweep_interior_samples; }}},
    };
}

// The termination-aware build and reinsertion after the build.
std::vector<SettingEntry> termination_and_reinsertion_entries() {
    return {
        {{.name = "termination_rays",
          .flag = "--termination-rays",
          .row_key = "trays",
          .type = T::whole,
          .max = kMaxWhole,
          .ours_only = true,
          .example = "2000",
          .help = "termination-aware split choice: trace this many bounce rays on a quick tree and choose splits "
                  "by the share of their segments (each ending at its first hit) that meets each child, where at "
                  "least 8 reach a node (0 = off)"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.termination_rays; }}},
        {{.name = "termination_shrinkage",
          .flag = "--termination-shrinkage",
          .row_key = "tn0",
          .type = T::number,
          .max = kUnbounded,
          .example = "8",
          .help = "n_0 of the blend: a node met by n segments weighs the sampled cost n / (n + n_0)"},
         FloatField{[](TreeRecipe& r) -> float& { return r.termination.shrinkage; }}},
        {{.name = "termination_candidates",
          .flag = "--termination-candidates",
          .row_key = "tcand",
          .type = T::whole,
          .min = 1,
          .max = 16,
          .example = "2",
          .help = "cheapest splits per axis and search space the termination-aware cost chooses among"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.termination.candidates; }}},
        {{.name = "termination_split",
          .flag = "--no-termination-split",
          .row_key = "tsplit",
          .type = T::flag,
          .example = "0",
          .help = "the termination rays choose splits (off: they serve {termination_optimize} only, traced on the "
                  "built tree itself, and the cost model chooses every split)"},
         FlagField{[](TreeRecipe& r) -> bool& { return r.termination.split_choice; }}},
        {{.name = "termination_optimize",
          .flag = "--termination-optimize",
          .row_key = "topt",
          .type = T::whole,
          .max = kMaxReinsertionIterations,
          .example = "4",
          .help = "after the build, this many reinsertion iterations that price each inner node by the "
                  "termination rays' segments meeting its box plus {termination_prior} pseudo-rays spread by area "
                  "(needs {termination_rays}; 0 = off)"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.termination.reinsertion_iterations; }}},
        {{.name = "termination_prior",
          .flag = "--termination-prior",
          .row_key = "tprior",
          .type = T::number,
          .max = kUnbounded,
          .example = "16",
          .help = "{termination_optimize}: pseudo-rays spread by area (the SAH's share of the price)"},
         FloatField{[](TreeRecipe& r) -> float& { return r.termination.reinsertion_prior; }}},
        {{.name = "optimize",
          .flag = "--optimize-iterations",
          .row_key = "optimize",
          .type = T::whole,
          .max = kMaxReinsertionIterations,
          .example = "4",
          .help = "after the build, move subtrees to where they lower the tree SAH (reinsertion, Bittner et al. "
                  "2013): at most this many batches of moves, each searching 5 % of the nodes (the largest not yet "
                  "settled), stopping once 20 batches in a row gain < 0.01 %; leaves stay as built (0 = off)"},
         UintField{[](TreeRecipe& r) -> uint32_t& { return r.reinsertion.iterations; }}},
    };
}

}  // namespace

const std::vector<SettingEntry>& setting_entries() {
    static const std::vector<SettingEntry> entries = [] {
        std::vector<SettingEntry> all = cost_and_limit_entries();
        for (auto group : {search_entries, lookahead_and_sweep_entries, termination_and_reinsertion_entries}) {
            std::vector<SettingEntry> more = group();
            all.insert(all.end(), more.begin(), more.end());
        }
        return all;
    }();
    return entries;
}

}  // namespace spacebvh::builders
