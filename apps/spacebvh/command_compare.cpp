// SPDX-License-Identifier: MIT
// spacebvh compare [SCENE...]: the main job. Per scene, every builder (under each --kernel) and Embree
// (single rays and 16-ray packets) side by side on the same rays: build time, tree quality, Mrays/s
// (median of --runs) and work per ray for random, primary and diffuse rays, each also as a ratio to
// the first row; and every row's answers checked against Embree with disagreements settled by the
// exact arbiter (docs/rays.md).
#include "compare_plan.hpp"
#include "compare_scene.hpp"
#include "spacebvh/settings.hpp"

namespace spacebvh::cli {

using namespace spacebvh::cli::compare;

void add_compare_command(CLI::App& app) {
    auto options = std::make_shared<CompareOptions>();
    CLI::App* command = app.add_subcommand(
        "compare",
        "the main job: builders and Embree side by side per scene (quality, build time, Mrays/s, correctness)");
    command->add_option("scenes", options->sources, "scene files or builtin:NAME (default: every built-in scene)");
    command
        ->add_option("--builders", options->builders,
                     "comma-separated builders, each NAME or NAME@key=value;key=value with the keys " +
                         known_settings(SettingSpelling::row_key) +
                         " (each as its build option; e.g. spatial@co=inf;search=object+grid); NAME+opt: optimised "
                         "with the default effort; the first is the ratio baseline")
        ->capture_default_str();
    command->add_option("--embree", options->embree, "Embree 3 quality rows: any of low,medium,high, or 'none'")
        ->capture_default_str();
    command
        ->add_option("--kernel", options->kernels,
                     "comma-separated traversal kernels, one row each per builder: " + kernel_help())
        ->capture_default_str();
    command
        ->add_option("--embree-packets", options->embree_packets,
                     "Embree qualities also traced with rtcIntersect16/rtcOccluded16 packets (rays in 4x4 tiles for "
                     "primary), or 'none'")
        ->capture_default_str();
    command
        ->add_option("--tile", options->tile,
                     "primary rays in tile x tile blocks (what packets trace together); 0: row-major")
        ->capture_default_str();
    command
        ->add_option("--runs", options->runs,
                     "timed runs per measurement (the median is reported); 0: answers only, for soaks (one pass per "
                     "measurement, itself timed, and no work-per-ray pass)")
        ->capture_default_str();
    command->add_option("--build-runs", options->build_runs, "builds per builder (the median is reported)")
        ->capture_default_str();
    command->add_option("--random", options->random_count, "random rays per scene")->capture_default_str();
    command->add_option("--seed", options->seed, "seed of the random and diffuse rays")->capture_default_str();
    command->add_flag("--no-verify", options->no_verify, "skip checking answers against Embree and the arbiter");
    command->add_flag("--no-epo", options->no_epo, "skip the EPO metric");
    options->scene.add_to(*command);
    options->build.add_to(*command, false);
    options->camera.add_to(*command);
    options->common.add_to(*command);
    options->tree.add_to(*command,
                         "a saved tree (build --save) of the one scene given: its rows (one per --kernel, build ms = "
                         "load ms) replace the builder rows and are the ratio baseline; rows of --builders, when "
                         "given explicitly, follow");

    command->callback([options, command] {
        const auto limit = options->common.thread_limit();
        const InterruptScope interrupts;  // Ctrl-C stops between measurements (and inside our builds)
        const ComparePlan plan = make_plan(*options, command->count("--builders") > 0);
        print_plan_header(plan);
        nlohmann::json json_scenes = nlohmann::json::array();
        for (const std::string& source : plan.sources) {
            SceneComparison comparison = load_comparison(plan, source);
            Progress progress("compare " + comparison.scene.name, options->common);
            add_our_rows(plan, comparison, progress);
            add_embree_rows(plan, comparison, progress);
            measure(plan, comparison, progress);
            json_scenes.push_back(report(plan, comparison));
        }
        const CostModel& cost = plan.builders.front().options.cost;
        write_json(options->common.json_path, {{"threads", options->common.effective_threads()},
                                               {"C_T", cost.traversal_cost},
                                               {"C_I", cost.intersection_cost},
                                               {"runs", options->runs},
                                               {"peak_rss_bytes", peak_rss_bytes()},
                                               {"scenes", json_scenes}});
    });
}

}  // namespace spacebvh::cli
