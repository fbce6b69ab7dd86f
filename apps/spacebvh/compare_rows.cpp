// SPDX-License-Identifier: MIT
#include "compare_rows.hpp"

#include <chrono>

#include "cli_common.hpp"
#include "spacebvh/tools/verify.hpp"

namespace spacebvh::cli::compare {

void measure_round_robin(std::vector<Measurement>& measurements, int runs,
                         const std::function<void(double)>& progress) {
    const size_t total = measurements.size() * 2 * size_t(runs + 1);
    size_t done = 0;
    std::vector<Hit> hits;
    std::vector<SceneHit> scene_hits;
    std::vector<uint8_t> occluded;
    for (const bool occlusion : {false, true}) {
        auto trace = [&](size_t m) {
            Measurement& measurement = measurements[m];
            throw_if_interrupted();
            const bool scene = bool(measurement.intersect_scene);
            hits.resize(occlusion || scene ? 0 : measurement.rays.size());
            scene_hits.resize(occlusion || !scene ? 0 : measurement.rays.size());
            occluded.resize(occlusion ? measurement.rays.size() : 0);
            if (occlusion)
                measurement.occluded(measurement.rays, occluded);
            else if (scene)
                measurement.intersect_scene(measurement.rays, scene_hits);
            else
                measurement.intersect(measurement.rays, hits);
            progress(double(++done) / double(total));
        };
        std::vector<std::vector<double>> ms(measurements.size());
        for (size_t m = 0; m < measurements.size(); ++m) {
            Measurement& measurement = measurements[m];
            const auto start = std::chrono::steady_clock::now();
            trace(m);  // warm-up; its answers are the ones checked
            if (runs == 0) ms[m].push_back(milliseconds_since(start));
            KindResult& result = *measurement.result;
            std::vector<HitRecord>& records = occlusion ? result.occlusion : result.closest;
            records.resize(measurement.rays.size());
            for (size_t i = 0; i < measurement.rays.size(); ++i) {
                const size_t ray = measurement.order.empty() ? i : measurement.order[i];
                records[ray] = occlusion            ? occlusion_record(occluded[i])
                               : scene_hits.empty() ? to_record(hits[i])
                                                    : HitRecord{scene_hits[i].t, scene_hits[i].primitive};
            }
        }
        for (int run = 0; run < runs; ++run) {
            for (size_t m = 0; m < measurements.size(); ++m) {
                const auto start = std::chrono::steady_clock::now();
                trace(m);
                ms[m].push_back(milliseconds_since(start));
            }
        }
        for (size_t m = 0; m < measurements.size(); ++m) {
            KindResult& result = *measurements[m].result;
            const double mrays = double(measurements[m].rays.size()) / median(ms[m]) / 1000.0;
            (occlusion ? result.occlusion_mrays : result.closest_mrays) = mrays;
            (occlusion ? result.occlusion_ms : result.closest_ms) = ms[m];
        }
    }
}

void count_work_per_ray(const Tracer& tracer, std::span<const Ray> rays, KindResult& result) {
    TraversalStats closest, occlusion;
    std::vector<Hit> hits(rays.size());
    tracer.intersect(rays, hits, &closest);
    std::vector<uint8_t> occluded(rays.size());
    tracer.occluded(rays, occluded, &occlusion);
    const double n = std::max<double>(1.0, double(rays.size()));
    result.nodes_per_ray = double(closest.nodes_visited) / n;
    result.triangles_per_ray = double(closest.triangles_tested) / n;
    result.occlusion_nodes_per_ray = double(occlusion.nodes_visited) / n;
    result.occlusion_triangles_per_ray = double(occlusion.triangles_tested) / n;
}

void count_wrong_answers(const Scene& scene, const std::vector<Ray> (&ray_sets)[3], std::vector<Row>& rows,
                         size_t first_embree_row, const SceneArbiter* instances) {
    const auto wrong = [&](std::span<const Ray> rays, const std::vector<HitRecord>& mine,
                           const std::vector<HitRecord>& theirs, bool occlusion) {
        if (!instances) return verify_against_reference(scene, rays, mine, theirs, occlusion).ours_wrong;
        return verify_with_arbiter(rays, mine, theirs, instances->diagonal(),
                                   [&](const Ray& ray) {
                                       return occlusion ? occlusion_record(instances->occluded(ray))
                                                        : instances->closest_hit(ray).hit;
                                   })
            .ours_wrong;
    };
    for (size_t r = 0; r < rows.size(); ++r) {
        const size_t reference = r < first_embree_row ? first_embree_row : 0;
        for (RayKind kind : kKinds) {
            const auto& rays = ray_sets[int(kind)];
            KindResult& mine = rows[r].kinds[int(kind)];
            const KindResult& theirs = rows[reference].kinds[int(kind)];
            mine.wrong =
                wrong(rays, mine.closest, theirs.closest, false) + wrong(rays, mine.occlusion, theirs.occlusion, true);
        }
    }
}

}  // namespace spacebvh::cli::compare
