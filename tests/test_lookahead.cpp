// SPDX-License-Identifier: MIT
// Recursive cost evaluation (src/builders/driver/lookahead.hpp) and what it rests on: the search spaces'
// candidate lists (SplitFinder::find_candidates), the candidates of all search spaces
// (SplitSearch::candidates), the pricing of a candidate's subtree, and cancellation of a build.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "builders/search_spaces/binned_object_split_finder.hpp"
#include "builders/search_spaces/binned_spatial_split_finder.hpp"
#include "builders/driver/lookahead.hpp"
#include "builders/search_spaces/object_sweep_split_finder.hpp"
#include "builders/driver/partition.hpp"
#include "builders/driver/split_search.hpp"
#include "builders/driver/top_down_builder.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/tools/metrics.hpp"
#include "test_support.hpp"

namespace spacebvh {

using namespace spacebvh::tools;
namespace {

using builders::Reference;
using builders::ReferenceSummary;
using builders::Split;

// Nodes to search: random samples of the soup's and the interior's references (a sample of a scene
// is a node whose references are spread like a real node's), from tiny to a few thousand.
struct TestNode {
    const Scene* scene;
    std::vector<Reference> references;
};

std::vector<TestNode> test_nodes() {
    std::vector<TestNode> nodes;
    std::mt19937 random(7);
    for (const char* name : {"soup", "interior"}) {
        const Scene& scene = testing_support::cached_builtin_scene(name);
        const std::vector<Reference> all = builders::make_references(scene.triangles);
        for (size_t count : {2, 3, 9, 40, 300, 2500}) {
            TestNode node{&scene, {}};
            std::sample(all.begin(), all.end(), std::back_inserter(node.references), count, random);
            nodes.push_back(std::move(node));
        }
    }
    return nodes;
}

bool same_split(const Split& a, const Split& b) {
    return a.kind == b.kind && a.cost == b.cost && a.axis == b.axis && a.left_count == b.left_count &&
           a.right_count == b.right_count && a.left_bounds == b.left_bounds && a.right_bounds == b.right_bounds &&
           a.position == b.position && a.bin == b.bin && a.tie.primitive == b.tie.primitive &&
           a.tie.bounds == b.tie.bounds;
}

std::vector<std::unique_ptr<builders::SplitFinder>> every_search_space(const Scene& scene, float gate_alpha = 0.0f) {
    std::vector<std::unique_ptr<builders::SplitFinder>> spaces;
    spaces.push_back(std::make_unique<builders::ObjectSweepSplitFinder>());
    spaces.push_back(std::make_unique<builders::BinnedObjectSplitFinder>(32));
    builders::SpatialSearchOptions spatial;
    spatial.gate_alpha = gate_alpha;
    spaces.push_back(std::make_unique<builders::BinnedSpatialSplitFinder>(scene.triangles, spatial));
    return spaces;
}

}  // namespace

// Every search space's candidate list: at most K per axis, axis by axis and cheapest first, and its
// first cheapest split is exactly find()'s. For the exact sweep, the K costs per axis are the K
// smallest of all cuts of the centroid order (computed here from the definition).
TEST(FindCandidates, AreTheCheapestPerAxisAndStartWithFindsSplit) {
    const CostModel cost;
    size_t checked = 0;
    for (TestNode& node : test_nodes()) {
        const ReferenceSummary summary = builders::summarize(node.references);
        for (const auto& space : every_search_space(*node.scene)) {
            for (uint32_t per_axis : {1u, 2u, 5u}) {
                SCOPED_TRACE(std::string(space->name()) + ", " + std::to_string(node.references.size()) +
                             " references, K = " + std::to_string(per_axis));
                std::vector<Reference> a = node.references, b = node.references;
                const Split none;
                const Split found = space->find({a, summary, a.size(), summary.bounds.area(), none}, cost);
                const std::vector<Split> candidates =
                    space->find_candidates({b, summary, b.size(), summary.bounds.area(), none}, cost, per_axis);
                ASSERT_EQ(found.is_valid(), !candidates.empty());
                if (candidates.empty()) continue;
                const auto first_cheapest =
                    std::min_element(candidates.begin(), candidates.end(),
                                     [](const Split& x, const Split& y) { return x.cost < y.cost; });
                EXPECT_TRUE(same_split(*first_cheapest, found));
                std::vector<float> costs_on_axis[3];
                for (size_t i = 0; i < candidates.size(); ++i) {
                    EXPECT_TRUE(candidates[i].is_valid());
                    if (i > 0) {
                        EXPECT_GE(candidates[i].axis, candidates[i - 1].axis) << "axis by axis";
                    }
                    costs_on_axis[candidates[i].axis].push_back(candidates[i].cost);
                }
                for (int axis = 0; axis < 3; ++axis) {
                    EXPECT_LE(costs_on_axis[axis].size(), per_axis);
                    EXPECT_TRUE(std::is_sorted(costs_on_axis[axis].begin(), costs_on_axis[axis].end()));
                }
                if (std::string(space->name()) != "object-sweep") continue;
                for (int axis = 0; axis < 3; ++axis) {
                    std::vector<Reference> sorted = node.references;
                    std::sort(sorted.begin(), sorted.end(), builders::CentroidOrder{axis});
                    std::vector<float> all_cuts;
                    if (summary.centroid_bounds.lo[axis] != summary.centroid_bounds.hi[axis]) {
                        std::vector<AABB> right(sorted.size());  // right[i]: box of sorted[i..]
                        for (size_t i = sorted.size(); i-- > 0;)
                            right[i] = merge(sorted[i].bounds, i + 1 < sorted.size() ? right[i + 1] : AABB{});
                        AABB left;
                        for (size_t i = 1; i < sorted.size(); ++i) {
                            left.extend(sorted[i - 1].bounds);
                            all_cuts.push_back(cost.split_cost(summary.bounds, left, i, right[i], sorted.size() - i));
                        }
                    }
                    std::sort(all_cuts.begin(), all_cuts.end());
                    all_cuts.resize(std::min<size_t>(all_cuts.size(), per_axis));
                    EXPECT_EQ(costs_on_axis[axis], all_cuts) << "axis " << axis;
                }
                ++checked;
            }
        }
    }
    EXPECT_GT(checked, 20u);
}

// The object sweep sorts only the axes its references are not already sorted on (sweep_order), and
// visits that axis first: its split must not depend on the order the references come in, with or
// without an overlap penalty (equal costs on two axes go to the lower axis, whatever the visit order).
TEST(ObjectSweep, SplitDoesNotDependOnTheReferencesOrder) {
    std::mt19937 random(11);
    size_t checked = 0;
    for (float overlap_penalty : {0.0f, 1.0f}) {
        CostModel cost;
        cost.overlap_penalty = overlap_penalty;
        for (TestNode& node : test_nodes()) {
            const ReferenceSummary summary = builders::summarize(node.references);
            const builders::ObjectSweepSplitFinder sweep;
            const Split none;
            std::vector<Reference> shuffled = node.references;
            std::shuffle(shuffled.begin(), shuffled.end(), random);
            const Split reference_split =
                sweep.find({shuffled, summary, shuffled.size(), summary.bounds.area(), none}, cost);
            for (int axis = 0; axis < 3; ++axis) {
                std::vector<Reference> sorted = node.references;
                std::sort(sorted.begin(), sorted.end(), builders::CentroidOrder{axis});
                const Split split = sweep.find({sorted, summary, sorted.size(), summary.bounds.area(), none}, cost);
                EXPECT_TRUE(same_split(split, reference_split))
                    << node.references.size() << " references, sorted on " << axis;
                ++checked;
            }
        }
    }
    EXPECT_GT(checked, 50u);
}

// The sweep's centroid sort (integer keys of 32 + B bits, radix passes from 256 references up) gives
// the total CentroidOrder: the same bytes as std::sort with CentroidOrder on every axis. Large
// primitive ids (B = 32), many equal centroids, and pieces of one triangle (same primitive, different
// bounds, equal centroid on some axis) exercise the key's every part.
std::vector<Reference> references_with_equal_keys(size_t count, uint32_t seed) {
    std::mt19937 random(seed);
    std::uniform_int_distribution<int> coarse(0, 15);
    std::vector<Reference> references;
    Vec3 lo;
    for (size_t i = 0; i < count; ++i) {
        // Three references per primitive: its box and two pieces sharing the box's centroid on x.
        if (i % 3 == 0) lo = Vec3(float(coarse(random)), float(coarse(random)), float(coarse(random)));
        const uint32_t primitive = 0xfffffff0u - uint32_t(i / 3) * 977u;
        const float half = float(i % 3);
        references.push_back(
            Reference{AABB{lo - Vec3(half, 0.0f, 0.0f), lo + Vec3(1.0f + half, 1.0f, 1.0f)}, primitive});
    }
    std::shuffle(references.begin(), references.end(), random);
    return references;
}

TEST(ObjectSweep, SortsIntoTheTotalCentroidOrder) {
    for (const size_t count : {size_t(40), size_t(200), size_t(3000)}) {
        const std::vector<Reference> input = references_with_equal_keys(count, 5);
        for (int axis = 0; axis < 3; ++axis) {
            std::vector<Reference> sorted = input, expected = input;
            builders::sort_in_centroid_order(sorted, axis);
            std::sort(expected.begin(), expected.end(), builders::CentroidOrder{axis});
            for (size_t i = 0; i < count; ++i) {
                ASSERT_EQ(sorted[i].primitive, expected[i].primitive)
                    << count << " references, axis " << axis << ", " << i;
                ASSERT_EQ(sorted[i].bounds, expected[i].bounds) << count << " references, axis " << axis << ", " << i;
            }
        }
    }
}

// The sweep leaves the node's references as they are (it sorts copies), and given the driver's
// centroid orders (NodeContext::sorted) it finds the same split as when it sorts them itself.
TEST(ObjectSweep, ReadsTheNodeInPlaceOrFromTheDriversOrdersAlike) {
    for (const size_t count : {size_t(40), size_t(3000)}) {
        const std::vector<Reference> references = references_with_equal_keys(count, 9);
        const ReferenceSummary summary = builders::summarize(references);
        const Split none;
        CostModel cost;
        cost.overlap_penalty = 1.0f;
        const builders::ObjectSweepSplitFinder sweep;
        std::vector<Reference> node = references;
        const Split alone = sweep.find({node, summary, count, summary.bounds.area(), none}, cost);
        for (size_t i = 0; i < count; ++i) ASSERT_EQ(node[i].bounds, references[i].bounds) << "reordered at " << i;

        std::array<std::vector<Reference>, 3> orders;
        for (int axis = 0; axis < 3; ++axis) {
            orders[axis] = references;
            std::sort(orders[axis].begin(), orders[axis].end(), builders::CentroidOrder{axis});
        }
        builders::NodeContext context{node, summary, count, summary.bounds.area(), none};
        context.sorted = {orders[0], orders[1], orders[2]};
        const Split presorted = sweep.find(context, cost);
        ASSERT_TRUE(alone.is_valid());
        EXPECT_EQ(presorted.cost, alone.cost);
        EXPECT_EQ(presorted.axis, alone.axis);
        EXPECT_EQ(presorted.left_count, alone.left_count);
        EXPECT_EQ(presorted.left_bounds, alone.left_bounds);
        EXPECT_EQ(presorted.right_bounds, alone.right_bounds);
        EXPECT_EQ(presorted.tie.bounds, alone.tie.bounds);
        EXPECT_EQ(presorted.tie.primitive, alone.tie.primitive);
    }
}

// CheapestSplit: the lowest cost wins; of equal costs the lower axis, then the earlier offer.
TEST(CheapestSplit, EqualCostsGoToTheLowerAxisWhateverTheOfferOrder) {
    auto offer = [](builders::CheapestSplit& sink, int axis, float cost, uint32_t tag) {
        if (cost < sink.threshold(axis)) {
            Split split = builders::make_split(builders::SplitKind::object_sorted, cost, axis, AABB{}, tag, AABB{}, 1);
            sink.offer(split);
        }
    };
    builders::CheapestSplit later_axis_first;
    offer(later_axis_first, 2, 5.0f, 1);
    offer(later_axis_first, 0, 5.0f, 2);
    offer(later_axis_first, 0, 5.0f, 3);  // same axis, same cost, later: loses
    offer(later_axis_first, 1, 5.0f, 4);  // higher axis than the best: loses
    EXPECT_EQ(later_axis_first.best.axis, 0);
    EXPECT_EQ(later_axis_first.best.left_count, 2u);
    builders::CheapestSplit lower_axis_first;
    offer(lower_axis_first, 0, 5.0f, 2);
    offer(lower_axis_first, 2, 5.0f, 1);
    EXPECT_EQ(lower_axis_first.best.axis, 0);
    EXPECT_EQ(lower_axis_first.best.left_count, 2u);
    offer(lower_axis_first, 2, 4.0f, 5);  // cheaper wins on any axis
    EXPECT_EQ(lower_axis_first.best.axis, 2);
    EXPECT_EQ(lower_axis_first.best.left_count, 5u);
}

// Applying a sweep split keeps the references' order: children of a node sorted on an axis are
// sorted on it too (what lets them skip that sort), and they hold exactly the cut's references.
TEST(ApplySplit, SweepSplitKeepsTheOrder) {
    const CostModel cost;
    size_t checked = 0;
    for (TestNode& node : test_nodes()) {
        const ReferenceSummary summary = builders::summarize(node.references);
        const builders::ObjectSweepSplitFinder sweep;
        const Split none;
        for (int axis = 0; axis < 3; ++axis) {
            std::vector<Reference> storage = node.references;
            const Split split = sweep.find({storage, summary, storage.size(), summary.bounds.area(), none}, cost);
            if (!split.is_valid()) continue;
            std::sort(storage.begin(), storage.end(), builders::CentroidOrder{axis});
            const std::vector<Reference> before = storage;
            const builders::ChildRanges children =
                builders::apply_split(storage, uint32_t(storage.size()), split, node.scene->triangles);
            ASSERT_EQ(children.left_count, split.left_count);
            ASSERT_EQ(children.left_count + children.right_count, before.size());
            std::vector<Reference> expected_left, expected_right;
            for (const Reference& reference : before)
                (builders::CentroidOrder{split.axis}(reference, split.tie) ? expected_left : expected_right)
                    .push_back(reference);
            const std::span<const Reference> left(storage.data(), children.left_count);
            const std::span<const Reference> right(storage.data() + children.left_capacity, children.right_count);
            auto same = [](std::span<const Reference> a, const std::vector<Reference>& b) {
                return a.size() == b.size() &&
                       std::equal(a.begin(), a.end(), b.begin(), [](const Reference& x, const Reference& y) {
                           return x.primitive == y.primitive && x.bounds == y.bounds;
                       });
            };
            EXPECT_TRUE(same(left, expected_left)) << "axis " << axis;
            EXPECT_TRUE(same(right, expected_right)) << "axis " << axis;
            EXPECT_TRUE(std::is_sorted(left.begin(), left.end(), builders::CentroidOrder{axis}));
            EXPECT_TRUE(std::is_sorted(right.begin(), right.end(), builders::CentroidOrder{axis}));
            ++checked;
        }
    }
    EXPECT_GT(checked, 20u);
}

// The candidates of all search spaces start with the greedy split (what the driver takes without a
// lookahead), also when the spatial gate reads the cheapest split of the spaces before it.
TEST(SplitSearch, CandidatesStartWithTheCheapestSplit) {
    for (float gate_alpha : {0.0f, 1e-5f}) {
        for (float overlap_penalty : {0.0f, 1.0f, kInfinity}) {
            CostModel cost;
            cost.overlap_penalty = overlap_penalty;
            for (TestNode& node : test_nodes()) {
                const auto spaces = every_search_space(*node.scene, gate_alpha);
                const builders::SplitSearch search(cost, {}, spaces, node.scene->triangles,
                                                   node.scene->bounds().area());
                const ReferenceSummary summary = builders::summarize(node.references);
                std::vector<Reference> a = node.references, b = node.references;
                const Split cheapest = search.cheapest(a, summary, a.size());
                const std::vector<Split> candidates = search.candidates(b, summary, b.size(), 2);
                ASSERT_EQ(cheapest.is_valid(), !candidates.empty());
                if (!candidates.empty()) {
                    EXPECT_TRUE(same_split(candidates.front(), cheapest));
                    for (const Split& candidate : candidates) EXPECT_GE(candidate.cost, cheapest.cost);
                }
            }
        }
    }
}

// Each search space's cheapest split, the cheapest of them first: the options of the lookahead to
// the leaves at the top of the tree. The list holds exactly the valid find() results, each found as
// cheapest() walks the spaces (the spatial gate reads the cheapest split of the spaces before it).
TEST(SplitSearch, CheapestPerSpaceIsEverySpacesFindCheapestFirst) {
    size_t lists = 0, with_several = 0;
    for (float gate_alpha : {0.0f, 1e-5f}) {
        for (float overlap_penalty : {0.0f, 1.0f}) {
            CostModel cost;
            cost.overlap_penalty = overlap_penalty;
            for (TestNode& node : test_nodes()) {
                const auto spaces = every_search_space(*node.scene, gate_alpha);
                const float root_area = node.scene->bounds().area();
                const builders::SplitSearch search(cost, {}, spaces, node.scene->triangles, root_area);
                const ReferenceSummary summary = builders::summarize(node.references);
                std::vector<Reference> a = node.references, b = node.references;
                const Split cheapest = search.cheapest(a, summary, a.size() * 2);
                const std::vector<Split> per_space = search.cheapest_per_space(b, summary, b.size() * 2);
                ASSERT_EQ(cheapest.is_valid(), !per_space.empty());
                if (per_space.empty()) continue;
                EXPECT_TRUE(same_split(per_space.front(), cheapest));
                // By hand: the walk of cheapest(), every valid offer kept.
                std::vector<Split> expected;
                Split best;
                for (const auto& space : spaces) {
                    std::vector<Reference> c = node.references;
                    const builders::NodeContext context{c,         summary, c.size() * 2,
                                                        root_area, best,    search.must_split(c.size())};
                    const Split found = space->find(context, cost);
                    if (!found.is_valid()) continue;
                    if (found.cost < best.cost) best = found;
                    expected.push_back(found);
                }
                ASSERT_EQ(per_space.size(), expected.size());
                for (const Split& split : per_space) {
                    EXPECT_TRUE(split.is_valid());
                    EXPECT_GE(split.cost, cheapest.cost);
                    EXPECT_EQ(std::count_if(expected.begin(), expected.end(),
                                            [&](const Split& e) { return same_split(e, split); }),
                              1);
                }
                ++lists;
                with_several += per_space.size() > 1;
            }
        }
    }
    EXPECT_GT(lists, 20u);
    EXPECT_GT(with_several, 10u) << "the object and spatial spaces should both offer splits";
}

// The lookahead to the leaves (DriverOptions::lookahead_top_share): at a node it prices each search
// space's cheapest split by the SAH of the whole greedy subtree. Checked against the driver itself:
// the greedy option's price is the SAH of the tree the greedy driver builds over the node, and the
// chosen option's price is the SAH of the tree the driver builds when the node looks ahead (its
// children below the share, so greedy). Never above the greedy tree.
TEST(Lookahead, ToTheLeavesPricesOptionsByTheTreesTheDriverBuilds) {
    CostModel cost;
    cost.overlap_penalty = 1.0f;
    const builders::BuildLimits limits;
    size_t checked = 0;
    for (TestNode& node : test_nodes()) {
        const uint32_t count = uint32_t(node.references.size());
        if (count < 300) continue;
        SCOPED_TRACE(std::to_string(count) + " references");
        const size_t capacity = count + count / 4;
        const ReferenceSummary summary = builders::summarize(node.references);
        const double area = summary.bounds.area();
        const auto spaces = every_search_space(*node.scene);
        const builders::SplitSearch search(cost, limits, spaces, node.scene->triangles, summary.bounds.area());
        const builders::Lookahead to_the_leaves(search, limits.max_depth, 0, nullptr);
        std::vector<Reference> storage = node.references;
        storage.resize(capacity);
        const builders::LookaheadChoice choice = to_the_leaves.choose(storage, count, summary, 0);
        EXPECT_EQ(choice.options, spaces.size()) << "one option per search space (all offer a split here)";
        EXPECT_LE(choice.cost, choice.greedy_cost);

        auto driver_tree_sah = [&](float top_share) {
            builders::DriverOptions options;
            options.lookahead_top_share = top_share;
            builders::TopDownBuilder builder(cost, limits, every_search_space(*node.scene), node.scene->triangles,
                                             options);
            return tree_sah(builder.build(node.references, capacity), cost);
        };
        const double greedy_sah = driver_tree_sah(0.0f), looked_ahead_sah = driver_tree_sah(1.0f);
        EXPECT_NEAR(choice.greedy_cost / area, greedy_sah, 1e-5 * greedy_sah);
        EXPECT_NEAR(choice.cost / area, looked_ahead_sah, 1e-5 * looked_ahead_sah);
        EXPECT_LE(looked_ahead_sah, greedy_sah * (1 + 1e-6));
        ++checked;
    }
    EXPECT_EQ(checked, 4u);
}

// A node with nothing to compare (one search space, must be split) takes the greedy split unpriced:
// pricing it to the leaves would build its whole subtree for nothing.
TEST(Lookahead, SingleOptionIsTheGreedyDecisionUnpriced) {
    const CostModel cost;
    const builders::BuildLimits limits;
    size_t checked = 0;
    for (TestNode& node : test_nodes()) {
        const uint32_t count = uint32_t(node.references.size());
        if (!(count > limits.max_leaf_size)) continue;
        std::vector<std::unique_ptr<builders::SplitFinder>> spaces;
        spaces.push_back(std::make_unique<builders::ObjectSweepSplitFinder>());
        const ReferenceSummary summary = builders::summarize(node.references);
        const builders::SplitSearch search(cost, limits, spaces, node.scene->triangles, summary.bounds.area());
        std::vector<Reference> storage = node.references, expected_storage = node.references;
        const builders::LookaheadChoice choice =
            builders::Lookahead(search, limits.max_depth, 0, nullptr).choose(storage, count, summary, 0);
        const std::optional<Split> greedy = search.greedy_decision(expected_storage, summary, count);
        ASSERT_TRUE(greedy && choice.split);
        EXPECT_TRUE(same_split(*choice.split, *greedy)) << count << " references";
        EXPECT_EQ(choice.options, 1u);
        EXPECT_TRUE(choice.greedy);
        EXPECT_EQ(choice.cost, 0.0);
        ++checked;
    }
    EXPECT_GE(checked, 6u);
}

// The lookahead's choice: never priced above the greedy decision; the greedy decision priced as the
// greedy subtree of the node; and, one level deep, by the definition: C_T*SA(N) plus, per child, its
// leaf cost or its cheapest split's local cost (whichever the greedy step takes), area-weighted.
TEST(Lookahead, ChoiceIsPricedByItsSubtreeAndNeverAboveTheGreedyDecision) {
    CostModel cost;
    cost.overlap_penalty = 1.0f;
    size_t non_greedy = 0, compared = 0;
    for (TestNode& node : test_nodes()) {
        const auto spaces = every_search_space(*node.scene);
        const builders::SplitSearch search(cost, {}, spaces, node.scene->triangles, node.scene->bounds().area());
        const uint32_t count = uint32_t(node.references.size());
        const ReferenceSummary summary = builders::summarize(node.references);
        const size_t capacity = count + count / 4;  // room for spatial splits
        auto storage_of = [&] {
            std::vector<Reference> storage = node.references;
            storage.resize(capacity);
            return storage;
        };
        for (uint32_t depth : {1u, 2u}) {
            SCOPED_TRACE(std::to_string(count) + " references, lookahead " + std::to_string(depth));
            const builders::Lookahead lookahead(search, depth, 2, nullptr);
            std::vector<Reference> storage = storage_of();
            const builders::LookaheadChoice choice = lookahead.choose(storage, count, summary, 0);
            EXPECT_LE(choice.cost, choice.greedy_cost);
            EXPECT_GT(choice.options, 1u);
            non_greedy += !choice.greedy;
            ++compared;

            std::vector<Reference> greedy_storage = storage_of();
            const double greedy_subtree = lookahead.greedy_subtree_cost(greedy_storage, count, summary, 0, depth);
            EXPECT_EQ(choice.greedy_cost, greedy_subtree);
            if (choice.greedy) {
                EXPECT_EQ(choice.cost, greedy_subtree);
            }

            if (depth != 1) continue;
            std::vector<Reference> manual = storage_of();
            std::optional<Split> greedy = search.greedy_decision(std::span(manual).first(count), summary, capacity);
            ASSERT_TRUE(greedy.has_value());  // these nodes are worth splitting at the root
            const builders::ChildRanges children = builders::apply_split(manual, count, *greedy, node.scene->triangles);
            double expected = double(cost.traversal_cost) * summary.bounds.area();
            const std::pair<uint32_t, uint32_t> ranges[2] = {{0, children.left_count},
                                                             {children.left_capacity, children.right_count}};
            const uint32_t capacities[2] = {children.left_capacity, children.right_capacity};
            for (int side = 0; side < 2; ++side) {
                std::span<Reference> child(manual.data() + ranges[side].first, ranges[side].second);
                const ReferenceSummary child_summary = builders::summarize(child);
                const double area = child_summary.bounds.area();
                double local = cost.leaf_cost(child.size()) * area;
                if (child.size() > 1) {
                    const Split split = search.cheapest(child, child_summary, capacities[side]);
                    if (split.is_valid() &&
                        (split.cost < cost.leaf_cost(child.size()) || search.must_split(child.size())))
                        local = double(split.cost) * area;
                }
                expected += local;
            }
            EXPECT_NEAR(choice.greedy_cost, expected, 1e-9 * expected);
        }
    }
    EXPECT_GT(compared, 0u);
    RecordProperty("non_greedy_choices", std::to_string(non_greedy) + " of " + std::to_string(compared));
}

TEST(Lookahead, InvalidSettingsAreRejected) {
    BuildConfig options = config_for("cbvh");
    options.lookahead.depth = kMaxLookaheadDepth + 1;
    EXPECT_THROW(options.validate(), Error);
    options.lookahead.depth = 1;
    options.lookahead.candidates = 0;
    EXPECT_THROW(options.validate(), Error);
    options.lookahead.candidates = 3;
    EXPECT_NO_THROW(options.validate());
    for (float share : {0.001f, -0.5f, 1.5f, std::nanf(""), kInfinity}) {
        options.lookahead.top_share = share;
        EXPECT_THROW(options.validate(), Error) << share;
    }
    for (float share : {0.0f, kMinLookaheadTopShare, 0.5f, 1.0f}) {
        options.lookahead.top_share = share;
        EXPECT_NO_THROW(options.validate()) << share;
    }
}

// Cancellation: a flag set while the build runs (here from the progress callback, once the first
// leaves are done) stops it with Cancelled, greedy or with a lookahead, serial or parallel; a set
// flag stops a build before it starts; and the next build with the flag clear is unharmed.
TEST(Cancellation, FlagSetDuringTheBuildThrowsCancelled) {
    Scene scene = testing_support::cached_builtin_scene("soup");
    scene.triangles.resize(10000);  // more than one parallel subtree
    for (const char* builder : {"cbvh", "spatial"}) {
        for (uint32_t lookahead : {0u, 1u}) {
            SCOPED_TRACE(std::string(builder) + " lookahead " + std::to_string(lookahead));
            std::atomic<bool> cancel{false};
            std::atomic<int> reports{0};
            BuildConfig options = config_for(builder);
            options.lookahead.depth = lookahead;
            options.hooks.cancel = &cancel;
            options.hooks.progress = [&](double fraction) {
                reports++;
                if (fraction < 1.0) cancel = true;
            };
            EXPECT_THROW(spacebvh::build(scene, options), Cancelled);
            EXPECT_GE(reports.load(), 1);
            EXPECT_LT(reports.load(), 50) << "the build went on long after the flag was set";
        }
    }
    std::atomic<bool> cancel{true};
    BuildConfig options = config_for("binned");
    options.hooks.cancel = &cancel;
    EXPECT_THROW(spacebvh::build(scene, options), Cancelled);
    cancel = false;
    const Bvh bvh = spacebvh::build(scene, options);
    EXPECT_EQ(bvh.primitives.size(), scene.triangles.size());
}

}  // namespace spacebvh

namespace spacebvh {
namespace {

// A tree as a depth-first list (left first) of node boxes, each leaf followed by its triangles.
struct TreeListing {
    std::vector<AABB> boxes;
    std::vector<std::vector<uint32_t>> leaves;
    bool operator==(const TreeListing&) const = default;
};

void list_greedy_tree(const builders::SplitSearch& search, std::span<Reference> storage, uint32_t count,
                      const ReferenceSummary& summary, uint32_t depth, TreeListing& listing,
                      std::array<size_t, 3>& kinds) {
    listing.boxes.push_back(summary.bounds);
    auto leaf = [&] {
        std::vector<uint32_t> triangles;
        for (const Reference& reference : storage.first(count)) triangles.push_back(reference.primitive);
        std::sort(triangles.begin(), triangles.end());
        triangles.erase(std::unique(triangles.begin(), triangles.end()), triangles.end());
        listing.leaves.push_back(triangles);
    };
    if (search.must_be_leaf(count, depth)) return leaf();
    std::optional<Split> split = search.greedy_decision(storage.first(count), summary, storage.size());
    if (!split) return leaf();
    search.order_for_apply(storage.first(count));
    const std::optional<builders::ChildRanges> children = search.apply(storage, count, *split, summary);
    if (!children) return leaf();
    kinds[split->kind == builders::SplitKind::spatial         ? 2
          : split->kind == builders::SplitKind::object_binned ? 1
                                                              : 0]++;
    const std::span<Reference> left = storage.first(children->left_capacity);
    const std::span<Reference> right = storage.subspan(children->left_capacity, children->right_capacity);
    list_greedy_tree(search, left, children->left_count, builders::summarize(left.first(children->left_count)),
                     depth + 1, listing, kinds);
    list_greedy_tree(search, right, children->right_count, builders::summarize(right.first(children->right_count)),
                     depth + 1, listing, kinds);
}

void list_bvh(const Bvh& bvh, uint32_t index, TreeListing& listing) {
    const BvhNode& node = bvh.nodes[index];
    listing.boxes.push_back(node.bounds);
    if (node.is_leaf()) {
        listing.leaves.emplace_back(bvh.primitives.begin() + node.first,
                                    bvh.primitives.begin() + node.first + node.reference_count);
        return;
    }
    list_bvh(bvh, node.first, listing);
    list_bvh(bvh, node.first + 1, listing);
}

}  // namespace

// The driver keeps every node's references in centroid order on each axis, so that no node sorts:
// children inherit the orders through object splits, and a spatial split merges its straddlers'
// new pieces in. Its trees are those of the plain greedy step that sorts every node itself, also
// where the reference budget runs out (which straddlers are still duplicated depends on the order
// splits are applied in: SplitSearch::order_for_apply).
TEST(TopDownBuilder, CentroidOrdersGiveTheTreesOfTheGreedyStepThatSortsItself) {
    CostModel cost;
    cost.overlap_penalty = 1.0f;
    const builders::BuildLimits limits;
    std::array<size_t, 3> kinds{};  // splits taken: sweep, binned object, spatial
    size_t checked = 0;
    for (TestNode& node : test_nodes()) {
        const uint32_t count = uint32_t(node.references.size());
        if (count < 40) continue;
        // The binned object space first too: its splits then win ties with the sweep's, so both
        // kinds of object split occur.
        for (const bool binned_first : {false, true}) {
            auto search_spaces = [&] {
                auto spaces = every_search_space(*node.scene);
                if (binned_first) std::swap(spaces[0], spaces[1]);
                return spaces;
            };
            for (const uint32_t capacity : {count, count + count / 50, 2 * count}) {
                SCOPED_TRACE(std::to_string(count) + " references, capacity " + std::to_string(capacity) +
                             (binned_first ? ", binned first" : ""));
                const ReferenceSummary summary = builders::summarize(node.references);
                const auto spaces = search_spaces();
                const builders::SplitSearch search(cost, limits, spaces, node.scene->triangles, summary.bounds.area());
                ASSERT_TRUE(search.reads_centroid_orders());
                std::vector<Reference> storage = node.references;
                storage.resize(capacity);
                TreeListing expected, built;
                list_greedy_tree(search, storage, count, summary, 0, expected, kinds);
                builders::TopDownBuilder builder(cost, limits, search_spaces(), node.scene->triangles, {});
                list_bvh(builder.build(node.references, capacity), 0, built);
                EXPECT_EQ(built.boxes.size(), expected.boxes.size());
                EXPECT_TRUE(built == expected);
                ++checked;
            }
        }
    }
    EXPECT_EQ(checked, 36u);
    EXPECT_GT(kinds[0], 100u) << "sweep splits";
    EXPECT_GT(kinds[1], 100u) << "binned object splits";
    EXPECT_GT(kinds[2], 20u) << "spatial splits";
}

}  // namespace spacebvh
