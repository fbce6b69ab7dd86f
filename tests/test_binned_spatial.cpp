// SPDX-License-Identifier: MIT
// The binned spatial search space (src/builders/search_spaces/binned_spatial_split_finder.hpp): its bins against the
// exact clipping of apply_split, and when its search is skipped (the budget and alpha gates).
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "builders/search_spaces/binned_spatial_split_finder.hpp"
#include "builders/search_spaces/object_sweep_split_finder.hpp"
#include "builders/driver/partition.hpp"
#include "builders/search_spaces/spatial_split.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "test_support.hpp"

namespace spacebvh::builders {

using namespace spacebvh::tools;
namespace {

using Node = testing_support::SmallNode;

// Random triangles of mixed sizes in [0, 2]^3. With `clipped`, some references are pieces cut by an
// earlier plane (bounds smaller than their triangle's), as deeper in a tree.
Node random_node(uint32_t seed, int count, bool clipped) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::vector<Triangle> triangles;
    for (int i = 0; i < count; ++i) {
        const Vec3 base{unit(rng), unit(rng), unit(rng)};
        const float size = i % 3 == 0 ? 1.0f : 0.25f;
        auto vertex = [&] { return base + Vec3{unit(rng), unit(rng), unit(rng)} * size; };
        triangles.push_back({vertex(), vertex(), vertex()});
    }
    Node node = testing_support::small_node(std::move(triangles));
    if (clipped) {
        for (size_t i = 1; i < node.references.size(); i += 3) {
            Reference& reference = node.references[i];
            const int axis = int(i % 3);
            const float plane = 0.5f * (reference.bounds.lo[axis] + reference.bounds.hi[axis]);
            const auto [left, right] = split_reference(reference, node.triangles[reference.primitive], axis, plane);
            reference = i % 2 ? left : right;
        }
        node.summary = summarize(node.references);
    }
    return node;
}

// Every straddler clipped exactly into both sides (apply_split, room for all of them): the counts
// and tight child boxes a plane really gives.
struct Children {
    uint32_t left_count = 0, right_count = 0;
    AABB left, right;
};
Children split_exactly(const Node& node, int axis, float position) {
    std::vector<Reference> storage(node.references);
    storage.resize(2 * node.references.size());
    Split split;
    split.kind = SplitKind::spatial;
    split.axis = axis;
    split.position = position;
    split.unsplit = false;
    const ChildRanges ranges = apply_split(storage, uint32_t(node.references.size()), split, node.triangles);
    Children children{ranges.left_count, ranges.right_count, AABB::empty(), AABB::empty()};
    for (uint32_t i = 0; i < ranges.left_count; ++i) children.left.extend(storage[i].bounds);
    for (uint32_t i = 0; i < ranges.right_count; ++i) children.right.extend(storage[ranges.left_capacity + i].bounds);
    return children;
}

AABB grown(AABB box, float margin) {
    box.lo = box.lo - Vec3{margin, margin, margin};
    box.hi = box.hi + Vec3{margin, margin, margin};
    return box;
}

bool contains(const AABB& outer, const AABB& inner) { return inner.is_empty() || outer.contains(inner); }

std::vector<Split> every_plane(const BinnedSpatialSplitFinder& finder, Node& node, size_t capacity, const Split& best,
                               bool must_split = false) {
    const NodeContext context{node.references, node.summary, capacity, node.summary.bounds.area(), best, must_split};
    return finder.find_candidates(context, CostModel{}, 1024);
}

// The finder prices each plane with boxes from its bins, which it fills without clipping exactly
// (Embree's way). Those boxes must hold what the exact clipping gives each child (up to the rounding
// of the crossing points), never cross the plane, and count the same references.
TEST(BinnedSpatial, BinBoxesHoldTheExactlyClippedChildren) {
    const float margin = 1e-5f;  // node extent ~2: a few hundred ulps, far above the crossings' rounding
    int planes = 0;
    for (uint32_t seed = 0; seed < 24; ++seed) {
        Node node = random_node(seed, 6 + int(seed % 5) * 7, /*clipped=*/true);
        SpatialSearchOptions options;
        options.bins = 4 + seed % 13;
        options.unsplit = false;
        const BinnedSpatialSplitFinder finder(node.triangles, options);
        for (const Split& split : every_plane(finder, node, 2 * node.references.size(), Split{})) {
            SCOPED_TRACE("seed " + std::to_string(seed) + " axis " + std::to_string(split.axis) + " plane " +
                         std::to_string(split.position));
            const Children exact = split_exactly(node, split.axis, split.position);
            EXPECT_EQ(split.left_count, exact.left_count);
            EXPECT_EQ(split.right_count, exact.right_count);
            EXPECT_TRUE(contains(grown(split.left_bounds, margin), exact.left));
            EXPECT_TRUE(contains(grown(split.right_bounds, margin), exact.right));
            EXPECT_LE(split.left_bounds.hi[split.axis], split.position);
            EXPECT_GE(split.right_bounds.lo[split.axis], split.position);
            EXPECT_TRUE(contains(node.summary.bounds, split.left_bounds));
            EXPECT_TRUE(contains(node.summary.bounds, split.right_bounds));
            ++planes;
        }
    }
    EXPECT_GT(planes, 500);
}

// Where no reference was clipped before, the box of the triangle between two planes is the exact
// piece's box: the bins are then tight, not just conservative.
TEST(BinnedSpatial, BinBoxesAreTightForUnclippedReferences) {
    const float margin = 1e-5f;
    int planes = 0;
    for (uint32_t seed = 0; seed < 12; ++seed) {
        Node node = random_node(100 + seed, 5 + int(seed) * 3, /*clipped=*/false);
        SpatialSearchOptions options;
        options.bins = 3 + seed % 9;
        const BinnedSpatialSplitFinder finder(node.triangles, options);
        for (const Split& split : every_plane(finder, node, 2 * node.references.size(), Split{})) {
            const Children exact = split_exactly(node, split.axis, split.position);
            EXPECT_TRUE(contains(grown(exact.left, margin), split.left_bounds)) << "seed " << seed;
            EXPECT_TRUE(contains(grown(exact.right, margin), split.right_bounds)) << "seed " << seed;
            ++planes;
        }
    }
    EXPECT_GT(planes, 100);
}

// Without spare capacity a plane can duplicate nothing, so where an object split is on offer the
// spatial search is skipped; alone (kdbvh) it still runs. Spare capacity brings it back, and so does
// a node that must be split while the object split loses to a leaf (PerBuilder.MaxLeafSizeIsRespected
// builds such nodes: a soup of large triangles under C_o = 1, where object splits only peel).
TEST(BinnedSpatial, SearchIsSkippedWithoutSpareCapacityWhenAnObjectSplitIsOffered) {
    Node node = random_node(7, 40, /*clipped=*/false);
    const size_t count = node.references.size();
    const BinnedSpatialSplitFinder finder(node.triangles, SpatialSearchOptions{});
    const NodeContext object_context{node.references, node.summary, count, node.summary.bounds.area(), Split{}};
    const Split object = ObjectSweepSplitFinder{}.find(object_context, CostModel{});
    ASSERT_TRUE(object.is_valid());
    EXPECT_TRUE(every_plane(finder, node, count, object).empty());
    EXPECT_FALSE(every_plane(finder, node, count, Split{}).empty());
    EXPECT_FALSE(every_plane(finder, node, count + 1, object).empty());
    EXPECT_TRUE(every_plane(finder, node, count, object, /*must_split=*/true).empty());  // it pays: still skipped
    Split losing = object;
    losing.cost = CostModel{}.leaf_cost(count);  // no better than a leaf
    EXPECT_TRUE(every_plane(finder, node, count, losing, /*must_split=*/false).empty());
    EXPECT_FALSE(every_plane(finder, node, count, losing, /*must_split=*/true).empty());
}

// The alpha gate (--spatial-gate): alpha = 1 asks for an object overlap of the whole root's area,
// which no split has, so spatial planes remain only where the node must be split and no object
// split beats a leaf (a few); 0 searches them everywhere. Absurd values are refused.
TEST(BinnedSpatial, GateAlphaOptionControlsTheSpatialSearch) {
    const Scene& scene = testing_support::cached_builtin_scene("interior");
    BuildConfig options = config_for("spatial");
    const size_t by_default = spacebvh::build(scene, options).primitives.size();
    options.spatial.gate_alpha = 0.0f;
    const size_t ungated = spacebvh::build(scene, options).primitives.size();
    options.spatial.gate_alpha = 1.0f;
    const size_t gated = spacebvh::build(scene, options).primitives.size();
    EXPECT_GT(by_default, scene.triangles.size());
    EXPECT_LE(by_default, ungated);
    EXPECT_LT(gated, scene.triangles.size() + (ungated - scene.triangles.size()) / 4) << gated << " " << ungated;
    for (float absurd : {2.0f, kInfinity, std::numeric_limits<float>::quiet_NaN()}) {
        options.spatial.gate_alpha = absurd;
        EXPECT_THROW(spacebvh::build(scene, options), Error) << absurd;
    }
}

}  // namespace
}  // namespace spacebvh::builders
