// SPDX-License-Identifier: MIT
// The exact object-partitioning SAH sweep (the slides' CBVH; MacDonald & Booth 1990): on each axis,
// sort the references by centroid and evaluate every cut of the sorted order.
#pragma once

#include "builders/driver/split.hpp"

namespace spacebvh::builders {

class ObjectSweepSplitFinder final : public SplitFinder {
public:
    const char* name() const override { return "object-sweep"; }
    Split find(const NodeContext& node, const CostModel& cost) const override;
    std::vector<Split> find_candidates(const NodeContext& node, const CostModel& cost,
                                       uint32_t per_axis) const override;
    // Given NodeContext::sorted, the sweep reads the driver's orders and sorts nothing.
    bool reads_centroid_orders() const override { return true; }
};

// Orders references by centroid[axis], then primitive, then bounds: a total order on the whole
// record (pre-split pieces of one triangle can share centroid and primitive), so references that tie
// are byte-identical and any sort, parallel or not, gives the same bytes.
struct CentroidOrder {
    int axis;
    bool operator()(const Reference& a, const Reference& b) const {
        const float ca = a.centroid(axis), cb = b.centroid(axis);
        if (ca != cb) return ca < cb;
        if (a.primitive != b.primitive) return a.primitive < b.primitive;
        for (int k = 0; k < 3; ++k) {
            if (a.bounds.lo[k] != b.bounds.lo[k]) return a.bounds.lo[k] < b.bounds.lo[k];
            if (a.bounds.hi[k] != b.bounds.hi[k]) return a.bounds.hi[k] < b.bounds.hi[k];
        }
        return false;
    }
};

// Sorts the references by CentroidOrder{axis} (the sweep's sort; radix sort on integer keys), in
// place or into `sorted`.
void sort_in_centroid_order(std::span<Reference> references, int axis);
void sort_in_centroid_order(std::span<const Reference> references, int axis, std::vector<Reference>& sorted);

}  // namespace spacebvh::builders
