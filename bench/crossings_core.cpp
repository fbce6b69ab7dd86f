// SPDX-License-Identifier: MIT
// The crossing walks of RayQueries alone (no Python): count_hits, all_hits (the batch, and one ray at
// a time as the Python binding calls it) and contains, on the rays of bench/open3d_drop_in.py (origins
// uniform in the mesh's box, directions normally distributed, not normalised, over [0, inf)) and the
// binned tree the Python package builds by default. Prints the median milliseconds of each query and
// a checksum of its answers, so that two builds can be compared on the same rays
// (bench/crossings_core.sh runs them interleaved).
// Usage: spacebvh_crossings_core SCENE [RAYS=1000000] [THREADS=2] [RUNS=5] [QUERIES=count,all,rays,contains]
//        [BUILDER=binned]
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "bench_timing.hpp"
#include "spacebvh/queries.hpp"
#include "spacebvh/recipe.hpp"
#include "spacebvh/tools/scene.hpp"

using namespace spacebvh;

namespace {

struct Inputs {
    std::vector<Ray> rays;
    std::vector<Vec3> points;
};

Inputs make_inputs(const std::vector<Triangle>& triangles, size_t count) {
    AABB box;
    for (const Triangle& t : triangles) box.extend(t.bounds());
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::normal_distribution<float> normal(0.0f, 1.0f);
    const auto inside = [&] {
        Vec3 p;
        for (int a = 0; a < 3; ++a) p[a] = box.lo[a] + (box.hi[a] - box.lo[a]) * unit(rng);
        return p;
    };
    Inputs in;
    in.rays.resize(count);
    in.points.resize(count);
    for (size_t i = 0; i < count; ++i) {
        Ray& r = in.rays[i];
        r.org = inside();
        do r.dir = Vec3{normal(rng), normal(rng), normal(rng)};
        while (r.dir.x == 0.0f && r.dir.y == 0.0f && r.dir.z == 0.0f);
        r.tmin = 0.0f;
        r.tmax = kInfinity;
        in.points[i] = inside();
    }
    return in;
}

// A weighted sum of per-ray answers: equal for two builds only if (almost surely) every answer is.
template <class T>
unsigned long long weighted_sum(const std::vector<T>& answers) {
    unsigned long long sum = 0;
    for (size_t i = 0; i < answers.size(); ++i) sum += answers[i] * (i % 7 + 1);
    return sum;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s SCENE [RAYS] [THREADS] [RUNS] [QUERIES]\n", argv[0]);
        return 2;
    }
    const size_t count = argc > 2 ? std::stoul(argv[2]) : 1000000;
    const int threads = argc > 3 ? std::stoi(argv[3]) : 2;
    const int runs = argc > 4 ? std::stoi(argv[4]) : 5;
    const std::string which = argc > 5 ? argv[5] : "count,all,rays,contains";
    const std::string builder = argc > 6 ? argv[6] : "binned";
    const tools::Scene scene = tools::load_scene(argv[1]);
    const Bvh bvh = build(MeshView(scene.triangles), TreeRecipe::for_builder(builder));
    const RayQueries queries(scene.triangles, bvh);
    const Inputs in = make_inputs(scene.triangles, count);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    tbb::task_arena arena(threads);
    std::printf("%s: %zu triangles, %s tree, %zu rays, %d threads, median of %d runs\n", scene.name.c_str(),
                scene.triangles.size(), builder.c_str(), count, threads, runs);
    // Times `work` and prints its median with checksum(), when `name` is among the queries asked for.
    const auto time_query = [&](const char* name, const std::function<void()>& work,
                                const std::function<unsigned long long()>& checksum) {
        if (("," + which + ",").find(std::string(",") + name + ",") == std::string::npos) return;
        const double ms = bench::median_ms(runs, [&] { arena.execute(work); });
        std::printf("  %-9s %9.1f ms  checksum %llu\n", name, ms, checksum());
    };
    std::vector<uint32_t> counts(count);
    time_query(
        "count", [&] { queries.count_hits(in.rays, counts); }, [&] { return weighted_sum(counts); });
    HitLists lists;
    time_query(
        "all", [&] { lists = queries.all_hits(in.rays); },
        [&] {
            unsigned long long sum = 0;
            for (size_t k = 0; k < lists.hits.size(); ++k) sum += (lists.hits[k].primitive + 1ull) * (k % 13 + 1);
            for (size_t i = 0; i <= count; ++i) sum += lists.offsets[i];
            return sum;
        });
    // The per-ray all_hits in blocks of 256 rays across the arena, as the Python binding calls it.
    std::vector<uint32_t> firsts(count);
    time_query(
        "rays",
        [&] {
            tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 256), [&](const tbb::blocked_range<size_t>& range) {
                std::vector<QueryHit> hits;
                for (size_t i = range.begin(); i < range.end(); ++i) {
                    queries.all_hits(in.rays[i], hits);
                    counts[i] = uint32_t(hits.size());
                    firsts[i] = hits.empty() ? kInvalidIndex : hits.back().primitive;
                }
            });
        },
        [&] {
            unsigned long long sum = 0;
            for (size_t i = 0; i < count; ++i) sum += (counts[i] + 3ull * firsts[i]) * (i % 7 + 1);
            return sum;
        });
    std::vector<uint8_t> inside(count);
    time_query(
        "contains", [&] { queries.contains(in.points, inside); }, [&] { return weighted_sum(inside); });
    return 0;
}
