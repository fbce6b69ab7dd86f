// SPDX-License-Identifier: MIT
#include "compare_scene.hpp"

#include <cstdio>
#include <map>

#include "compare_table.hpp"
#include "spacebvh/tools/metrics.hpp"

namespace spacebvh::cli::compare {
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

// A builder's tree, built (or loaded) --build-runs times: the last one, and every run's time.
struct TimedTree {
    Bvh bvh;
    std::vector<double> build_ms;
};

TimedTree timed_tree(const ComparePlan& plan, const BuilderSpec& builder, const Scene& scene) {
    TimedTree tree;
    for (int run = 0; run < plan.options.build_runs; ++run) {
        const auto start = std::chrono::steady_clock::now();
        tree.bvh = builder.saved_tree ? tree_for(plan.options.tree, scene, builder.options)
                                      : build_tree(scene, builder.options);
        tree.build_ms.push_back(milliseconds_since(start));
    }
    return tree;
}

// The three ray sets, made with a tracer over the first tree (diffuse rays start where primary rays
// hit); the primary rays in `primary_order`, their row-major order kept for Embree's packets.
void make_ray_sets(SceneComparison& comparison, const Bvh& bvh) {
    const Tracer tracer(comparison.scene, bvh, Kernel::binary);
    for (RayKind kind : kKinds)
        comparison.ray_sets[int(kind)] = make_ray_set(kind, comparison.scene, tracer, comparison.parameters);
    comparison.primary_row_major = comparison.ray_sets[int(RayKind::primary)];
    comparison.ray_sets[int(RayKind::primary)] = gathered(comparison.primary_row_major, comparison.primary_order);
}

// `row` (a tree's, its name and build filled in) under --kernel `kernel`: the tracer of each kernel
// the ray kinds need (shared between kinds; it holds its own layout, not the tree), a measurement per
// kind, and each kind's work per ray.
void add_kernel_row(const ComparePlan& plan, SceneComparison& comparison, const std::string& kernel, const Bvh& bvh,
                    Row tree_row) {
    const Scene& scene = comparison.scene;
    Row& row = comparison.rows.emplace_back(std::move(tree_row));
    std::map<std::string, const Tracer*> by_kernel;
    for (RayKind kind : kKinds) {
        const std::string name = kernel_for(kernel, kind);
        const Tracer*& tracer = by_kernel[name];
        if (!tracer) tracer = comparison.tracers.emplace_back(make_tracer(name, scene, bvh)).get();
        row.kernels[int(kind)] = tracer->name();
        if (kind == RayKind::random && !scene.triangles.empty())
            row.layout_bytes_per_triangle = double(tracer->memory_bytes()) / double(scene.triangles.size());
        KindResult& result = row.kinds[int(kind)];
        const auto& rays = comparison.ray_sets[int(kind)];
        add_measurement(
            comparison, result, rays, [tracer](auto r, auto h) { tracer->intersect(r, h); },
            [tracer](auto r, auto o) { tracer->occluded(r, o); });
        if (plan.options.runs > 0) count_work_per_ray(*tracer, rays, result);  // 0: answers only
    }
    row.peak_rss_bytes = peak_rss_bytes();
    row.kernel = row.kernels[0] == row.kernels[1] && row.kernels[1] == row.kernels[2]
                     ? row.kernels[0]
                     : kernel + ": " + row.kernels[0] + ", " + row.kernels[1] + ", " + row.kernels[2];
}

// Embree's measurements of `row`: single rays (rtcIntersect1/rtcOccluded1), or 16-ray packets
// (rtcIntersect16/rtcOccluded16) with the primary rays in 4x4 tiles.
void add_embree_measurements(SceneComparison& comparison, Row& row, const EmbreeScene* traced, bool packets,
                             const EmbreePacketOrder& packet_order) {
    for (RayKind kind : kKinds) {
        KindResult& result = row.kinds[int(kind)];
        if (!packets) {
            add_measurement(
                comparison, result, comparison.ray_sets[int(kind)],
                [traced](auto r, auto h) { traced->intersect(r, h); },
                [traced](auto r, auto o) { traced->occluded(r, o); });
        } else if (kind != RayKind::primary || packet_order.tiles_of_16.empty()) {
            add_measurement(
                comparison, result, comparison.ray_sets[int(kind)],
                [traced](auto r, auto h) { traced->intersect16(r, h); },
                [traced](auto r, auto o) { traced->occluded16(r, o); });
        } else {
            Measurement& tiled = add_measurement(
                comparison, result, {}, [traced](auto r, auto h) { traced->intersect16(r, h); },
                [traced](auto r, auto o) { traced->occluded16(r, o); });
            packet_order.apply(comparison, tiled);
        }
    }
}

// One Embree row: its scene built --build-runs times (the median time; the last one kept), then its
// measurements.
void add_embree_row(const ComparePlan& plan, SceneComparison& comparison, EmbreeQuality quality, bool packets,
                    const EmbreePacketOrder& packet_order) {
    const Scene& scene = comparison.scene;
    Row& row = comparison.rows.emplace_back();
    row.name = std::string("embree-") + to_string(quality);
    row.kernel = packets ? "Embree rtcIntersect16/rtcOccluded16" : "Embree rtcIntersect1/rtcOccluded1";
    std::vector<double> build_ms;
    std::unique_ptr<EmbreeScene>& embree = comparison.embree_scenes.emplace_back();
    for (int run = 0; run < plan.options.build_runs; ++run) {
        embree.reset();
        embree = std::make_unique<EmbreeScene>(scene, quality);
        build_ms.push_back(embree->build_milliseconds());
        throw_if_interrupted();
    }
    row.build_ms = median(build_ms);
    row.build_ms_runs = build_ms;
    if (!scene.triangles.empty())
        row.layout_bytes_per_triangle = double(embree->memory_bytes()) / double(scene.triangles.size());
    add_embree_measurements(comparison, row, embree.get(), packets, packet_order);
    row.peak_rss_bytes = peak_rss_bytes();
}

}  // namespace

std::vector<Ray> gathered(const std::vector<Ray>& rays, const std::vector<uint32_t>& order) {
    std::vector<Ray> ordered;
    ordered.reserve(order.size());
    for (uint32_t i : order) ordered.push_back(rays[i]);
    return ordered;
}

Measurement& add_measurement(SceneComparison& comparison, KindResult& result, std::span<const Ray> rays,
                             std::function<void(std::span<const Ray>, std::span<Hit>)> intersect,
                             std::function<void(std::span<const Ray>, std::span<uint8_t>)> occluded) {
    comparison.measurements.push_back({&result, rays, {}, {}, std::move(intersect), std::move(occluded), {}});
    return comparison.measurements.back();
}

void show_rows_built(const ComparePlan& plan, const SceneComparison& comparison, Progress& progress) {
    progress.update(kBuildShare * double(comparison.rows.size()) / double(plan.row_count()));
}

EmbreePacketOrder::EmbreePacketOrder(const ComparePlan& plan, const SceneComparison& comparison)
    : position_in_primary(comparison.primary_order.size()) {
    if (plan.options.tile != 0) tiles_of_16 = tile_order(comparison.parameters.width, comparison.parameters.height, 4);
    for (size_t i = 0; i < comparison.primary_order.size(); ++i)
        position_in_primary[comparison.primary_order[i]] = uint32_t(i);
}

void EmbreePacketOrder::apply(const SceneComparison& comparison, Measurement& measurement) const {
    if (tiles_of_16.empty()) return;
    measurement.reordered = gathered(comparison.primary_row_major, tiles_of_16);
    measurement.rays = measurement.reordered;
    for (uint32_t pixel : tiles_of_16) measurement.order.push_back(position_in_primary[pixel]);
}

SceneComparison load_comparison(const ComparePlan& plan, const std::string& source) {
    const CompareOptions& options = plan.options;
    SceneComparison comparison;
    comparison.source = source;
    if (names_instanced_scene(source))
        load_instanced_comparison(plan, comparison);
    else
        comparison.scene = load_scene(source, plan.transform);
    RaySetParameters& parameters = comparison.parameters;
    parameters.random_count = options.random_count;
    parameters.seed = options.seed;
    parameters.camera = options.camera.camera_for(comparison.scene, source, plan.transform);
    parameters.width = options.camera.width;
    parameters.height = options.camera.height;
    comparison.primary_order = pixel_order(parameters.width, parameters.height, options.tile);
    comparison.rows.reserve(plan.row_count());
    return comparison;
}

void add_our_rows(const ComparePlan& plan, SceneComparison& comparison, Progress& progress) {
    if (comparison.instanced) return add_our_instanced_rows(plan, comparison, progress);
    for (const BuilderSpec& builder : plan.builders) {
        const TimedTree tree = timed_tree(plan, builder, comparison.scene);
        const std::string label = builder.saved_tree ? plan.options.tree.path + ": " + tree.bvh.builder : builder.label;
        const CostModel& tree_cost = builder.saved_tree ? tree.bvh.cost : builder.options.cost;
        const TreeStats tree_stats = compute_tree_stats(comparison.scene, tree.bvh, tree_cost, !plan.options.no_epo);
        if (&builder == &plan.builders.front()) make_ray_sets(comparison, tree.bvh);
        for (const std::string& kernel : plan.kernels) {
            Row row;
            row.name = label + " (C_o=" + number_or_dash(tree_cost.overlap_penalty, 2) + ")";
            row.cost = tree_cost;
            row.build_ms = median(tree.build_ms);
            row.build_ms_runs = tree.build_ms;
            row.stats = tree_stats;
            add_kernel_row(plan, comparison, kernel, tree.bvh, std::move(row));
            show_rows_built(plan, comparison, progress);
        }
    }
}

void add_embree_rows(const ComparePlan& plan, SceneComparison& comparison, Progress& progress) {
    const EmbreePacketOrder packet_order(plan, comparison);
    const auto add_embree = comparison.instanced ? add_embree_instanced_row : add_embree_row;
    for (const EmbreeQuality quality : plan.embree_rows) {
        add_embree(plan, comparison, quality, false, packet_order);
        show_rows_built(plan, comparison, progress);
    }
    for (const EmbreeQuality quality : plan.embree_packet_rows) {
        add_embree(plan, comparison, quality, true, packet_order);
        show_rows_built(plan, comparison, progress);
    }
}

void measure(const ComparePlan& plan, SceneComparison& comparison, Progress& progress) {
    measure_round_robin(comparison.measurements, plan.options.runs,
                        [&](double within) { progress.update(kBuildShare + (1.0 - kBuildShare) * within); });
    if (plan.verifies())
        count_wrong_answers(comparison.scene, comparison.ray_sets, comparison.rows, plan.our_row_count(),
                            comparison.instanced ? &comparison.instanced->arbiter() : nullptr);
}

nlohmann::json report(const ComparePlan& plan, const SceneComparison& comparison) {
    const Scene& scene = comparison.scene;
    const auto& ray_sets = comparison.ray_sets;
    const bool with_epo = !plan.options.no_epo;
    std::string counts = std::to_string(comparison.triangle_count()) + " triangles";
    if (comparison.instanced)
        counts += " in " + std::to_string(comparison.instanced->instance_count()) + " instances of " +
                  std::to_string(comparison.instanced->meshes().size()) + " meshes";
    std::printf("## %s: %s; %zu random, %zu primary (%ux%u), %zu diffuse rays\n\n", scene.name.c_str(), counts.c_str(),
                ray_sets[0].size(), ray_sets[1].size(), comparison.parameters.width, comparison.parameters.height,
                ray_sets[2].size());
    print_table(comparison.rows, plan.verifies(), with_epo);
    nlohmann::json json_rows = nlohmann::json::array();
    for (const Row& row : comparison.rows) json_rows.push_back(row_json(row, plan.verifies(), with_epo));
    std::printf("\npeak memory so far: %.1f MiB resident (whole process)\n\n",
                double(peak_rss_bytes()) / (1024.0 * 1024.0));
    std::fflush(stdout);
    nlohmann::json json = {
        {"scene", scene.name},
        {"source", comparison.source},
        {"triangles", comparison.triangle_count()},
        {"rays", {{"random", ray_sets[0].size()}, {"primary", ray_sets[1].size()}, {"diffuse", ray_sets[2].size()}}},
        {"rows", json_rows}};
    if (comparison.instanced) {
        json["instances"] = comparison.instanced->instance_count();
        json["meshes"] = comparison.instanced->meshes().size();
    }
    return json;
}

}  // namespace spacebvh::cli::compare
