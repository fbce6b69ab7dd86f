// SPDX-License-Identifier: MIT
// The termination-aware term of the split choice (spacebvh::TerminationConfig): sample segments that
// end where their rays stop, the share of a node's segments that meets each child box, and the
// choice among the search spaces' candidates by the blend of that term with the cost model's cost.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "builders/driver/split_search.hpp"
#include "spacebvh/build.hpp"

namespace spacebvh::builders {

// A sample ray's segment, from tmin to where the ray stops, with its inverse direction for slab tests.
struct SampleSegment {
    Vec3 org, inverse_dir;
    float tmin, tmax;
    static SampleSegment of(const Ray& ray) {
        return {ray.org, Vec3(1.0f / ray.dir.x, 1.0f / ray.dir.y, 1.0f / ray.dir.z), ray.tmin, ray.tmax};
    }
};
// Whether the segment meets the box. Monotone: a segment that meets a box meets every box containing it
// (each slab bound enters through rounded, monotone operations), which the optimiser's bounds rely on.
// Slab test (Kay & Kajiya 1986) over [tmin, tmax]; a zero direction component gives infinite
// inverses, and the NaN of 0 * inf (origin on a slab plane) is dropped by std::max/min keeping their
// first argument when the comparison is false.
inline bool segment_meets(const SampleSegment& s, const AABB& box) {
    if (box.is_empty()) return false;
    float near = s.tmin, far = s.tmax;
    for (int axis = 0; axis < 3; ++axis) {
        const float t0 = (box.lo[axis] - s.org[axis]) * s.inverse_dir[axis];
        const float t1 = (box.hi[axis] - s.org[axis]) * s.inverse_dir[axis];
        near = std::max(near, std::min(t0, t1));  // a NaN second argument leaves near
        far = std::min(far, std::max(t0, t1));
    }
    return near <= far;
}

class TerminationTerm {
public:
    explicit TerminationTerm(const TerminationConfig& config);

    bool enabled() const { return !segments_.empty(); }
    // The segments (indices, increasing) among `candidates` that meet `box`; all segments when
    // `candidates` is null (the root).
    std::vector<uint32_t> meeting(const AABB& box, const std::vector<uint32_t>* candidates) const;

    // The split to apply at a node met by `rays`: `greedy` (the cost model's choice) when fewer than
    // min_rays segments meet the node, else the candidate of lowest blended cost (the earlier
    // candidate on ties, so the cost model's choice wins a tie).
    Split choose(const SplitSearch& search, std::span<const Reference> references, const ReferenceSummary& summary,
                 size_t capacity, const Split& greedy, std::span<const uint32_t> rays) const;

    // w * (C_T + C_I * (P(L) counted(|L|) + P(R) counted(|R|))) + (1 - w) * split.cost, with P(X) the
    // share of `rays` whose segment meets X's box and w = n / (n + shrinkage).
    float blended_cost(const Split& split, std::span<const uint32_t> rays, const CostModel& cost) const;

private:
    std::vector<SampleSegment> segments_;
    float shrinkage_;
    uint32_t min_rays_, candidates_;
};

}  // namespace spacebvh::builders
