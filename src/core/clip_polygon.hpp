// SPDX-License-Identifier: MIT
// Internal: the part of a triangle inside a reference's bounds, kept as a convex polygon (double
// precision) so that it can be cut at many axis-aligned planes without clipping the triangle again.
// It is the one implementation of reference clipping behind include/spacebvh/clip.hpp and the
// spatial search spaces (binned and sweep); the robustness rules are those listed in clip.cpp.
#pragma once

#include <array>
#include <span>

#include "spacebvh/clip.hpp"
#include "spacebvh/geometry.hpp"

namespace spacebvh::clipping {

struct Point {
    std::array<double, 3> c;
};

// A convex polygon clipped by at most 6 planes has at most 3 + 6 vertices. Rounding can in theory
// make a nearly degenerate polygon slightly non-convex, so keep generous headroom and report
// overflow rather than write out of bounds.
constexpr int kMaxVertices = 32;

struct Polygon {
    std::array<Point, kMaxVertices> points;
    int count = 0;
    bool overflow = false;

    void push(const Point& p) {
        if (count < kMaxVertices) {
            points[count++] = p;
        } else {
            overflow = true;
        }
    }
};

Polygon polygon_of(const Triangle& triangle);

// Keeps the part of `in` with x[axis] <= plane (keep_below) or x[axis] >= plane (otherwise).
void clip_half_space(const Polygon& in, Polygon& out, int axis, double plane, bool keep_below);

// Tight float bounds of the polygon, rounded outward, then clamped into `limit`; empty for no points.
AABB bounds_of(const Polygon& polygon, const AABB& limit);

// A triangle restricted to a reference's current bounds. Building it clips the triangle once; each
// cut below is then a pass over the polygon's vertices and the points where its edges cross the
// plane, with the same arithmetic (and so the same bits) as clipping the polygon by half-spaces.
class TrianglePiece {
public:
    TrianglePiece() = default;
    TrianglePiece(const Triangle& triangle, const AABB& current_bounds);

    // No part of the triangle lies in the reference's bounds.
    bool empty() const { return polygon_.count == 0; }

    // Tight bounds of the piece on either side of x[axis] = position (split_triangle_bounds).
    SplitBounds split(int axis, float position) const;

    // box.extend(below ? split(axis, position).left : split(axis, position).right), bit for bit, but
    // only computing what can change `box` (points inside it are skipped, crossings between two such
    // points are not computed): a sweep extends a child box by many straddlers at many planes.
    void extend_side(AABB& box, int axis, float position, bool below) const;

    // Right after extend_side(box, axis, position, below): how far a sweep may move the plane on
    // (up for below, down otherwise) while extend_side keeps leaving `box` unchanged. Returned as a
    // distance along the sweep, u = x (below) or -x: extend_side at any plane with u(plane) < the
    // result is a no-op. Conservative: the piece's edges are followed to where they leave the box,
    // less a margin far above the rounding of the crossing points.
    float quiet_until(const AABB& box, int axis, float position, bool below) const;

private:
    Polygon polygon_;
    AABB limit_ = AABB::empty();  // triangle bounds ∩ reference bounds: every result lies inside
};

}  // namespace spacebvh::clipping
