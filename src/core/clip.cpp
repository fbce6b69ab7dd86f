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
#include <cmath>
#include <limits>
#include <utility>

namespace spacebvh {
namespace {

struct DPoint {
    std::array<double, 3> c;
};

// A convex polygon clipped by at most 6 planes has at most 3 + 6 vertices. Rounding can in theory
// make a nearly degenerate polygon slightly non-convex, so keep generous headroom and report
// overflow rather than write out of bounds.
constexpr int kMaxVertices = 32;

struct Polygon {
    std::array<DPoint, kMaxVertices> points;
    int count = 0;
    bool overflow = false;

    void push(const DPoint& p) {
        if (count < kMaxVertices) {
            points[count++] = p;
        } else {
            overflow = true;
        }
    }
};

Polygon polygon_of(const Triangle& triangle) {
    Polygon polygon;
    for (int i = 0; i < 3; ++i) {
        Vec3 v = triangle.vertex(i);
        polygon.push({{double(v.x), double(v.y), double(v.z)}});
    }
    return polygon;
}

// Keeps the part of `in` with x[axis] <= plane (keep_below) or x[axis] >= plane (otherwise).
void clip_half_space(const Polygon& in, Polygon& out, int axis, double plane, bool keep_below) {
    out.count = 0;
    out.overflow = in.overflow;
    if (in.count == 0) return;
    // Signed distance, positive inside.
    auto inside_distance = [&](const DPoint& p) { return keep_below ? plane - p.c[axis] : p.c[axis] - plane; };
    for (int i = 0; i < in.count; ++i) {
        const DPoint& a = in.points[i];
        const DPoint& b = in.points[(i + 1) % in.count];
        double da = inside_distance(a);
        double db = inside_distance(b);
        if (da >= 0.0) out.push(a);
        if ((da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0)) {
            // Interpolate from a towards b; t is in (0, 1) because the crossing is strict.
            double t = da / (da - db);
            DPoint p;
            for (int k = 0; k < 3; ++k) {
                if (k == axis) {
                    p.c[k] = plane;  // exactly on the plane: never outside through rounding
                } else {
                    double value = a.c[k] + t * (b.c[k] - a.c[k]);
                    p.c[k] = std::clamp(value, std::min(a.c[k], b.c[k]), std::max(a.c[k], b.c[k]));
                }
            }
            out.push(p);
        }
    }
}

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

float round_down(double value) {
    float f = float(value);
    if (double(f) > value) f = std::nextafter(f, -kInfinity);
    return f;
}

float round_up(double value) {
    float f = float(value);
    if (double(f) < value) f = std::nextafter(f, kInfinity);
    return f;
}

// Float bounds of the polygon, rounded outward, then clamped into `limit` (non-empty). Points are
// normally inside `limit` already, so this is an intersection; clamping (rather than intersecting)
// keeps a non-empty polygon non-empty when split_triangle_bounds had to use a widened box.
AABB bounds_of(const Polygon& polygon, const AABB& limit) {
    if (polygon.count == 0) return AABB::empty();
    std::array<double, 3> lo = polygon.points[0].c, hi = polygon.points[0].c;
    for (int i = 1; i < polygon.count; ++i) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], polygon.points[i].c[k]);
            hi[k] = std::max(hi[k], polygon.points[i].c[k]);
        }
    }
    AABB result;
    for (int k = 0; k < 3; ++k) {
        result.lo[k] = std::clamp(round_down(lo[k]), limit.lo[k], limit.hi[k]);
        result.hi[k] = std::clamp(round_up(hi[k]), limit.lo[k], limit.hi[k]);
    }
    return result;
}

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

bool boxes_overlap(const AABB& a, const AABB& b) { return !intersect(a, b).is_empty(); }

}  // namespace

AABB clip_triangle_bounds(const Triangle& triangle, const AABB& box) {
    AABB triangle_box = triangle.bounds();
    if (box.is_empty() || !boxes_overlap(triangle_box, box)) return AABB::empty();
    if (box.contains(triangle_box)) return triangle_box;
    Polygon polygon = polygon_of(triangle);
    clip_to_box(polygon, triangle_box, box);
    AABB limit = intersect(triangle_box, box);
    // Unreachable in practice; stay conservative rather than lose part of the triangle.
    if (polygon.overflow) return limit;
    return bounds_of(polygon, limit);
}

namespace {

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

SplitBounds split_triangle_bounds(const Triangle& triangle, const AABB& current_bounds, int axis, float position) {
    SplitBounds result{AABB::empty(), AABB::empty()};
    AABB triangle_box = triangle.bounds();
    if (current_bounds.is_empty() || !boxes_overlap(triangle_box, current_bounds)) return result;

    AABB limit = intersect(triangle_box, current_bounds);
    if (limit.is_empty()) return result;

    Polygon piece;
    if (!piece_within(triangle, triangle_box, current_bounds, piece)) return result;
    AABB left_limit = limit, right_limit = limit;
    left_limit.hi[axis] = std::min(left_limit.hi[axis], position);
    right_limit.lo[axis] = std::max(right_limit.lo[axis], position);

    Polygon side;
    clip_half_space(piece, side, axis, double(position), true);
    if (!left_limit.is_empty()) result.left = side.overflow ? left_limit : bounds_of(side, left_limit);
    clip_half_space(piece, side, axis, double(position), false);
    if (!right_limit.is_empty()) result.right = side.overflow ? right_limit : bounds_of(side, right_limit);
    return result;
}

void chop_triangle_bounds(const Triangle& triangle, const AABB& current_bounds, int axis,
                          std::span<const float> planes, std::span<AABB> pieces) {
    std::fill(pieces.begin(), pieces.end(), AABB::empty());
    const AABB triangle_box = triangle.bounds();
    if (current_bounds.is_empty() || !boxes_overlap(triangle_box, current_bounds)) return;
    const AABB limit = intersect(triangle_box, current_bounds);
    if (limit.is_empty()) return;
    // Clip once to the reference's bounds, then peel one slab off per plane: the same operations
    // as split_triangle_bounds applied plane by plane, without re-clipping the triangle each time.
    Polygon buffers[3];
    Polygon* rest = &buffers[0];
    Polygon* next = &buffers[1];
    Polygon& slab = buffers[2];
    if (!piece_within(triangle, triangle_box, current_bounds, *rest)) return;
    float low = -kInfinity;
    for (size_t i = 0; i < planes.size(); ++i) {
        AABB slab_limit = limit;
        slab_limit.lo[axis] = std::max(slab_limit.lo[axis], low);
        slab_limit.hi[axis] = std::min(slab_limit.hi[axis], planes[i]);
        clip_half_space(*rest, slab, axis, double(planes[i]), true);
        if (!slab_limit.is_empty() && slab.count > 0) pieces[i] = slab.overflow ? slab_limit : bounds_of(slab, slab_limit);
        clip_half_space(*rest, *next, axis, double(planes[i]), false);
        std::swap(rest, next);
        low = planes[i];
        if (rest->count == 0) return;
    }
    AABB last_limit = limit;
    last_limit.lo[axis] = std::max(last_limit.lo[axis], low);
    if (!last_limit.is_empty()) pieces[planes.size()] = rest->overflow ? last_limit : bounds_of(*rest, last_limit);
}

double clipped_triangle_area(const Triangle& triangle, const AABB& box) {
    AABB triangle_box = triangle.bounds();
    if (box.is_empty() || !boxes_overlap(triangle_box, box)) return 0.0;
    Polygon polygon = polygon_of(triangle);
    if (!box.contains(triangle_box)) clip_to_box(polygon, triangle_box, box);
    return polygon_area(polygon);
}

}  // namespace spacebvh
