// SPDX-License-Identifier: MIT
#include "builders/reinsertion_optimizer.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <deque>
#include <numeric>
#include <optional>
#include <vector>

#include "builders/termination_term.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh::builders {
namespace {

constexpr uint32_t kNone = ~0u;
constexpr uint32_t kRoot = 0;  // the root never moves: neither N, nor N's parent, nor a destination
// Nodes searched per iteration, as a fraction of all nodes (Meister & Bittner 2018 and bvh v2: 5 %).
constexpr double kBatchFraction = 0.05;
// The optimisation ends once the last 1 / kBatchFraction iterations (a batch's worth of every node)
// have together lowered the inner nodes' area by less than this fraction of it. (Not one iteration:
// in a triangle soup the largest nodes may have nowhere better to go while smaller ones still gain.)
constexpr double kMinimumGain = 1e-4;
constexpr size_t kGainWindow = size_t(1.0 / kBatchFraction + 0.5);
// A move must gain more than this fraction of SA(root), so that rounding never passes for a gain.
constexpr double kMinimumMoveGain = 1e-9;

struct Move {
    uint32_t node = kNone, destination = kNone;
    double gain = 0;  // decrease of the summed inner-node price
};

// A search's candidate, with the segments among which the box of (candidate u N) is priced: the list
// of node `list_node`, or, when that is kNone, `size` entries of the search's arena from `offset`.
struct SearchEntry {
    uint32_t candidate;
    double induced;
    uint32_t list_node, offset, size;
};
struct SearchScratch {
    std::vector<SearchEntry> stack;
    std::vector<uint32_t> arena;  // segment lists of the merged boxes priced in one subtree search
};

class Optimizer {
public:
    Optimizer(const Bvh& bvh, uint32_t max_depth, std::span<const Ray> segments, float area_prior);

    // Boxes of the inner nodes (the root's excepted) shrunk to the union of their children: a moved
    // node's old ancestors must be tight for the gains below to be exact.
    void refit_all();
    // The next batch: of the eligible nodes (depth >= 2) that are not settled, the `count` with the
    // largest boxes (Bittner et al.'s M_area; with segments, the highest prices), largest first, ties by index.
    std::vector<uint32_t> select_candidates(size_t count) const;
    // A node whose search found no move stays where it is until a move changes its surroundings.
    void settle(uint32_t node) { settled_[node] = 1; }
    // The best place for `node` on the tree as it was at the start of the iteration; destination kNone
    // when no place gains more than the threshold.
    Move find_best_move(uint32_t node, SearchScratch& scratch) const;
    // The gain of moving `node` to `destination` on the tree as it is now, priced exactly as
    // find_best_move prices it; nothing when the move is impossible or breaks the depth cap.
    std::optional<double> price_move(uint32_t node, uint32_t destination);
    void apply(uint32_t node, uint32_t destination);
    void compute_depths();
    double inner_price() const;
    double minimum_gain() const { return minimum_gain_; }
    Bvh emit(const Bvh& source) const;

private:
    bool is_leaf(uint32_t node) const { return children_[node][0] == kNone; }
    uint32_t sibling(uint32_t node) const {
        const auto& children = children_[parent_[node]];
        return children[0] == node ? children[1] : children[0];
    }
    void replace_child(uint32_t parent, uint32_t old_child, uint32_t new_child) {
        auto& children = children_[parent];
        children[children[0] == old_child ? 0 : 1] = new_child;
        parent_[new_child] = parent;
    }
    bool depth_allows(uint32_t node, uint32_t destination, uint32_t destination_depth) const {
        // The new parent takes the destination's depth; N and the destination go one level down.
        return destination_depth + 1 + std::max(height_[node], height_[destination]) <= max_depth_;
    }
    void refit_upwards(uint32_t node);
    // Lists and prices of every node, from the root down.
    void price_all();
    // Lists and prices of the nodes whose boxes the last move changed, parents first.
    void reprice_changed();
    void set_price(uint32_t node) {
        price_[node] = area_weight_ * area_in_double(bounds_[node]) + (sampled_ ? double(lists_[node].size()) : 0.0);
    }
    // The price of `box`, whose meeting segments are all among `superset`; the meeting ones are
    // appended to `meeting` when given (which must not hold `superset`'s storage). `known`: segments
    // known to meet it (those of a box inside it), taken without a test; all lists increase.
    double price_among(const AABB& box, std::span<const uint32_t> superset, std::span<const uint32_t> known,
                       std::vector<uint32_t>* meeting) const {
        const double area_part = area_weight_ * area_in_double(box);
        if (!sampled_) return area_part;
        size_t count = 0, next_known = 0;
        for (uint32_t i : superset) {
            bool meets;
            if (next_known < known.size() && known[next_known] == i) {
                ++next_known;
                meets = true;
            } else {
                meets = segment_meets(segments_[i], box);
            }
            if (meets) {
                ++count;
                if (meeting) meeting->push_back(i);
            }
        }
        return area_part + double(count);
    }
    // The price of `box`, a box inside `node`'s.
    double price_inside(const AABB& box, uint32_t node) const {
        if (box == bounds_[node]) return price_[node];
        // Without segments lists_ is empty (indexing it would be undefined): the area part alone.
        return price_among(box, sampled_ ? std::span<const uint32_t>(lists_[node]) : std::span<const uint32_t>{}, {}, nullptr);
    }
    void search_subtree(uint32_t node, uint32_t top, uint32_t pivot, double base_gain, uint32_t depth_shift,
                        bool top_is_sibling, Move& best, SearchScratch& scratch) const;
    void emit_node(uint32_t node, uint32_t out_index, const Bvh& source, Bvh& out) const;

    std::vector<AABB> bounds_;
    std::vector<uint32_t> parent_;
    std::vector<std::array<uint32_t, 2>> children_;  // {kNone, kNone} for a leaf
    std::vector<uint32_t> height_;                   // levels below the node (0 for a leaf)
    std::vector<uint32_t> depth_;                    // as of the last compute_depths()
    std::vector<uint8_t> settled_;                   // searched without a move since its surroundings last changed
    // The price of an inner node's box: area_weight_ * area, plus, with segments, the number meeting it.
    bool sampled_ = false;
    double area_weight_ = 1.0;
    std::vector<SampleSegment> segments_;
    std::vector<std::vector<uint32_t>> lists_;  // with segments: those meeting each node's box, increasing
    std::vector<double> price_;                 // each node's price, as of its current box
    std::vector<uint32_t> changed_;             // nodes whose boxes the refits since the last repricing changed
    uint32_t max_depth_ = 0;
    double minimum_gain_ = 0;
    // price_move's scratch: N's ancestors stamped with their level, and a path.
    std::vector<uint32_t> stamp_, level_;
    uint32_t current_stamp_ = 0;
    std::vector<uint32_t> chain_, path_;
    std::array<std::vector<uint32_t>, 2> path_lists_;
};

Optimizer::Optimizer(const Bvh& bvh, uint32_t max_depth, std::span<const Ray> segments, float area_prior)
    : bounds_(bvh.nodes.size()),
      parent_(bvh.nodes.size(), kNone),
      children_(bvh.nodes.size(), {kNone, kNone}),
      height_(bvh.nodes.size(), 0),
      depth_(bvh.nodes.size(), 0),
      settled_(bvh.nodes.size(), 0),
      sampled_(!segments.empty()),
      lists_(segments.empty() ? 0 : bvh.nodes.size()),
      price_(bvh.nodes.size(), 0.0),
      stamp_(bvh.nodes.size(), 0),
      level_(bvh.nodes.size(), 0) {
    for (uint32_t i = 0; i < bvh.nodes.size(); ++i) {
        const BvhNode& node = bvh.nodes[i];
        bounds_[i] = node.bounds;
        if (node.is_leaf()) continue;
        children_[i] = {node.first, node.first + 1};
        parent_[node.first] = parent_[node.first + 1] = i;
    }
    // Children come after their parents: a backward sweep sees children first.
    for (uint32_t i = uint32_t(bvh.nodes.size()); i-- > 0;)
        if (!is_leaf(i)) height_[i] = 1 + std::max(height_[children_[i][0]], height_[children_[i][1]]);
    max_depth_ = std::max(max_depth, height_[kRoot]);
    if (sampled_) {
        segments_.reserve(segments.size());
        for (const Ray& ray : segments) segments_.push_back(SampleSegment::of(ray));
        const double root_area = area_in_double(bounds_[kRoot]);
        area_weight_ = root_area > 0.0 ? double(area_prior) / root_area : 0.0;
    }
    price_all();
    minimum_gain_ = kMinimumMoveGain * price_[kRoot];
}

void Optimizer::price_all() {
    std::vector<uint32_t> stack{kRoot};
    if (sampled_) {
        std::vector<uint32_t> all(segments_.size());
        std::iota(all.begin(), all.end(), 0u);
        lists_[kRoot].clear();
        price_among(bounds_[kRoot], all, {}, &lists_[kRoot]);
    }
    while (!stack.empty()) {
        const uint32_t node = stack.back();
        stack.pop_back();
        set_price(node);
        if (is_leaf(node)) continue;
        for (uint32_t child : children_[node]) {
            if (sampled_) {
                lists_[child].clear();
                price_among(bounds_[child], lists_[node], {}, &lists_[child]);
            }
            stack.push_back(child);
        }
    }
    changed_.clear();
}

void Optimizer::reprice_changed() {
    if (!sampled_) {
        for (uint32_t node : changed_) set_price(node);
        changed_.clear();
        return;
    }
    // A list is filtered from its parent's, which must be current: shallower nodes first.
    std::vector<std::pair<uint32_t, uint32_t>> by_depth;
    for (uint32_t node : changed_) {
        uint32_t depth = 0;
        for (uint32_t up = node; up != kRoot; up = parent_[up]) ++depth;
        by_depth.push_back({depth, node});
    }
    std::sort(by_depth.begin(), by_depth.end());
    by_depth.erase(std::unique(by_depth.begin(), by_depth.end()), by_depth.end());
    std::vector<uint32_t> meeting;
    for (const auto& [depth, node] : by_depth) {
        meeting.clear();
        price_among(bounds_[node], lists_[parent_[node]], {}, &meeting);
        lists_[node].swap(meeting);
        set_price(node);
    }
    changed_.clear();
}

void Optimizer::refit_all() {
    for (uint32_t i = uint32_t(bounds_.size()); i-- > 1;)
        if (!is_leaf(i)) bounds_[i] = merge(bounds_[children_[i][0]], bounds_[children_[i][1]]);
    price_all();
}

void Optimizer::refit_upwards(uint32_t node) {
    for (; node != kNone; node = parent_[node]) {
        settled_[node] = 0;  // its box or its subtree changed
        const auto [left, right] = children_[node];
        if (node != kRoot) {  // the root's box is kept
            const AABB box = merge(bounds_[left], bounds_[right]);
            if (!(box == bounds_[node])) {
                bounds_[node] = box;
                changed_.push_back(node);
            }
        }
        height_[node] = 1 + std::max(height_[left], height_[right]);
    }
}

void Optimizer::compute_depths() {
    std::vector<uint32_t> stack{kRoot};
    depth_[kRoot] = 0;
    while (!stack.empty()) {
        const uint32_t node = stack.back();
        stack.pop_back();
        if (is_leaf(node)) continue;
        for (uint32_t child : children_[node]) {
            depth_[child] = depth_[node] + 1;
            stack.push_back(child);
        }
    }
}

double Optimizer::inner_price() const {
    double sum = 0.0;
    for (uint32_t i = 0; i < bounds_.size(); ++i)
        if (!is_leaf(i)) sum += price_[i];
    return sum;
}

std::vector<uint32_t> Optimizer::select_candidates(size_t count) const {
    std::vector<std::pair<double, uint32_t>> eligible;
    for (uint32_t i = 0; i < bounds_.size(); ++i)
        if (depth_[i] >= 2 && !settled_[i]) eligible.push_back({price_[i], i});
    count = std::min(count, eligible.size());
    auto larger_first = [](const auto& a, const auto& b) { return a.first > b.first || (a.first == b.first && a.second < b.second); };
    std::nth_element(eligible.begin(), eligible.begin() + count, eligible.end(), larger_first);
    std::sort(eligible.begin(), eligible.begin() + count, larger_first);
    std::vector<uint32_t> candidates(count);
    for (size_t i = 0; i < count; ++i) candidates[i] = eligible[i].second;
    return candidates;
}

// Branch and bound over the subtree of `top`, every node of which keeps its box after N's removal.
// Putting N above a node X there costs the price of X u N for the new parent plus, for every node Y
// on the way down from `top` to X, the growth price(Y u N) - price(Y) ("induced cost", Bittner et al.
// 2013, Sec. 3.2); a subtree whose induced cost already leaves no more than the best gain (even with
// the cheapest possible new parent, N's box) is skipped. `depth_shift` is 1 in the subtree of N's
// sibling, which moves up a level when N's parent goes. With segments, Y u N lies inside (parent of
// Y) u N, and `top` u N inside `pivot`'s box, so each merged box is priced among its parent's list.
void Optimizer::search_subtree(uint32_t node, uint32_t top, uint32_t pivot, double base_gain, uint32_t depth_shift,
                               bool top_is_sibling, Move& best, SearchScratch& scratch) const {
    const AABB& node_box = bounds_[node];
    const double node_price = price_[node];
    auto& stack = scratch.stack;
    auto& arena = scratch.arena;
    stack.clear();
    arena.clear();
    stack.push_back({top, 0.0, pivot, 0, 0});
    while (!stack.empty()) {
        const SearchEntry entry = stack.back();
        const uint32_t candidate = entry.candidate;
        const double induced = entry.induced;
        stack.pop_back();
        if (base_gain - induced - node_price <= best.gain) continue;
        const uint32_t new_depth = depth_[candidate] - depth_shift;
        // Deeper candidates would only put N deeper still.
        if (new_depth + 1 + height_[node] > max_depth_) continue;
        const AABB merged = merge(bounds_[candidate], node_box);
        double merged_price;
        SearchEntry below{kNone, 0.0, kNone, 0, 0};  // where the children's merged boxes are priced
        if (merged == bounds_[candidate]) {
            merged_price = price_[candidate];
            below.list_node = candidate;
        } else if (!sampled_) {
            merged_price = price_among(merged, {}, {}, nullptr);
        } else {
            // A lower bound first: the merged box meets the candidate's segments and N's, so counting
            // N's that miss the candidate's box (a search per N's segment) often settles the
            // candidate and its subtree without scanning the larger list.
            const auto& candidate_list = lists_[candidate];
            size_t outside = 0;
            for (uint32_t i : lists_[node]) outside += !std::binary_search(candidate_list.begin(), candidate_list.end(), i);
            const double least_price = price_[candidate] + double(outside) +
                                       area_weight_ * (area_in_double(merged) - area_in_double(bounds_[candidate]));
            const bool may_win = !(top_is_sibling && candidate == top) && base_gain - induced - least_price > best.gain;
            const bool may_descend =
                !is_leaf(candidate) && base_gain - (induced + least_price - price_[candidate]) - node_price > best.gain;
            if (!may_win && !may_descend) continue;
            // The arena may grow while it is read from: reserve first, then take the span.
            const size_t superset_size = entry.list_node != kNone ? lists_[entry.list_node].size() : entry.size;
            arena.reserve(arena.size() + superset_size);
            const std::span<const uint32_t> superset =
                entry.list_node != kNone ? std::span<const uint32_t>(lists_[entry.list_node])
                                         : std::span<const uint32_t>(arena.data() + entry.offset, entry.size);
            below.offset = uint32_t(arena.size());
            merged_price = price_among(merged, superset, lists_[candidate], is_leaf(candidate) ? nullptr : &arena);
            below.size = uint32_t(arena.size()) - below.offset;
        }
        // N back at its sibling is where it came from.
        if (!(top_is_sibling && candidate == top)) {
            const double gain = base_gain - induced - merged_price;
            if (gain > best.gain && depth_allows(node, candidate, new_depth)) best = {node, candidate, gain};
        }
        if (is_leaf(candidate)) continue;
        const double child_induced = induced + (merged_price - price_[candidate]);
        if (base_gain - child_induced - node_price <= best.gain) continue;
        below.induced = child_induced;
        below.candidate = children_[candidate][1];
        stack.push_back(below);
        below.candidate = children_[candidate][0];
        stack.push_back(below);  // left first
    }
}

// Taking N out: its parent P goes (gain SA(P)) and the ancestors c_2, c_3, ... of P shrink to the
// union of what stays below them. Putting N back below c_i's other child Q_i brings c_i and everything
// above it back to their old boxes, so only the shrinking of c_2 .. c_(i-1) counts; putting it above
// c_i itself (a new parent with c_i's old box) counts the shrinking of c_2 .. c_i. So the walk from P
// up to the root (the level-by-level search of bvh v2's reinsertion optimizer) prices every place
// exactly, with the gain of the removal known at each level.
Move Optimizer::find_best_move(uint32_t node, SearchScratch& scratch) const {
    Move best{node, kNone, minimum_gain_};
    const uint32_t parent = parent_[node];
    double base_gain = price_[parent];
    AABB shrunk;  // the box of `below` once N is out
    uint32_t below = node, pivot = parent;
    for (;;) {
        const auto& children = children_[pivot];
        const uint32_t other = children[0] == below ? children[1] : children[0];
        search_subtree(node, other, pivot, base_gain, pivot == parent ? 1 : 0, pivot == parent, best, scratch);
        if (pivot == kRoot) break;
        shrunk = pivot == parent ? bounds_[other] : merge(shrunk, bounds_[other]);
        below = pivot;
        pivot = parent_[pivot];
        if (below == parent) continue;  // P itself goes; counted at the start
        base_gain += price_[below] - price_inside(shrunk, below);
        // N as the sibling of the shrunk ancestor: the new parent has the ancestor's old box.
        const double gain = base_gain - price_[below];
        if (gain > best.gain && depth_allows(node, below, depth_[below])) best = {node, below, gain};
    }
    return best;
}

std::optional<double> Optimizer::price_move(uint32_t node, uint32_t destination) {
    if (node == kRoot || parent_[node] == kRoot) return std::nullopt;
    const uint32_t parent = parent_[node];
    if (destination == kRoot || destination == node || destination == parent || destination == sibling(node))
        return std::nullopt;
    // N's ancestors c_1 = P, c_2, ..., the root, stamped with their level.
    ++current_stamp_;
    chain_.clear();
    for (uint32_t ancestor = parent; ancestor != kNone; ancestor = parent_[ancestor]) {
        chain_.push_back(ancestor);
        stamp_[ancestor] = current_stamp_;
        level_[ancestor] = uint32_t(chain_.size());
    }
    // Up from the destination to the first of N's ancestors; meeting N means it lies in N's subtree.
    path_.clear();
    uint32_t meeting = destination;
    while (stamp_[meeting] != current_stamp_) {
        if (meeting == node) return std::nullopt;
        path_.push_back(meeting);
        meeting = parent_[meeting];
    }
    const uint32_t level = level_[meeting];
    const uint32_t meeting_depth = uint32_t(chain_.size()) - level;
    const bool above_ancestor = path_.empty();  // the destination is c_i itself (i >= 2)
    // The removal's gain: P, then the shrinking of c_2 .. c_(i-1), or .. c_i above an ancestor.
    double base_gain = price_[parent];
    AABB shrunk = bounds_[sibling(node)];
    const uint32_t last_shrunk = above_ancestor ? level : level - 1;
    for (uint32_t j = 2; j <= last_shrunk; ++j) {
        const uint32_t ancestor = chain_[j - 1], below = chain_[j - 2];
        const auto& children = children_[ancestor];
        shrunk = merge(shrunk, bounds_[children[0] == below ? children[1] : children[0]]);
        base_gain += price_[ancestor] - price_inside(shrunk, ancestor);
    }
    if (above_ancestor) {
        if (!depth_allows(node, destination, meeting_depth)) return std::nullopt;
        return base_gain - price_[destination];
    }
    const uint32_t new_depth = meeting_depth + uint32_t(path_.size()) - (level == 1 ? 1 : 0);
    if (!depth_allows(node, destination, new_depth)) return std::nullopt;
    // The insertion's cost, summed from the top down as search_subtree sums it, each merged box priced
    // among the segments of the one above it (the first inside the meeting node's box).
    const AABB& node_box = bounds_[node];
    double induced = 0.0, merged_price = 0.0;
    std::span<const uint32_t> superset = sampled_ ? std::span<const uint32_t>(lists_[meeting]) : std::span<const uint32_t>{};
    for (size_t k = path_.size(); k-- > 0;) {
        const uint32_t on_the_way = path_[k];
        const AABB merged = merge(bounds_[on_the_way], node_box);
        if (merged == bounds_[on_the_way]) {
            merged_price = price_[on_the_way];
            if (sampled_) superset = lists_[on_the_way];
        } else {
            std::vector<uint32_t>& meeting_list = path_lists_[k % 2];
            meeting_list.clear();
            merged_price = price_among(merged, superset, sampled_ ? std::span<const uint32_t>(lists_[on_the_way]) : std::span<const uint32_t>{},
                                       sampled_ ? &meeting_list : nullptr);
            superset = meeting_list;
        }
        if (k > 0) induced = induced + (merged_price - price_[on_the_way]);
    }
    return base_gain - induced - merged_price;
}

void Optimizer::apply(uint32_t node, uint32_t destination) {
    const uint32_t parent = parent_[node];
    const uint32_t grandparent = parent_[parent];
    const uint32_t old_sibling = sibling(node);
    // These have new parents, so their own best places may have changed (the refits below unsettle
    // the nodes whose boxes change).
    settled_[node] = settled_[old_sibling] = settled_[destination] = 0;
    // Out: N's sibling takes P's place.
    replace_child(grandparent, parent, old_sibling);
    // In: P, with children the destination and N, takes the destination's place.
    replace_child(parent_[destination], destination, parent);
    children_[parent] = {destination, node};
    parent_[destination] = parent_[node] = parent;
    refit_upwards(grandparent);
    refit_upwards(parent);
    reprice_changed();
}

// Depth-first, left first, the two children of a node side by side (as the builders emit), leaves
// listing their triangles in that order.
void Optimizer::emit_node(uint32_t node, uint32_t out_index, const Bvh& source, Bvh& out) const {
    out.nodes[out_index].bounds = bounds_[node];
    if (is_leaf(node)) {
        const BvhNode& leaf = source.nodes[node];
        out.nodes[out_index].first = uint32_t(out.primitives.size());
        out.nodes[out_index].reference_count = leaf.reference_count;
        out.primitives.insert(out.primitives.end(), source.primitives.begin() + leaf.first,
                              source.primitives.begin() + leaf.first + leaf.reference_count);
        return;
    }
    const uint32_t first_child = uint32_t(out.nodes.size());
    out.nodes.resize(out.nodes.size() + 2);
    out.nodes[out_index].first = first_child;
    out.nodes[out_index].reference_count = 0;
    emit_node(children_[node][0], first_child, source, out);
    emit_node(children_[node][1], first_child + 1, source, out);
}

Bvh Optimizer::emit(const Bvh& source) const {
    Bvh out;
    out.builder = source.builder;
    out.cost = source.cost;
    out.nodes.reserve(source.nodes.size());
    out.primitives.reserve(source.primitives.size());
    out.nodes.resize(1);
    emit_node(kRoot, 0, source, out);
    return out;
}

}  // namespace

ReinsertionReport optimize_by_reinsertion(Bvh& bvh, const ReinsertionOptions& options) {
    ReinsertionReport report;
    // C_T = 0: inner nodes cost nothing, so no move changes the SAH.
    if (options.iterations == 0 || bvh.nodes.size() < 5 || bvh.cost.traversal_cost == 0.0f) return report;
    auto check_cancel = [&] {
        if (options.cancel && options.cancel->load(std::memory_order_relaxed)) throw Cancelled("build cancelled");
    };
    Optimizer optimizer(bvh, options.max_depth, options.segments, options.area_prior);
    report.inner_area_before = optimizer.inner_price();
    optimizer.refit_all();
    report.inner_area_refitted = optimizer.inner_price();
    const size_t batch = std::max<size_t>(1, size_t(kBatchFraction * double(bvh.nodes.size())));
    tbb::enumerable_thread_specific<SearchScratch> scratches;
    std::vector<Move> moves;
    std::deque<double> recent_gains;  // of the last kGainWindow iterations
    for (uint32_t iteration = 0; iteration < options.iterations; ++iteration) {
        check_cancel();
        optimizer.compute_depths();
        const std::vector<uint32_t> candidates = optimizer.select_candidates(batch);
        if (candidates.empty()) break;  // every node was searched since anything near it last changed
        moves.assign(candidates.size(), Move{});
        // Searches read the tree only; each writes its own slot, so the order of work does not matter.
        tbb::parallel_for(tbb::blocked_range<size_t>(0, candidates.size(), 16),
                          [&](const tbb::blocked_range<size_t>& range) {
                              auto& scratch = scratches.local();
                              for (size_t i = range.begin(); i != range.end(); ++i) {
                                  check_cancel();
                                  moves[i] = optimizer.find_best_move(candidates[i], scratch);
                              }
                          });
        for (size_t i = 0; i < candidates.size(); ++i)
            if (moves[i].destination == kNone) optimizer.settle(candidates[i]);
        std::erase_if(moves, [](const Move& move) { return move.destination == kNone; });
        std::sort(moves.begin(), moves.end(), [](const Move& a, const Move& b) {
            return a.gain > b.gain || (a.gain == b.gain && a.node < b.node);
        });
        double gain_of_iteration = 0.0;
        for (const Move& move : moves) {
            const std::optional<double> gain = optimizer.price_move(move.node, move.destination);
            if (!gain || *gain <= optimizer.minimum_gain()) continue;  // earlier moves changed its surroundings
            optimizer.apply(move.node, move.destination);
            gain_of_iteration += *gain;
            ++report.moves;
        }
        report.iterations = iteration + 1;
        report.applied_gain += gain_of_iteration;
        if (options.progress) options.progress(double(iteration + 1) / double(options.iterations));
        recent_gains.push_back(gain_of_iteration);
        if (recent_gains.size() > kGainWindow) recent_gains.pop_front();
        const double recent_gain = std::accumulate(recent_gains.begin(), recent_gains.end(), 0.0);
        if (recent_gains.size() == kGainWindow && recent_gain <= kMinimumGain * optimizer.inner_price()) break;
    }
    report.inner_area_after = optimizer.inner_price();
    bvh = optimizer.emit(bvh);
    return report;
}

}  // namespace spacebvh::builders
