// SPDX-License-Identifier: MIT
// The grid search space of Popov et al. 2009 ("Geometric Partitioning", "Practical Considerations"):
// fix the two child boxes first, then put every reference where the SAH wants it.
//
// Child boxes have their faces on a regular grid of G cells per axis over the node box, and every
// face of the node box is inherited by at least one child ("O(N^12) is actually O(N^6)"). For a fixed
// pair of child boxes the SAH is linear in the counts, so the best assignment is forced: a reference
// contained in one child goes there; one contained in both goes to the child of smaller surface area
// (ties: left); one contained in neither makes the pair infeasible, unless primitive splitting is on
// and the two boxes together cover the node box (see below), in which case it is clipped exactly into
// both children (the slides' "Splitting Primitives").
//
// Exact counts for every pair (no sampling): a reference snapped to the grid is a 6-D point (first
// grid line at or below its lo, first grid line at or above its hi, per axis), and "inside box
// [l, h]" is 6-D dominance (lo >= l and hi <= h per axis). A dominance-sum table over all grid boxes
// (ContainmentGrid) answers |inside L|, |inside R| and |inside L ∩ R| (inside both boxes = inside
// their intersection box) in one lookup each; |inside neither| follows by inclusion-exclusion.
//
// Why splitting needs L ∪ R = node box: a reference in neither child is cut into its parts inside L
// and inside R. Where L ∪ R leaves a hole in the node box, the part of the triangle in the hole would
// belong to no leaf and rays through it would miss. The pairs whose union is the whole node box are
// exactly the slabs [0, b] and [a, G] (a <= b) on one axis, full on the other two: the kd planes
// (a = b) and overlapping slabs (a < b) of the grid. Clipped pieces cost reference capacity; a pair
// with more straddlers than the node's spare capacity is infeasible, so the budget always holds.
//
// Grid size (slides: "G = R N^(1/6)" gives an O(N^1.5) build): G = ceil(R * N^(1/6)), at least 2 and
// at most `max_cells`. The per-axis pairs number about 3.4 G^2 (217 at G = 8), so a node evaluates ~20 G^6
// configurations (5.1 M at G = 8, after the L <-> R symmetry) from a table of ((G+1)(G+2)/2)^3 counts (364 KiB at
// G = 8). The cap keeps big nodes at a constant cost: above N = (max_cells / R)^6 a node costs O(N)
// for the table plus a constant enumeration, so the whole build is O(N log N) there.
#pragma once

#include <array>
#include <span>
#include <vector>

#include "builders/driver/split.hpp"

namespace spacebvh::builders {

struct GridSearchOptions {
    float resolution = 1.0f;       // R in G = ceil(R * N^(1/6))
    uint32_t max_cells = 8;        // cap on G (memory and time grow as G^6)
    bool split_primitives = true;  // clip references in neither child (only where L ∪ R covers the node)
};

inline constexpr uint32_t kMaxGridCells = 16;

// The grid size G for a node of `reference_count` references (the rule above).
uint32_t grid_cells_for(size_t reference_count, const GridSearchOptions& options);

// A box of the grid: grid lines lo[axis] <= hi[axis] on each axis (flat boxes are allowed: they can
// hold planar geometry).
struct GridBox {
    std::array<uint8_t, 3> lo{}, hi{};
};

// A node's references snapped to the grid, and the count of references inside every grid box.
class ContainmentGrid {
public:
    // `cells` per axis; an axis on which the node is flat gets 0 cells (one grid line), and an axis too
    // thin for `cells` distinct float planes gets 1.
    ContainmentGrid(std::span<const Reference> references, const AABB& node, uint32_t cells);

    uint32_t cells(int axis) const { return cells_[axis]; }
    float plane(int axis, uint32_t line) const { return planes_[axis][line]; }
    AABB box(const GridBox& box) const;
    // The number of references whose bounds lie inside box(b) (closed box), exactly.
    uint32_t contained(const GridBox& b) const { return table_[index(b)]; }
    // The same count by flat table index (interval indices i0, i1, i2 -> (i0 * T1 + i1) * T2 + i2).
    uint32_t contained_at(size_t flat_index) const { return table_[flat_index]; }
    uint32_t intervals(int axis) const { return intervals_[axis]; }
    static uint32_t interval_index(uint32_t lo, uint32_t hi) { return hi * (hi + 1) / 2 + lo; }
    size_t table_size() const { return table_.size(); }

private:
    size_t index(const GridBox& b) const {
        return (size_t(interval_index(b.lo[0], b.hi[0])) * intervals_[1] + interval_index(b.lo[1], b.hi[1])) *
                   intervals_[2] +
               interval_index(b.lo[2], b.hi[2]);
    }
    std::array<uint32_t, 3> cells_{};
    std::array<std::vector<float>, 3> planes_;
    std::array<uint32_t, 3> intervals_{};  // (cells + 1)(cells + 2) / 2 intervals per axis
    std::vector<uint32_t> table_;
};

struct GridConfiguration {
    GridBox left, right;
};

// True when every face of the node box is a face of `left` or of `right` (the grid search space).
bool inherits_every_face(const ContainmentGrid& grid, const GridConfiguration& configuration);
// True when left ∪ right is the whole node box (primitive splitting is allowed only then).
bool covers_node(const ContainmentGrid& grid, const GridConfiguration& configuration);

// The forced assignment of a configuration, counted from the table: left/right include the clipped
// references, which are counted on both sides.
struct GridCounts {
    uint32_t left = 0, right = 0, clipped = 0;
};
GridCounts count_assignment(const ContainmentGrid& grid, const GridConfiguration& configuration,
                            uint32_t reference_count);

struct GridSearchResult {
    bool found = false;
    GridConfiguration configuration;
    float cost = kInfinity;  // with the grid boxes as the children's boxes
    GridCounts counts;
};
// The cheapest configuration of the grid search space (ties: the first in enumeration order).
// `spare_capacity`: how many references clipping may add. Deterministic; parallel for big grids.
GridSearchResult search_grid(const ContainmentGrid& grid, const AABB& node, uint32_t reference_count,
                             size_t spare_capacity, const CostModel& cost, bool split_primitives);

// Where a reference goes in a grid split with child boxes left_region and right_region: the forced
// assignment above, with exact clipping (src/core/clip.cpp) for a reference in neither. A side it
// does not go to gets an empty box. Used by the finder (to tighten the children's boxes) and by
// apply_split, so both see the same references.
std::pair<Reference, Reference> place_in_grid_children(const Reference& reference, const Triangle& triangle,
                                                       const AABB& left_region, const AABB& right_region);

class GridSplitFinder final : public SplitFinder {
public:
    GridSplitFinder(std::span<const Triangle> triangles, GridSearchOptions options)
        : triangles_(triangles), options_(options) {}
    const char* name() const override { return "grid"; }
    // The best configuration by the cost with grid boxes, then its cost with the tight boxes of the
    // references it assigns (never higher: smaller boxes, less overlap).
    Split find(const NodeContext& node, const CostModel& cost) const override;

private:
    std::span<const Triangle> triangles_;
    GridSearchOptions options_;
};

}  // namespace spacebvh::builders
