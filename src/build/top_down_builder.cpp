#include "build/top_down_builder.hpp"

#include <tbb/parallel_invoke.h>

#include <atomic>

#include "build/partition.hpp"

namespace spacebvh::build {

// Determinism: a subtree over n references has at most 2n-1 nodes, so it is given the node slots
// [s, s + 2n - 1): its root takes s, its left child (n_L references) takes s + 1 onwards, and its right
// child s + 2*n_L onwards. Every node's slot is a function of the splits alone, so the tasks of a
// parallel build can write their nodes without coordination and the result is the same for any
// thread count. A final depth-first pass drops the unused slots and places siblings side by side.
struct TopDownBuilder::Impl {
    struct SlotNode {
        AABB bounds;
        uint32_t begin = 0, count = 0;  // the node's references
        uint32_t left_slot = 0, right_slot = 0;
        bool is_leaf = false;
    };

    const TopDownBuilder& builder;
    std::vector<Reference> references;
    std::vector<SlotNode> slots;
    std::atomic<size_t> references_in_leaves{0};
    std::atomic<size_t> next_progress_report{0};

    static constexpr uint32_t kParallelSubtreeThreshold = 4096;

    void make_leaf(SlotNode& node) {
        node.is_leaf = true;
        if (!builder.progress_) return;
        const size_t done = references_in_leaves.fetch_add(node.count) + node.count;
        const size_t step = references.size() / 100 + 1;
        size_t next = next_progress_report.load();
        if (done >= next && next_progress_report.compare_exchange_strong(next, done + step))
            builder.progress_(double(done) / double(references.size()));
    }

    Split choose_split(std::span<Reference> node_references, const ReferenceSummary& summary) const {
        Split best;
        for (const auto& search_space : builder.search_spaces_) {
            Split candidate = search_space->find(node_references, summary, builder.cost_);
            if (candidate.cost < best.cost) best = candidate;
        }
        return best;
    }

    void build_subtree(uint32_t slot, uint32_t begin, uint32_t end, const ReferenceSummary& summary, uint32_t depth) {
        SlotNode& node = slots[slot];
        node.bounds = summary.bounds;
        node.begin = begin;
        node.count = end - begin;
        const uint32_t count = node.count;
        if (count <= 1 || depth >= builder.limits_.max_depth) return make_leaf(node);

        std::span<Reference> node_references(references.data() + begin, count);
        Split split = choose_split(node_references, summary);
        const bool must_split = count > builder.limits_.max_leaf_size;
        const bool split_pays = split.is_valid() && split.cost < builder.cost_.leaf_cost(count);
        if (!must_split && !split_pays) return make_leaf(node);
        if (!split.is_valid()) split = median_split(node_references, summary);

        uint32_t left_count = uint32_t(partition_references(node_references, split));
        if (left_count == 0 || left_count == count) {
            // Cannot happen for the finders' own splits; guard against float surprises anyway.
            split = median_split(node_references, summary);
            left_count = uint32_t(partition_references(node_references, split));
            if (left_count == 0 || left_count == count) return make_leaf(node);
        }
        const uint32_t middle = begin + left_count;
        const ReferenceSummary left_summary = summarize({references.data() + begin, left_count});
        const ReferenceSummary right_summary = summarize({references.data() + middle, end - middle});
        node.left_slot = slot + 1;
        node.right_slot = slot + 2 * left_count;

        auto build_left = [&] { build_subtree(slot + 1, begin, middle, left_summary, depth + 1); };
        auto build_right = [&] { build_subtree(slot + 2 * left_count, middle, end, right_summary, depth + 1); };
        if (count >= kParallelSubtreeThreshold) {
            tbb::parallel_invoke(build_left, build_right);
        } else {
            build_left();
            build_right();
        }
    }

    // Depth-first, left first; the two children of a node are stored next to each other.
    void emit(uint32_t slot, uint32_t out_index, Bvh& bvh) const {
        const SlotNode& node = slots[slot];
        BvhNode& out = bvh.nodes[out_index];
        out.bounds = node.bounds;
        if (node.is_leaf) {
            out.first = uint32_t(bvh.primitives.size());
            out.reference_count = node.count;
            for (uint32_t i = node.begin; i < node.begin + node.count; ++i)
                bvh.primitives.push_back(references[i].primitive);
            return;
        }
        const uint32_t first_child = uint32_t(bvh.nodes.size());
        bvh.nodes.resize(bvh.nodes.size() + 2);
        bvh.nodes[out_index].first = first_child;  // `out` may have moved with the resize
        bvh.nodes[out_index].reference_count = 0;
        emit(node.left_slot, first_child, bvh);
        emit(node.right_slot, first_child + 1, bvh);
    }
};

TopDownBuilder::TopDownBuilder(CostModel cost, BuildLimits limits,
                               std::vector<std::unique_ptr<SplitFinder>> search_spaces,
                               std::function<void(double)> progress)
    : cost_(cost), limits_(limits), search_spaces_(std::move(search_spaces)), progress_(std::move(progress)) {}

TopDownBuilder::~TopDownBuilder() = default;

Bvh TopDownBuilder::build(std::vector<Reference> references) {
    Impl impl{*this, std::move(references), {}};
    const size_t count = impl.references.size();
    Bvh bvh;
    bvh.cost = cost_;
    if (count == 0) return bvh;
    impl.slots.resize(2 * count - 1);
    const ReferenceSummary root = summarize(impl.references);
    impl.build_subtree(0, 0, uint32_t(count), root, 0);

    bvh.nodes.reserve(2 * count - 1);
    bvh.primitives.reserve(count);
    bvh.nodes.resize(1);
    impl.emit(0, 0, bvh);
    bvh.nodes.shrink_to_fit();
    if (progress_) progress_(1.0);
    return bvh;
}

}  // namespace spacebvh::build
