// SPDX-License-Identifier: MIT
// Sutherland-Hodgman clipping of a triangle against axis-aligned half-spaces (Sutherland & Hodgman,
// "Reentrant Polygon Clipping", CACM 1974), as used for spatial splits by Popov et al. 2009 and
// Stich et al. 2009, and for the EPO metric of Aila, Karras & Laine 2013.
//
// Robustness rules (the spatial-split builders rely on them):
//  * Half-spaces are closed: a point exactly on a plane is inside, so a triangle lying in a box face
//    or in a split plane survives as a flat piece (and goes to both sides of a split).
//  * Clipping runs in double on the float input. A new vertex created on plane x[axis] = c gets
//    x[axis] = c exactly, and its other coordinates are clamped to the edge's span, so points never
//    drift outside the box or the triangle's bounds through rounding.
//  * New vertices are only created when an edge crosses the plane strictly (one end strictly inside,
//    the other strictly outside); a vertex on the plane is simply kept. This gives no duplicate
//    points and handles degenerate (segment or point) triangles: the "polygon" is then a segment
//    traversed forth and back, and clipping it keeps exactly the part of the segment in the box.
//  * Float bounds are rounded outward from the double result (conservative by at most one ulp) and
//    then intersected with the box and the triangle's bounds, so the result is contained in both.
#include "spacebvh/clip.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "core/clip_polygon.hpp"

namespace spacebvh::clipping {

Polygon polygon_of(const Triangle& triangle) {
    Polygon polygon;
    for (int i = 0; i < 3; ++i) {
        Vec3 v = triangle.vertex(i);
        polygon.push({{double(v.x), double(v.y), double(v.z)}});
    }
    return polygon;
}

namespace {

// The point where edge a -> b crosses x[axis] = plane, given the signed distances of a and b to the
// plane (opposite signs, both nonzero). Interpolated from a towards b; t is in (0, 1) because the
// crossing is strict. Negating both distances (the other side's view) gives the same t bit for bit,
// so both sides of a cut share one crossing point.
Point crossing(const Point& a, const Point& b, double da, double db, int axis, double plane) {
    const double t = da / (da - db);
    Point p;
    for (int k = 0; k < 3; ++k) {
        if (k == axis) {
            p.c[k] = plane;  // exactly on the plane: never outside through rounding
        } else {
            const double value = a.c[k] + t * (b.c[k] - a.c[k]);
            p.c[k] = std::clamp(value, std::min(a.c[k], b.c[k]), std::max(a.c[k], b.c[k]));
        }
    }
    return p;
}

bool crosses_strictly(double da, double db) { return (da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0); }

// The neighbouring floats below and above (std::nextafter without the library call; finite or
// infinite input, never NaN).
float next_down(float f) {
    if (f == 0.0f) return -std::numeric_limits<float>::denorm_min();
    const uint32_t bits = std::bit_cast<uint32_t>(f);
    return std::bit_cast<float>(f > 0.0f ? bits - 1 : bits + 1);
}
float next_up(float f) {
    if (f == 0.0f) return std::numeric_limits<float>::denorm_min();
    const uint32_t bits = std::bit_cast<uint32_t>(f);
    return std::bit_cast<float>(f > 0.0f ? bits + 1 : bits - 1);
}

constexpr double kHugeDouble = std::numeric_limits<double>::infinity();

// Written as selects, not branches: about half the points need the step, unpredictably.
float round_down(double value) {
    const float f = float(value);
    const float below = next_down(f);
    return double(f) > value ? below : f;
}

float round_up(double value) {
    const float f = float(value);
    const float above = next_up(f);
    return double(f) < value ? above : f;
}

// Bounds of points accumulated in double and rounded outward once. Rounding is monotone, so
// round_down(min x) = min round_down(x): this is exactly the union of the points' float boxes each
// rounded outward, for a fraction of the work (the spatial split finders bin millions of points).
struct DoubleBounds {
    std::array<double, 3> lo{kHugeDouble, kHugeDouble, kHugeDouble}, hi{-kHugeDouble, -kHugeDouble, -kHugeDouble};

    void extend(const Point& p) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], p.c[k]);
            hi[k] = std::max(hi[k], p.c[k]);
        }
    }
    bool empty() const { return lo[0] > hi[0]; }
    AABB rounded() const {
        if (empty()) return AABB::empty();
        AABB box;
        for (int k = 0; k < 3; ++k) {
            box.lo[k] = round_down(lo[k]);
            box.hi[k] = round_up(hi[k]);
        }
        return box;
    }
};

// Clamps accumulated float bounds into `limit` (non-empty); empty stays empty. Clamping (rather than
// intersecting) keeps a non-empty polygon non-empty when piece_within had to use a widened box.
AABB clamped_into(const AABB& bounds, const AABB& limit) {
    if (bounds.is_empty()) return AABB::empty();
    AABB result;
    for (int k = 0; k < 3; ++k) {
        result.lo[k] = std::clamp(bounds.lo[k], limit.lo[k], limit.hi[k]);
        result.hi[k] = std::clamp(bounds.hi[k], limit.lo[k], limit.hi[k]);
    }
    return result;
}

}  // namespace

void clip_half_space(const Polygon& in, Polygon& out, int axis, double plane, bool keep_below) {
    out.count = 0;
    out.overflow = in.overflow;
    if (in.count == 0) return;
    // Signed distance, positive inside.
    auto inside_distance = [&](const Point& p) { return keep_below ? plane - p.c[axis] : p.c[axis] - plane; };
    for (int i = 0; i < in.count; ++i) {
        const Point& a = in.points[i];
        const Point& b = in.points[(i + 1) % in.count];
        const double da = inside_distance(a);
        const double db = inside_distance(b);
        if (da >= 0.0) out.push(a);
        if (crosses_strictly(da, db)) out.push(crossing(a, b, da, db, axis, plane));
    }
}

AABB bounds_of(const Polygon& polygon, const AABB& limit) {
    DoubleBounds bounds;
    for (int i = 0; i < polygon.count; ++i) bounds.extend(polygon.points[i]);
    return clamped_into(bounds.rounded(), limit);
}

namespace {

// Clips `polygon` in place to the box [lo, hi] (double planes), only against the planes that the
// polygon's bounds `extent` actually cross (the others cannot remove anything).
void clip_to_box(Polygon& polygon, const AABB& extent, const std::array<double, 3>& lo,
                 const std::array<double, 3>& hi) {
    // Ping-pong between two buffers; copy back (only the live points) at most once.
    Polygon scratch;
    Polygon* source = &polygon;
    Polygon* target = &scratch;
    for (int axis = 0; axis < 3 && source->count > 0; ++axis) {
        if (double(extent.lo[axis]) < lo[axis]) {
            clip_half_space(*source, *target, axis, lo[axis], false);
            std::swap(source, target);
        }
        if (source->count > 0 && double(extent.hi[axis]) > hi[axis]) {
            clip_half_space(*source, *target, axis, hi[axis], true);
            std::swap(source, target);
        }
    }
    if (source != &polygon) {
        std::copy_n(source->points.begin(), source->count, polygon.points.begin());
        polygon.count = source->count;
        polygon.overflow = source->overflow;
    }
}

void clip_to_box(Polygon& polygon, const AABB& extent, const AABB& box) {
    clip_to_box(polygon, extent, {double(box.lo.x), double(box.lo.y), double(box.lo.z)},
                {double(box.hi.x), double(box.hi.y), double(box.hi.z)});
}

bool boxes_overlap(const AABB& a, const AABB& b) { return !intersect(a, b).is_empty(); }

// The part of the triangle inside `current_bounds` (a reference's bounds) as a polygon; false when
// there is none.
bool piece_within(const Triangle& triangle, const AABB& triangle_box, const AABB& current_bounds, Polygon& piece) {
    piece = polygon_of(triangle);
    clip_to_box(piece, triangle_box, current_bounds);
    if (piece.count > 0) return true;
    // current_bounds came from an earlier clip, so the triangle does meet it; it can still be
    // lost here when the piece is a single touching point or edge that rounding moves just
    // outside a flat box. Retry with the box widened by a few ulps so the reference does not
    // vanish from both sides (bounds_of clamps the result back into current_bounds).
    // The rounding of interpolated points scales with the largest coordinate involved.
    double scale = 0.0;
    for (int k = 0; k < 3; ++k) {
        scale = std::max({scale, std::abs(double(triangle_box.lo[k])), std::abs(double(triangle_box.hi[k])),
                          std::abs(double(current_bounds.lo[k])), std::abs(double(current_bounds.hi[k]))});
    }
    double widen = 16.0 * double(std::numeric_limits<float>::epsilon()) * scale + 1e-30;
    std::array<double, 3> lo, hi;
    for (int k = 0; k < 3; ++k) {
        lo[k] = double(current_bounds.lo[k]) - widen;
        hi[k] = double(current_bounds.hi[k]) + widen;
    }
    piece = polygon_of(triangle);
    clip_to_box(piece, triangle_box, lo, hi);
    return piece.count > 0;
}

}  // namespace

TrianglePiece::TrianglePiece(const Triangle& triangle, const AABB& current_bounds) {
    const AABB triangle_box = triangle.bounds();
    if (current_bounds.is_empty() || !boxes_overlap(triangle_box, current_bounds)) return;
    const AABB limit = intersect(triangle_box, current_bounds);
    if (limit.is_empty()) return;
    if (!piece_within(triangle, triangle_box, current_bounds, polygon_)) return;
    limit_ = limit;
}

// One pass instead of two half-space clips: the part below the plane is the vertices with
// x <= plane plus the strict crossings of the edges, the part above likewise (Sutherland-Hodgman
// keeps exactly these points), so both boxes come out as clip_half_space + bounds_of would give.
SplitBounds TrianglePiece::split(int axis, float position) const {
    SplitBounds result{AABB::empty(), AABB::empty()};
    if (empty()) return result;
    AABB left_limit = limit_, right_limit = limit_;
    left_limit.hi[axis] = std::min(left_limit.hi[axis], position);
    right_limit.lo[axis] = std::max(right_limit.lo[axis], position);
    const double plane = position;
    DoubleBounds below_points, above_points;
    for (int i = 0; i < polygon_.count; ++i) {
        const Point& a = polygon_.points[i];
        const Point& b = polygon_.points[(i + 1) % polygon_.count];
        const double da = a.c[axis] - plane, db = b.c[axis] - plane;
        if (da <= 0.0) below_points.extend(a);
        if (da >= 0.0) above_points.extend(a);
        if (crosses_strictly(da, db)) {
            const Point cut = crossing(a, b, da, db, axis, plane);
            below_points.extend(cut);
            above_points.extend(cut);
        }
    }
    const AABB below = below_points.rounded(), above = above_points.rounded();
    if (!left_limit.is_empty())
        result.left = polygon_.overflow && !below.is_empty() ? left_limit : clamped_into(below, left_limit);
    if (!right_limit.is_empty())
        result.right = polygon_.overflow && !above.is_empty() ? right_limit : clamped_into(above, right_limit);
    return result;
}

// Exactness of the skipping: the side's box is clamp(round(min of its points)) per bound, rounding and
// clamping are monotone, so a point at or inside box.lo[k] cannot lower box.lo[k] unless the clamp
// itself lies below box.lo[k] (the side's limit entirely below the box on k); on such bounds every
// point is taken.
void TrianglePiece::extend_side(AABB& box, int axis, float position, bool below) const {
    if (empty()) return;
    AABB limit = limit_;
    if (below) {
        limit.hi[axis] = std::min(limit.hi[axis], position);
    } else {
        limit.lo[axis] = std::max(limit.lo[axis], position);
    }
    if (limit.is_empty()) return;
    if (polygon_.overflow) {
        const SplitBounds pieces = split(axis, position);
        box.extend(below ? pieces.left : pieces.right);
        return;
    }
    constexpr double kHuge = std::numeric_limits<double>::infinity();
    std::array<double, 3> needed_lo, needed_hi, lo, hi;  // a coordinate matters below needed_lo / above needed_hi
    for (int k = 0; k < 3; ++k) {
        needed_lo[k] = limit.hi[k] >= box.lo[k] ? double(box.lo[k]) : kHuge;
        needed_hi[k] = limit.lo[k] <= box.hi[k] ? double(box.hi[k]) : -kHuge;
        lo[k] = kHuge;
        hi[k] = -kHuge;
    }
    auto matters = [&](const Point& p) {
        for (int k = 0; k < 3; ++k)
            if (p.c[k] < needed_lo[k] || p.c[k] > needed_hi[k]) return true;
        return false;
    };
    auto take = [&](const Point& p) {
        for (int k = 0; k < 3; ++k) {
            if (p.c[k] < needed_lo[k]) lo[k] = std::min(lo[k], p.c[k]);
            if (p.c[k] > needed_hi[k]) hi[k] = std::max(hi[k], p.c[k]);
        }
    };
    const double plane = position;
    for (int i = 0; i < polygon_.count; ++i) {
        const Point& a = polygon_.points[i];
        const Point& b = polygon_.points[(i + 1) % polygon_.count];
        const double da = a.c[axis] - plane, db = b.c[axis] - plane;
        if (below ? da <= 0.0 : da >= 0.0) take(a);
        // The crossing lies between a and b on every coordinate (clamped), so it matters only if one does.
        if (crosses_strictly(da, db) && (matters(a) || matters(b))) take(crossing(a, b, da, db, axis, plane));
    }
    for (int k = 0; k < 3; ++k) {
        if (lo[k] != kHuge) box.lo[k] = std::min(box.lo[k], std::clamp(round_down(lo[k]), limit.lo[k], limit.hi[k]));
        if (hi[k] != -kHuge) box.hi[k] = std::max(box.hi[k], std::clamp(round_up(hi[k]), limit.lo[k], limit.hi[k]));
    }
}

float TrianglePiece::quiet_until(const AABB& box, int axis, float position, bool below) const {
    const double sign = below ? 1.0 : -1.0;
    const float now = float(sign) * position;
    if (empty()) return kInfinity;
    if (polygon_.overflow) return now;
    // Clamping into the limit could move a point that is inside the box out of it.
    for (int k = 0; k < 3; ++k)
        if (k != axis && (limit_.lo[k] > box.hi[k] || limit_.hi[k] < box.lo[k])) return now;
    const double swept = sign * double(position);
    double quiet = std::numeric_limits<double>::infinity();
    constexpr double kMargin = 1e-12;  // relative; the crossing arithmetic errs by ~1e-16
    for (int i = 0; i < polygon_.count; ++i) {
        const Point& a = polygon_.points[i];
        const Point& b = polygon_.points[(i + 1) % polygon_.count];
        const double ua = sign * a.c[axis], ub = sign * b.c[axis];
        if (ua <= swept && ub <= swept) continue;  // already inside the box
        for (int k = 0; k < 3; ++k) {
            if (k == axis) continue;
            for (const bool upper : {false, true}) {
                const double bound = upper ? double(box.hi[k]) : double(box.lo[k]);
                auto outside = [&](const Point& p) { return upper ? p.c[k] > bound : p.c[k] < bound; };
                const bool out_a = outside(a), out_b = outside(b);
                if (!out_a && !out_b) continue;
                if (ua > swept && ub > swept) {
                    quiet = std::min(quiet, std::min(ua, ub));  // the whole edge is ahead: stop at its start
                    continue;
                }
                // One end is behind the plane (inside the box, or give up) and the other ahead, outside.
                const Point& in = ua <= swept ? a : b;
                const Point& out = ua <= swept ? b : a;
                if (outside(in)) return now;
                const double u_in = sign * in.c[axis], u_out = sign * out.c[axis];
                const double delta = out.c[k] - in.c[k];
                const double t_exit = (bound - in.c[k]) / delta;
                const double margin = kMargin * (1.0 + (std::abs(in.c[k]) + std::abs(out.c[k])) / std::abs(delta) +
                                                 (std::abs(u_in) + std::abs(u_out)) / (u_out - u_in));
                const double t = t_exit - margin;
                if (!(t > 0.0)) return now;
                quiet = std::min(quiet, u_in + t * (u_out - u_in));
            }
        }
    }
    if (quiet == std::numeric_limits<double>::infinity()) return kInfinity;
    return std::max(now, round_down(quiet));
}

}  // namespace spacebvh::clipping

namespace spacebvh {
namespace {

using clipping::Polygon;

// Area of a planar polygon: half the length of its vector area (sum of fan cross products).
double polygon_area(const Polygon& polygon) {
    if (polygon.count < 3) return 0.0;
    const auto& o = polygon.points[0].c;
    double sx = 0.0, sy = 0.0, sz = 0.0;
    for (int i = 1; i + 1 < polygon.count; ++i) {
        const auto& p = polygon.points[i].c;
        const auto& q = polygon.points[i + 1].c;
        double ax = p[0] - o[0], ay = p[1] - o[1], az = p[2] - o[2];
        double bx = q[0] - o[0], by = q[1] - o[1], bz = q[2] - o[2];
        sx += ay * bz - az * by;
        sy += az * bx - ax * bz;
        sz += ax * by - ay * bx;
    }
    return 0.5 * std::sqrt(sx * sx + sy * sy + sz * sz);
}

}  // namespace

AABB clip_triangle_bounds(const Triangle& triangle, const AABB& box) {
    AABB triangle_box = triangle.bounds();
    if (box.is_empty() || !clipping::boxes_overlap(triangle_box, box)) return AABB::empty();
    if (box.contains(triangle_box)) return triangle_box;
    Polygon polygon = clipping::polygon_of(triangle);
    clipping::clip_to_box(polygon, triangle_box, box);
    AABB limit = intersect(triangle_box, box);
    // Unreachable in practice; stay conservative rather than lose part of the triangle.
    if (polygon.overflow) return limit;
    return clipping::bounds_of(polygon, limit);
}

SplitBounds split_triangle_bounds(const Triangle& triangle, const AABB& current_bounds, int axis, float position) {
    return clipping::TrianglePiece(triangle, current_bounds).split(axis, position);
}

double clipped_triangle_area(const Triangle& triangle, const AABB& box) {
    AABB triangle_box = triangle.bounds();
    if (box.is_empty() || !clipping::boxes_overlap(triangle_box, box)) return 0.0;
    Polygon polygon = clipping::polygon_of(triangle);
    if (!box.contains(triangle_box)) clipping::clip_to_box(polygon, triangle_box, box);
    return polygon_area(polygon);
}

}  // namespace spacebvh
