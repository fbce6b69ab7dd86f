// SPDX-License-Identifier: MIT
// Tree quality metrics: structure, memory, tree SAH and End-Point Overlap (EPO).
//
// SAH (Aila, Karras & Laine 2013, Eq. 1; the cost model header):
//   SAH = sum_inner C_T * SA(n) / SA(root) + sum_leaf C_I * |l| * SA(l) / SA(root),
// |l| = distinct triangles of the leaf (a spatial-split builder may list a triangle twice in a leaf;
// a ray tests it once). Areas are evaluated in double from the float boxes.
//
// EPO (Aila, Karras & Laine 2013, Section 4):
//   EPO = sum_n C_n * A((S \ Q(n)) ∩ n) / A(S),
// S = all scene triangles, Q(n) = triangles referenced anywhere in n's subtree, A = triangle surface
// area (exact Sutherland-Hodgman clipping to n's closed box, so a triangle lying in a face of the box
// counts, one merely touching it does not), C_n = C_T for inner nodes and C_I * |n| for leaves with
// |n| = distinct triangles of the leaf (the same convention as tree SAH and tinybvh's EPOCost).
//
// Finding the triangles that overlap a node's box: the tree itself is the search structure. For node
// n we traverse from the root with n's box, skipping n's own subtree (all of it is in Q(n)) and every
// node whose box does not overlap; each leaf triangle found is clipped to n's box unless it is also
// referenced inside n's subtree (possible only when a builder duplicates references). Nodes run in
// parallel; per-node values are stored and summed in node order in double, so the result does not
// depend on the thread count.
#include "spacebvh/tools/metrics.hpp"

#include <algorithm>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "spacebvh/clip.hpp"

namespace spacebvh::tools {
namespace {

double triangle_area(const Triangle& t) {
    double ax = double(t.v1.x) - t.v0.x, ay = double(t.v1.y) - t.v0.y, az = double(t.v1.z) - t.v0.z;
    double bx = double(t.v2.x) - t.v0.x, by = double(t.v2.y) - t.v0.y, bz = double(t.v2.z) - t.v0.z;
    double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
    return 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
}

bool boxes_overlap(const AABB& a, const AABB& b) {
    return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y && a.lo.z <= b.hi.z &&
           b.lo.z <= a.hi.z;
}

size_t distinct_in_leaf(const Bvh& bvh, const BvhNode& leaf) {
    const uint32_t* begin = bvh.primitives.data() + leaf.first;
    const uint32_t* end = begin + leaf.reference_count;
    // Leaves are small: a quadratic scan avoids allocating.
    size_t distinct = 0;
    for (const uint32_t* p = begin; p != end; ++p) {
        if (std::find(begin, p, *p) == p) ++distinct;
    }
    return distinct;
}

// Calls visit(node_index, depth) for every node reachable from the root, depth-first, left first.
template <class Visit>
void for_each_reachable(const Bvh& bvh, Visit&& visit) {
    if (bvh.empty()) return;
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};
    while (!stack.empty()) {
        auto [index, depth] = stack.back();
        stack.pop_back();
        visit(index, depth);
        const BvhNode& node = bvh.nodes[index];
        if (!node.is_leaf()) {
            stack.push_back({node.first + 1, depth + 1});
            stack.push_back({node.first, depth + 1});
        }
    }
}

// Pre-order numbering of the reachable nodes: node m is in n's subtree iff
// order[n] <= order[m] <= last[n]. `reachable` lists the nodes in that order.
struct PreOrder {
    std::vector<uint32_t> order, last, reachable;

    explicit PreOrder(const Bvh& bvh) : order(bvh.nodes.size(), kInvalidIndex), last(bvh.nodes.size(), 0) {
        reachable.reserve(bvh.nodes.size());
        for_each_reachable(bvh, [&](uint32_t index, uint32_t) {
            order[index] = uint32_t(reachable.size());
            reachable.push_back(index);
        });
        // Pre-order lists parents before children, so a backward sweep finishes children first.
        for (size_t i = reachable.size(); i-- > 0;) {
            uint32_t index = reachable[i];
            const BvhNode& node = bvh.nodes[index];
            last[index] = node.is_leaf() ? order[index] : std::max(last[node.first], last[node.first + 1]);
        }
    }
};

// For each triangle, the pre-order numbers of the leaves that reference it (CSR), so that
// "t in Q(n)" is a range test. Only consulted for triangles referenced more than once.
struct ReferencingLeaves {
    std::vector<uint32_t> offsets, orders;

    ReferencingLeaves(const Bvh& bvh, const PreOrder& pre_order, size_t triangle_count)
        : offsets(triangle_count + 1, 0) {
        for (uint32_t index : pre_order.reachable) {
            const BvhNode& node = bvh.nodes[index];
            if (!node.is_leaf()) continue;
            for (uint32_t k = 0; k < node.reference_count; ++k) ++offsets[bvh.primitives[node.first + k] + 1];
        }
        for (size_t t = 0; t < triangle_count; ++t) offsets[t + 1] += offsets[t];
        orders.resize(offsets.back());
        std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
        for (uint32_t index : pre_order.reachable) {
            const BvhNode& node = bvh.nodes[index];
            if (!node.is_leaf()) continue;
            for (uint32_t k = 0; k < node.reference_count; ++k) {
                orders[fill[bvh.primitives[node.first + k]]++] = pre_order.order[index];
            }
        }
    }
    uint32_t references(uint32_t triangle) const { return offsets[triangle + 1] - offsets[triangle]; }
    bool in_subtree(uint32_t triangle, uint32_t node, const PreOrder& pre_order) const {
        for (uint32_t i = offsets[triangle]; i < offsets[triangle + 1]; ++i) {
            if (orders[i] >= pre_order.order[node] && orders[i] <= pre_order.last[node]) return true;
        }
        return false;
    }
};

// Triangle boxes in leaf-slot order, so that the common rejection (a leaf triangle whose box
// misses n's box) reads memory sequentially instead of gathering vertices.
std::vector<AABB> bounds_by_slot(const Scene& scene, const Bvh& bvh) {
    std::vector<AABB> slot_bounds(bvh.primitives.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, slot_bounds.size(), 4096),
                      [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i != r.end(); ++i)
                              slot_bounds[i] = scene.triangles[bvh.primitives[i]].bounds();
                      });
    return slot_bounds;
}

// What a thread reuses from node to node.
struct EpoScratch {
    std::vector<uint32_t> stamp;  // stamp[t] == epoch: triangle t already handled for this node
    uint32_t epoch = 0;
    std::vector<uint32_t> stack;
};

// Everything tree_epo precomputes once for every node's term.
struct EpoTables {
    const Scene& scene;
    const Bvh& bvh;
    std::vector<double> areas;
    PreOrder pre_order;
    ReferencingLeaves leaves;
    std::vector<AABB> slot_bounds;
};

// A((S \ Q(n)) ∩ n) of node n: the tree traversed with n's box, n's own subtree skipped, every leaf
// triangle found clipped to the box unless it is also referenced inside the subtree.
double area_outside_subtree(const EpoTables& tables, uint32_t n, EpoScratch& s) {
    const Bvh& bvh = tables.bvh;
    const AABB& box = bvh.nodes[n].bounds;
    if (++s.epoch == 0) {  // wrapped: clear the stamps once
        std::fill(s.stamp.begin(), s.stamp.end(), 0);
        s.epoch = 1;
    }
    double area = 0.0;
    s.stack.clear();
    s.stack.push_back(0);
    while (!s.stack.empty()) {
        uint32_t m = s.stack.back();
        s.stack.pop_back();
        if (m == n) continue;  // n's own subtree is Q(n)
        const BvhNode& other = bvh.nodes[m];
        if (!boxes_overlap(other.bounds, box)) continue;
        if (!other.is_leaf()) {
            s.stack.push_back(other.first + 1);
            s.stack.push_back(other.first);
            continue;
        }
        for (uint32_t slot = other.first; slot < other.first + other.reference_count; ++slot) {
            const AABB& triangle_box = tables.slot_bounds[slot];
            if (!boxes_overlap(triangle_box, box)) continue;
            uint32_t t = bvh.primitives[slot];
            // Referenced once: met only here, and that reference is outside n's subtree, so t is not
            // in Q(n). Referenced more often: count it once, and only if no reference lies inside
            // n's subtree.
            if (tables.leaves.references(t) > 1) {
                if (s.stamp[t] == s.epoch) continue;
                s.stamp[t] = s.epoch;
                if (tables.leaves.in_subtree(t, n, tables.pre_order)) continue;
            }
            area +=
                box.contains(triangle_box) ? tables.areas[t] : clipped_triangle_area(tables.scene.triangles[t], box);
        }
    }
    return area;
}

}  // namespace

double tree_sah(const Bvh& bvh, const CostModel& cost) {
    if (bvh.empty()) return 0.0;
    double root_area = area_in_double(bvh.root().bounds);
    // A root of zero area (e.g. all triangles on one line or point): every ratio is taken as 1, as
    // CostModel::split_cost does for SA(N) = 0, so the SAH still counts the work.
    auto ratio = [&](const AABB& box) { return root_area > 0.0 ? area_in_double(box) / root_area : 1.0; };
    double sah = 0.0;
    for_each_reachable(bvh, [&](uint32_t index, uint32_t) {
        const BvhNode& node = bvh.nodes[index];
        if (node.is_leaf()) {
            sah += double(cost.intersection_cost) * double(distinct_in_leaf(bvh, node)) * ratio(node.bounds);
        } else {
            sah += double(cost.traversal_cost) * ratio(node.bounds);
        }
    });
    return sah;
}

double tree_epo(const Scene& scene, const Bvh& bvh, const CostModel& cost) {
    if (bvh.empty() || scene.triangles.empty()) return 0.0;
    const size_t triangle_count = scene.triangles.size();
    std::vector<double> areas(triangle_count);
    double total_area = 0.0;
    for (size_t t = 0; t < triangle_count; ++t) {
        areas[t] = triangle_area(scene.triangles[t]);
        total_area += areas[t];
    }
    if (total_area <= 0.0) return 0.0;
    PreOrder pre_order(bvh);
    ReferencingLeaves leaves(bvh, pre_order, triangle_count);
    const EpoTables tables{
        scene, bvh, std::move(areas), std::move(pre_order), std::move(leaves), bounds_by_slot(scene, bvh)};

    tbb::enumerable_thread_specific<EpoScratch> scratch;
    const std::vector<uint32_t>& reachable = tables.pre_order.reachable;
    std::vector<double> contribution(reachable.size(), 0.0);
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, reachable.size(), 64), [&](const tbb::blocked_range<size_t>& range) {
            EpoScratch& s = scratch.local();
            if (s.stamp.size() != triangle_count) s.stamp.assign(triangle_count, 0);
            for (size_t i = range.begin(); i != range.end(); ++i) {
                const BvhNode& node = bvh.nodes[reachable[i]];
                if (node.bounds.is_empty()) continue;
                double weight = node.is_leaf() ? double(cost.intersection_cost) * double(distinct_in_leaf(bvh, node))
                                               : double(cost.traversal_cost);
                contribution[i] = weight * area_outside_subtree(tables, reachable[i], s);
            }
        });

    double epo = 0.0;
    for (double c : contribution) epo += c;  // in node order: deterministic
    return epo / total_area;
}

TreeStats compute_tree_stats(const Scene& scene, const Bvh& bvh, const CostModel& cost, bool with_epo) {
    TreeStats stats;
    stats.bytes = bvh.nodes.size() * sizeof(BvhNode) + bvh.primitives.size() * sizeof(uint32_t);
    if (bvh.empty()) return stats;

    std::vector<uint8_t> seen(scene.triangles.size(), 0);
    double leaf_depth_sum = 0.0;
    for_each_reachable(bvh, [&](uint32_t index, uint32_t depth) {
        const BvhNode& node = bvh.nodes[index];
        ++stats.nodes;
        stats.max_depth = std::max(stats.max_depth, depth);
        if (!node.is_leaf()) {
            ++stats.inner_nodes;
            return;
        }
        ++stats.leaves;
        leaf_depth_sum += depth;
        stats.references += node.reference_count;
        for (uint32_t k = 0; k < node.reference_count; ++k) {
            uint32_t t = bvh.primitives[node.first + k];
            if (t < seen.size() && !seen[t]) {
                seen[t] = 1;
                ++stats.distinct_primitives;
            }
        }
    });
    stats.mean_leaf_depth = stats.leaves ? leaf_depth_sum / double(stats.leaves) : 0.0;
    stats.sah = tree_sah(bvh, cost);
    if (with_epo) stats.epo = tree_epo(scene, bvh, cost);
    return stats;
}

}  // namespace spacebvh::tools
