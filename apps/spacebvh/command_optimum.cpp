// SPDX-License-Identifier: MIT
// spacebvh optimum [SCENE]: how far each search space's best local split is from the exhaustive
// optimum (all 2^N partitions; spacebvh/split_optimum.hpp) on random small nodes and on small
// nodes sampled from a scene's cbvh tree. The slides' example: CBVH ~700 against the optimum ~100.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "cli_common.hpp"
#include "spacebvh/split_optimum.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;
namespace {

using TriangleSet = std::vector<Triangle>;

// Random triangles of very different sizes in a unit cube, some long (where centroids mislead).
std::vector<TriangleSet> random_nodes(size_t nodes, uint32_t min_size, uint32_t max_size, uint64_t seed) {
    std::mt19937_64 random(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::vector<TriangleSet> sets(nodes);
    for (TriangleSet& set : sets) {
        const uint32_t size = min_size + uint32_t(random() % (max_size - min_size + 1));
        for (uint32_t i = 0; i < size; ++i) {
            const Vec3 a{unit(random), unit(random), unit(random)};
            const float extent = i % 3 == 0 ? 0.8f : 0.1f;
            auto near = [&] { return a + Vec3{extent * unit(random), extent * unit(random), extent * unit(random)}; };
            set.push_back({a, near(), near()});
        }
    }
    return sets;
}

// Inner nodes of the scene's cbvh tree holding between min_size and max_size triangles, every k-th
// of them in depth-first order so that at most `nodes` are taken.
std::vector<TriangleSet> tree_nodes(const Scene& scene, size_t nodes, uint32_t min_size, uint32_t max_size) {
    BuildConfig options = config_for("cbvh");
    options.limits.max_leaf_size = 1;  // leaves of single triangles: every small cluster is an inner node
    const Bvh bvh = spacebvh::build(scene, options);
    std::vector<uint32_t> subtree_size(bvh.nodes.size(), 0);
    for (size_t i = bvh.nodes.size(); i-- > 0;) {  // children come after their parent
        const BvhNode& node = bvh.nodes[i];
        subtree_size[i] =
            node.is_leaf() ? node.reference_count : subtree_size[node.first] + subtree_size[node.first + 1];
    }
    std::vector<uint32_t> candidates;
    for (uint32_t i = 0; i < bvh.nodes.size(); ++i)
        if (!bvh.nodes[i].is_leaf() && subtree_size[i] >= min_size && subtree_size[i] <= max_size)
            candidates.push_back(i);
    const size_t step = std::max<size_t>(1, candidates.size() / std::max<size_t>(nodes, 1));
    std::vector<TriangleSet> sets;
    for (size_t k = 0; k < candidates.size() && sets.size() < nodes; k += step) {
        TriangleSet set;
        std::vector<uint32_t> stack{candidates[k]};
        while (!stack.empty()) {
            const BvhNode& node = bvh.nodes[stack.back()];
            stack.pop_back();
            if (node.is_leaf()) {
                for (uint32_t j = node.first; j < node.first + node.reference_count; ++j)
                    set.push_back(scene.triangles[bvh.primitives[j]]);
            } else {
                stack.push_back(node.first + 1);
                stack.push_back(node.first);
            }
        }
        sets.push_back(std::move(set));
    }
    return sets;
}

struct Row {
    std::string name;
    uint32_t search_spaces;
    bool grid_splitting;
    std::vector<double> ratios;  // best cost / optimum, per node with a finite optimum
    double cost_sum = 0;
    size_t at_optimum = 0, below_optimum = 0, infeasible = 0;
};

nlohmann::json report(const char* label, const std::vector<TriangleSet>& sets, const BuildConfig& base) {
    std::vector<Row> rows = {
        {"object (cbvh sweep)", uint32_t(SearchSpace::object_sweep), false, {}},
        {"binned", uint32_t(SearchSpace::object_binned), false, {}},
        {"spatial (kd planes)*", uint32_t(SearchSpace::spatial_binned), false, {}},
        {"grid, no splitting", uint32_t(SearchSpace::grid), false, {}},
        {"grid + splitting*", uint32_t(SearchSpace::grid), true, {}},
        {"full: object+spatial+grid*",
         SearchSpace::object_sweep | SearchSpace::spatial_binned | SearchSpace::grid,
         true,
         {}},
    };
    double optimum_sum = 0, leaf_sum = 0;
    size_t feasible = 0;
    for (const TriangleSet& set : sets) {
        const float optimum = exhaustive_split_cost(set, base.cost);
        if (!(optimum < kInfinity)) continue;
        ++feasible;
        optimum_sum += optimum;
        leaf_sum += base.cost.leaf_cost(set.size());
        for (Row& row : rows) {
            BuildConfig options = base;
            options.grid.splitting = row.grid_splitting;
            const float best = best_local_split_cost(set, row.search_spaces, options);
            if (!(best < kInfinity)) {
                ++row.infeasible;
                continue;
            }
            const double ratio = double(best) / double(optimum);
            row.ratios.push_back(ratio);
            row.cost_sum += best;
            row.at_optimum += std::fabs(ratio - 1.0) <= 1e-6;
            row.below_optimum += ratio < 1.0 - 1e-6;
        }
    }
    std::printf("\n%s: %zu nodes with a feasible partition (%s); mean optimum cost %.3f, mean leaf cost %.3f\n", label,
                feasible, base.cost.describe().c_str(), feasible ? optimum_sum / double(feasible) : 0.0,
                feasible ? leaf_sum / double(feasible) : 0.0);
    std::printf("  %-28s %10s %10s %10s %10s %9s %9s %10s\n", "search space", "mean cost", "mean x", "median x",
                "max x", "at opt", "below*", "infeasible");
    nlohmann::json json = {{"nodes", feasible}, {"mean_optimum_cost", feasible ? optimum_sum / double(feasible) : 0.0}};
    for (Row& row : rows) {
        const size_t n = row.ratios.size();
        double mean = 0, worst = 0;
        for (double r : row.ratios) mean += r, worst = std::max(worst, r);
        mean = n ? mean / double(n) : 0.0;
        const double middle = median(row.ratios);
        std::printf("  %-28s %10.3f %10.3f %10.3f %10.3f %8.1f%% %8.1f%% %10zu\n", row.name.c_str(),
                    n ? row.cost_sum / double(n) : 0.0, mean, middle, worst,
                    n ? 100.0 * double(row.at_optimum) / double(n) : 0.0,
                    n ? 100.0 * double(row.below_optimum) / double(n) : 0.0, row.infeasible);
        json["search_spaces"][row.name] = {{"mean_ratio", mean},
                                           {"median_ratio", middle},
                                           {"max_ratio", worst},
                                           {"at_optimum", row.at_optimum},
                                           {"below_optimum", row.below_optimum},
                                           {"infeasible", row.infeasible},
                                           {"ratios", row.ratios}};  // per node, for the distribution
    }
    return json;
}

}  // namespace

void add_optimum_command(CLI::App& app) {
    struct Options {
        std::string source;
        size_t nodes = 200;
        uint32_t min_size = 8, max_size = 16;
        uint64_t seed = 1;
        SceneOptions scene;
        BuildCliOptions build;
        CommonOptions common;
    };
    auto options = std::make_shared<Options>();
    CLI::App* command = app.add_subcommand(
        "optimum", "each search space's best split against the exhaustive optimum (all 2^N partitions) on small nodes");
    command->add_option("scene", options->source,
                        "also sample small nodes from this scene's cbvh tree (file or builtin:NAME)");
    command->add_option("--nodes", options->nodes, "nodes per set")->capture_default_str();
    command->add_option("--min-refs", options->min_size, "smallest node")->capture_default_str();
    command
        ->add_option("--max-refs", options->max_size,
                     "largest node (at most " + std::to_string(kMaxExhaustiveTriangles) + ")")
        ->capture_default_str();
    command->add_option("--seed", options->seed, "seed of the random nodes")->capture_default_str();
    options->scene.add_to(*command);
    options->build.add_to(*command, false);
    options->common.add_to(*command);
    command->callback([options] {
        const auto limit = options->common.thread_limit();
        if (options->min_size < 2 || options->max_size < options->min_size ||
            options->max_size > kMaxExhaustiveTriangles)
            throw Error("--min-refs and --max-refs must satisfy 2 <= min <= max <= " +
                        std::to_string(kMaxExhaustiveTriangles));
        const BuildConfig base = options->build.options("cbvh");
        std::printf("Best local split cost of each search space / the exhaustive optimum over all partitions\n");
        std::printf(
            "(x = ratio; * = clips references, so it may go below the partition optimum; grid G = ceil(%g N^(1/6)) <= "
            "%u)\n",
            base.grid.resolution, base.grid.max_cells);
        nlohmann::json json;
        json["random"] = report(
            "random nodes", random_nodes(options->nodes, options->min_size, options->max_size, options->seed), base);
        if (!options->source.empty()) {
            const Scene scene = load_scene(options->source, options->scene.transform());
            json["scene"] = report(("nodes of " + scene.name + "'s cbvh tree").c_str(),
                                   tree_nodes(scene, options->nodes, options->min_size, options->max_size), base);
            json["scene_name"] = scene.name;
        }
        write_json(options->common.json_path, json);
    });
}

}  // namespace spacebvh::cli
