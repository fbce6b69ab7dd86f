// SPDX-License-Identifier: MIT
// The exact sweep-plane spatial search space (Popov et al. 2009, slide "Implement KDBVH using sweep
// plane"): on each axis the candidate planes are the reference bound events (every reference's min
// and max), swept in order while the child boxes are maintained incrementally: the left box grows as
// the sweep passes references, with the references that straddle the plane clipped exactly to it;
// the right box comes from the reverse sweep. Children never overlap.
//
// What is exact, and what is not:
//  * Counts are exact for the partition of src/builders/driver/partition.cpp without unsplitting: left =
//    references with lo < p plus those lying flat in the plane, right = references with hi > p.
//  * Child boxes at an event plane are the union of the boxes apply_split would give the children:
//    whole boxes of the references entirely on one side, and for each straddler its piece clipped to
//    the plane by the same code (clipping::TrianglePiece, the one clipper behind every spatial
//    search space). The box is carried along the sweep (the part below p is below every later
//    plane), so a straddler need not be clipped at a plane where it cannot enlarge the box: it is
//    retired once its whole reference box lies inside, and it sleeps while its edges, followed from
//    the plane, stay inside (TrianglePiece::quiet_until, with a safety margin).
//    Exact up to float rounding: the carried box also holds the rounded crossing points of earlier
//    planes, which can exceed a later clip by an ulp where an edge is almost parallel to the sweep
//    (the brute-force tests find the boxes equal bit for bit). One assumption: a straddler's piece
//    reaches the plane (hi = p on the left, lo = p on the right), which holds except where rounding
//    made a reference box wider than its triangle piece.
//  * Between two events the counts are constant but the clipped boxes of the straddlers grow with
//    the plane, so the cost is a quadratic-like function of the position there (the slides' warning).
//    Events alone are therefore not exhaustive; with `interior_samples` > 0 the finder also evaluates
//    that many equally spaced positions inside the two intervals next to each of the best
//    `interior_intervals` event planes (each evaluated exactly, by a direct pass over the node).
#pragma once

#include <span>
#include <vector>

#include "builders/driver/split.hpp"

namespace spacebvh::builders {

struct SpatialSweepOptions {
    bool unsplit = true;            // reference unsplitting when the split is applied
    uint32_t interior_samples = 0;  // positions sampled inside each studied interval (0 = events only)
    uint32_t interior_intervals =
        2;                    // event planes (best first, over all axes) whose neighbouring intervals are sampled
    float gate_alpha = 0.0f;  // as SpatialSearchOptions::gate_alpha (sbvh)
};

// Child boxes and counts of the spatial split at x[axis] = position, computed directly (one pass
// over the references, straddlers clipped): the definition the sweep maintains incrementally.
struct SpatialPlaneEvaluation {
    AABB left_bounds, right_bounds;
    uint32_t left_count = 0, right_count = 0;
};
SpatialPlaneEvaluation evaluate_spatial_plane(std::span<const Reference> references,
                                              std::span<const Triangle> triangles, int axis, float position);

// Every event plane of one axis strictly inside `node`, ascending, with its exact counts and child
// boxes (the sweeps the finder runs; exposed for the brute-force tests).
struct SpatialSweepPlanes {
    std::vector<float> planes;
    std::vector<AABB> left_bounds, right_bounds;
    std::vector<uint32_t> left_counts, right_counts;
};
SpatialSweepPlanes sweep_spatial_planes(std::span<const Reference> references, std::span<const Triangle> triangles,
                                        const AABB& node, int axis);

class SpatialSweepSplitFinder final : public SplitFinder {
public:
    SpatialSweepSplitFinder(std::span<const Triangle> triangles, SpatialSweepOptions options)
        : triangles_(triangles), options_(options) {}
    const char* name() const override { return "spatial-sweep"; }
    Split find(const NodeContext& node, const CostModel& cost) const override;

private:
    std::span<const Triangle> triangles_;
    SpatialSweepOptions options_;
};

}  // namespace spacebvh::builders
