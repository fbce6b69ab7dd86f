// SPDX-License-Identifier: MIT
// Clipping of triangles against boxes and split planes (src/core/clip.cpp): the hand-checked cases,
// the robustness cases the spatial-split builders rely on, and randomized containment and area tests.
#include <gtest/gtest.h>

#include <random>

#include "spacebvh/clip.hpp"

namespace spacebvh {

namespace {

AABB box(Vec3 lo, Vec3 hi) { return {lo, hi}; }

// The right triangle (0,0,0), (4,0,0), (0,4,0): legs along x and y, hypotenuse x + y = 4, area 8.
const Triangle kRight{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}};

void expect_box_eq(const AABB& actual, const AABB& expected) {
    EXPECT_EQ(actual.lo, expected.lo) << "lo (" << actual.lo.x << ", " << actual.lo.y << ", " << actual.lo.z << ")";
    EXPECT_EQ(actual.hi, expected.hi) << "hi (" << actual.hi.x << ", " << actual.hi.y << ", " << actual.hi.z << ")";
}

TEST(Clip, TriangleFullyInsideKeepsItsBounds) {
    AABB b = box({-1, -1, -1}, {5, 5, 1});
    expect_box_eq(clip_triangle_bounds(kRight, b), kRight.bounds());
    EXPECT_DOUBLE_EQ(clipped_triangle_area(kRight, b), 8.0);
}

TEST(Clip, TriangleFullyOutsideIsEmpty) {
    EXPECT_TRUE(clip_triangle_bounds(kRight, box({5, 5, -1}, {6, 6, 1})).is_empty());
    // Overlapping bounds but no overlap with the triangle itself (beyond the hypotenuse).
    EXPECT_TRUE(clip_triangle_bounds(kRight, box({3, 3, -1}, {4, 4, 1})).is_empty());
    EXPECT_EQ(clipped_triangle_area(kRight, box({3, 3, -1}, {4, 4, 1})), 0.0);
    // Empty box.
    EXPECT_TRUE(clip_triangle_bounds(kRight, AABB::empty()).is_empty());
}

TEST(Clip, StraddlingOnePlane) {
    // x <= 1 keeps (0,0), (1,0), (1,3), (0,4).
    AABB b = box({-1, -1, -1}, {1, 10, 1});
    expect_box_eq(clip_triangle_bounds(kRight, b), box({0, 0, 0}, {1, 4, 0}));
    EXPECT_NEAR(clipped_triangle_area(kRight, b), 3.5, 1e-12);
}

TEST(Clip, StraddlingCorner) {
    // x >= 2, y >= 1, x + y <= 4: the small triangle (2,1), (3,1), (2,2).
    AABB b = box({2, 1, -1}, {5, 5, 1});
    expect_box_eq(clip_triangle_bounds(kRight, b), box({2, 1, 0}, {3, 2, 0}));
    EXPECT_NEAR(clipped_triangle_area(kRight, b), 0.5, 1e-12);
    // x <= 3 and y <= 3 cut two corners: area 8 - 0.5 - 0.5.
    AABB c = box({-1, -1, -1}, {3, 3, 1});
    expect_box_eq(clip_triangle_bounds(kRight, c), box({0, 0, 0}, {3, 3, 0}));
    EXPECT_NEAR(clipped_triangle_area(kRight, c), 7.0, 1e-12);
}

TEST(Clip, TriangleInBoxFaceIsInside) {
    // The triangle lies in z = 0, the lower and upper faces of these boxes: closed boxes keep it.
    expect_box_eq(clip_triangle_bounds(kRight, box({-1, -1, 0}, {5, 5, 1})), kRight.bounds());
    expect_box_eq(clip_triangle_bounds(kRight, box({-1, -1, -1}, {5, 5, 0})), kRight.bounds());
    EXPECT_DOUBLE_EQ(clipped_triangle_area(kRight, box({-1, -1, 0}, {5, 5, 1})), 8.0);
    // ... and clipped in the face.
    expect_box_eq(clip_triangle_bounds(kRight, box({-1, -1, 0}, {1, 10, 1})), box({0, 0, 0}, {1, 4, 0}));
}

TEST(Clip, TriangleInSplitPlaneGoesToBothSides) {
    AABB current = kRight.bounds();
    SplitBounds split = split_triangle_bounds(kRight, current, 2, 0.0f);
    expect_box_eq(split.left, kRight.bounds());
    expect_box_eq(split.right, kRight.bounds());
}

TEST(Clip, VertexOnPlane) {
    Triangle t{{1, 0, 0}, {2, 0, 0}, {2, 1, 0}};
    // Only the vertex (1,0,0) touches x <= 1.
    expect_box_eq(clip_triangle_bounds(t, box({-1, -1, -1}, {1, 1, 1})), box({1, 0, 0}, {1, 0, 0}));
    SplitBounds split = split_triangle_bounds(t, t.bounds(), 0, 1.0f);
    expect_box_eq(split.left, box({1, 0, 0}, {1, 0, 0}));
    expect_box_eq(split.right, t.bounds());
    // A plane through a vertex and the opposite edge: split at y = 0 keeps the edge on the left.
    SplitBounds at_edge = split_triangle_bounds(t, t.bounds(), 1, 0.0f);
    expect_box_eq(at_edge.left, box({1, 0, 0}, {2, 0, 0}));
    expect_box_eq(at_edge.right, t.bounds());
    // Split beyond the triangle: one side empty.
    SplitBounds outside = split_triangle_bounds(t, t.bounds(), 0, 3.0f);
    expect_box_eq(outside.left, t.bounds());
    EXPECT_TRUE(outside.right.is_empty());
}

TEST(Clip, FlatBox) {
    // The plane x = 1 cuts the triangle in the segment y in [0, 3].
    AABB flat = box({1, -10, -1}, {1, 10, 1});
    expect_box_eq(clip_triangle_bounds(kRight, flat), box({1, 0, 0}, {1, 3, 0}));
    EXPECT_EQ(clipped_triangle_area(kRight, flat), 0.0);
    // A box flat in two axes (a line segment) crossing the triangle.
    AABB line = box({1, 1, -1}, {1, 1, 1});
    expect_box_eq(clip_triangle_bounds(kRight, line), box({1, 1, 0}, {1, 1, 0}));
}

TEST(Clip, DegenerateTriangles) {
    // Collinear vertices: the segment from (0,0,0) to (4,4,0).
    Triangle segment{{0, 0, 0}, {4, 4, 0}, {2, 2, 0}};
    ASSERT_TRUE(segment.is_degenerate());
    expect_box_eq(clip_triangle_bounds(segment, box({1, -10, -1}, {3, 10, 1})), box({1, 1, 0}, {3, 3, 0}));
    EXPECT_EQ(clipped_triangle_area(segment, box({1, -10, -1}, {3, 10, 1})), 0.0);
    SplitBounds split = split_triangle_bounds(segment, segment.bounds(), 0, 1.0f);
    expect_box_eq(split.left, box({0, 0, 0}, {1, 1, 0}));
    expect_box_eq(split.right, box({1, 1, 0}, {4, 4, 0}));
    // A point.
    Triangle point{{1, 2, 3}, {1, 2, 3}, {1, 2, 3}};
    expect_box_eq(clip_triangle_bounds(point, box({0, 0, 0}, {1, 2, 3})), point.bounds());
    EXPECT_TRUE(clip_triangle_bounds(point, box({0, 0, 0}, {0.5f, 2, 3})).is_empty());
}

TEST(Clip, SplitRestrictsToCurrentBounds) {
    // The reference was already clipped to x <= 1; splitting at y = 2 sees only that piece.
    AABB current = box({0, 0, 0}, {1, 4, 0});
    SplitBounds split = split_triangle_bounds(kRight, current, 1, 2.0f);
    expect_box_eq(split.left, box({0, 0, 0}, {1, 2, 0}));
    expect_box_eq(split.right, box({0, 2, 0}, {1, 4, 0}));
    // Empty current bounds: nothing on either side.
    SplitBounds none = split_triangle_bounds(kRight, AABB::empty(), 0, 1.0f);
    EXPECT_TRUE(none.left.is_empty());
    EXPECT_TRUE(none.right.is_empty());
}

// Random triangle and box, sometimes with coordinates on a coarse grid so that vertices often lie
// exactly on box planes.
struct RandomCase {
    Triangle triangle;
    AABB box;
};

RandomCase random_case(std::mt19937& rng, bool grid) {
    std::uniform_real_distribution<float> coordinate(-10.0f, 10.0f);
    std::uniform_int_distribution<int> grid_coordinate(-4, 4);
    auto value = [&] { return grid ? float(grid_coordinate(rng)) : coordinate(rng); };
    RandomCase c;
    c.triangle = {{value(), value(), value()}, {value(), value(), value()}, {value(), value(), value()}};
    for (int axis = 0; axis < 3; ++axis) {
        float a = value(), b = value();
        c.box.lo[axis] = std::min(a, b);
        c.box.hi[axis] = std::max(a, b);
    }
    return c;
}

TEST(Clip, RandomResultsAreInsideBoxAndTriangleBoundsAndConservative) {
    std::mt19937 rng(12345);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (int i = 0; i < 10000; ++i) {
        RandomCase c = random_case(rng, i % 2 == 0);
        AABB clipped = clip_triangle_bounds(c.triangle, c.box);
        if (clipped.is_empty()) {
            EXPECT_EQ(clipped_triangle_area(c.triangle, c.box), 0.0);
        } else {
            ASSERT_TRUE(c.box.contains(clipped)) << "case " << i;
            ASSERT_TRUE(c.triangle.bounds().contains(clipped)) << "case " << i;
        }
        // Conservative: points of the triangle inside the box are inside the result (up to the
        // rounding of the sample point itself).
        for (int s = 0; s < 8; ++s) {
            float a = unit(rng), b = unit(rng);
            if (a + b > 1.0f) a = 1.0f - a, b = 1.0f - b;
            Vec3 p = c.triangle.v0 + (c.triangle.v1 - c.triangle.v0) * a + (c.triangle.v2 - c.triangle.v0) * b;
            if (!c.box.contains(p)) continue;
            ASSERT_FALSE(clipped.is_empty()) << "case " << i;
            for (int axis = 0; axis < 3; ++axis) {
                float tolerance = 1e-5f * (1.0f + std::abs(p[axis]));
                ASSERT_GE(p[axis], clipped.lo[axis] - tolerance) << "case " << i;
                ASSERT_LE(p[axis], clipped.hi[axis] + tolerance) << "case " << i;
            }
        }
        // Splitting the clipped reference: both sides inside it, and together they cover it.
        if (!clipped.is_empty()) {
            int axis = int(rng() % 3);
            float position = clipped.lo[axis] + unit(rng) * (clipped.hi[axis] - clipped.lo[axis]);
            SplitBounds split = split_triangle_bounds(c.triangle, clipped, axis, position);
            ASSERT_TRUE(clipped.contains(split.left)) << "case " << i;
            ASSERT_TRUE(clipped.contains(split.right)) << "case " << i;
            ASSERT_FALSE(split.left.is_empty() && split.right.is_empty()) << "case " << i;
            if (!split.left.is_empty()) {
                EXPECT_LE(split.left.hi[axis], position);
            }
            if (!split.right.is_empty()) {
                EXPECT_GE(split.right.lo[axis], position);
            }
            AABB both = merge(split.left, split.right);
            for (int k = 0; k < 3; ++k) {
                float tolerance = 1e-5f * (1.0f + std::abs(clipped.lo[k]) + std::abs(clipped.hi[k]));
                ASSERT_NEAR(both.lo[k], clipped.lo[k], tolerance) << "case " << i;
                ASSERT_NEAR(both.hi[k], clipped.hi[k], tolerance) << "case " << i;
            }
        }
    }
}

TEST(Clip, TouchingPointReferenceSurvivesSplits) {
    // The triangle meets the box only at (-1, 0.2, 0), on the box edge x = -1, z = 0. Re-clipping the
    // resulting flat reference must not lose it on both sides (found by the random test with FMA).
    Triangle t{{0, -2, 4}, {1, -1, -2}, {-4, 2, 3}};
    AABB clipped = clip_triangle_bounds(t, box({-3, -3, -4}, {-1, 2, 0}));
    ASSERT_FALSE(clipped.is_empty());
    for (float position : {clipped.lo.y, clipped.hi.y, 0.2f}) {
        SplitBounds split = split_triangle_bounds(t, clipped, 1, position);
        EXPECT_FALSE(split.left.is_empty() && split.right.is_empty()) << position;
    }
}

// A builder splits a reference again and again; on grid coordinates (many exact contacts with
// planes), the reference must never vanish from both sides and must stay inside its parent piece.
TEST(Clip, RepeatedSplitsNeverLoseTheReference) {
    std::mt19937 rng(4242);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (int i = 0; i < 3000; ++i) {
        RandomCase c = random_case(rng, true);
        AABB current = clip_triangle_bounds(c.triangle, c.box);
        for (int level = 0; level < 8 && !current.is_empty(); ++level) {
            int axis = int(rng() % 3);
            float position =
                current.lo[axis] + float(int(unit(rng) * 5.0f)) * 0.25f * (current.hi[axis] - current.lo[axis]);
            SplitBounds split = split_triangle_bounds(c.triangle, current, axis, position);
            ASSERT_FALSE(split.left.is_empty() && split.right.is_empty()) << "case " << i << " level " << level;
            ASSERT_TRUE(current.contains(split.left) && current.contains(split.right));
            AABB next = (rng() % 2 == 0 && !split.left.is_empty()) || split.right.is_empty() ? split.left : split.right;
            current = next;
        }
    }
}

TEST(Clip, AreasOfSplitPiecesSumToTheWhole) {
    std::mt19937 rng(777);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (int i = 0; i < 2000; ++i) {
        RandomCase c = random_case(rng, false);
        AABB whole = c.triangle.bounds();
        double full = clipped_triangle_area(c.triangle, whole);
        int axis = int(rng() % 3);
        float position = whole.lo[axis] + unit(rng) * (whole.hi[axis] - whole.lo[axis]);
        AABB left = whole, right = whole;
        left.hi[axis] = position;
        right.lo[axis] = position;
        double pieces = clipped_triangle_area(c.triangle, left) + clipped_triangle_area(c.triangle, right);
        ASSERT_NEAR(pieces, full, 1e-5 * full + 1e-12) << "case " << i;
        // The whole-box area equals the triangle's own area.
        Vec3 n = c.triangle.geometric_normal();
        double own = 0.5 * std::sqrt(double(n.x) * n.x + double(n.y) * n.y + double(n.z) * n.z);
        ASSERT_NEAR(full, own, 1e-5 * own + 1e-12);
    }
}

}  // namespace
}  // namespace spacebvh
