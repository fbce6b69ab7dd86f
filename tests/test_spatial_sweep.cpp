// SPDX-License-Identifier: MIT
// The exact sweep-plane spatial search space (src/builders/search_spaces/spatial_sweep_split_finder.hpp) against brute
// force, its clipping edge cases, and the partition rule for straddlers when the budget is spent.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "builders/driver/partition.hpp"
#include "builders/search_spaces/spatial_split.hpp"
#include "builders/search_spaces/spatial_sweep_split_finder.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh::builders {

namespace {

// Brute force for one plane: apply the split with the partition code (every straddler clipped into
// both sides, room for all of them) and take the tight boxes of what each child received.
SpatialPlaneEvaluation partition_directly(std::span<const Reference> references, std::span<const Triangle> triangles,
                                          int axis, float position) {
    std::vector<Reference> storage(references.begin(), references.end());
    storage.resize(2 * references.size());
    Split split;
    split.kind = SplitKind::spatial;
    split.axis = axis;
    split.position = position;
    split.unsplit = false;
    const ChildRanges ranges = apply_split(storage, uint32_t(references.size()), split, triangles);
    SpatialPlaneEvaluation result;
    result.left_count = ranges.left_count;
    result.right_count = ranges.right_count;
    for (uint32_t i = 0; i < ranges.left_count; ++i) result.left_bounds.extend(storage[i].bounds);
    for (uint32_t i = 0; i < ranges.right_count; ++i)
        result.right_bounds.extend(storage[ranges.left_capacity + i].bounds);
    return result;
}

struct Node {
    std::vector<Triangle> triangles;
    std::vector<Reference> references;
    AABB bounds() const {
        AABB box;
        for (const Reference& reference : references) box.extend(reference.bounds);
        return box;
    }
};

// Random triangles of mixed sizes; some references are pieces already clipped by an earlier split
// (their bounds are smaller than their triangle's), as deeper in a tree.
Node random_node(uint32_t seed, int count) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    Node node;
    for (int i = 0; i < count; ++i) {
        const Vec3 base{unit(rng), unit(rng), unit(rng)};
        const float size = i % 3 == 0 ? 0.8f : 0.2f;
        auto vertex = [&] { return base + Vec3{unit(rng), unit(rng), unit(rng)} * size; };
        node.triangles.push_back({vertex(), vertex(), vertex()});
        Reference reference{node.triangles.back().bounds(), uint32_t(i)};
        if (i % 4 == 1) {
            const int axis = i % 3;
            const float plane = 0.5f * (reference.bounds.lo[axis] + reference.bounds.hi[axis]);
            const auto [left, right] = split_reference(reference, node.triangles.back(), axis, plane);
            reference = (i % 8 == 1) ? left : right;
        }
        node.references.push_back(reference);
    }
    return node;
}

void expect_sweep_matches_brute_force(const Node& node, const std::string& what) {
    const AABB box = node.bounds();
    for (int axis = 0; axis < 3; ++axis) {
        const SpatialSweepPlanes sweep = sweep_spatial_planes(node.references, node.triangles, box, axis);
        // Every event strictly inside the node is a candidate, and nothing else.
        std::vector<float> events;
        for (const Reference& reference : node.references)
            for (float e : {reference.bounds.lo[axis], reference.bounds.hi[axis]})
                if (e > box.lo[axis] && e < box.hi[axis]) events.push_back(e);
        std::sort(events.begin(), events.end());
        events.erase(std::unique(events.begin(), events.end()), events.end());
        ASSERT_EQ(sweep.planes, events) << what << " axis " << axis;
        for (size_t k = 0; k < sweep.planes.size(); ++k) {
            const SpatialPlaneEvaluation expected =
                partition_directly(node.references, node.triangles, axis, sweep.planes[k]);
            SCOPED_TRACE(what + " axis " + std::to_string(axis) + " plane " + std::to_string(k));
            EXPECT_EQ(sweep.left_counts[k], expected.left_count);
            EXPECT_EQ(sweep.right_counts[k], expected.right_count);
            EXPECT_EQ(sweep.left_bounds[k], expected.left_bounds);
            EXPECT_EQ(sweep.right_bounds[k], expected.right_bounds);
            // The finder's own direct evaluation (used for interior positions) is the same thing.
            const SpatialPlaneEvaluation direct =
                evaluate_spatial_plane(node.references, node.triangles, axis, sweep.planes[k]);
            EXPECT_EQ(direct.left_bounds, expected.left_bounds);
            EXPECT_EQ(direct.right_bounds, expected.right_bounds);
            EXPECT_EQ(direct.left_count, expected.left_count);
            EXPECT_EQ(direct.right_count, expected.right_count);
        }
    }
}

TEST(SpatialSweep, EveryEventPlaneMatchesThePartitionOnRandomNodes) {
    for (uint32_t seed = 1; seed <= 40; ++seed) {
        const Node node = random_node(seed, 4 + int(seed % 29));
        expect_sweep_matches_brute_force(node, "seed " + std::to_string(seed));
        if (::testing::Test::HasFailure()) return;
    }
}

// Edge cases of clipping at event planes: a triangle lying in a candidate plane (it goes left and
// must not enlarge the right child), a plane through a vertex of a straddler, and a straddler that
// touches the plane only at a point or along an edge (flat clipped boxes).
TEST(SpatialSweep, ClippingEdgeCasesMatchThePartition) {
    Node node;
    node.triangles = {
        {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}},                 // ends at x = 1
        {{0.5f, 0, 0}, {0.5f, 1, 0}, {0.5f, 0, 1}},        // lies in x = 0.5
        {{0, 0.2f, 0.2f}, {2, 0.4f, 0.9f}, {1, 2, 0.3f}},  // straddles; vertex on x = 1 (an event)
        {{0.25f, 0, 0}, {2, 0, 0}, {2, 0, 2}},             // lies in y = 0: flat box
        {{1.5f, 3, 3}, {2, 3.5f, 3}, {1.75f, 3, 4}},       // starts at x = 1.5
        {{1, -1, -1}, {1, -1, -0.5f}, {1, -0.5f, -1}},     // lies in x = 1 (the vertex plane)
    };
    for (uint32_t i = 0; i < node.triangles.size(); ++i) node.references.push_back({node.triangles[i].bounds(), i});
    expect_sweep_matches_brute_force(node, "edge cases");

    // A piece clipped to a flat box (the part of a triangle in the plane x = 1 only), and an empty
    // piece of the node: neither may change the other children.
    const auto [left, right] = split_reference(node.references[2], node.triangles[2], 0, 1.0f);
    ASSERT_FALSE(left.bounds.is_empty());
    Reference flat = node.references[2];
    flat.bounds.lo.x = flat.bounds.hi.x = 1.0f;
    flat.bounds = split_reference(flat, node.triangles[2], 0, 1.0f).first.bounds;
    ASSERT_FALSE(flat.bounds.is_empty());
    EXPECT_EQ(flat.bounds.lo.x, 1.0f);
    EXPECT_EQ(flat.bounds.hi.x, 1.0f);
    node.references.push_back(flat);
    node.references.push_back(right);
    expect_sweep_matches_brute_force(node, "edge cases with clipped pieces");
}

// The finder's split is the cheapest event plane by brute force; sampling interior positions can only
// lower the cost.
TEST(SpatialSweep, FinderPicksTheCheapestEventAndInteriorSamplesNeverHurt) {
    CostModel cost;
    for (uint32_t seed = 100; seed < 110; ++seed) {
        Node node = random_node(seed, 24);
        const ReferenceSummary summary = summarize(node.references);
        float brute_force = kInfinity;
        for (int axis = 0; axis < 3; ++axis) {
            const SpatialSweepPlanes sweep =
                sweep_spatial_planes(node.references, node.triangles, summary.bounds, axis);
            for (float plane : sweep.planes) {
                const SpatialPlaneEvaluation e = partition_directly(node.references, node.triangles, axis, plane);
                if (e.left_count && e.right_count)
                    brute_force = std::min(brute_force, cost.split_cost(summary.bounds, e.left_bounds, e.left_count,
                                                                        e.right_bounds, e.right_count));
            }
        }
        const Split none;
        const NodeContext context{node.references, summary, 2 * node.references.size(), summary.bounds.area(), none};
        const Split events = SpatialSweepSplitFinder(node.triangles, {}).find(context, cost);
        ASSERT_TRUE(events.is_valid());
        EXPECT_EQ(events.kind, SplitKind::spatial);
        EXPECT_EQ(events.cost, brute_force) << "seed " << seed;
        const Split sampled = SpatialSweepSplitFinder(node.triangles, {true, 4, 3}).find(context, cost);
        EXPECT_LE(sampled.cost, events.cost) << "seed " << seed;
        // Whatever the position, the split's boxes and counts are those of the partition.
        const SpatialPlaneEvaluation applied =
            partition_directly(node.references, node.triangles, sampled.axis, sampled.position);
        EXPECT_EQ(sampled.left_bounds, applied.left_bounds);
        EXPECT_EQ(sampled.right_bounds, applied.right_bounds);
    }
}

// With the budget spent, a straddler that unsplitting would duplicate goes whole to the cheaper
// side. Here (|L| = 10, |R| = 2, equal areas) both sides cost 72, right only 72.4, left only 98.
TEST(SpatialSweep, SpentBudgetSendsAStraddlerToTheCheaperSide) {
    const std::vector<Triangle> triangles = {
        {{0, 0, 0}, {0.5f, 0, 0}, {0, 1, 1}},     // left of x = 1
        {{0.2f, 0, 0}, {1.8f, 1, 0}, {1, 0, 1}},  // straddles x = 1
        {{1.5f, 0, 0}, {2, 1, 0}, {2, 0, 1}},     // right of x = 1
    };
    std::vector<Reference> storage;
    for (uint32_t i = 0; i < triangles.size(); ++i) storage.push_back({triangles[i].bounds(), i});
    Split split;
    split.kind = SplitKind::spatial;
    split.axis = 0;
    split.position = 1.0f;
    split.unsplit = true;
    split.left_bounds = {{0, 0, 0}, {1, 1, 1}};
    split.right_bounds = {{1, 0, 0}, {2, 1, 1}};
    split.left_count = 10;
    split.right_count = 2;
    // No spare capacity: no reference may be duplicated.
    const ChildRanges ranges = apply_split(storage, 3, split, triangles);
    ASSERT_EQ(ranges.left_count + ranges.right_count, 3u);
    EXPECT_EQ(ranges.left_count, 1u);
    EXPECT_EQ(ranges.right_count, 2u);
    const auto right = std::span(storage).subspan(ranges.left_capacity, ranges.right_count);
    EXPECT_TRUE(std::any_of(right.begin(), right.end(), [](const Reference& r) { return r.primitive == 1; }))
        << "the straddler should go right";
}

TEST(SpatialSweep, InteriorSamplesAreValidated) {
    BuildConfig options = config_for("kdbvh");
    options.spatial.exact_sweep = true;
    options.spatial.sweep_interior_samples = 65;
    EXPECT_THROW(options.validate(), Error);
}

}  // namespace
}  // namespace spacebvh::builders
