// The exact object-partitioning SAH sweep (the slides' CBVH; MacDonald & Booth 1990): on each axis,
// sort the references by centroid and evaluate every cut of the sorted order.
#pragma once

#include "build/split.hpp"

namespace spacebvh::build {

class ObjectSweepSplitFinder final : public SplitFinder {
public:
    const char* name() const override { return "object-sweep"; }
    Split find(const NodeContext& node, const CostModel& cost) const override;
};

// Orders references by (centroid[axis], primitive): a total order, so sorting is deterministic.
struct CentroidOrder {
    int axis;
    bool operator()(const Reference& a, const Reference& b) const {
        const float ca = a.centroid(axis), cb = b.centroid(axis);
        return ca < cb || (ca == cb && a.primitive < b.primitive);
    }
};

}  // namespace spacebvh::build
