// SPDX-License-Identifier: MIT
// The binned ("chopped") spatial search space of Stich, Friedrich and Dietrich 2009 ("Spatial Splits
// in Bounding Volume Hierarchies"): B equal bins per axis over the node box; each reference is
// clipped into every bin it spans, bins record the clipped boxes and enter/exit counts, and the
// B-1 planes between bins are evaluated. Children never overlap.
#pragma once

#include <span>

#include "builders/driver/split.hpp"

namespace spacebvh::builders {

struct SpatialSearchOptions {
    uint32_t bins = 32;
    // Reference unsplitting (Stich et al.): a straddling reference goes to one side whole when that
    // is cheaper than clipping it into both.
    bool unsplit = true;
    // Gate (Stich et al., as NVIDIA's reference builder): try spatial splits only when the best
    // split found so far has children whose overlap area is >= gate_alpha * SA(root). 0 = always.
    float gate_alpha = 0.0f;
};

class BinnedSpatialSplitFinder final : public SplitFinder {
public:
    BinnedSpatialSplitFinder(std::span<const Triangle> triangles, SpatialSearchOptions options)
        : triangles_(triangles), options_(options) {}
    const char* name() const override { return "spatial-binned"; }
    Split find(const NodeContext& node, const CostModel& cost) const override;
    std::vector<Split> find_candidates(const NodeContext& node, const CostModel& cost,
                                       uint32_t per_axis) const override;

private:
    std::span<const Triangle> triangles_;
    SpatialSearchOptions options_;
};

}  // namespace spacebvh::builders
