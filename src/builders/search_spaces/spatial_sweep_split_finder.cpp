// SPDX-License-Identifier: MIT
#include "builders/search_spaces/spatial_sweep_split_finder.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <numeric>
#include <vector>

#include "builders/driver/partition.hpp"
#include "builders/search_spaces/spatial_split.hpp"

namespace spacebvh::builders {

SpatialPlaneEvaluation evaluate_spatial_plane(std::span<const Reference> references,
                                              std::span<const Triangle> triangles, int axis, float position) {
    SpatialPlaneEvaluation result;
    for (const Reference& reference : references) {
        // The classification of apply_spatial_split (without unsplitting).
        const PlaneSide side = plane_side(reference, axis, position);
        if (side == PlaneSide::left) {
            result.left_bounds.extend(reference.bounds);
            ++result.left_count;
        } else if (side == PlaneSide::right) {
            result.right_bounds.extend(reference.bounds);
            ++result.right_count;
        } else {
            const auto [left, right] = split_reference(reference, triangles[reference.primitive], axis, position);
            result.left_bounds.extend(left.bounds);
            result.right_bounds.extend(right.bounds);
            result.left_count += !left.bounds.is_empty();
            result.right_count += !right.bounds.is_empty();
        }
    }
    return result;
}

namespace {

// Straddlers whose piece is still clipped at every plane, with their pieces in a pool whose slots
// are reused (a piece is only built when the straddler first sticks out of the child box).
class Straddlers {
public:
    void add(uint32_t reference) { active_.push_back({reference, kNoSlot, -kInfinity}); }
    size_t size() const { return active_.size(); }

    // Extends `box` by the piece of every active straddler at `position` on `side` (below: the left
    // child). Drops references that no longer straddle, and retires straddlers whose whole box
    // lies inside `box` except on the plane side (their later pieces would add nothing).
    template <typename StillStraddles>
    void extend(AABB& box, std::span<const Reference> references, std::span<const Triangle> triangles, int axis,
                float position, bool below, StillStraddles still_straddles) {
        for (size_t i = 0; i < active_.size();) {
            Entry& entry = active_[i];
            const Reference& reference = references[entry.reference];
            if (!still_straddles(reference) || inside_except_plane(reference.bounds, box, axis, below)) {
                release(entry);
                entry = active_.back();
                active_.pop_back();
                continue;
            }
            // Asleep: its piece cannot leave the box before the sweep reaches entry.quiet_until.
            if ((below ? position : -position) < entry.quiet_until) {
                ++i;
                continue;
            }
            if (entry.slot == kNoSlot) entry.slot = acquire(triangles[reference.primitive], reference.bounds);
            const clipping::TrianglePiece& piece = pool_[entry.slot];
            piece.extend_side(box, axis, position, below);
            entry.quiet_until = piece.quiet_until(box, axis, position, below);
            ++i;
        }
    }

    void clear() {
        active_.clear();
        pool_.clear();
        free_.clear();
    }

private:
    static constexpr uint32_t kNoSlot = ~0u;
    struct Entry {
        uint32_t reference;
        uint32_t slot;
        float quiet_until;  // along the sweep (x, or -x sweeping down); see TrianglePiece::quiet_until
    };

    static bool inside_except_plane(const AABB& reference, const AABB& box, int axis, bool below) {
        for (int k = 0; k < 3; ++k) {
            if (reference.lo[k] < box.lo[k] && !(k == axis && !below)) return false;
            if (reference.hi[k] > box.hi[k] && !(k == axis && below)) return false;
        }
        return true;
    }
    uint32_t acquire(const Triangle& triangle, const AABB& bounds) {
        if (!free_.empty()) {
            const uint32_t slot = free_.back();
            free_.pop_back();
            pool_[slot] = clipping::TrianglePiece(triangle, bounds);
            return slot;
        }
        pool_.emplace_back(triangle, bounds);
        return uint32_t(pool_.size() - 1);
    }
    void release(const Entry& entry) {
        if (entry.slot != kNoSlot) free_.push_back(entry.slot);
    }

    std::vector<Entry> active_;
    std::vector<clipping::TrianglePiece> pool_;
    std::vector<uint32_t> free_;
};

struct Candidate {
    float cost;
    int axis;
    size_t plane;
};

}  // namespace

SpatialSweepPlanes sweep_spatial_planes(std::span<const Reference> references, std::span<const Triangle> triangles,
                                        const AABB& node, int axis) {
    SpatialSweepPlanes sweep;
    const uint32_t count = uint32_t(references.size());
    auto lo_of = [&](uint32_t i) { return references[i].bounds.lo[axis]; };
    auto hi_of = [&](uint32_t i) { return references[i].bounds.hi[axis]; };
    // Total orders (position, then index): the sweep is a function of the references' order alone.
    std::vector<uint32_t> by_lo(count), by_hi(count);
    std::iota(by_lo.begin(), by_lo.end(), 0u);
    std::iota(by_hi.begin(), by_hi.end(), 0u);
    std::sort(by_lo.begin(), by_lo.end(),
              [&](uint32_t a, uint32_t b) { return lo_of(a) != lo_of(b) ? lo_of(a) < lo_of(b) : a < b; });
    std::sort(by_hi.begin(), by_hi.end(),
              [&](uint32_t a, uint32_t b) { return hi_of(a) != hi_of(b) ? hi_of(a) < hi_of(b) : a < b; });
    // Candidate planes: the distinct events strictly inside the node (a plane on the node's faces
    // leaves one child empty).
    sweep.planes.reserve(2 * size_t(count));
    for (uint32_t i : by_lo) sweep.planes.push_back(lo_of(i));
    for (uint32_t i : by_hi) sweep.planes.push_back(hi_of(i));
    std::sort(sweep.planes.begin(), sweep.planes.end());
    sweep.planes.erase(std::unique(sweep.planes.begin(), sweep.planes.end()), sweep.planes.end());
    std::erase_if(sweep.planes, [&](float p) { return !(p > node.lo[axis] && p < node.hi[axis]); });
    const size_t plane_count = sweep.planes.size();
    sweep.left_bounds.resize(plane_count);
    sweep.right_bounds.resize(plane_count);
    sweep.left_counts.resize(plane_count);
    sweep.right_counts.resize(plane_count);

    Straddlers straddlers;
    // Left to right. Left child at p: references with hi <= p whole (those lying flat in the plane
    // included), and the straddlers (lo < p < hi) clipped below p.
    // The child box only grows along the sweep (a part below p is below every later plane), so it is
    // carried from plane to plane; retired and sleeping straddlers rely on that.
    AABB box;
    size_t next_lo = 0, next_hi = 0;
    uint32_t below_count = 0, settled_count = 0;  // #(lo < p), #(hi <= p)
    for (size_t k = 0; k < plane_count; ++k) {
        const float p = sweep.planes[k];
        uint32_t flat_in_plane = 0;
        for (; next_hi < count && hi_of(by_hi[next_hi]) <= p; ++next_hi, ++settled_count) {
            const Reference& reference = references[by_hi[next_hi]];
            box.extend(reference.bounds);
            flat_in_plane += reference.bounds.lo[axis] == p;
        }
        for (; next_lo < count && lo_of(by_lo[next_lo]) < p; ++next_lo, ++below_count)
            if (hi_of(by_lo[next_lo]) > p) straddlers.add(by_lo[next_lo]);
        const uint32_t straddling = below_count - (settled_count - flat_in_plane);
        if (straddling > 0) box.hi[axis] = std::max(box.hi[axis], p);  // straddlers reach the plane
        straddlers.extend(box, references, triangles, axis, p, true,
                          [&](const Reference& reference) { return reference.bounds.hi[axis] > p; });
        sweep.left_bounds[k] = box;
        sweep.left_counts[k] = below_count + flat_in_plane;
    }

    // Right to left. Right child at p: references with lo > p, or lo == p < hi, whole; straddlers
    // clipped above p. References flat in the plane go left, so they join the right side only at the
    // next plane down.
    straddlers.clear();
    box = AABB::empty();
    std::vector<uint32_t> flat_pending;
    size_t lo_index = count, hi_index = count;
    uint32_t above_count = 0;  // #(hi > p)
    settled_count = 0;         // #(lo > p or lo == p < hi)
    for (size_t k = plane_count; k-- > 0;) {
        const float p = sweep.planes[k];
        for (uint32_t i : flat_pending) box.extend(references[i].bounds);
        settled_count += uint32_t(flat_pending.size());
        flat_pending.clear();
        for (; lo_index > 0 && lo_of(by_lo[lo_index - 1]) >= p; --lo_index) {
            const uint32_t i = by_lo[lo_index - 1];
            if (lo_of(i) == p && hi_of(i) == p) {
                flat_pending.push_back(i);
            } else {
                box.extend(references[i].bounds);
                ++settled_count;
            }
        }
        for (; hi_index > 0 && hi_of(by_hi[hi_index - 1]) > p; --hi_index, ++above_count)
            if (lo_of(by_hi[hi_index - 1]) < p) straddlers.add(by_hi[hi_index - 1]);
        const uint32_t straddling = above_count - settled_count;
        if (straddling > 0) box.lo[axis] = std::min(box.lo[axis], p);
        straddlers.extend(box, references, triangles, axis, p, false,
                          [&](const Reference& reference) { return reference.bounds.lo[axis] < p; });
        sweep.right_bounds[k] = box;
        sweep.right_counts[k] = above_count;
    }
    return sweep;
}

Split SpatialSweepSplitFinder::find(const NodeContext& context, const CostModel& cost) const {
    Split best;
    const std::span<const Reference> references = context.references;
    if (references.size() < 2 || spatial_search_gated_off(context, cost, options_.gate_alpha)) return best;
    const AABB& node = context.summary.bounds;
    std::array<SpatialSweepPlanes, 3> sweeps;
    auto run = [&](int axis) {
        if (node.hi[axis] > node.lo[axis]) sweeps[axis] = sweep_spatial_planes(references, triangles_, node, axis);
    };
    // The axes are independent; each result is a function of the references alone.
    constexpr size_t kParallelThreshold = 4096;
    if (references.size() >= kParallelThreshold) {
        tbb::parallel_for(0, 3, run);
    } else {
        for (int axis = 0; axis < 3; ++axis) run(axis);
    }

    auto consider = [&](float split_cost, int axis, float position, const AABB& left, uint32_t left_count,
                        const AABB& right, uint32_t right_count) {
        if (split_cost < best.cost)
            best = spatial_split(split_cost, axis, position, left, left_count, right, right_count, options_.unsplit);
    };
    std::vector<Candidate> ranked;  // the best event planes, for the interior study
    for (int axis = 0; axis < 3; ++axis) {
        const SpatialSweepPlanes& sweep = sweeps[axis];
        for (size_t k = 0; k < sweep.planes.size(); ++k) {
            if (sweep.left_counts[k] == 0 || sweep.right_counts[k] == 0) continue;
            // Over this subtree's budget the plane is still a candidate: apply_split then sends the
            // straddlers it cannot duplicate whole to their cheaper side (the budget always holds).
            const float split_cost = cost.split_cost(node, sweep.left_bounds[k], sweep.left_counts[k],
                                                     sweep.right_bounds[k], sweep.right_counts[k]);
            consider(split_cost, axis, sweep.planes[k], sweep.left_bounds[k], sweep.left_counts[k],
                     sweep.right_bounds[k], sweep.right_counts[k]);
            if (options_.interior_samples > 0 && split_cost < kInfinity) ranked.push_back({split_cost, axis, k});
        }
    }
    if (options_.interior_samples == 0 || ranked.empty()) return best;

    // The interior study: positions strictly between an event plane and its neighbours.
    const size_t studied = std::min<size_t>(options_.interior_intervals, ranked.size());
    std::partial_sort(ranked.begin(), ranked.begin() + studied, ranked.end(),
                      [](const Candidate& a, const Candidate& b) {
                          if (a.cost != b.cost) return a.cost < b.cost;
                          return a.axis != b.axis ? a.axis < b.axis : a.plane < b.plane;
                      });
    for (size_t r = 0; r < studied; ++r) {
        const int axis = ranked[r].axis;
        const std::vector<float>& planes = sweeps[axis].planes;
        const size_t k = ranked[r].plane;
        const float low_end[2] = {k > 0 ? planes[k - 1] : node.lo[axis], planes[k]};
        const float high_end[2] = {planes[k], k + 1 < planes.size() ? planes[k + 1] : node.hi[axis]};
        for (int side = 0; side < 2; ++side) {
            const float a = low_end[side], b = high_end[side];
            for (uint32_t s = 1; s <= options_.interior_samples; ++s) {
                const float position = a + (b - a) * (float(s) / float(options_.interior_samples + 1));
                if (!(position > a && position < b)) continue;  // no float strictly inside
                const SpatialPlaneEvaluation plane = evaluate_spatial_plane(references, triangles_, axis, position);
                if (plane.left_count == 0 || plane.right_count == 0) continue;
                consider(
                    cost.split_cost(node, plane.left_bounds, plane.left_count, plane.right_bounds, plane.right_count),
                    axis, position, plane.left_bounds, plane.left_count, plane.right_bounds, plane.right_count);
            }
        }
    }
    return best;
}

}  // namespace spacebvh::builders
