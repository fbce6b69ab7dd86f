// SPDX-License-Identifier: MIT
// The termination-aware term of the split choice (spacebvh::TerminationConfig): sample segments that
// end where their rays stop, the share of a node's segments that meets each child box, and the
// choice among the search spaces' candidates by the blend of that term with the cost model's cost.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "builders/split_search.hpp"
#include "spacebvh/build.hpp"

namespace spacebvh::builders {

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
    struct Segment {
        Vec3 org, inverse_dir;
        float tmin, tmax;
    };
    bool meets(const Segment& segment, const AABB& box) const;

    std::vector<Segment> segments_;
    float shrinkage_;
    uint32_t min_rays_, candidates_;
};

}  // namespace spacebvh::builders
