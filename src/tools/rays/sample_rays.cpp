// SPDX-License-Identifier: MIT
#include "spacebvh/tools/sample_rays.hpp"

#include <algorithm>
#include <cmath>

#include "spacebvh/error.hpp"

namespace spacebvh::tools {

SampleKind parse_sample_kind(const std::string& text) {
    if (text == "bounce") return SampleKind::bounce;
    if (text == "area") return SampleKind::area;
    throw Error("unknown sample kind '" + text + "' (expected bounce or area)");
}

const char* to_string(SampleKind kind) { return kind == SampleKind::bounce ? "bounce" : "area"; }

namespace {

// Random rays in batches until `count` of them hit; a batch's seed is the seed plus its number, so
// the sample is a prefix of the same sequence whatever `count` is.
std::vector<Ray> bounce_sample(const Scene& scene, const Tracer& tracer, size_t count, uint64_t seed, float epsilon) {
    std::vector<Ray> sample;
    const size_t batch = std::max<size_t>(count, 4096);
    // A scene whose random rays almost never hit gives up after a bounded number of batches.
    for (uint64_t round = 0; sample.size() < count && round < 64; ++round) {
        const std::vector<Ray> random = generate_random_rays(scene.bounds(), batch, seed + round);
        std::vector<Hit> hits(random.size());
        tracer.intersect(random, hits);
        const std::vector<Ray> bounces = generate_diffuse_rays(scene, random, hits, seed + round, epsilon);
        sample.insert(sample.end(), bounces.begin(), bounces.begin() + std::min(bounces.size(), count - sample.size()));
    }
    return sample;
}

// Each surface point is handed to the spec's bounce as a short arrival along the chosen side's inward
// normal, so the direction follows exactly the construction of the benchmark's diffuse rays. The
// arrival is short (1e-3 of the diagonal) so that its origin plus t * direction rounds back close to
// the point.
std::vector<Ray> area_sample(const Scene& scene, size_t count, uint64_t seed, float epsilon) {
    std::vector<double> cumulative_area(scene.triangles.size());
    std::vector<Vec3> unit_normal(scene.triangles.size(), Vec3(0.0f));
    double total = 0.0;
    const float arrival_length = 1e-3f * scene.diagonal();
    for (size_t i = 0; i < scene.triangles.size(); ++i) {
        const Triangle& tri = scene.triangles[i];
        const Vec3 n = cross(tri.v1 - tri.v0, tri.v2 - tri.v0);
        const float len = length(n);
        // Triangles without a float normal (zero or underflowing area) are never picked.
        if (len > 0.0f && std::isfinite(len) && is_finite(n / len)) {
            unit_normal[i] = n / len;
            total += 0.5 * double(len);
        }
        cumulative_area[i] = total;
    }
    if (!(total > 0.0)) return {};
    SplitMix64 rng(seed);
    std::vector<Ray> arrivals;
    std::vector<Hit> hits;
    arrivals.reserve(count);
    hits.reserve(count);
    for (size_t k = 0; k < count; ++k) {
        const double target = double(rng.uniform()) * total;
        const size_t i = std::min(
            size_t(std::upper_bound(cumulative_area.begin(), cumulative_area.end(), target) - cumulative_area.begin()),
            scene.triangles.size() - 1);
        float u = rng.uniform(), v = rng.uniform();
        if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
        const Triangle& tri = scene.triangles[i];
        const Vec3 point = tri.v0 + (tri.v1 - tri.v0) * u + (tri.v2 - tri.v0) * v;
        const Vec3 inward = rng.uniform() < 0.5f ? unit_normal[i] : -unit_normal[i];
        Ray arrival;
        arrival.org = point - inward * arrival_length;
        arrival.dir = inward;
        arrivals.push_back(arrival);
        Hit hit;
        hit.t = arrival_length;
        hit.primitive = uint32_t(i);
        hits.push_back(hit);
    }
    return generate_diffuse_rays(scene, arrivals, hits, seed ^ 0x5A4D504C45ull, epsilon);
}

}  // namespace

std::vector<Ray> generate_sample_rays(SampleKind kind, const Scene& scene, const Tracer& tracer, size_t count,
                                      uint64_t seed, float epsilon) {
    return kind == SampleKind::bounce ? bounce_sample(scene, tracer, count, seed, epsilon)
                                      : area_sample(scene, count, seed, epsilon);
}

std::vector<Ray> termination_segments(const Scene& scene, const Tracer& tracer, size_t count, uint64_t seed) {
    std::vector<Ray> segments = generate_sample_rays(SampleKind::bounce, scene, tracer, count, seed);
    std::vector<Hit> hits(segments.size());
    tracer.intersect(segments, hits);
    for (size_t i = 0; i < segments.size(); ++i)
        if (hits[i].is_hit()) segments[i].tmax = hits[i].t;
    return segments;
}

}  // namespace spacebvh::tools
