// SPDX-License-Identifier: MIT
// A reference: a primitive id and its current bounds. Object partitioning moves references between
// children; spatial splits (next milestone) clip a reference's bounds and duplicate it.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "spacebvh/geometry.hpp"
#include <span>

#include "spacebvh/geometry.hpp"

namespace spacebvh::builders {

struct Reference {
    AABB bounds;
    uint32_t primitive = kInvalidIndex;

    float centroid(int axis) const { return bounds.centroid(axis); }
};

// One reference per triangle, bounds = the triangle's box. Degenerate triangles are kept (they are
// never hit, but keeping them preserves numbering and costs nothing in correctness).
std::vector<Reference> make_references(std::span<const Triangle> triangles);

struct ReferenceSummary {
    AABB bounds;           // union of the reference boxes
    AABB centroid_bounds;  // box of the reference centroids
};
// Parallel for large spans; min/max are exact, so the result does not depend on the thread count.
ReferenceSummary summarize(std::span<const Reference> references);

}  // namespace spacebvh::builders
