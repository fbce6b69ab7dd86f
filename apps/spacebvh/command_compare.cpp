// SPDX-License-Identifier: MIT
// spacebvh compare [SCENE...]: the main job. Per scene, every builder (under each --kernel) and Embree
// (single rays and 16-ray packets) side by side on the same rays: build time, tree quality, Mrays/s
// (median of --runs) and work per ray for random, primary and diffuse rays, each also as a ratio to
// the first row; and every row's answers checked against Embree with disagreements settled by the
// exact arbiter (docs/rays.md).
#include <cstdio>
#include <map>

#include "builder_spec.hpp"
#include "cli_common.hpp"
#include "compare_rows.hpp"
#include "compare_table.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/settings.hpp"
#include "spacebvh/tools/embree_scene.hpp"
#include "ray_sets.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "spacebvh/trace.hpp"
#include "tree_option.hpp"

namespace spacebvh::cli {

using namespace spacebvh::tools;
using namespace spacebvh::cli::compare;
namespace {

// The kernel a --kernel name means for a ray kind: "auto" is the fastest on the benchmark scenes
// (bench/): coherent packets of 8x8 tiles for primary rays, 8-wide single rays otherwise.
std::string kernel_for(const std::string& kernel, RayKind kind) {
    if (kernel != "auto") return kernel;
    return kind == RayKind::primary ? "packet8" : "bvh8";
}

// The order in which to trace an image's primary rays: each tile x tile block of pixels consecutive
// (what packets of tile^2 rays need); tile 0 keeps the spec's row-major order.
std::vector<uint32_t> pixel_order(uint32_t width, uint32_t height, uint32_t tile) {
    if (tile > 0) return tile_order(width, height, tile);
    std::vector<uint32_t> identity(size_t(width) * height);
    for (size_t i = 0; i < identity.size(); ++i) identity[i] = uint32_t(i);
    return identity;
}

std::vector<Ray> gathered(const std::vector<Ray>& rays, const std::vector<uint32_t>& order) {
    std::vector<Ray> ordered;
    ordered.reserve(order.size());
    for (uint32_t i : order) ordered.push_back(rays[i]);
    return ordered;
}

}  // namespace

void add_compare_command(CLI::App& app) {
    struct Options {
        std::vector<std::string> sources;
        std::string builders = "cbvh,binned,kdbvh,spatial,sbvh";
        std::string embree = "low,medium,high";
        std::string kernels = "auto";
        std::string embree_packets = "high";
        uint32_t tile = 8;
        int runs = 5, build_runs = 3;
        size_t random_count = 1000000;
        uint64_t seed = 1;
        bool no_verify = false, no_epo = false;
        SceneOptions scene;
        BuildCliOptions build;
        CameraOptions camera;
        CommonOptions common;
        TreeOption tree;
    };
    auto options = std::make_shared<Options>();
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
        if (options->runs < 0 || options->runs > 1000) throw Error("--runs must be in [0, 1000]");
        if (options->build_runs < 1 || options->build_runs > 1000) throw Error("--build-runs must be in [1, 1000]");
        if (options->random_count == 0 || options->random_count > (size_t(1) << 31))
            throw Error("--random must be in [1, 2^31]");
        std::vector<BuilderSpec> builders;
        for (const auto& name : CLI::detail::split(options->builders, ','))
            if (!name.empty()) builders.push_back(parse_builder_spec(name, options->build));  // validates each
        if (options->tree.given()) {
            if (command->count("--builders") == 0) builders.clear();
            builders.insert(builders.begin(), BuilderSpec{options->tree.path, options->build.options("binned"), true});
            if (options->sources.size() != 1) throw Error("--tree: name the one scene the tree was built over");
        }
        if (builders.empty()) throw Error("--builders names no builder");
        std::vector<std::string> kernels;
        for (const auto& name : CLI::detail::split(options->kernels, ','))
            if (!name.empty()) kernels.push_back(name);
        if (kernels.empty()) throw Error("--kernel names no kernel");
        if (options->tile > 1024) throw Error("--tile must be in [0, 1024]");
        std::vector<EmbreeQuality> embree_packet_rows;
        if (options->embree_packets != "none")
            for (const auto& name : CLI::detail::split(options->embree_packets, ','))
                if (!name.empty()) embree_packet_rows.push_back(parse_embree_quality(name));
        std::vector<EmbreeQuality> embree_rows;
        if (options->embree != "none")
            for (const auto& name : CLI::detail::split(options->embree, ','))
                if (!name.empty()) embree_rows.push_back(parse_embree_quality(name));

        std::vector<std::string> sources = options->sources;
        if (sources.empty())
            for (const auto& name : builtin_scene_names()) sources.push_back("builtin:" + name);

        const SceneTransform transform = options->scene.transform();
        const CostModel cost = builders.front().options.cost;
        nlohmann::json json_scenes = nlohmann::json::array();
        std::printf(
            "# spacebvh compare: %u threads, C_T=%g C_I=%g (C_o per row), max leaf %u; Mrays/s = median of %d "
            "runs; ratios to %s\n\n",
            options->common.effective_threads(), cost.traversal_cost, cost.intersection_cost,
            builders.front().options.limits.max_leaf_size, options->runs, builders.front().label.c_str());

        for (const std::string& source : sources) {
            const Scene scene = load_scene(source, transform);
            RaySetParameters parameters;
            parameters.random_count = options->random_count;
            parameters.seed = options->seed;
            parameters.camera = options->camera.camera_for(scene, source, transform);
            parameters.width = options->camera.width;
            parameters.height = options->camera.height;

            std::vector<Row> rows;
            std::vector<Ray> ray_sets[3];
            std::vector<Ray> primary_row_major;
            const std::vector<uint32_t> primary_order = pixel_order(parameters.width, parameters.height, options->tile);
            Progress progress("compare " + scene.name, options->common);
            const size_t our_rows = builders.size() * kernels.size();
            const size_t row_total = our_rows + embree_rows.size() + embree_packet_rows.size();

            // Every row's tracer or Embree scene first (kept alive; a tracer holds its own layout, not
            // the tree), then all the timing, round robin.
            rows.reserve(row_total);  // measurements point into the rows
            std::vector<Measurement> measurements;
            std::vector<std::unique_ptr<Tracer>> tracers;
            std::vector<std::unique_ptr<EmbreeScene>> embree_scenes;
            auto add_measurement = [&](KindResult& result, std::span<const Ray> rays, auto intersect, auto occluded) {
                measurements.push_back({&result, rays, {}, {}, intersect, occluded});
            };
            const double build_share = 0.3;  // of the progress bar
            for (size_t b = 0; b < builders.size(); ++b) {
                const TreeRecipe& build_options = builders[b].options;
                std::vector<double> build_ms;
                Bvh bvh;
                for (int run = 0; run < options->build_runs; ++run) {
                    const auto start = std::chrono::steady_clock::now();
                    bvh = builders[b].saved_tree ? tree_for(options->tree, scene, build_options)
                                                 : build_tree(scene, build_options);
                    build_ms.push_back(milliseconds_since(start));
                }
                if (builders[b].saved_tree) builders[b].label = options->tree.path + ": " + bvh.builder;
                const CostModel& tree_cost = builders[b].saved_tree ? bvh.cost : build_options.cost;
                const TreeStats tree_stats = compute_tree_stats(scene, bvh, tree_cost, !options->no_epo);
                if (b == 0) {
                    const Tracer tracer(scene, bvh, Kernel::binary);
                    for (RayKind kind : kKinds) ray_sets[int(kind)] = make_ray_set(kind, scene, tracer, parameters);
                    primary_row_major = ray_sets[int(RayKind::primary)];
                    ray_sets[int(RayKind::primary)] = gathered(primary_row_major, primary_order);
                }
                for (size_t k = 0; k < kernels.size(); ++k) {
                    Row& row = rows.emplace_back();
                    row.name = builders[b].label + " (C_o=" + number_or_dash(tree_cost.overlap_penalty, 2) + ")";
                    row.cost = tree_cost;
                    row.build_ms = median(build_ms);
                    row.build_ms_runs = build_ms;
                    row.stats = tree_stats;
                    std::map<std::string, const Tracer*> by_kernel;  // shared between kinds
                    for (RayKind kind : kKinds) {
                        const std::string name = kernel_for(kernels[k], kind);
                        const Tracer*& tracer = by_kernel[name];
                        if (!tracer) tracer = tracers.emplace_back(make_tracer(name, scene, bvh)).get();
                        row.kernels[int(kind)] = tracer->name();
                        if (kind == RayKind::random && !scene.triangles.empty())
                            row.layout_bytes_per_triangle =
                                double(tracer->memory_bytes()) / double(scene.triangles.size());
                        KindResult& result = row.kinds[int(kind)];
                        const auto& rays = ray_sets[int(kind)];
                        add_measurement(
                            result, rays, [tracer](auto r, auto h) { tracer->intersect(r, h); },
                            [tracer](auto r, auto o) { tracer->occluded(r, o); });
                        if (options->runs > 0) count_work_per_ray(*tracer, rays, result);  // 0: answers only
                    }
                    row.peak_rss_bytes = peak_rss_bytes();
                    row.kernel =
                        row.kernels[0] == row.kernels[1] && row.kernels[1] == row.kernels[2]
                            ? row.kernels[0]
                            : kernels[k] + ": " + row.kernels[0] + ", " + row.kernels[1] + ", " + row.kernels[2];
                    progress.update(build_share * double(rows.size()) / double(row_total));
                }
            }
            // Embree: single rays (rtcIntersect1/rtcOccluded1) per quality, then 16-ray packets
            // (rtcIntersect16/rtcOccluded16), their primary rays in 4x4 tiles, answers put back in our order.
            const std::vector<uint32_t> tiles_of_16 =
                options->tile == 0 ? std::vector<uint32_t>{} : tile_order(parameters.width, parameters.height, 4);
            std::vector<uint32_t> position_in_primary(primary_order.size());  // row-major pixel -> our ray index
            for (size_t i = 0; i < primary_order.size(); ++i) position_in_primary[primary_order[i]] = uint32_t(i);
            for (size_t e = 0; e < embree_rows.size() + embree_packet_rows.size(); ++e) {
                const bool packets = e >= embree_rows.size();
                const EmbreeQuality quality = packets ? embree_packet_rows[e - embree_rows.size()] : embree_rows[e];
                Row& row = rows.emplace_back();
                row.name = std::string("embree-") + to_string(quality);
                row.kernel = packets ? "Embree rtcIntersect16/rtcOccluded16" : "Embree rtcIntersect1/rtcOccluded1";
                std::vector<double> build_ms;
                std::unique_ptr<EmbreeScene>& embree = embree_scenes.emplace_back();
                for (int run = 0; run < options->build_runs; ++run) {
                    embree.reset();
                    embree = std::make_unique<EmbreeScene>(scene, quality);
                    build_ms.push_back(embree->build_milliseconds());
                    throw_if_interrupted();
                }
                row.build_ms = median(build_ms);
                row.build_ms_runs = build_ms;
                if (!scene.triangles.empty())
                    row.layout_bytes_per_triangle = double(embree->memory_bytes()) / double(scene.triangles.size());
                const EmbreeScene* traced = embree.get();
                for (RayKind kind : kKinds) {
                    KindResult& result = row.kinds[int(kind)];
                    if (!packets) {
                        add_measurement(
                            result, ray_sets[int(kind)], [traced](auto r, auto h) { traced->intersect(r, h); },
                            [traced](auto r, auto o) { traced->occluded(r, o); });
                    } else if (kind != RayKind::primary || tiles_of_16.empty()) {
                        add_measurement(
                            result, ray_sets[int(kind)], [traced](auto r, auto h) { traced->intersect16(r, h); },
                            [traced](auto r, auto o) { traced->occluded16(r, o); });
                    } else {
                        add_measurement(
                            result, {}, [traced](auto r, auto h) { traced->intersect16(r, h); },
                            [traced](auto r, auto o) { traced->occluded16(r, o); });
                        Measurement& tiled = measurements.back();
                        tiled.reordered = gathered(primary_row_major, tiles_of_16);
                        tiled.rays = tiled.reordered;
                        for (uint32_t pixel : tiles_of_16) tiled.order.push_back(position_in_primary[pixel]);
                    }
                }
                row.peak_rss_bytes = peak_rss_bytes();
                progress.update(build_share * double(rows.size()) / double(row_total));
            }
            measure_round_robin(measurements, options->runs,
                                [&](double within) { progress.update(build_share + (1.0 - build_share) * within); });

            const bool verify = !options->no_verify && !embree_rows.empty();
            if (verify) count_wrong_answers(scene, ray_sets, rows, our_rows);

            // The table.
            std::printf("## %s: %zu triangles; %zu random, %zu primary (%ux%u), %zu diffuse rays\n\n",
                        scene.name.c_str(), scene.triangles.size(), ray_sets[0].size(), ray_sets[1].size(),
                        parameters.width, parameters.height, ray_sets[2].size());
            print_table(rows, verify, !options->no_epo);
            nlohmann::json json_rows = nlohmann::json::array();
            for (const Row& row : rows) json_rows.push_back(row_json(row, verify, !options->no_epo));
            std::printf("\npeak memory so far: %.1f MiB resident (whole process)\n\n",
                        double(peak_rss_bytes()) / (1024.0 * 1024.0));
            std::fflush(stdout);
            json_scenes.push_back(
                {{"scene", scene.name},
                 {"source", source},
                 {"triangles", scene.triangles.size()},
                 {"rays",
                  {{"random", ray_sets[0].size()}, {"primary", ray_sets[1].size()}, {"diffuse", ray_sets[2].size()}}},
                 {"rows", json_rows}});
        }
        write_json(options->common.json_path, {{"threads", options->common.effective_threads()},
                                               {"C_T", cost.traversal_cost},
                                               {"C_I", cost.intersection_cost},
                                               {"runs", options->runs},
                                               {"peak_rss_bytes", peak_rss_bytes()},
                                               {"scenes", json_scenes}});
    });
}

}  // namespace spacebvh::cli
