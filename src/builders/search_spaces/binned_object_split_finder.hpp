// SPDX-License-Identifier: MIT
// Binned object SAH (Wald 2007, "On fast Construction of SAH-based Bounding Volume Hierarchies"):
// centroids are binned into B equal bins per axis and only the B-1 cuts between bins are evaluated.
#pragma once

#include "builders/driver/split.hpp"

namespace spacebvh::builders {

class BinnedObjectSplitFinder final : public SplitFinder {
public:
    explicit BinnedObjectSplitFinder(uint32_t bins) : bins_(bins) {}
    const char* name() const override { return "object-binned"; }
    Split find(const NodeContext& node, const CostModel& cost) const override;
    std::vector<Split> find_candidates(const NodeContext& node, const CostModel& cost,
                                       uint32_t per_axis) const override;

private:
    uint32_t bins_;
};

}  // namespace spacebvh::builders
