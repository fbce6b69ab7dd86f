// SPDX-License-Identifier: MIT
#include "builders/search_spaces/grid_split_finder.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "spacebvh/clip.hpp"

namespace spacebvh::builders {

uint32_t grid_cells_for(size_t reference_count, const GridSearchOptions& options) {
    // The small slack keeps exact sixth powers exact (64^(1/6) may round above 2).
    const double cells = std::ceil(double(options.resolution) * std::pow(double(reference_count), 1.0 / 6.0) - 1e-9);
    return uint32_t(std::clamp(cells, 2.0, double(std::max(options.max_cells, 2u))));
}

ContainmentGrid::ContainmentGrid(std::span<const Reference> references, const AABB& node, uint32_t cells) {
    for (int axis = 0; axis < 3; ++axis) {
        const float lo = node.lo[axis], hi = node.hi[axis];
        std::vector<float>& planes = planes_[axis];
        if (!(hi > lo)) {
            cells_[axis] = 0;  // flat: the one grid line is the node's plane
            planes = {lo};
        } else {
            // A node spanning more than FLT_MAX: the same width without the overflowing difference.
            const float extent = hi - lo;
            const float width = std::isfinite(extent) ? extent / float(cells) : hi / float(cells) - lo / float(cells);
            planes.resize(cells + 1);
            for (uint32_t i = 0; i < cells; ++i) planes[i] = lo + float(i) * width;
            planes[cells] = hi;
            // Snapping needs strictly increasing planes; a box too thin for them gets one cell.
            const bool increasing =
                std::adjacent_find(planes.begin(), planes.end(), std::greater_equal<float>()) == planes.end();
            cells_[axis] = increasing ? cells : 1;
            if (!increasing) planes = {lo, hi};
        }
        intervals_[axis] = (cells_[axis] + 1) * (cells_[axis] + 2) / 2;
    }
    table_.assign(size_t(intervals_[0]) * intervals_[1] * intervals_[2], 0);

    // Snap: the last grid line at or below lo, the first at or above hi (so "inside box [l, h]" is
    // exactly l <= lo_line and hi_line <= h, with the float planes themselves deciding).
    GridBox snapped;
    for (const Reference& reference : references) {
        for (int axis = 0; axis < 3; ++axis) {
            const std::vector<float>& planes = planes_[axis];
            const uint32_t last = cells_[axis];
            const float scale = last ? float(last) / (planes[last] - planes[0]) : 0.0f;
            // A first guess of the cell, which the loops settle on the planes; 0 where the position is
            // NaN (an infinite difference times a zero scale, on a node spanning more than FLT_MAX).
            const auto guess = [last](float position) {
                return position >= 0.0f ? uint32_t(std::min(position, float(last))) : 0u;
            };
            const float x_lo = reference.bounds.lo[axis], x_hi = reference.bounds.hi[axis];
            uint32_t l = guess((x_lo - planes[0]) * scale);
            while (l > 0 && planes[l] > x_lo) --l;
            while (l < last && planes[l + 1] <= x_lo) ++l;
            uint32_t h = guess(std::ceil((x_hi - planes[0]) * scale));
            while (h < last && planes[h] < x_hi) ++h;
            while (h > 0 && planes[h - 1] >= x_hi) --h;
            snapped.lo[axis] = uint8_t(l);
            snapped.hi[axis] = uint8_t(std::max(h, l));
        }
        ++table_[index(snapped)];
    }

    // Dominance sums, one axis at a time: count(l, h) = sum over l' >= l, h' <= h (l' <= h') of the
    // snapped counts. First a suffix sum over l for each h, then a prefix sum over h for each l.
    const size_t strides[3] = {size_t(intervals_[1]) * intervals_[2], intervals_[2], 1};
    for (int axis = 0; axis < 3; ++axis) {
        const int a = (axis + 1) % 3, b = (axis + 2) % 3;
        const uint32_t last = cells_[axis];
        for (uint32_t i = 0; i < intervals_[a]; ++i)
            for (uint32_t j = 0; j < intervals_[b]; ++j) {
                uint32_t* line = table_.data() + i * strides[a] + j * strides[b];
                auto at = [&](uint32_t lo, uint32_t hi) -> uint32_t& {
                    return line[interval_index(lo, hi) * strides[axis]];
                };
                for (uint32_t h = 1; h <= last; ++h)
                    for (uint32_t l = h; l-- > 0;) at(l, h) += at(l + 1, h);
                for (uint32_t l = 0; l < last; ++l)
                    for (uint32_t h = l + 1; h <= last; ++h) at(l, h) += at(l, h - 1);
            }
    }
}

AABB ContainmentGrid::box(const GridBox& b) const {
    AABB box;
    for (int axis = 0; axis < 3; ++axis) {
        box.lo[axis] = planes_[axis][b.lo[axis]];
        box.hi[axis] = planes_[axis][b.hi[axis]];
    }
    return box;
}

bool inherits_every_face(const ContainmentGrid& grid, const GridConfiguration& c) {
    for (int axis = 0; axis < 3; ++axis) {
        const uint32_t last = grid.cells(axis);
        if (c.left.lo[axis] != 0 && c.right.lo[axis] != 0) return false;
        if (c.left.hi[axis] != last && c.right.hi[axis] != last) return false;
    }
    return true;
}

bool covers_node(const ContainmentGrid& grid, const GridConfiguration& c) {
    auto full = [&](const GridBox& b, int axis) { return b.lo[axis] == 0 && b.hi[axis] == grid.cells(axis); };
    int both_full = 0;
    bool left_is_node = true, right_is_node = true, intervals_cover = true;
    for (int axis = 0; axis < 3; ++axis) {
        left_is_node = left_is_node && full(c.left, axis);
        right_is_node = right_is_node && full(c.right, axis);
        both_full += full(c.left, axis) && full(c.right, axis);
        const uint32_t lo = std::min(c.left.lo[axis], c.right.lo[axis]);
        const uint32_t hi = std::max(c.left.hi[axis], c.right.hi[axis]);
        const bool touch = std::max(c.left.lo[axis], c.right.lo[axis]) <= std::min(c.left.hi[axis], c.right.hi[axis]);
        intervals_cover = intervals_cover && lo == 0 && hi == grid.cells(axis) && touch;
    }
    // The union of two boxes is the node box when one of them is, or when they agree (full) on two
    // axes and their intervals cover the third.
    return left_is_node || right_is_node || (both_full >= 2 && intervals_cover);
}

namespace {

// The assignment rule shared by the table search and the brute-force view of it.
GridCounts assign(uint32_t inside_left, uint32_t inside_right, uint32_t inside_both, uint32_t reference_count,
                  bool both_go_left) {
    GridCounts counts;
    counts.clipped = reference_count - inside_left - inside_right + inside_both;
    counts.left = inside_left - inside_both + (both_go_left ? inside_both : 0) + counts.clipped;
    counts.right = inside_right - inside_both + (both_go_left ? 0 : inside_both) + counts.clipped;
    return counts;
}

GridBox intersection_box(const GridBox& a, const GridBox& b, bool& exists) {
    GridBox box;
    exists = true;
    for (int axis = 0; axis < 3; ++axis) {
        box.lo[axis] = std::max(a.lo[axis], b.lo[axis]);
        box.hi[axis] = std::min(a.hi[axis], b.hi[axis]);
        exists = exists && box.lo[axis] <= box.hi[axis];
    }
    return box;
}

// One axis of a configuration: the children's intervals on it, among the pairs that inherit both of
// the node's faces on this axis.
struct AxisPair {
    uint8_t left_lo, left_hi, right_lo, right_hi;
    uint16_t left, right, intersection;  // interval indices
    bool has_intersection;               // the intervals meet (then their union is the whole axis)
    bool both_full;
    bool overlaps;  // V(L ∩ R) may be positive: a positive overlap length, or a flat axis
    float left_lo_plane, left_hi_plane, right_lo_plane, right_hi_plane;
    uint32_t swapped;  // the index of the pair with left and right exchanged
};

std::vector<AxisPair> axis_pairs(const ContainmentGrid& grid, int axis) {
    const uint32_t last = grid.cells(axis);
    std::vector<AxisPair> pairs;
    for (uint32_t left_lo = 0; left_lo <= last; ++left_lo)
        for (uint32_t left_hi = left_lo; left_hi <= last; ++left_hi)
            for (uint32_t right_lo = 0; right_lo <= last; ++right_lo)
                for (uint32_t right_hi = right_lo; right_hi <= last; ++right_hi) {
                    if (left_lo != 0 && right_lo != 0) continue;        // the lower face is inherited
                    if (left_hi != last && right_hi != last) continue;  // the upper face is inherited
                    AxisPair pair;
                    pair.left_lo = uint8_t(left_lo);
                    pair.left_hi = uint8_t(left_hi);
                    pair.right_lo = uint8_t(right_lo);
                    pair.right_hi = uint8_t(right_hi);
                    pair.left = uint16_t(ContainmentGrid::interval_index(left_lo, left_hi));
                    pair.right = uint16_t(ContainmentGrid::interval_index(right_lo, right_hi));
                    const uint32_t meet_lo = std::max(left_lo, right_lo), meet_hi = std::min(left_hi, right_hi);
                    pair.has_intersection = meet_lo <= meet_hi;
                    pair.intersection =
                        uint16_t(pair.has_intersection ? ContainmentGrid::interval_index(meet_lo, meet_hi) : 0);
                    pair.both_full = left_lo == 0 && right_lo == 0 && left_hi == last && right_hi == last;
                    pair.left_lo_plane = grid.plane(axis, left_lo);
                    pair.left_hi_plane = grid.plane(axis, left_hi);
                    pair.right_lo_plane = grid.plane(axis, right_lo);
                    pair.right_hi_plane = grid.plane(axis, right_hi);
                    // The same float expression as overlap_fraction's intersect().extent().
                    const float overlap = std::min(pair.left_hi_plane, pair.right_hi_plane) -
                                          std::max(pair.left_lo_plane, pair.right_lo_plane);
                    pair.overlaps = last == 0 || overlap > 0.0f;
                    pairs.push_back(pair);
                }
    for (AxisPair& pair : pairs) {
        const auto swapped = std::find_if(pairs.begin(), pairs.end(), [&](const AxisPair& other) {
            return other.left == pair.right && other.right == pair.left;
        });
        pair.swapped = uint32_t(swapped - pairs.begin());
    }
    return pairs;
}

struct Candidate {
    float cost = kInfinity;
    uint64_t order = std::numeric_limits<uint64_t>::max();  // enumeration index: ties go to the first
    GridCounts counts;

    bool better_than(const Candidate& other) const {
        return cost < other.cost || (cost == other.cost && order < other.order);
    }
};

}  // namespace

GridCounts count_assignment(const ContainmentGrid& grid, const GridConfiguration& c, uint32_t reference_count) {
    bool meet = false;
    const GridBox both = intersection_box(c.left, c.right, meet);
    const bool both_go_left = grid.box(c.left).area() <= grid.box(c.right).area();
    return assign(grid.contained(c.left), grid.contained(c.right), meet ? grid.contained(both) : 0, reference_count,
                  both_go_left);
}

GridSearchResult search_grid(const ContainmentGrid& grid, const AABB& node, uint32_t reference_count,
                             size_t spare_capacity, const CostModel& cost, bool split_primitives) {
    const std::vector<AxisPair> pairs[3] = {axis_pairs(grid, 0), axis_pairs(grid, 1), axis_pairs(grid, 2)};
    const size_t count1 = pairs[1].size(), count2 = pairs[2].size();
    const bool disjoint_only = cost.overlap_penalty == kInfinity;
    const uint32_t intervals1 = grid.intervals(1), intervals2 = grid.intervals(2);

    auto evaluate = [&](size_t begin, size_t end, Candidate best) {
        for (size_t p0 = begin; p0 < end; ++p0) {
            const AxisPair& a = pairs[0][p0];
            // L <-> R symmetry: evaluate a configuration only if it comes before its mirror.
            if (p0 > a.swapped) continue;
            for (size_t p1 = 0; p1 < count1; ++p1) {
                const AxisPair& b = pairs[1][p1];
                if (p0 == a.swapped && p1 > b.swapped) continue;
                const bool mirror_so_far = p0 == a.swapped && p1 == b.swapped;
                const size_t left01 = (size_t(a.left) * intervals1 + b.left) * intervals2;
                const size_t right01 = (size_t(a.right) * intervals1 + b.right) * intervals2;
                const size_t both01 = (size_t(a.intersection) * intervals1 + b.intersection) * intervals2;
                for (size_t p2 = 0; p2 < count2; ++p2) {
                    const AxisPair& c = pairs[2][p2];
                    if (mirror_so_far && p2 > c.swapped) continue;
                    if (disjoint_only && a.overlaps && b.overlaps && c.overlaps) continue;  // cost would be inf
                    const uint32_t inside_left = grid.contained_at(left01 + c.left);
                    const uint32_t inside_right = grid.contained_at(right01 + c.right);
                    const bool meet = a.has_intersection && b.has_intersection && c.has_intersection;
                    const uint32_t inside_both = meet ? grid.contained_at(both01 + c.intersection) : 0;
                    const uint32_t neither = reference_count - inside_left - inside_right + inside_both;
                    if (neither > 0) {
                        // Clipping into both children needs L ∪ R = node box (see the header).
                        const bool covers = meet && int(a.both_full) + int(b.both_full) + int(c.both_full) >= 2;
                        if (!split_primitives || !covers || neither > spare_capacity) continue;
                    }
                    const AABB left{{a.left_lo_plane, b.left_lo_plane, c.left_lo_plane},
                                    {a.left_hi_plane, b.left_hi_plane, c.left_hi_plane}};
                    const AABB right{{a.right_lo_plane, b.right_lo_plane, c.right_lo_plane},
                                     {a.right_hi_plane, b.right_hi_plane, c.right_hi_plane}};
                    const GridCounts counts =
                        assign(inside_left, inside_right, inside_both, reference_count, left.area() <= right.area());
                    if (counts.left == 0 || counts.right == 0) continue;
                    const float candidate_cost = cost.split_cost(node, left, counts.left, right, counts.right);
                    if (candidate_cost < best.cost) {
                        best.cost = candidate_cost;
                        best.order = (uint64_t(p0) * count1 + p1) * count2 + p2;
                        best.counts = counts;
                    }
                }
            }
        }
        return best;
    };

    Candidate best;
    const size_t count0 = pairs[0].size();
    constexpr size_t kParallelConfigurations = size_t(1) << 18;
    if (count0 * count1 * count2 < kParallelConfigurations) {
        best = evaluate(0, count0, Candidate{});
    } else {
        // (cost, order) is a total order, so the reduction does not depend on how TBB splits the range.
        best = tbb::parallel_reduce(
            tbb::blocked_range<size_t>(0, count0, 1), Candidate{},
            [&](const tbb::blocked_range<size_t>& range, Candidate partial) {
                return evaluate(range.begin(), range.end(), partial);
            },
            [](const Candidate& x, const Candidate& y) { return y.better_than(x) ? y : x; });
    }

    GridSearchResult result;
    if (!(best.cost < kInfinity)) return result;
    const size_t p2 = best.order % count2, p1 = (best.order / count2) % count1, p0 = best.order / count2 / count1;
    const AxisPair* chosen[3] = {&pairs[0][p0], &pairs[1][p1], &pairs[2][p2]};
    for (int axis = 0; axis < 3; ++axis) {
        result.configuration.left.lo[axis] = chosen[axis]->left_lo;
        result.configuration.left.hi[axis] = chosen[axis]->left_hi;
        result.configuration.right.lo[axis] = chosen[axis]->right_lo;
        result.configuration.right.hi[axis] = chosen[axis]->right_hi;
    }
    result.found = true;
    result.cost = best.cost;
    result.counts = best.counts;
    return result;
}

std::pair<Reference, Reference> place_in_grid_children(const Reference& reference, const Triangle& triangle,
                                                       const AABB& left_region, const AABB& right_region) {
    const Reference nowhere{AABB{}, reference.primitive};
    const bool in_left = left_region.contains(reference.bounds), in_right = right_region.contains(reference.bounds);
    if (in_left && in_right)
        return left_region.area() <= right_region.area() ? std::pair{reference, nowhere}
                                                         : std::pair{nowhere, reference};
    if (in_left) return {reference, nowhere};
    if (in_right) return {nowhere, reference};
    // In neither: the parts of the triangle (as restricted by the reference) inside each child.
    const Reference left{clip_triangle_bounds(triangle, intersect(reference.bounds, left_region)), reference.primitive};
    const Reference right{clip_triangle_bounds(triangle, intersect(reference.bounds, right_region)),
                          reference.primitive};
    if (left.bounds.is_empty() && right.bounds.is_empty()) return {reference, nowhere};  // rounding: keep it whole
    return {left, right};
}

Split GridSplitFinder::find(const NodeContext& context, const CostModel& cost) const {
    Split best;
    const std::span<const Reference> references = context.references;
    const uint32_t count = uint32_t(references.size());
    if (count < 2) return best;
    const AABB& node = context.summary.bounds;
    const ContainmentGrid grid(references, node, grid_cells_for(count, options_));
    const size_t spare = context.capacity > count ? context.capacity - count : 0;
    const GridSearchResult result = search_grid(grid, node, count, spare, cost, options_.split_primitives);
    if (!result.found) return best;

    // The children's real boxes: the tight bounds of what each receives (clipped pieces included).
    const AABB left_region = grid.box(result.configuration.left), right_region = grid.box(result.configuration.right);
    AABB left, right;
    uint32_t left_count = 0, right_count = 0;
    for (const Reference& reference : references) {
        const auto [left_piece, right_piece] =
            place_in_grid_children(reference, triangles_[reference.primitive], left_region, right_region);
        if (!left_piece.bounds.is_empty()) left.extend(left_piece.bounds), ++left_count;
        if (!right_piece.bounds.is_empty()) right.extend(right_piece.bounds), ++right_count;
    }
    if (left_count == 0 || right_count == 0) return best;
    // Axis 0: a grid split has no plane; the regions below say where references go.
    best = make_split(SplitKind::grid, cost.split_cost(node, left, left_count, right, right_count), 0, left, left_count,
                      right, right_count);
    best.left_region = left_region;
    best.right_region = right_region;
    return best;
}

}  // namespace spacebvh::builders
