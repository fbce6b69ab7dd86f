// SPDX-License-Identifier: MIT
#include "builders/driver/termination_term.hpp"

#include <algorithm>
#include <cmath>

namespace spacebvh::builders {

TerminationTerm::TerminationTerm(const TerminationConfig& config)
    : shrinkage_(config.shrinkage), min_rays_(config.min_rays), candidates_(config.candidates) {
    segments_.reserve(config.segments.size());
    for (const Ray& ray : config.segments) segments_.push_back(SampleSegment::of(ray));
}

std::vector<uint32_t> TerminationTerm::meeting(const AABB& box, const std::vector<uint32_t>* candidates) const {
    std::vector<uint32_t> result;
    if (!candidates) {
        for (uint32_t i = 0; i < segments_.size(); ++i)
            if (segment_meets(segments_[i], box)) result.push_back(i);
        return result;
    }
    for (uint32_t i : *candidates)
        if (segment_meets(segments_[i], box)) result.push_back(i);
    return result;
}

float TerminationTerm::blended_cost(const Split& split, std::span<const uint32_t> rays, const CostModel& cost) const {
    if (rays.empty()) return split.cost;
    size_t left = 0, right = 0;
    for (uint32_t i : rays) {
        left += segment_meets(segments_[i], split.left_bounds);
        right += segment_meets(segments_[i], split.right_bounds);
    }
    const double n = double(rays.size());
    const double sampled =
        double(cost.traversal_cost) +
        double(cost.intersection_cost) *
            (double(left) * cost.counted(split.left_count) + double(right) * cost.counted(split.right_count)) / n;
    const double weight = n / (n + double(shrinkage_));
    return float(weight * sampled + (1.0 - weight) * double(split.cost));
}

Split TerminationTerm::choose(const SplitSearch& search, std::span<const Reference> references,
                              const ReferenceSummary& summary, size_t capacity, const Split& greedy,
                              std::span<const uint32_t> rays) const {
    if (rays.size() < min_rays_) return greedy;
    Split best = greedy;
    float best_cost = blended_cost(greedy, rays, search.cost());
    for (const Split& candidate : search.candidates(references, summary, capacity, candidates_)) {
        if (!candidate.is_valid()) continue;
        const float candidate_cost = blended_cost(candidate, rays, search.cost());
        if (candidate_cost < best_cost) {
            best = candidate;
            best_cost = candidate_cost;
        }
    }
    return best;
}

}  // namespace spacebvh::builders
