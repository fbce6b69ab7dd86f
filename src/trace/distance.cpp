// SPDX-License-Identifier: MIT
// DistanceQueries (distance.hpp, docs/distance.md): argument checks and batches over the nearest-
// triangle walk (distance/nearest.hpp), the winding numbers (distance/winding.hpp) and RayQueries'
// containment.
#include "spacebvh/distance.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "spacebvh/error.hpp"
#include "spacebvh/queries.hpp"
#include "trace/distance/nearest.hpp"
#include "trace/distance/winding.hpp"
#include "trace/queries/query_batches.hpp"

namespace spacebvh {

using namespace trace::distance;

struct DistanceQueries::Layout {
    std::vector<Triangle> triangles;
    RayQueries rays;  // containment; built first: it refuses trees too deep for the walks
    trace::WideLayout<8> wide;
    std::vector<TriangleConditioning> conditioning;  // of wide's pack lanes
    WindingTree winding;
    AABB bounds;  // of every triangle: the grid large batches are ordered on

    Layout(std::span<const Triangle> t, const Bvh& bvh)
        : triangles(t.begin(), t.end()),
          rays(t, bvh),
          wide(bvh.empty() || t.empty() ? trace::WideLayout<8>{}
                                        : trace::collapse_to_wide<8>(t, bvh, WideCollapse::sah_optimal)),
          conditioning(pack_conditioning(wide)),
          winding(t, bvh) {
        for (const Triangle& triangle : t) bounds.extend(triangle.bounds());
    }

    ClosestPoint nearest(const Vec3d& p, double max_distance, std::vector<Candidate>& scratch) const {
        return nearest_triangle(wide, conditioning, triangles, p, max_distance, scratch);
    }
    // Runs nearest(points[i]) for every i into answer(i, result), across the arena: large batches in
    // coherent_order (query_batches.hpp), which finds the nodes and leaves a point walks in cache.
    template <class Answer>
    void nearest_batch(std::span<const Vec3d> points, double max_distance, Answer&& answer) const {
        using namespace trace::queries;
        const size_t n = points.size();
        std::vector<uint32_t> order;
        if (n >= kOrderedBatch && n <= std::numeric_limits<uint32_t>::max() && !wide.nodes.empty())
            order = coherent_order(bounds, n, [&](size_t i) {
                struct {
                    Vec3 org;
                } at{Vec3{float(points[i][0]), float(points[i][1]), float(points[i][2])}};
                return at;
            });
        for_chunks(n, [&](size_t begin, size_t end) {
            std::vector<Candidate> scratch;
            for (size_t k = begin; k < end; ++k) {
                const size_t i = order.empty() ? k : order[k];
                answer(i, nearest(points[i], max_distance, scratch));
            }
        });
    }
};

namespace {

// The largest accuracy accepted: beyond it the approximation is the direct sum in all but name.
constexpr double kMaxAccuracy = 1e6;

void check_point(const Vec3d& p, size_t index) {
    for (double c : p)
        if (!std::isfinite(c) || std::fabs(c) > kMaxCoordinate)
            throw Error("distance: point " + std::to_string(index) + " is not finite or beyond 2^400 in magnitude");
}

void check_points(std::span<const Vec3d> points, size_t answers) {
    if (points.size() != answers)
        throw Error("distance: " + std::to_string(points.size()) + " points but room for " + std::to_string(answers) +
                    " answers");
    for (size_t i = 0; i < points.size(); ++i) check_point(points[i], i);
}

void check_max_distance(double max_distance) {
    if (std::isnan(max_distance) || max_distance < 0.0)
        throw Error("distance: max_distance must be >= 0 (inf: no limit), not " + std::to_string(max_distance));
}

void check_accuracy(double accuracy, int order) {
    if (!(accuracy >= 0.0 && accuracy <= kMaxAccuracy))
        throw Error("distance: the winding number's accuracy must be 0 (the direct sum) or in (0, 1e6], not " +
                    std::to_string(accuracy));
    if (order < 0 || order > kMaxWindingOrder)
        throw Error(
            "distance: the winding number's order must be 0, 1 or 2 (the Taylor order of the far field), "
            "not " +
            std::to_string(order));
}

D3 as_d3(const Vec3d& p) { return {p[0], p[1], p[2]}; }

Vec3 as_float(const Vec3d& p) { return {float(p[0]), float(p[1]), float(p[2])}; }

// The point rounded to float for containment, which needs it within float's range.
Vec3 float_point(const Vec3d& p, size_t index) {
    check_point(p, index);
    const Vec3 rounded = as_float(p);
    if (!is_finite(rounded))
        throw Error("distance: occupancy of point " + std::to_string(index) + " beyond float32's range");
    return rounded;
}

}  // namespace

DistanceQueries::DistanceQueries(std::span<const Triangle> triangles, const Bvh& bvh)
    : layout_(std::make_unique<Layout>(triangles, bvh)) {}
DistanceQueries::~DistanceQueries() = default;
DistanceQueries::DistanceQueries(DistanceQueries&&) noexcept = default;
DistanceQueries& DistanceQueries::operator=(DistanceQueries&&) noexcept = default;

size_t DistanceQueries::triangle_count() const { return layout_->triangles.size(); }

ClosestPoint DistanceQueries::closest_point(const Vec3d& point, double max_distance) const {
    check_point(point, 0);
    check_max_distance(max_distance);
    std::vector<Candidate> scratch;
    return layout_->nearest(point, max_distance, scratch);
}

double DistanceQueries::distance(const Vec3d& point, double max_distance) const {
    return closest_point(point, max_distance).distance;
}

namespace {

// The winding number that decides the sign: the hierarchical one (Taylor order 2) where it lies
// farther from one half than its error bound or than 0.25, the direct sum otherwise. The bound is
// rigorous but loose (hundreds of times the error seen, docs/distance.md): alone it would send most
// points near a surface to the direct sum; the margin of 0.25 is fifty times the largest error measured.
bool inside_by_winding(const WindingTree& tree, std::span<const Triangle> triangles, D3 p) {
    const auto [w, bound] = tree.hierarchical(triangles, p, kDefaultWindingAccuracy, kMaxWindingOrder);
    if (std::fabs(w - 0.5) > std::min(bound, 0.25)) return w >= 0.5;
    return tree.direct(triangles, p).first >= 0.5;
}

}  // namespace

double DistanceQueries::signed_distance(const Vec3d& point, SignRule rule) const {
    const double d = distance(point);
    if (d == 0.0 || std::isinf(d)) return d;
    const bool inside = rule == SignRule::parity
                            ? layout_->rays.contains(float_point(point, 0))
                            : inside_by_winding(layout_->winding, layout_->triangles, as_d3(point));
    return inside ? -d : d;
}

double DistanceQueries::winding_number(const Vec3d& point, double accuracy, int order) const {
    return winding_number_bound(point, accuracy, order).first;
}

std::pair<double, double> DistanceQueries::winding_number_bound(const Vec3d& point, double accuracy, int order) const {
    check_point(point, 0);
    check_accuracy(accuracy, order);
    if (accuracy == 0.0) return layout_->winding.direct(layout_->triangles, as_d3(point));
    return layout_->winding.hierarchical(layout_->triangles, as_d3(point), accuracy, order);
}

bool DistanceQueries::occupancy(const Vec3d& point) const { return layout_->rays.contains(float_point(point, 0)); }

void DistanceQueries::closest_points(std::span<const Vec3d> points, std::span<ClosestPoint> out,
                                     double max_distance) const {
    check_points(points, out.size());
    check_max_distance(max_distance);
    layout_->nearest_batch(points, max_distance, [&](size_t i, const ClosestPoint& c) { out[i] = c; });
}

void DistanceQueries::distances(std::span<const Vec3d> points, std::span<double> out, double max_distance) const {
    check_points(points, out.size());
    check_max_distance(max_distance);
    layout_->nearest_batch(points, max_distance, [&](size_t i, const ClosestPoint& c) { out[i] = c.distance; });
}

void DistanceQueries::signed_distances(std::span<const Vec3d> points, std::span<double> out, SignRule rule) const {
    distances(points, out);
    std::vector<uint8_t> inside(points.size(), 0);
    if (rule == SignRule::parity) {
        occupancies(points, inside);
    } else {
        trace::queries::for_chunks(points.size(), [&](size_t begin, size_t end) {
            for (size_t i = begin; i < end; ++i)
                inside[i] = inside_by_winding(layout_->winding, layout_->triangles, as_d3(points[i]));
        });
    }
    for (size_t i = 0; i < points.size(); ++i)
        if (inside[i] && out[i] != 0.0 && !std::isinf(out[i])) out[i] = -out[i];
}

void DistanceQueries::winding_numbers(std::span<const Vec3d> points, std::span<double> out, double accuracy,
                                      int order) const {
    check_points(points, out.size());
    check_accuracy(accuracy, order);
    const WindingTree& tree = layout_->winding;
    trace::queries::for_chunks(points.size(), [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i)
            out[i] = accuracy == 0.0 ? tree.direct(layout_->triangles, as_d3(points[i])).first
                                     : tree.hierarchical(layout_->triangles, as_d3(points[i]), accuracy, order).first;
    });
}

void DistanceQueries::occupancies(std::span<const Vec3d> points, std::span<uint8_t> out) const {
    check_points(points, out.size());
    std::vector<Vec3> rounded(points.size());
    for (size_t i = 0; i < points.size(); ++i) rounded[i] = float_point(points[i], i);
    layout_->rays.contains(rounded, out);
}

}  // namespace spacebvh
