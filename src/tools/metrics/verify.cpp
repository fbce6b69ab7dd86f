// SPDX-License-Identifier: MIT
// Ray-by-ray checking of docs/rays.md ("Agreement and the arbiter").
#include "spacebvh/tools/verify.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/combinable.h>
#include <oneapi/tbb/parallel_for.h>

#include "core/exact_triangle.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh::tools {

namespace {

// Running totals of one thread; keeps only the smallest wrong indices so memory stays bounded.
constexpr size_t kMaxWrongRays = 32;
struct Tally {
    size_t disagreements = 0, ours_wrong = 0, reference_wrong = 0;
    std::vector<size_t> wrong_rays;
    void add_wrong(size_t index) {
        wrong_rays.push_back(index);
        if (wrong_rays.size() >= 4 * kMaxWrongRays) trim();
    }
    void trim() {
        std::sort(wrong_rays.begin(), wrong_rays.end());
        if (wrong_rays.size() > kMaxWrongRays) wrong_rays.resize(kMaxWrongRays);
    }
};

}  // namespace

HitRecord arbiter_closest_hit(const Scene& scene, const Ray& ray) {
    double best_t = std::numeric_limits<double>::infinity();
    uint32_t best = kInvalidIndex;
    for (size_t i = 0; i < scene.triangles.size(); ++i) {
        const std::optional<double> t = intersect_triangle_exact(ray, scene.triangles[i]);
        if (t && *t < best_t) {  // strict: equal t keeps the lower index, so the answer is deterministic
            best_t = *t;
            best = uint32_t(i);
        }
    }
    if (best == kInvalidIndex) return {};
    return {float(best_t), best};
}

HitRecord arbiter_occlusion(const Scene& scene, const Ray& ray) {
    for (const Triangle& tri : scene.triangles)
        if (intersect_triangle_exact(ray, tri)) return occlusion_record(true);
    return occlusion_record(false);
}

Hit64 arbiter_closest_hit(std::span<const Triangle64> triangles, const Ray64& ray) {
    Hit64 best;
    for (size_t i = 0; i < triangles.size(); ++i) {
        const Hit64 hit = intersect_exact(ray, triangles[i], uint32_t(i));
        if (hit.is_hit() && hit.t < best.t) best = hit;  // strict: equal t keeps the lower index
    }
    return best;
}

bool arbiter_occlusion(std::span<const Triangle64> triangles, const Ray64& ray) {
    for (size_t i = 0; i < triangles.size(); ++i)
        if (intersect_exact(ray, triangles[i], uint32_t(i)).is_hit()) return true;
    return false;
}

bool hits_agree(const HitRecord& a, const HitRecord& b, const Ray& ray, float scene_diagonal) {
    if (!a.is_hit() || !b.is_hit()) return a.is_hit() == b.is_hit();
    const double ta = a.t, tb = b.t;
    const double dir_length =
        std::sqrt(double(ray.dir.x) * ray.dir.x + double(ray.dir.y) * ray.dir.y + double(ray.dir.z) * ray.dir.z);
    const double tolerance = 1e-4 * std::max(std::abs(ta), std::abs(tb)) + 1e-6 * double(scene_diagonal) / dir_length;
    return std::abs(ta - tb) <= tolerance;
}

VerificationReport verify_against_reference(const Scene& scene, std::span<const Ray> rays,
                                            std::span<const HitRecord> ours, std::span<const HitRecord> reference,
                                            bool occlusion) {
    return verify_with_arbiter(rays, ours, reference, scene.diagonal(), [&](const Ray& ray) {
        return occlusion ? arbiter_occlusion(scene, ray) : arbiter_closest_hit(scene, ray);
    });
}

VerificationReport verify_with_arbiter(std::span<const Ray> rays, std::span<const HitRecord> ours,
                                       std::span<const HitRecord> reference, float scene_diagonal,
                                       const std::function<HitRecord(const Ray&)>& arbiter) {
    if (ours.size() != rays.size() || reference.size() != rays.size())
        throw Error("verify: " + std::to_string(rays.size()) + " rays but " + std::to_string(ours.size()) +
                    " of our answers and " + std::to_string(reference.size()) + " reference answers");
    tbb::combinable<Tally> tallies;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 1024), [&](const tbb::blocked_range<size_t>& range) {
        Tally& tally = tallies.local();
        for (size_t i = range.begin(); i != range.end(); ++i) {
            if (hits_agree(ours[i], reference[i], rays[i], scene_diagonal)) continue;
            // Only disagreements pay for the brute-force arbiter.
            ++tally.disagreements;
            const HitRecord truth = arbiter(rays[i]);
            if (!hits_agree(ours[i], truth, rays[i], scene_diagonal)) {
                ++tally.ours_wrong;
                tally.add_wrong(i);
            }
            if (!hits_agree(reference[i], truth, rays[i], scene_diagonal)) ++tally.reference_wrong;
        }
    });
    VerificationReport report;
    report.rays = rays.size();
    tallies.combine_each([&](const Tally& t) {
        report.disagreements += t.disagreements;
        report.ours_wrong += t.ours_wrong;
        report.reference_wrong += t.reference_wrong;
        report.wrong_rays.insert(report.wrong_rays.end(), t.wrong_rays.begin(), t.wrong_rays.end());
    });
    // The smallest indices, sorted: the same report whatever the thread schedule.
    std::sort(report.wrong_rays.begin(), report.wrong_rays.end());
    if (report.wrong_rays.size() > kMaxWrongRays) report.wrong_rays.resize(kMaxWrongRays);
    return report;
}

}  // namespace spacebvh::tools
