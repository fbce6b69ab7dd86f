// SPDX-License-Identifier: MIT
// Checking answers ray by ray, as docs/rays.md defines it: agreement of two hit records,
// and the exact double-precision arbiter that settles disagreements.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "spacebvh/float64.hpp"
#include "spacebvh/geometry.hpp"
#include "spacebvh/tools/rays.hpp"
#include "spacebvh/tools/scene.hpp"

namespace spacebvh::tools {

// The arbiter: the closest exact hit over every triangle (brute force), or occlusion.
HitRecord arbiter_closest_hit(const Scene& scene, const Ray& ray);
HitRecord arbiter_occlusion(const Scene& scene, const Ray& ray);
// The float64 arbiter: every triangle by the exact float64 test (intersect_exact); equal t keeps the
// lower triangle id.
Hit64 arbiter_closest_hit(std::span<const Triangle64> triangles, const Ray64& ray);
bool arbiter_occlusion(std::span<const Triangle64> triangles, const Ray64& ray);

// Two records agree when both miss, or both hit with
// |tA - tB| <= 1e-4 * max(|tA|, |tB|) + 1e-6 * scene_diagonal / |dir|.
bool hits_agree(const HitRecord& a, const HitRecord& b, const Ray& ray, float scene_diagonal);

struct VerificationReport {
    size_t rays = 0;
    size_t disagreements = 0;  // ours vs the reference (e.g. Embree)
    size_t ours_wrong = 0;     // of those, where ours disagrees with the arbiter
    size_t reference_wrong = 0;
    std::vector<size_t> wrong_rays;  // indices of our wrong answers (at most 32 kept)
};

// Compares our answers with a reference ray by ray; every disagreement goes to the arbiter
// (closest hit or occlusion as `occlusion` says). Parallel over the calling thread's arena.
VerificationReport verify_against_reference(const Scene& scene, std::span<const Ray> rays,
                                            std::span<const HitRecord> ours, std::span<const HitRecord> reference,
                                            bool occlusion);
// The same check with the arbiter's answer for a ray given by `arbiter` (called for disagreements
// only, from several threads at once): for answers that are not one mesh's, such as a scene of
// instances (scene_arbiter.hpp). `scene_diagonal` sets the agreement tolerance (hits_agree).
VerificationReport verify_with_arbiter(std::span<const Ray> rays, std::span<const HitRecord> ours,
                                       std::span<const HitRecord> reference, float scene_diagonal,
                                       const std::function<HitRecord(const Ray&)>& arbiter);

}  // namespace spacebvh::tools
