// SPDX-License-Identifier: MIT
// The grid search space (src/builders/search_spaces/grid_split_finder.hpp): its containment counts and its best
// configuration against brute force on every configuration of random small nodes, its relation to
// the object sweep and the kd (spatial) planes where its search space contains theirs, and the
// composable search spaces (--search) and `full` preset.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "builders/search_spaces/binned_spatial_split_finder.hpp"
#include "builders/search_spaces/grid_split_finder.hpp"
#include "builders/search_spaces/object_sweep_split_finder.hpp"
#include "builders/driver/partition.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/build.hpp"
#include "spacebvh/error.hpp"
#include "test_support.hpp"

namespace spacebvh::builders {

using namespace spacebvh::tools;
namespace {

using Node = testing_support::SmallNode;
using testing_support::small_node;

// Random triangles in [0, 10]^3; some flat on an axis (walls), some tiny, some long.
Node random_node(std::mt19937& random, uint32_t count) {
    std::uniform_real_distribution<float> coordinate(0.0f, 10.0f), size(0.05f, 6.0f);
    std::vector<Triangle> triangles;
    for (uint32_t i = 0; i < count; ++i) {
        const Vec3 center{coordinate(random), coordinate(random), coordinate(random)};
        const float s = size(random);
        auto offset = [&] {
            return Vec3{s * (coordinate(random) / 10 - 0.5f), s * (coordinate(random) / 10 - 0.5f),
                        s * (coordinate(random) / 10 - 0.5f)};
        };
        Triangle t{center + offset(), center + offset(), center + offset()};
        if (i % 4 == 3) {
            const int flat = int(i / 4 % 3);  // axis-aligned: a wall
            t.v1[flat] = t.v0[flat];
            t.v2[flat] = t.v0[flat];
        }
        triangles.push_back(t);
    }
    return small_node(std::move(triangles));
}

// Triangles with integer vertices in [0, cells]^3, plus two that pin the node box to exactly that
// cube, so every coordinate lies on a grid line of a `cells`-grid over the node.
Node grid_aligned_node(std::mt19937& random, uint32_t count, uint32_t cells) {
    std::uniform_int_distribution<int> coordinate(0, int(cells));
    const float g = float(cells);
    std::vector<Triangle> triangles = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{g, g, g}, {g - 1, g, g}, {g, g - 1, g}}};
    for (uint32_t i = 0; i < count; ++i) {
        auto point = [&] {
            return Vec3{float(coordinate(random)), float(coordinate(random)), float(coordinate(random))};
        };
        triangles.push_back({point(), point(), point()});
    }
    return small_node(std::move(triangles));
}

// The per-axis interval pairs that inherit both faces of the node on that axis, enumerated here
// independently of the finder.
struct Interval {
    uint8_t lo, hi;
};
std::vector<std::pair<Interval, Interval>> inheriting_pairs(uint32_t last) {
    std::vector<std::pair<Interval, Interval>> pairs;
    for (uint32_t a = 0; a <= last; ++a)
        for (uint32_t b = a; b <= last; ++b)
            for (uint32_t c = 0; c <= last; ++c)
                for (uint32_t d = c; d <= last; ++d)
                    if ((a == 0 || c == 0) && (b == last || d == last))
                        pairs.push_back({{uint8_t(a), uint8_t(b)}, {uint8_t(c), uint8_t(d)}});
    return pairs;
}

template <typename Visit>
void for_each_configuration(const ContainmentGrid& grid, Visit visit) {
    const auto x = inheriting_pairs(grid.cells(0)), y = inheriting_pairs(grid.cells(1)),
               z = inheriting_pairs(grid.cells(2));
    for (const auto& px : x)
        for (const auto& py : y)
            for (const auto& pz : z) {
                GridConfiguration c;
                c.left.lo = {px.first.lo, py.first.lo, pz.first.lo};
                c.left.hi = {px.first.hi, py.first.hi, pz.first.hi};
                c.right.lo = {px.second.lo, py.second.lo, pz.second.lo};
                c.right.hi = {px.second.hi, py.second.hi, pz.second.hi};
                visit(c);
            }
}

// The assignment by direct containment tests on every reference (no table).
struct BruteCounts {
    uint32_t left = 0, right = 0, neither = 0;
};
BruteCounts brute_counts(const ContainmentGrid& grid, const GridConfiguration& c,
                         std::span<const Reference> references) {
    const AABB left = grid.box(c.left), right = grid.box(c.right);
    BruteCounts counts;
    for (const Reference& reference : references) {
        const bool in_left = left.contains(reference.bounds), in_right = right.contains(reference.bounds);
        if (in_left && in_right)
            (left.area() <= right.area() ? counts.left : counts.right)++;
        else if (in_left)
            counts.left++;
        else if (in_right)
            counts.right++;
        else
            counts.left++, counts.right++, counts.neither++;
    }
    return counts;
}

TEST(GridSearch, CellsFollowTheRuleWithinTheCap) {
    GridSearchOptions options;
    options.resolution = 2.0f;
    options.max_cells = 8;
    EXPECT_EQ(grid_cells_for(1, options), 2u);
    EXPECT_EQ(grid_cells_for(64, options), 4u);    // 2 * 64^(1/6) = 4
    EXPECT_EQ(grid_cells_for(729, options), 6u);   // 2 * 3
    EXPECT_EQ(grid_cells_for(4096, options), 8u);  // 2 * 4 = 8, the cap
    EXPECT_EQ(grid_cells_for(1000000, options), 8u);
    options.resolution = 1.0f;
    EXPECT_EQ(grid_cells_for(4096, options), 4u);
    EXPECT_EQ(grid_cells_for(4097, options), 5u);  // the ceiling
}

// Every grid box's containment count equals a direct count, and every configuration's forced
// assignment (table + inclusion-exclusion) equals the assignment by direct containment tests.
TEST(GridSearch, CountsEqualBruteForceForEveryConfiguration) {
    std::mt19937 random(11);
    size_t configurations = 0;
    for (int trial = 0; trial < 12; ++trial) {
        const Node node = random_node(random, 4 + trial);
        const uint32_t cells = 2 + trial % 3;
        const ContainmentGrid grid(node.references, node.summary.bounds, cells);
        ASSERT_EQ(grid.cells(0), cells);
        for (uint32_t l0 = 0; l0 <= cells; ++l0)
            for (uint32_t h0 = l0; h0 <= cells; ++h0)
                for (uint32_t l1 = 0; l1 <= cells; ++l1)
                    for (uint32_t h1 = l1; h1 <= cells; ++h1)
                        for (uint32_t l2 = 0; l2 <= cells; ++l2)
                            for (uint32_t h2 = l2; h2 <= cells; ++h2) {
                                GridBox b;
                                b.lo = {uint8_t(l0), uint8_t(l1), uint8_t(l2)};
                                b.hi = {uint8_t(h0), uint8_t(h1), uint8_t(h2)};
                                const AABB box = grid.box(b);
                                const auto direct =
                                    std::count_if(node.references.begin(), node.references.end(),
                                                  [&](const Reference& r) { return box.contains(r.bounds); });
                                ASSERT_EQ(grid.contained(b), uint32_t(direct)) << "trial " << trial;
                            }
        for_each_configuration(grid, [&](const GridConfiguration& c) {
            ASSERT_TRUE(inherits_every_face(grid, c));
            const GridCounts table = count_assignment(grid, c, uint32_t(node.references.size()));
            const BruteCounts brute = brute_counts(grid, c, node.references);
            ASSERT_EQ(table.left, brute.left);
            ASSERT_EQ(table.right, brute.right);
            ASSERT_EQ(table.clipped, brute.neither);
            ++configurations;
        });
    }
    EXPECT_GT(configurations, 100000u);
}

// The search returns the minimum over every configuration of the cost with grid boxes, with the
// feasibility rules (splitting only where the children cover the node, within the spare capacity).
TEST(GridSearch, BestConfigurationEqualsBruteForceMinimum) {
    std::mt19937 random(5);
    for (int trial = 0; trial < 18; ++trial) {
        const Node node = random_node(random, 5 + trial % 9);
        const uint32_t count = uint32_t(node.references.size());
        const ContainmentGrid grid(node.references, node.summary.bounds, 2 + trial % 3);
        CostModel cost;
        cost.overlap_penalty = std::array{0.0f, 0.7f, kInfinity}[trial % 3];
        const bool split = trial % 2 == 0;
        const size_t spare = trial % 4 < 2 ? count : 1;
        float minimum = kInfinity;
        for_each_configuration(grid, [&](const GridConfiguration& c) {
            const BruteCounts counts = brute_counts(grid, c, node.references);
            if (counts.neither > 0 && (!split || !covers_node(grid, c) || counts.neither > spare)) return;
            if (counts.left == 0 || counts.right == 0) return;
            minimum = std::min(minimum, cost.split_cost(node.summary.bounds, grid.box(c.left), counts.left,
                                                        grid.box(c.right), counts.right));
        });
        const GridSearchResult result = search_grid(grid, node.summary.bounds, count, spare, cost, split);
        ASSERT_EQ(result.found, minimum < kInfinity) << "trial " << trial;
        if (result.found) {
            EXPECT_EQ(result.cost, minimum) << "trial " << trial;
            // The reported configuration is one of the search space with exactly that cost.
            EXPECT_TRUE(inherits_every_face(grid, result.configuration));
            const GridCounts counts = count_assignment(grid, result.configuration, count);
            EXPECT_EQ(cost.split_cost(node.summary.bounds, grid.box(result.configuration.left), counts.left,
                                      grid.box(result.configuration.right), counts.right),
                      result.cost);
        }
    }
}

Split find_with(const SplitFinder& finder, Node& node, const CostModel& cost, size_t capacity) {
    const Split none;
    const NodeContext context{node.references, node.summary, capacity, node.summary.bounds.area(), none};
    return finder.find(context, cost);
}

// When every coordinate lies on the grid, every object partition is a grid configuration: its
// children's tight boxes are grid boxes, and together they inherit every face of the node (their
// union is the node box). The grid's forced assignment for those boxes is at least as cheap, and the
// finder's cost only drops when it tightens the boxes, so the grid never loses to the object sweep.
// (Excluded: a partition whose two children have the same box, which the grid sees as one child.)
TEST(GridSearch, NeverWorseThanTheObjectSweepWhenCoordinatesLieOnTheGrid) {
    std::mt19937 random(3);
    int compared = 0, strictly_better = 0;
    for (int trial = 0; trial < 40; ++trial) {
        const uint32_t cells = 4 + trial % 2 * 2;
        Node node = grid_aligned_node(random, 4 + trial % 10, cells);
        CostModel cost;
        cost.overlap_penalty = std::array{0.0f, 1.0f, kInfinity}[trial % 3];
        const Split object = find_with(ObjectSweepSplitFinder{}, node, cost, node.references.size());
        if (!object.is_valid() || object.left_bounds == object.right_bounds) continue;
        GridSearchOptions options;
        options.resolution = 64.0f;
        options.max_cells = cells;
        options.split_primitives = trial % 2 == 0;
        const Split grid = find_with(GridSplitFinder(node.triangles, options), node, cost, node.references.size());
        ASSERT_TRUE(grid.is_valid()) << "trial " << trial;
        EXPECT_LE(grid.cost, object.cost) << "trial " << trial;
        ++compared;
        strictly_better += grid.cost < object.cost;
    }
    EXPECT_GE(compared, 25);
    EXPECT_GT(strictly_better, 0) << "the grid's search space is strictly larger";
}

// Frame triangles make every kd plane's children fill their half of the node: for each axis, one
// triangle holds a full face at the axis' minimum and one at its maximum, so clipped at any plane
// the two children's tight boxes are exactly the two halves of the node box. Then the grid's kd
// configurations (full on two axes, [0, p] and [p, G] on the third) are the spatial splits with the
// same boxes and at most the same counts (the grid sends a reference touching the plane to one side;
// the binned spatial finder counts it on both), so with splitting and enough capacity the grid never
// loses to the spatial planes on the same grid.
TEST(GridSearch, NeverWorseThanSpatialPlanesOnTheSameGridWhenChildrenFillTheirHalves) {
    std::mt19937 random(9);
    const uint32_t cells = 8;
    const float g = float(cells);
    int compared = 0;
    for (int trial = 0; trial < 16; ++trial) {
        std::vector<Triangle> triangles;
        for (int axis = 0; axis < 3; ++axis) {
            auto point = [&](float a, float b, float c) {
                Vec3 p;
                p[axis] = a;
                p[(axis + 1) % 3] = b;
                p[(axis + 2) % 3] = c;
                return p;
            };
            triangles.push_back({point(0, 0, 0), point(0, g, g), point(g, g, g)});
            triangles.push_back({point(g, 0, 0), point(g, g, g), point(0, 0, 0)});
        }
        std::uniform_real_distribution<float> coordinate(0.0f, g);
        for (int i = 0; i < 4 + trial % 8; ++i) {
            auto p = [&] { return Vec3{coordinate(random), coordinate(random), coordinate(random)}; };
            triangles.push_back({p(), p(), p()});
        }
        Node node = small_node(std::move(triangles));
        ASSERT_EQ(node.summary.bounds, (AABB{{0, 0, 0}, {g, g, g}}));
        CostModel cost;
        cost.overlap_penalty = trial % 2 ? kInfinity : 0.0f;
        SpatialSearchOptions spatial;
        spatial.bins = trial % 3 == 0 ? cells / 2 : cells;
        const size_t capacity = 4 * node.references.size();
        const Split plane = find_with(BinnedSpatialSplitFinder(node.triangles, spatial), node, cost, capacity);
        GridSearchOptions options;
        options.resolution = 64.0f;
        options.max_cells = cells;
        const Split grid = find_with(GridSplitFinder(node.triangles, options), node, cost, capacity);
        ASSERT_TRUE(plane.is_valid());
        ASSERT_TRUE(grid.is_valid());
        EXPECT_LE(grid.cost, plane.cost) << "trial " << trial;
        ++compared;
    }
    EXPECT_EQ(compared, 16);
}

// apply_split gives the children exactly the references the finder counted, within the capacity,
// with every clipped piece inside its child box, and the children's boxes are the finder's.
TEST(GridSearch, ApplySplitReproducesTheFinderCounts) {
    std::mt19937 random(21);
    int clipped_splits = 0;
    for (int trial = 0; trial < 60; ++trial) {
        Node node = random_node(random, 6 + trial % 20);
        CostModel cost;
        cost.overlap_penalty = std::array{0.0f, 1.0f, kInfinity}[trial % 3];
        GridSearchOptions options;
        options.resolution = 3.0f;
        const size_t capacity = node.references.size() + trial % 5;
        const Split split = find_with(GridSplitFinder(node.triangles, options), node, cost, capacity);
        if (!split.is_valid()) continue;
        ASSERT_EQ(split.kind, SplitKind::grid);
        std::vector<Reference> storage = node.references;
        storage.resize(capacity);
        const ChildRanges ranges = apply_split(storage, uint32_t(node.references.size()), split, node.triangles);
        EXPECT_EQ(ranges.left_count, split.left_count) << "trial " << trial;
        EXPECT_EQ(ranges.right_count, split.right_count) << "trial " << trial;
        EXPECT_LE(ranges.left_capacity + ranges.right_capacity, capacity);
        const ReferenceSummary left = summarize({storage.data(), ranges.left_count});
        const ReferenceSummary right = summarize({storage.data() + ranges.left_capacity, ranges.right_count});
        EXPECT_EQ(left.bounds, split.left_bounds);
        EXPECT_EQ(right.bounds, split.right_bounds);
        EXPECT_TRUE(split.left_region.contains(left.bounds));
        EXPECT_TRUE(split.right_region.contains(right.bounds));
        EXPECT_LE(split.cost, cost.split_cost(node.summary.bounds, split.left_region, split.left_count,
                                              split.right_region, split.right_count));
        clipped_splits += ranges.left_count + ranges.right_count > node.references.size();
    }
    EXPECT_GT(clipped_splits, 0) << "some chosen splits should clip references";
}

TEST(SearchSpaces, ParseNamesAndRejectUnknownOnes) {
    EXPECT_EQ(parse_search_spaces("object,spatial,grid"),
              SearchSpace::object_sweep | SearchSpace::spatial_binned | SearchSpace::grid);
    EXPECT_EQ(parse_search_spaces("object+grid"), SearchSpace::object_sweep | SearchSpace::grid);
    EXPECT_EQ(parse_search_spaces("binned"), uint32_t(SearchSpace::object_binned));
    EXPECT_EQ(search_space_names(parse_search_spaces("grid,object")), "object+grid");
    EXPECT_THROW(parse_search_spaces("object,kd"), Error);
    EXPECT_THROW(parse_search_spaces(""), Error);
    BuildConfig options = config_for("cbvh");
    options.search_spaces = 1u << 9;
    EXPECT_THROW(options.validate(), Error);
    options = config_for("full");
    EXPECT_EQ(options.cost.overlap_penalty, kInfinity);
    options.grid.max_cells = 17;
    EXPECT_THROW(options.validate(), Error);
    options.grid.max_cells = 8;
    options.grid.resolution = 0.0f;
    EXPECT_THROW(options.validate(), Error);
}

// Any union of search spaces with any C_o builds a tree that lists every triangle within the budget
// (--search on a preset replaces its search spaces).
TEST(SearchSpaces, AnyUnionBuildsAValidTreeWithAnyOverlapPenalty) {
    const Scene& scene = testing_support::cached_builtin_scene("soup");
    Scene small = scene;
    small.triangles.resize(3000);
    for (const char* spaces : {"grid", "object,grid", "binned,spatial,grid", "spatial,grid"})
        for (float overlap_penalty : {0.0f, 1.0f, kInfinity}) {
            BuildConfig options = config_for("cbvh");
            options.search_spaces = parse_search_spaces(spaces);
            options.cost.overlap_penalty = overlap_penalty;
            const Bvh bvh = spacebvh::build(small, options);
            std::vector<uint8_t> seen(small.triangles.size(), 0);
            for (uint32_t id : bvh.primitives) seen[id] = 1;
            EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), ptrdiff_t(small.triangles.size())) << spaces;
            EXPECT_LE(bvh.primitives.size(), size_t(1.3 * small.triangles.size())) << spaces;
        }
}

}  // namespace
}  // namespace spacebvh::builders
