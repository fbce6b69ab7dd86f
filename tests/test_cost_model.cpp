// SPDX-License-Identifier: MIT
// The cost model of include/spacebvh/cost_model.hpp: the split cost formula with its overlap penalty
// (Popov et al. 2009), the overlap fraction for solid and flat nodes, validation and the description.
#include <gtest/gtest.h>

#include <immintrin.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "builders/driver/simd_box.hpp"
#include "spacebvh/cost_model.hpp"
#include "spacebvh/error.hpp"

using namespace spacebvh;

namespace {

AABB box(Vec3 lo, Vec3 hi) { return {lo, hi}; }

CostModel model(float c_t, float c_i, float c_o) {
    CostModel cost;
    cost.traversal_cost = c_t;
    cost.intersection_cost = c_i;
    cost.overlap_penalty = c_o;
    return cost;
}

// N = [0,4]x[0,2]x[0,2]: SA 40, V 16.
const AABB kNode = box({0, 0, 0}, {4, 2, 2});
// Touching halves: L = [0,2]x.., R = [2,4]x..: SA 24 each.
const AABB kLeftHalf = box({0, 0, 0}, {2, 2, 2});
const AABB kRightHalf = box({2, 0, 0}, {4, 2, 2});
// Overlapping: L = [0,3]x.., R = [1,4]x..: SA 32 each, L ∩ R = [1,3]x[0,2]x[0,2], V 8 (half of N).
const AABB kLeftWide = box({0, 0, 0}, {3, 2, 2});
const AABB kRightWide = box({1, 0, 0}, {4, 2, 2});

}  // namespace

// The box areas and volumes the hand computations below rely on.
TEST(CostModel, HandComputedBoxesHaveTheExpectedAreaAndVolume) {
    EXPECT_EQ(kNode.area(), 40.0f);
    EXPECT_EQ(kNode.volume(), 16.0f);
    EXPECT_EQ(kLeftHalf.area(), 24.0f);
    EXPECT_EQ(kLeftWide.area(), 32.0f);
    EXPECT_EQ(AABB::empty().area(), 0.0f);
    EXPECT_EQ(AABB::empty().volume(), 0.0f);
}

// cost = C_T + C_I * (SA(L)|L| + SA(R)|R|) / SA(N) when the children do not overlap.
TEST(CostModel, SplitCostMatchesTheFormulaForTouchingChildren) {
    // 1.5 + 2 * (24*3 + 24*5) / 40 = 1.5 + 9.6
    EXPECT_FLOAT_EQ(model(1.5f, 2.0f, 0.0f).split_cost(kNode, kLeftHalf, 3, kRightHalf, 5), 11.1f);
    // The overlap penalty plays no part when the children only touch.
    EXPECT_FLOAT_EQ(model(1.5f, 2.0f, 7.0f).split_cost(kNode, kLeftHalf, 3, kRightHalf, 5), 11.1f);
    // Default model C_T = C_I = 1: 1 + (24 + 24*3) / 40.
    EXPECT_FLOAT_EQ(CostModel{}.split_cost(kNode, kLeftHalf, 1, kRightHalf, 3), 1.0f + 96.0f / 40.0f);
    // C_T = 0 leaves only the intersection term.
    EXPECT_FLOAT_EQ(model(0.0f, 1.0f, 0.0f).split_cost(kNode, kLeftHalf, 2, kRightHalf, 2), 96.0f / 40.0f);
}

// cost = C_T + (1 + C_o * V(L∩R)/V(N)) * C_I * (SA(L)|L| + SA(R)|R|) / SA(N) for overlapping children.
TEST(CostModel, SplitCostMatchesTheFormulaForOverlappingChildren) {
    // Area term: 2 * (32*3 + 32*5) / 40 = 12.8; overlap fraction 0.5.
    EXPECT_FLOAT_EQ(model(1.5f, 2.0f, 2.0f).split_cost(kNode, kLeftWide, 3, kRightWide, 5), 1.5f + 2.0f * 12.8f);
    EXPECT_FLOAT_EQ(model(1.5f, 2.0f, 0.5f).split_cost(kNode, kLeftWide, 3, kRightWide, 5), 1.5f + 1.25f * 12.8f);
    // Identical children: the overlap is the whole node, factor 1 + C_o.
    EXPECT_FLOAT_EQ(model(1.0f, 1.0f, 3.0f).split_cost(kNode, kNode, 1, kNode, 1), 1.0f + 4.0f * 2.0f);
}

// C_o = 0 is plain SAH: overlap costs nothing extra.
TEST(CostModel, ZeroOverlapPenaltyIsPlainSah) {
    const CostModel sah = model(1.25f, 3.0f, 0.0f);
    EXPECT_FLOAT_EQ(sah.split_cost(kNode, kLeftWide, 3, kRightWide, 5), 1.25f + 3.0f * (32.0f * 8.0f) / 40.0f);
    EXPECT_FLOAT_EQ(sah.split_cost(kNode, kNode, 4, kNode, 4), 1.25f + 3.0f * 8.0f);
}

// C_o = inf: overlapping children are infeasible (+inf); touching, disjoint or empty ones stay finite.
TEST(CostModel, InfiniteOverlapPenaltyForbidsOverlapOnly) {
    const CostModel disjoint_only = model(1.0f, 1.0f, kInfinity);
    EXPECT_EQ(disjoint_only.split_cost(kNode, kLeftWide, 3, kRightWide, 5), kInfinity);
    EXPECT_EQ(disjoint_only.split_cost(kNode, kNode, 1, kNode, 1), kInfinity);
    // A sliver of overlap is still overlap.
    const AABB barely = box({1.99f, 0, 0}, {4, 2, 2});
    EXPECT_EQ(disjoint_only.split_cost(kNode, kLeftHalf, 3, barely, 5), kInfinity);

    const float touching = disjoint_only.split_cost(kNode, kLeftHalf, 3, kRightHalf, 5);
    EXPECT_TRUE(std::isfinite(touching));
    EXPECT_FLOAT_EQ(touching, 1.0f + (24.0f * 3 + 24.0f * 5) / 40.0f);
    const AABB left_gap = box({0, 0, 0}, {1, 2, 2}), right_gap = box({3, 0, 0}, {4, 2, 2});  // SA 16 each
    EXPECT_FLOAT_EQ(disjoint_only.split_cost(kNode, left_gap, 2, right_gap, 2), 1.0f + (16.0f * 4) / 40.0f);
    // Boxes that overlap in x and y but are separated in z are disjoint.
    const AABB low = box({0, 0, 0}, {4, 2, 0.5f}), high = box({0, 0, 1.5f}, {4, 2, 2});
    EXPECT_TRUE(std::isfinite(disjoint_only.split_cost(kNode, low, 1, high, 1)));
    // An empty child never overlaps.
    EXPECT_TRUE(std::isfinite(disjoint_only.split_cost(kNode, kNode, 4, AABB::empty(), 0)));
    // Children that touch at a corner only.
    const AABB corner_a = box({0, 0, 0}, {2, 1, 1}), corner_b = box({2, 1, 1}, {4, 2, 2});
    EXPECT_TRUE(std::isfinite(disjoint_only.split_cost(kNode, corner_a, 1, corner_b, 1)));
}

// For a node of positive volume the overlap fraction is V(L ∩ R) / V(N).
TEST(CostModel, OverlapFractionIsTheVolumeRatioForSolidNodes) {
    EXPECT_FLOAT_EQ(overlap_fraction(kNode, kLeftWide, kRightWide), 0.5f);
    EXPECT_FLOAT_EQ(overlap_fraction(kNode, kNode, kNode), 1.0f);
    EXPECT_EQ(overlap_fraction(kNode, kLeftHalf, kRightHalf), 0.0f);                                 // touching
    EXPECT_EQ(overlap_fraction(kNode, box({0, 0, 0}, {1, 1, 1}), box({3, 1, 1}, {4, 2, 2})), 0.0f);  // disjoint
    EXPECT_EQ(overlap_fraction(kNode, AABB::empty(), kNode), 0.0f);
    EXPECT_EQ(overlap_fraction(kNode, kNode, AABB::empty()), 0.0f);
    // Overlap on all three axes: [1,2]x[0.5,1.5]x[1,2] = 1 of 16.
    EXPECT_FLOAT_EQ(overlap_fraction(kNode, box({0, 0, 0}, {2, 1.5f, 2}), box({1, 0.5f, 1}, {4, 2, 2})), 1.0f / 16.0f);
    // Compare with the volume of the intersection on a few irregular boxes.
    const AABB node = box({-1.5f, 0.25f, 2}, {3.5f, 4.25f, 2.5f});
    const AABB left = box({-1.5f, 0.25f, 2}, {1.0f, 3.0f, 2.5f}), right = box({0.0f, 1.0f, 2.25f}, {3.5f, 4.25f, 2.5f});
    const float expected = intersect(left, right).volume() / node.volume();
    EXPECT_NEAR(overlap_fraction(node, left, right), expected, 1e-6f);
    EXPECT_GT(expected, 0.0f);
}

// A flat node (V(N) = 0, all triangles in a plane) measures overlap by area in its plane.
TEST(CostModel, OverlapFractionOfAFlatNodeIsTheAreaRatioInItsPlane) {
    const AABB plane = box({0, 0, 1}, {4, 2, 1});  // z = 1
    ASSERT_EQ(plane.volume(), 0.0f);
    // L ∩ R = [1,3]x[0,2]: area 4 of 8.
    EXPECT_FLOAT_EQ(overlap_fraction(plane, box({0, 0, 1}, {3, 2, 1}), box({1, 0, 1}, {4, 2, 1})), 0.5f);
    // [1,3]x[1,2]: 2 of 8.
    EXPECT_FLOAT_EQ(overlap_fraction(plane, box({0, 0, 1}, {3, 2, 1}), box({1, 1, 1}, {4, 2, 1})), 0.25f);
    // Touching along a line: no overlap.
    EXPECT_EQ(overlap_fraction(plane, box({0, 0, 1}, {2, 2, 1}), box({2, 0, 1}, {4, 2, 1})), 0.0f);
    // The flat axis may be any of the three.
    const AABB wall = box({5, -1, 0}, {5, 1, 4});  // x = 5, area 8
    EXPECT_FLOAT_EQ(overlap_fraction(wall, box({5, -1, 0}, {5, 1, 3}), box({5, 0, 1}, {5, 1, 4})), 2.0f / 8.0f);
    // A line of primitives: the length ratio.
    const AABB line = box({0, 0, 0}, {0, 0, 10});
    EXPECT_FLOAT_EQ(overlap_fraction(line, box({0, 0, 0}, {0, 0, 6}), box({0, 0, 4}, {0, 0, 10})), 0.2f);

    // The penalty therefore applies inside planar nodes: SA(N) = 16, SA(L) = 12, SA(R) = 12.
    const CostModel penalised = model(1.0f, 1.0f, 1.0f);
    const float cost = penalised.split_cost(plane, box({0, 0, 1}, {3, 2, 1}), 1, box({1, 0, 1}, {4, 2, 1}), 1);
    EXPECT_FLOAT_EQ(cost, 1.0f + 1.5f * (12.0f + 12.0f) / 16.0f);
    EXPECT_EQ(
        model(1.0f, 1.0f, kInfinity).split_cost(plane, box({0, 0, 1}, {3, 2, 1}), 1, box({1, 0, 1}, {4, 2, 1}), 1),
        kInfinity);
    EXPECT_TRUE(std::isfinite(
        model(1.0f, 1.0f, kInfinity).split_cost(plane, box({0, 0, 1}, {2, 2, 1}), 1, box({2, 0, 1}, {4, 2, 1}), 1)));
}

// SA(N) = 0 (a point or a line of primitives): each reference costs one test, so splitting never pays.
TEST(CostModel, ZeroAreaNodeCountsOneTestPerReference) {
    const CostModel cost = model(1.5f, 2.0f, 0.0f);
    const AABB line = box({0, 0, 0}, {4, 0, 0});
    ASSERT_EQ(line.area(), 0.0f);
    const float split = cost.split_cost(line, box({0, 0, 0}, {2, 0, 0}), 3, box({2, 0, 0}, {4, 0, 0}), 5);
    EXPECT_FLOAT_EQ(split, 1.5f + 2.0f * 8.0f);
    EXPECT_GT(split, cost.leaf_cost(8));
    const AABB point = AABB::of_point({1, 2, 3});
    const float point_split = cost.split_cost(point, point, 2, point, 2);
    EXPECT_TRUE(std::isfinite(point_split));
    EXPECT_GE(point_split, 1.5f + 2.0f * 4.0f);
    EXPECT_GT(point_split, cost.leaf_cost(4));
    // Never NaN, whatever the children.
    EXPECT_FALSE(std::isnan(cost.split_cost(line, AABB::empty(), 0, line, 8)));
}

// Leaf cost is C_I * |N|.
TEST(CostModel, LeafCostIsIntersectionCostTimesCount) {
    EXPECT_EQ(model(1.0f, 2.5f, 0.0f).leaf_cost(4), 10.0f);
    EXPECT_EQ(CostModel{}.leaf_cost(0), 0.0f);
    EXPECT_EQ(CostModel{}.leaf_cost(7), 7.0f);
}

// validate() accepts sensible constants (C_o may be inf) and rejects negative, NaN, infinite C_T/C_I and C_I = 0.
TEST(CostModel, ValidateRejectsAbsurdConstants) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    EXPECT_NO_THROW(CostModel{}.validate());
    EXPECT_NO_THROW(model(0.0f, 1.0f, 0.0f).validate());  // C_T = 0 is allowed
    EXPECT_NO_THROW(model(1.0f, 0.5f, kInfinity).validate());
    EXPECT_NO_THROW(model(2.0f, 3.0f, 10.0f).validate());

    EXPECT_THROW(model(-1.0f, 1.0f, 0.0f).validate(), Error);
    EXPECT_THROW(model(1.0f, -1.0f, 0.0f).validate(), Error);
    EXPECT_THROW(model(1.0f, 1.0f, -0.5f).validate(), Error);
    EXPECT_THROW(model(nan, 1.0f, 0.0f).validate(), Error);
    EXPECT_THROW(model(1.0f, nan, 0.0f).validate(), Error);
    EXPECT_THROW(model(1.0f, 1.0f, nan).validate(), Error);
    EXPECT_THROW(model(1.0f, 0.0f, 0.0f).validate(), Error);
    EXPECT_THROW(model(kInfinity, 1.0f, 0.0f).validate(), Error);
    EXPECT_THROW(model(1.0f, kInfinity, 0.0f).validate(), Error);
    EXPECT_THROW(model(1.0f, 1.0f, -kInfinity).validate(), Error);

    // The message names the offending constant.
    try {
        model(1.0f, 1.0f, -2.0f).validate();
        FAIL() << "no exception";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("C_o"), std::string::npos) << e.what();
    }
    try {
        model(1.0f, 0.0f, 0.0f).validate();
        FAIL() << "no exception";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("C_I"), std::string::npos) << e.what();
    }
}

// describe() prints the three constants in the documented form.
TEST(CostModel, DescribePrintsTheConstants) {
    EXPECT_EQ(CostModel{}.describe(), "C_T=1 C_I=1 C_o=0");
    EXPECT_EQ(model(0.5f, 2.0f, 1.5f).describe(), "C_T=0.5 C_I=2 C_o=1.5");
    EXPECT_EQ(model(1.0f, 1.0f, kInfinity).describe(), "C_T=1 C_I=1 C_o=inf");
}

// A leaf block B counts references in whole blocks of B (rounded up) in the leaf cost and both
// children of the split cost; B = 1 is the plain SAH; B must be a power of two in [1, 64].
TEST(CostModel, LeafBlocksRoundReferenceCountsUp) {
    CostModel blocks = model(1.5f, 2.0f, 0.0f);
    blocks.leaf_block = 4;
    EXPECT_EQ(blocks.leaf_cost(0), 0.0f);
    EXPECT_EQ(blocks.leaf_cost(1), 8.0f);  // one block of four: 2 * 4
    EXPECT_EQ(blocks.leaf_cost(4), 8.0f);
    EXPECT_EQ(blocks.leaf_cost(5), 16.0f);
    // 1.5 + 2 * (24*4 + 24*8) / 40: |L| = 3 counts as 4, |R| = 5 as 8.
    EXPECT_FLOAT_EQ(blocks.split_cost(kNode, kLeftHalf, 3, kRightHalf, 5),
                    1.5f + 2.0f * (24.0f * 4 + 24.0f * 8) / 40.0f);
    // The same counts in whole blocks cost what the plain SAH says.
    EXPECT_FLOAT_EQ(blocks.split_cost(kNode, kLeftHalf, 4, kRightHalf, 8),
                    model(1.5f, 2.0f, 0.0f).split_cost(kNode, kLeftHalf, 4, kRightHalf, 8));
    EXPECT_EQ(blocks.describe(), "C_T=1.5 C_I=2 C_o=0 B=4");
    for (uint32_t bad : {0u, 3u, 6u, 128u}) {
        blocks.leaf_block = bad;
        EXPECT_THROW(blocks.validate(), Error) << bad;
    }
    for (uint32_t good : {1u, 2u, 8u, 64u}) {
        blocks.leaf_block = good;
        EXPECT_NO_THROW(blocks.validate()) << good;
    }
}

// The object sweep prices cuts from SimdBox registers (src/builders/driver/simd_box.hpp): its extend, area and
// overlap fraction must give the AABB forms' results bit for bit, or the sweep would build other
// trees. Random boxes, partly on a coarse grid (so that touching, flat and equal coordinates, and -0
// against +0, occur), partly with full mantissas (so that rounding order shows), some empty.
TEST(CostModel, SimdBoxesPriceExactlyAsAabbs) {
    uint64_t state = 12345;
    auto next = [&]() {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return uint32_t(state >> 33);
    };
    auto coordinate = [&]() {
        const float values[] = {-2.5f, -1.0f, -0.0f, 0.0f, 0.75f, 1.0f, 3.0f, 1e-30f, 7.25f};
        switch (next() % 3) {
            case 0:
                return values[next() % 9];
            case 1:
                return float(int(next() % 2001) - 1000) / 64.0f;
            default:
                return float(next()) * 0x1p-25f - 50.0f;  // full mantissas: rounding matters
        }
    };
    auto random_box = [&]() {
        AABB box;
        if (next() % 10 == 0) return box;  // empty
        const Vec3 a{coordinate(), coordinate(), coordinate()}, b{coordinate(), coordinate(), coordinate()};
        box.extend(a);
        box.extend(b);
        return box;
    };
    auto same_bits = [](float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; };
    // Bounds as a sweep reads them: a Reference-like record (bounds, then 4 more readable bytes).
    struct Record {
        AABB bounds;
        uint32_t after = 0xffffffffu;  // a NaN pattern in the unused lane must not matter
    };
    int overlapping = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        const AABB node = merge(random_box(), random_box());
        AABB left, right;
        builders::SimdBox simd_left, simd_right;
        for (int k = 0; k < 3; ++k) {
            const Record a{random_box()}, b{random_box()};
            left.extend(a.bounds);
            simd_left.extend_as_aabb(a.bounds);
            right.extend(b.bounds);
            simd_right.extend_as_aabb(b.bounds);
        }
        const AABB back = simd_left.aabb();
        for (int axis = 0; axis < 3; ++axis) {
            ASSERT_TRUE(same_bits(back.lo[axis], left.lo[axis]) && same_bits(back.hi[axis], left.hi[axis])) << trial;
        }
        ASSERT_TRUE(same_bits(simd_left.area(), left.area())) << trial;
        ASSERT_TRUE(same_bits(simd_right.area(), right.area())) << trial;
        const __m128 node_extent = _mm_sub_ps(builders::simd(node.hi), builders::simd(node.lo));
        const float expected = overlap_fraction(node, left, right);
        ASSERT_TRUE(same_bits(builders::overlap_fraction(node_extent, simd_left, simd_right), expected) ||
                    (expected == 0.0f && builders::overlap_fraction(node_extent, simd_left, simd_right) == 0.0f))
            << trial;
        overlapping += expected > 0.0f;
        const CostModel cost = model(1.0f, 1.0f, 0.0f);
        ASSERT_TRUE(same_bits(cost.split_cost_of_areas(node.area(), simd_left.area(), 3, simd_right.area(), 5),
                              cost.split_cost(node, left, 3, right, 5)))
            << trial;
    }
    EXPECT_GT(overlapping, 1000);  // the overlap branch was exercised
}
