// Applying a chosen split: moving each reference of a node to its child.
#pragma once

#include <span>

#include "build/split.hpp"

namespace spacebvh::build {

bool goes_left(const Reference& reference, const Split& split);

// Reorders the references so those going left come first; returns how many go left.
// Deterministic (the same input order gives the same output order).
size_t partition_references(std::span<Reference> references, const Split& split);

// The fallback when a node must be split (too many references) but no search space offers a
// feasible split: halve the node at the median of the centroid order on the widest axis.
Split median_split(std::span<Reference> references, const ReferenceSummary& node);

}  // namespace spacebvh::build
