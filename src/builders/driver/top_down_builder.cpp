// SPDX-License-Identifier: MIT
#include "builders/driver/top_down_builder.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <atomic>
#include <cmath>

#include "builders/driver/lookahead.hpp"
#include "builders/search_spaces/object_sweep_split_finder.hpp"
#include "builders/driver/partition.hpp"
#include "builders/driver/termination_term.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh::builders {

// Determinism: a subtree whose references may grow to `capacity` (its share of the reference
// budget; the count itself without spatial splits) has at most 2*capacity - 1 nodes, so it is given
// the node slots [s, s + 2*capacity - 1) and the reference storage [b, b + capacity): its root takes
// slot s, its left child (capacity c_L) slots from s + 1 and storage from b, its right child slots from
// s + 2*c_L and storage from b + c_L. Every node's place is a function of the splits alone, so the
// tasks of a parallel build write without coordination and the result is the same for any thread
// count. A final depth-first pass drops unused slots and places siblings side by side.
struct TopDownBuilder::Impl {
    // One per slot, 2 * capacity - 1 of them: the largest array of the build, so kept to 36 bytes.
    // An inner node's left child is always the next slot, and its right child's slot is never 0.
    struct SlotNode {
        AABB bounds;
        uint32_t begin = 0, count = 0;  // the node's references
        uint32_t right_slot = 0;        // 0: a leaf
        bool is_leaf() const { return right_slot == 0; }
    };
    static_assert(sizeof(SlotNode) == kSlotBytes);

    const TopDownBuilder& builder;
    const SplitSearch& search;
    const Lookahead& lookahead;
    const Lookahead& whole_subtree_lookahead;  // for nodes of at least `top_node_references`
    const TerminationTerm& termination;        // may be disabled (no segments)
    size_t top_node_references = 0;            // 0: no node looks ahead to the leaves
    std::vector<Reference> references;         // the storage of all subtrees, size = root capacity
    // Centroid orders for the object sweep, kept when a search space reads them: then every node's
    // references are in CentroidOrder{x} in `references`, and the same references are in
    // CentroidOrder{y} and {z} at the same places in these two copies, so that no node sorts
    // (two more copies of the references buy a build without a sort per node).
    bool keeps_orders = false;
    std::array<std::vector<Reference>, 2> other_orders{};
    size_t input_count = 0;
    std::vector<SlotNode> slots{};
    std::atomic<size_t> references_in_leaves{0};
    std::atomic<size_t> next_progress_report{0};

    void make_leaf(SlotNode& node) {
        node.right_slot = 0;
        if (!builder.options_.progress) return;
        const size_t done = references_in_leaves.fetch_add(node.count) + node.count;
        const size_t step = input_count / 100 + 1;
        size_t next = next_progress_report.load();
        if (done >= next && next_progress_report.compare_exchange_strong(next, done + step))
            builder.options_.progress(std::min(1.0, double(done) / double(input_count)));
    }

    // `rays`: the termination segments that meet the node (empty when the term is off).
    void build_subtree(uint32_t slot, uint32_t begin, uint32_t count, uint32_t capacity,
                       const ReferenceSummary& summary, uint32_t depth, const std::vector<uint32_t>& rays) {
        SlotNode& node = slots[slot];
        node.bounds = summary.bounds;
        node.begin = begin;
        node.count = count;
        if (search.must_be_leaf(count, depth)) return make_leaf(node);
        const std::atomic<bool>* cancel = builder.options_.cancel;
        if (cancel && cancel->load(std::memory_order_relaxed)) throw Cancelled("build cancelled");
        // Big nodes report too (a few hundred calls in all): the first leaves may be long in coming
        // when choosing a split is slow (a lookahead over a big node).
        if (count >= kParallelSubtreeThreshold && builder.options_.progress)
            builder.options_.progress(double(references_in_leaves.load()) / double(input_count));

        std::span<Reference> storage(references.data() + begin, capacity);
        std::optional<Split> split;
        if (top_node_references > 0 && count >= top_node_references)
            split = whole_subtree_lookahead.choose(storage, count, summary, depth).split;
        else if (builder.options_.lookahead_depth > 0)
            split = lookahead.choose(storage, count, summary, depth).split;
        else
            split = search.greedy_decision(storage.first(count), summary, capacity, centroid_orders(begin, count));
        // The term changes which split a node takes, never whether it is a leaf.
        if (split && termination.enabled() && builder.options_.lookahead_depth == 0)
            split = termination.choose(search, storage.first(count), summary, capacity, *split, rays);
        if (!split) return make_leaf(node);
        const SplitKind kind = split->kind;  // apply may fall back to the median split
        const std::optional<ChildRanges> applied = search.apply(storage, count, *split, summary);
        if (!applied) return make_leaf(node);
        const ChildRanges& children = *applied;
        if (keeps_orders) carry_orders(begin, count, capacity, kind, *split, children);
        const uint32_t right_begin = begin + children.left_capacity;
        const ReferenceSummary left_summary = summarize({references.data() + begin, children.left_count});
        const ReferenceSummary right_summary = summarize({references.data() + right_begin, children.right_count});
        node.right_slot = slot + 2 * children.left_capacity;
        std::vector<uint32_t> left_rays, right_rays;
        if (!rays.empty()) {
            left_rays = termination.meeting(left_summary.bounds, &rays);
            right_rays = termination.meeting(right_summary.bounds, &rays);
        }

        auto build_left = [&] {
            build_subtree(slot + 1, begin, children.left_count, children.left_capacity, left_summary, depth + 1,
                          left_rays);
        };
        auto build_right = [&] {
            build_subtree(node.right_slot, right_begin, children.right_count, children.right_capacity, right_summary,
                          depth + 1, right_rays);
        };
        if (count >= kParallelSubtreeThreshold) {
            tbb::parallel_invoke(build_left, build_right);
        } else {
            build_left();
            build_right();
        }
    }

    CentroidOrders centroid_orders(uint32_t begin, uint32_t count) const {
        if (!keeps_orders) return {};
        return {std::span<const Reference>(references.data() + begin, count),
                std::span<const Reference>(other_orders[0].data() + begin, count),
                std::span<const Reference>(other_orders[1].data() + begin, count)};
    }

    Reference* order_data(int axis) { return axis == 0 ? references.data() : other_orders[axis - 1].data(); }

    // Runs job(axis) for the three orders (0 = x, `references`; 1 = y, 2 = z), in parallel for big nodes.
    template <class Job>
    static void for_each_order(uint32_t count, Job&& job) {
        if (count >= kParallelSubtreeThreshold)
            tbb::parallel_for(0, 3, job);
        else
            for (int axis = 0; axis < 3; ++axis) job(axis);
    }

    // The children's orders, once apply_split has put the children in `references` (`kind`: the
    // split chosen; apply may have fallen back to the median split, then split.kind differs).
    void carry_orders(uint32_t begin, uint32_t count, uint32_t capacity, SplitKind kind, const Split& split,
                      const ChildRanges& children) {
        const bool object_split = kind == SplitKind::object_sorted || kind == SplitKind::object_binned;
        if (object_split && split.kind == kind) return split_orders_alike(begin, count, capacity, split, children);
        if (kind == SplitKind::spatial && split.kind == kind)
            return merge_pieces_into_orders(begin, count, split, children);
        sort_orders_again(begin, children);
    }

    // An object split sends each reference to the same side whatever the order, and apply_split keeps
    // the order: the y and z copies are split alike.
    void split_orders_alike(uint32_t begin, uint32_t count, uint32_t capacity, const Split& split,
                            const ChildRanges& children) {
        auto split_copy = [&](int k) {
            const ChildRanges same =
                apply_split({other_orders[k].data() + begin, capacity}, count, split, builder.triangles_);
            if (same.left_count != children.left_count || same.left_capacity != children.left_capacity)
                throw Error("internal: the centroid orders split differently");
        };
        if (count >= kParallelSubtreeThreshold) {
            tbb::parallel_invoke([&] { split_copy(0); }, [&] { split_copy(1); });
        } else {
            split_copy(0);
            split_copy(1);
        }
    }

    // A spatial split keeps the references lying on one side (first in each child, in the node's
    // order) and makes new pieces from the straddlers (last in each child). Each of a child's orders
    // is the node's same order filtered to the side, merged with the pieces sorted on their own:
    // linear but for the few pieces.
    void merge_pieces_into_orders(uint32_t begin, uint32_t count, const Split& split, const ChildRanges& children) {
        const uint32_t firsts[2] = {begin, begin + children.left_capacity};
        const uint32_t counts[2] = {children.left_count, children.right_count};
        const uint32_t kept_counts[2] = {children.left_count - children.left_from_straddlers,
                                         children.right_count - children.right_from_straddlers};
        std::array<std::vector<Reference>, 2> pieces;
        for (int child = 0; child < 2; ++child)
            pieces[child].assign(references.data() + firsts[child] + kept_counts[child],
                                 references.data() + firsts[child] + counts[child]);
        for_each_order(count, [&](int axis) {
            Reference* order = order_data(axis);
            // The kept references in this order, read before the children overwrite the node.
            std::array<std::vector<Reference>, 2> kept;
            if (axis == 0) {  // `references` holds them in x order already
                for (int child = 0; child < 2; ++child)
                    kept[child].assign(order + firsts[child], order + firsts[child] + kept_counts[child]);
            } else {
                for (int child = 0; child < 2; ++child) kept[child].reserve(kept_counts[child]);
                for (const Reference& reference : std::span<const Reference>(order + begin, count)) {
                    const PlaneSide side = plane_side(reference, split.axis, split.position);
                    if (side != PlaneSide::straddles) kept[side == PlaneSide::left ? 0 : 1].push_back(reference);
                }
            }
            for (int child = 0; child < 2; ++child) {
                if (kept[child].size() != kept_counts[child])
                    throw Error("internal: the centroid orders split differently");
                std::vector<Reference> sorted_pieces;
                sort_in_centroid_order(pieces[child], axis, sorted_pieces);
                std::merge(kept[child].begin(), kept[child].end(), sorted_pieces.begin(), sorted_pieces.end(),
                           order + firsts[child], CentroidOrder{axis});
            }
        });
    }

    // A grid split (or a fallback after a failed split): the copies take the children from
    // `references`, then the three orders are sorted.
    void sort_orders_again(uint32_t begin, const ChildRanges& children) {
        const uint32_t firsts[2] = {begin, begin + children.left_capacity};
        const uint32_t counts[2] = {children.left_count, children.right_count};
        for (int axis = 1; axis < 3; ++axis)
            for (int child = 0; child < 2; ++child)
                std::copy_n(references.data() + firsts[child], counts[child], order_data(axis) + firsts[child]);
        for_each_order(counts[0] + counts[1], [&](int axis) {
            for (int child = 0; child < 2; ++child)
                sort_in_centroid_order({order_data(axis) + firsts[child], counts[child]}, axis);
        });
    }

    // The nodes and leaf references of the subtree at `slot`, so that emit allocates the tree once.
    void tally(uint32_t slot, size_t& nodes, size_t& leaf_references) const {
        const SlotNode& node = slots[slot];
        ++nodes;
        if (node.is_leaf()) {
            leaf_references += node.count;
            return;
        }
        tally(slot + 1, nodes, leaf_references);
        tally(node.right_slot, nodes, leaf_references);
    }

    // Depth-first, left first; the two children of a node are stored next to each other. A leaf
    // lists each triangle once, in increasing id (pre-split references of one triangle may meet).
    void emit(uint32_t slot, uint32_t out_index, Bvh& bvh) const {
        const SlotNode& node = slots[slot];
        BvhNode& out = bvh.nodes[out_index];
        out.bounds = node.bounds;
        if (node.is_leaf()) {
            const size_t first = bvh.primitives.size();
            for (uint32_t i = node.begin; i < node.begin + node.count; ++i)
                bvh.primitives.push_back(references[i].primitive);
            std::sort(bvh.primitives.begin() + first, bvh.primitives.end());
            bvh.primitives.erase(std::unique(bvh.primitives.begin() + first, bvh.primitives.end()),
                                 bvh.primitives.end());
            out.first = uint32_t(first);
            out.reference_count = uint32_t(bvh.primitives.size() - first);
            return;
        }
        const uint32_t first_child = uint32_t(bvh.nodes.size());
        bvh.nodes.resize(bvh.nodes.size() + 2);
        bvh.nodes[out_index].first = first_child;  // `out` may have moved with the resize
        bvh.nodes[out_index].reference_count = 0;
        emit(slot + 1, first_child, bvh);
        emit(node.right_slot, first_child + 1, bvh);
    }
};

TopDownBuilder::TopDownBuilder(CostModel cost, BuildLimits limits,
                               std::vector<std::unique_ptr<SplitFinder>> search_spaces,
                               std::span<const Triangle> triangles, DriverOptions options)
    : cost_(cost),
      limits_(limits),
      search_spaces_(std::move(search_spaces)),
      triangles_(triangles),
      options_(std::move(options)) {}

TopDownBuilder::~TopDownBuilder() = default;

Bvh TopDownBuilder::build(std::vector<Reference> references, size_t capacity) {
    const size_t count = references.size();
    Bvh bvh;
    bvh.cost = cost_;
    if (count == 0) return bvh;
    capacity = std::max(capacity, count);
    const ReferenceSummary root = summarize(references);
    const SplitSearch search(cost_, limits_, search_spaces_, triangles_, root.bounds.area());
    const Lookahead lookahead(search, options_.lookahead_depth, options_.lookahead_candidates, options_.cancel);
    // Depth max_depth reaches every leaf (nodes there are leaves whatever their size). The options are
    // each search space's cheapest split: at the top of the tree the greedy step's error is in which
    // kind of split it takes (object or spatial), and the subtrees are too big to build more than a
    // few (per-axis candidates there cost several times the build time and give the same SAH).
    const Lookahead whole_subtree_lookahead(search, limits_.max_depth, 0, options_.cancel);
    // With one search space there is no kind of split to choose between: the greedy step decides.
    const size_t top_node_references =
        options_.lookahead_top_share > 0 && search_spaces_.size() > 1
            ? std::max<size_t>(2, size_t(std::ceil(double(options_.lookahead_top_share) * double(count))))
            : 0;
    const TerminationTerm termination(options_.termination ? *options_.termination : TerminationConfig{});
    Impl impl{
        *this, search, lookahead, whole_subtree_lookahead, termination, top_node_references, std::move(references)};
    impl.input_count = count;
    impl.references.resize(capacity);
    impl.keeps_orders = search.reads_centroid_orders();
    if (impl.keeps_orders) {
        impl.other_orders = {impl.references, impl.references};
        Impl::for_each_order(uint32_t(count), [&](int axis) {
            sort_in_centroid_order({impl.order_data(axis), count}, axis);
        });
    }
    impl.slots.resize(2 * capacity - 1);
    const std::vector<uint32_t> root_rays =
        termination.enabled() ? termination.meeting(root.bounds, nullptr) : std::vector<uint32_t>{};
    impl.build_subtree(0, 0, uint32_t(count), uint32_t(capacity), root, 0, root_rays);

    size_t node_count = 0, leaf_references = 0;
    impl.tally(0, node_count, leaf_references);
    bvh.nodes.reserve(node_count);
    bvh.primitives.reserve(leaf_references);  // an upper bound: a leaf lists a split triangle once
    bvh.nodes.resize(1);
    impl.emit(0, 0, bvh);
    if (options_.progress) options_.progress(1.0);
    return bvh;
}

}  // namespace spacebvh::builders
