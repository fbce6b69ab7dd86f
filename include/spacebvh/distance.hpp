// SPDX-License-Identifier: MIT
// Point queries over one triangle mesh: the closest point, unsigned and signed distance, the
// generalized winding number and occupancy. docs/distance.md states the rules and derives the bounds.
//
// The nearest triangle is decided exactly (double arithmetic with an error bound, exact dyadic
// arithmetic where two candidates lie within it), ties going to the smaller triangle id; the point,
// distance and barycentrics reported are computed in double from that triangle. Occupancy and the
// default sign are RayQueries::contains (exact parity along a fixed direction). Degenerate
// (zero-area) triangles are ignored, as by every ray query: they are never the closest triangle.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <utility>

#include "spacebvh/bvh.hpp"
#include "spacebvh/float64.hpp"
#include "spacebvh/geometry.hpp"

namespace spacebvh {

// The nearest point of the mesh to a query point.
struct ClosestPoint {
    Vec3d point{};  // on the triangle, in double
    double distance = std::numeric_limits<double>::infinity();
    uint32_t primitive = kInvalidIndex;  // triangle id; kInvalidIndex where nothing lies within the bound
    double u = 0.0, v = 0.0;             // barycentrics of v1 and v2 (v0's weight is 1 - u - v)
    // Where on the triangle the point lies: 0 the face's interior, 1 2 3 the edges v0v1, v1v2, v2v0,
    // 4 5 6 the vertices v0, v1, v2 (from the double computation: a point within rounding of a
    // region's border may name the neighbouring feature).
    uint8_t feature = 0;

    bool found() const { return primitive != kInvalidIndex; }
};

// How signed_distance takes its sign: exact parity of crossings (closed meshes), or the generalized
// winding number (inside where >= 0.5; open, self-intersecting or inconsistently closed meshes).
enum class SignRule { parity, winding };

// Barill et al.'s default accuracy of the hierarchical winding number (a cluster of triangles is
// approximated when the point lies beyond accuracy times its radius).
inline constexpr double kDefaultWindingAccuracy = 2.0;
// The default Taylor order of the hierarchical winding number's far field (0 the dipole, up to 2).
inline constexpr int kDefaultWindingOrder = 2;

// The queries over one mesh, from its triangles and any BVH over them; keeps its own copy of what it
// needs. Thread-safe (every query is const); batches run across the calling thread's oneTBB arena and
// give the same answers for any thread count. Points must be finite (Error otherwise, naming the
// index); max_distance must not be negative or NaN.
class DistanceQueries {
public:
    DistanceQueries(std::span<const Triangle> triangles, const Bvh& bvh);
    ~DistanceQueries();
    DistanceQueries(DistanceQueries&&) noexcept;
    DistanceQueries& operator=(DistanceQueries&&) noexcept;

    size_t triangle_count() const;

    // The nearest point of any triangle within max_distance (inclusive), or none (found() false).
    ClosestPoint closest_point(const Vec3d& point, double max_distance = kInfinity64) const;
    double distance(const Vec3d& point, double max_distance = kInfinity64) const;
    // The distance, negative inside. A point on the surface has distance +0.
    double signed_distance(const Vec3d& point, SignRule rule = SignRule::parity) const;
    // The generalized winding number: 1 inside a closed, outward-oriented mesh, 0 outside. accuracy 0:
    // the direct sum over every triangle; accuracy > 0: Barill et al.'s hierarchical approximation
    // with that parameter (beta), each far cluster of triangles replaced by its expansion to Taylor
    // order `order` (0 the dipole, 1, or 2) about its centre.
    double winding_number(const Vec3d& point, double accuracy = 0.0, int order = kDefaultWindingOrder) const;
    // The same and a bound on its error (docs/distance.md): {value, bound}. The bound is infinite for a
    // point on a triangle the sum takes directly, where the winding number jumps, and for a cluster
    // seen from within its radius (accuracy <= 1).
    std::pair<double, double> winding_number_bound(const Vec3d& point, double accuracy = 0.0,
                                                   int order = kDefaultWindingOrder) const;
    // Containment by exact parity (RayQueries::contains) of the point rounded to float.
    bool occupancy(const Vec3d& point) const;

    // Batches (points.size() == out.size()).
    void closest_points(std::span<const Vec3d> points, std::span<ClosestPoint> out,
                        double max_distance = kInfinity64) const;
    void distances(std::span<const Vec3d> points, std::span<double> out, double max_distance = kInfinity64) const;
    void signed_distances(std::span<const Vec3d> points, std::span<double> out, SignRule rule = SignRule::parity) const;
    void winding_numbers(std::span<const Vec3d> points, std::span<double> out, double accuracy = 0.0,
                         int order = kDefaultWindingOrder) const;
    void occupancies(std::span<const Vec3d> points, std::span<uint8_t> out) const;

    static constexpr double kInfinity64 = std::numeric_limits<double>::infinity();

    struct Layout;

private:
    std::unique_ptr<Layout> layout_;
};

}  // namespace spacebvh
