// The named builders: each is a preset of the generic driver (search spaces + cost model).
#include <algorithm>
#include <sstream>

#include "builders/binned_object_split_finder.hpp"
#include "builders/binned_spatial_split_finder.hpp"
#include "builders/grid_split_finder.hpp"
#include "builders/object_sweep_split_finder.hpp"
#include "builders/presplit.hpp"
#include "builders/reinsertion_optimizer.hpp"
#include "builders/search_spaces.hpp"
#include "builders/spatial_sweep_split_finder.hpp"
#include "builders/top_down_builder.hpp"
#include "spacebvh/bvh.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh {
namespace {

enum class Presplit { none, early_split_clipping, edge_volume_heuristic };

struct BuilderPreset {
    const char* name;
    uint32_t search_spaces;
    Presplit presplit;
    float overlap_penalty;     // default C_o
    bool allow_unsplitting;    // kdbvh keeps children disjoint, so never unsplits
    float spatial_gate_alpha;  // try spatial splits only above this overlap area / SA(root)
    const char* description;
};

constexpr float kInf = kInfinity;
constexpr BuilderPreset kPresets[] = {
    {"cbvh", uint32_t(SearchSpace::object_sweep), Presplit::none, 0.0f, false, 0.0f,
     "classical BVH: exact SAH sweep over centroid-sorted references on all three axes (Popov et al.'s CBVH)"},
    {"binned", uint32_t(SearchSpace::object_binned), Presplit::none, 0.0f, false, 0.0f,
     "binned object SAH (Wald 2007), --bins bins per axis; the fast classical builder"},
    {"kdbvh", uint32_t(SearchSpace::spatial_binned), Presplit::none, kInf, false, 0.0f,
     "spatial (kd) search space only: planes on --spatial-bins bins, straddlers clipped; disjoint children (KDBVH)"},
    {"spatial", SearchSpace::object_sweep | SearchSpace::spatial_binned, Presplit::none, 1.0f, true, 1e-4f,
     "object sweep + spatial planes chosen by the overlap-penalised SAH (--co), with unsplitting, spatial tried when object overlap >= 1e-4 SA(root): the practical builder (fast variant: --search binned,spatial)"},
    {"sbvh", SearchSpace::object_sweep | SearchSpace::spatial_binned, Presplit::none, 0.0f, true, 1e-5f,
     "SBVH (Stich et al. 2009): object sweep + binned spatial with unsplitting, spatial tried when object overlap >= 1e-5 SA(root)"},
    {"esc", uint32_t(SearchSpace::object_sweep), Presplit::early_split_clipping, 0.0f, false, 0.0f,
     "early split clipping (Ernst & Greiner 2007) pre-splits references within the budget, then the cbvh search"},
    {"evh", uint32_t(SearchSpace::object_sweep), Presplit::edge_volume_heuristic, 0.0f, false, 0.0f,
     "edge volume heuristic (Dammertz & Keller 2008, t = 14) pre-splits triangles within the budget, then the cbvh search"},
    {"full", SearchSpace::object_sweep | SearchSpace::spatial_binned | SearchSpace::grid, Presplit::none, kInf, false,
     0.0f,
     "Popov et al.'s Full search: grid (--grid-resolution, --grid-max) + kd planes + object sweep, C_o = inf"},
};

struct SearchSpaceName {
    const char* name;
    SearchSpace space;
};
constexpr SearchSpaceName kSearchSpaceNames[] = {
    {"object", SearchSpace::object_sweep},
    {"binned", SearchSpace::object_binned},
    {"spatial", SearchSpace::spatial_binned},
    {"spatial-sweep", SearchSpace::spatial_sweep},
    {"grid", SearchSpace::grid},
};
constexpr uint32_t kKnownSearchSpaces = SearchSpace::object_sweep | SearchSpace::object_binned |
                                        SearchSpace::spatial_binned | SearchSpace::spatial_sweep |
                                        uint32_t(SearchSpace::grid);

const BuilderPreset* find_preset(const std::string& name) {
    for (const BuilderPreset& preset : kPresets)
        if (name == preset.name) return &preset;
    return nullptr;
}

uint32_t search_spaces_of(const BuilderPreset& preset, const BuildOptions& options) {
    uint32_t spaces = options.search_spaces ? options.search_spaces : preset.search_spaces;
    // The exact sweep instead of bins: same planes' rule, every event a candidate (bench/SWEEP_RESULTS.md).
    if (options.exact_spatial_sweep && (spaces & uint32_t(SearchSpace::spatial_binned)))
        spaces = (spaces & ~uint32_t(SearchSpace::spatial_binned)) | uint32_t(SearchSpace::spatial_sweep);
    return spaces;
}

}  // namespace

namespace builders {

std::vector<std::unique_ptr<SplitFinder>> make_search_spaces(uint32_t spaces, std::span<const Triangle> triangles,
                                                             const BuildOptions& options, bool allow_unsplitting,
                                                             float spatial_gate_alpha) {
    std::vector<std::unique_ptr<SplitFinder>> finders;
    if (spaces & uint32_t(SearchSpace::object_sweep)) finders.push_back(std::make_unique<ObjectSweepSplitFinder>());
    if (spaces & uint32_t(SearchSpace::object_binned))
        finders.push_back(std::make_unique<BinnedObjectSplitFinder>(options.object_bins));
    if (spaces & uint32_t(SearchSpace::spatial_binned)) {
        SpatialSearchOptions spatial;
        spatial.bins = options.spatial_bins;
        spatial.unsplit = options.unsplitting && allow_unsplitting;
        spatial.gate_alpha = spatial_gate_alpha;
        finders.push_back(std::make_unique<BinnedSpatialSplitFinder>(triangles, spatial));
    }
    if (spaces & uint32_t(SearchSpace::spatial_sweep)) {
        SpatialSweepOptions sweep;
        sweep.unsplit = options.unsplitting && allow_unsplitting;
        sweep.interior_samples = options.sweep_interior_samples;
        sweep.gate_alpha = spatial_gate_alpha;
        finders.push_back(std::make_unique<SpatialSweepSplitFinder>(triangles, sweep));
    }
    if (spaces & uint32_t(SearchSpace::grid)) {
        GridSearchOptions grid;
        grid.resolution = options.grid_resolution;
        grid.max_cells = options.grid_max_cells;
        grid.split_primitives = options.grid_splitting;
        finders.push_back(std::make_unique<GridSplitFinder>(triangles, grid));
    }
    return finders;
}

bool splits_references(uint32_t spaces, const BuildOptions& options) {
    return (spaces & (SearchSpace::spatial_binned | SearchSpace::spatial_sweep)) ||
           ((spaces & uint32_t(SearchSpace::grid)) && options.grid_splitting);
}

}  // namespace build

uint32_t parse_search_spaces(const std::string& names) {
    uint32_t spaces = 0;
    std::string name;
    auto take = [&] {
        if (name.empty()) return;
        const auto known = std::find_if(std::begin(kSearchSpaceNames), std::end(kSearchSpaceNames),
                                        [&](const SearchSpaceName& entry) { return name == entry.name; });
        if (known == std::end(kSearchSpaceNames))
            throw Error("unknown search space '" + name + "' in '" + names + "' (known: object, binned, spatial, spatial-sweep, grid)");
        spaces |= uint32_t(known->space);
        name.clear();
    };
    for (char c : names) {
        if (c == ',' || c == '+') take();
        else if (c != ' ') name += c;
    }
    take();
    if (spaces == 0) throw Error("empty list of search spaces '" + names + "' (known: object, binned, spatial, spatial-sweep, grid)");
    return spaces;
}

std::string search_space_names(uint32_t spaces) {
    std::string names;
    for (const SearchSpaceName& entry : kSearchSpaceNames)
        if (spaces & uint32_t(entry.space)) names += (names.empty() ? "" : "+") + std::string(entry.name);
    return names;
}

std::vector<std::string> builder_names() {
    std::vector<std::string> names;
    for (const BuilderPreset& preset : kPresets) names.emplace_back(preset.name);
    return names;
}

BuildOptions options_for(const std::string& builder) {
    const BuilderPreset* preset = find_preset(builder);
    BuildOptions options;
    options.builder = builder;
    if (!preset) options.validate();  // throws the unknown-builder error
    options.cost.overlap_penalty = preset->overlap_penalty;
    return options;
}

std::string describe_builder(const std::string& name) {
    const BuilderPreset* preset = find_preset(name);
    return preset ? preset->description : "";
}

void BuildOptions::validate() const {
    if (!find_preset(builder)) {
        std::ostringstream message;
        message << "unknown builder '" << builder << "'; known builders:";
        for (const BuilderPreset& preset : kPresets) message << ' ' << preset.name;
        throw Error(message.str());
    }
    cost.validate();
    if (max_leaf_size < 1 || max_leaf_size > (1u << 20))
        throw Error("max leaf size must be in [1, 1048576], got " + std::to_string(max_leaf_size));
    if (max_depth < 1 || max_depth > 1024)
        throw Error("max depth must be in [1, 1024], got " + std::to_string(max_depth));
    if (spatial_bins < 2 || spatial_bins > 1024)
        throw Error("spatial bins must be in [2, 1024], got " + std::to_string(spatial_bins));
    if (!(spatial_gate_alpha < 0.0f || spatial_gate_alpha <= 1.0f))
        throw Error("spatial gate alpha must be in [0, 1] (or negative for the builder's own), got " +
                    std::to_string(spatial_gate_alpha));
    if (!(reference_budget >= 1.0f && reference_budget <= 4.0f))
        throw Error("reference budget must be in [1, 4] (a multiple of the triangle count), got " +
                    std::to_string(reference_budget));
    if (search_spaces & ~kKnownSearchSpaces)
        throw Error("search spaces: unknown bits in " + std::to_string(search_spaces) + " (known: object, binned, spatial, spatial-sweep, grid)");
    if (!(grid_resolution > 0.0f && grid_resolution <= 64.0f))
        throw Error("grid resolution R must be in (0, 64], got " + std::to_string(grid_resolution));
    if (grid_max_cells < 2 || grid_max_cells > builders::kMaxGridCells)
        throw Error("grid max cells must be in [2, " + std::to_string(builders::kMaxGridCells) + "], got " +
                    std::to_string(grid_max_cells));
    if (lookahead_depth > kMaxLookaheadDepth)
        throw Error("lookahead depth must be in [0, " + std::to_string(kMaxLookaheadDepth) + "], got " +
                    std::to_string(lookahead_depth));
    if (!(lookahead_top_share == 0.0f || (lookahead_top_share >= kMinLookaheadTopShare && lookahead_top_share <= 1.0f)))
        throw Error("lookahead top share must be 0 (off) or in [" + std::to_string(kMinLookaheadTopShare) +
                    ", 1] (a share of the root's references), got " + std::to_string(lookahead_top_share));
    if (sweep_interior_samples > 64)
        throw Error("sweep interior samples must be in [0, 64], got " + std::to_string(sweep_interior_samples));
    if (lookahead_candidates < 1 || lookahead_candidates > 16)
        throw Error("lookahead candidates (per axis and search space) must be in [1, 16], got " +
                    std::to_string(lookahead_candidates));
    if (object_bins < 2 || object_bins > builders::kMaxObjectBins)
        throw Error("object bins must be in [2, " + std::to_string(builders::kMaxObjectBins) + "], got " +
                    std::to_string(object_bins));
    if (reinsertion_iterations > kMaxReinsertionIterations)
        throw Error("reinsertion iterations must be in [0, " + std::to_string(kMaxReinsertionIterations) +
                    "] (0 = no optimisation), got " + std::to_string(reinsertion_iterations));
}

void optimize_bvh(Bvh& bvh, const BuildOptions& options) {
    if (options.reinsertion_iterations == 0) return;
    builders::ReinsertionOptions reinsertion;
    reinsertion.iterations = options.reinsertion_iterations;
    reinsertion.max_depth = options.max_depth;
    reinsertion.progress = options.progress;
    reinsertion.cancel = options.cancel;
    builders::optimize_by_reinsertion(bvh, reinsertion);
    bvh.builder += "+opt";
}

Bvh build_bvh(const Scene& scene, const BuildOptions& options) {
    options.validate();
    if (scene.triangles.empty()) throw Error("scene '" + scene.name + "' has no triangles to build a BVH over");
    if (scene.triangles.size() >= (size_t(1) << 31))
        throw Error("scene '" + scene.name + "' has too many triangles (at most 2^31 - 1)");
    const BuilderPreset& preset = *find_preset(options.builder);
    const uint32_t spaces = search_spaces_of(preset, options);
    builders::DriverOptions driver;
    driver.lookahead_depth = options.lookahead_depth;
    driver.lookahead_candidates = options.lookahead_candidates;
    driver.lookahead_top_share = options.lookahead_top_share;
    // With the optimisation, the build reports the first half of the progress and the optimiser the rest.
    const bool optimizing = options.reinsertion_iterations > 0;
    driver.progress = options.progress;
    if (optimizing && options.progress)
        driver.progress = [report = options.progress](double fraction) { report(0.5 * fraction); };
    driver.cancel = options.cancel;
    builders::TopDownBuilder builder(options.cost, {options.max_leaf_size, options.max_depth},
                                  builders::make_search_spaces(spaces, scene.triangles, options, preset.allow_unsplitting,
                                                            options.spatial_gate_alpha >= 0.0f ? options.spatial_gate_alpha
                                                                                               : preset.spatial_gate_alpha),
                                  scene.triangles, std::move(driver));
    // References: one per triangle, or the pre-split pieces (within the budget).
    std::vector<builders::Reference> references;
    builders::PresplitOptions presplit;
    presplit.reference_budget = options.reference_budget;
    switch (preset.presplit) {
        case Presplit::none: references = builders::make_references(scene); break;
        case Presplit::early_split_clipping: references = builders::early_split_clipping(scene, presplit); break;
        case Presplit::edge_volume_heuristic: references = builders::edge_volume_heuristic(scene, presplit); break;
    }
    // Spatial and grid splits may grow the references up to the budget; object splits never do.
    const size_t capacity = builders::splits_references(spaces, options)
                                ? size_t(double(options.reference_budget) * double(scene.triangles.size()))
                                : references.size();
    Bvh bvh = builder.build(std::move(references), capacity);
    bvh.builder = options.builder;
    if (optimizing) {
        BuildOptions optimization = options;
        if (options.progress)
            optimization.progress = [report = options.progress](double fraction) { report(0.5 + 0.5 * fraction); };
        optimize_bvh(bvh, optimization);
        if (options.progress) options.progress(1.0);
    }
    return bvh;
}

}  // namespace spacebvh
