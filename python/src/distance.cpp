// SPDX-License-Identifier: MIT
// Point queries (include/spacebvh/distance.hpp) on NumPy points of any leading shape (..., 3): the
// closest point, unsigned and signed distance, generalized winding numbers and occupancy. Answers
// are shaped by the points' leading shape; the GIL is released while the library works.
#include <cmath>
#include <optional>
#include <tuple>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "bindings.hpp"
#include "spacebvh/distance.hpp"

namespace spacebvh::python {

namespace {

using PyDistance = PyQueryObject<DistanceQueries>;

// Points of shape (..., 3) as rows in the scene's frame (double, not rounded), with their leading
// shape. Checked finite in blocks across the threads; the first row that is not is named.
struct Points {
    std::vector<Vec3d> rows;
    std::vector<py::ssize_t> shape;  // the leading shape
};

Points read_points(const PyDistance& self, const py::handle& object, int threads) {
    py::array array = py::array::ensure(object);
    if (!array) throw py::type_error("points must be an array of real numbers of shape (..., 3)");
    if (array.ndim() < 1 || array.shape(array.ndim() - 1) != 3)
        throw Error("points must have shape (..., 3), not one whose last axis is not 3 (ndim " +
                    std::to_string(array.ndim()) + ")");
    Points points;
    points.shape.assign(array.shape(), array.shape() + array.ndim() - 1);
    const py::array flat = array.attr("reshape")(-1, 3);
    const RealRows rows = RealRows::from(flat, "points");
    points.rows.resize(rows.rows());
    const Frame& frame = self.scene.frame;
    without_gil(threads, [&] {
        const size_t bad = read_finite_points(
            rows, std::span<Vec3d>(points.rows),
            [&](Vec3d& point, int axis, double value) { point[size_t(axis)] = value - frame.origin[size_t(axis)]; });
        if (bad != points.rows.size())
            throw Error("points: point " + std::to_string(bad) + " (in row-major order) is not finite");
    });
    return points;
}

std::vector<py::ssize_t> with_tail(std::vector<py::ssize_t> shape, py::ssize_t tail) {
    shape.push_back(tail);
    return shape;
}

py::dict closest_points(const PyDistance& self, const py::handle& points_arg, double max_distance,
                        std::optional<int> threads_arg) {
    const int threads = self.threads_for(threads_arg);
    const Points points = read_points(self, points_arg, threads);
    const size_t n = points.rows.size();
    std::vector<ClosestPoint> found(n);
    without_gil(threads, [&] { self.queries->closest_points(points.rows, found, max_distance); });
    py::array_t<double> out_points(with_tail(points.shape, 3)), distance(points.shape),
        barycentrics(with_tail(points.shape, 2));
    py::array_t<uint32_t> ids(points.shape);
    py::array_t<uint8_t> feature(points.shape);
    double *p_out = out_points.mutable_data(), *d_out = distance.mutable_data(), *b_out = barycentrics.mutable_data();
    uint32_t* id_out = ids.mutable_data();
    uint8_t* f_out = feature.mutable_data();
    const Frame& frame = self.scene.frame;
    without_gil(threads, [&] {
        const double nan = std::numeric_limits<double>::quiet_NaN();
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1 << 14), [&](const tbb::blocked_range<size_t>& range) {
            for (size_t i = range.begin(); i < range.end(); ++i) {
                const ClosestPoint& c = found[i];
                for (int a = 0; a < 3; ++a)
                    p_out[3 * i + size_t(a)] = c.found() ? c.point[size_t(a)] + frame.origin[size_t(a)] : nan;
                d_out[i] = c.distance;
                id_out[i] = c.primitive;
                b_out[2 * i] = c.found() ? c.u : 0.0;
                b_out[2 * i + 1] = c.found() ? c.v : 0.0;
                f_out[i] = c.feature;
            }
        });
    });
    py::dict result;
    result["points"] = out_points;
    result["distance"] = distance;
    result["triangle_ids"] = ids;
    result["barycentrics"] = barycentrics;
    result["feature"] = feature;
    return result;
}

// A float64 answer per point, by `work(rows, out)` in the arena.
template <class Work>
py::array_t<double> per_point(const PyDistance& self, const py::handle& points_arg, std::optional<int> threads_arg,
                              Work&& work) {
    const int threads = self.threads_for(threads_arg);
    const Points points = read_points(self, points_arg, threads);
    py::array_t<double> out(points.shape);
    double* data = out.mutable_data();
    without_gil(threads, [&] { work(points.rows, std::span<double>(data, points.rows.size())); });
    return out;
}

SignRule sign_rule(const std::string& sign) {
    if (sign == "parity") return SignRule::parity;
    if (sign == "winding") return SignRule::winding;
    throw Error("sign must be 'parity' or 'winding', not '" + sign + "'");
}

}  // namespace

void bind_distance(py::module_& m) {
    bind_query_class<DistanceQueries>(
        m, "DistanceQueries",
        "Point queries over a tree: the closest point (the nearest triangle decided exactly, ties to the smaller id), "
        "unsigned and signed distance, generalized winding numbers and occupancy (docs/distance.md). Points are any "
        "array of shape (..., 3), float32 or float64, in the scene's coordinates; answers have the points' leading "
        "shape. Degenerate triangles are ignored. Batch calls release the GIL.")
        .def("closest_points", &closest_points, py::arg("points"), py::arg("max_distance") = kInfinity, py::kw_only(),
             py::arg("threads") = py::none(),
             "The nearest point of the mesh within max_distance (inclusive) of each point: a dict of 'points' (..., 3) "
             "float64, 'distance' (...) float64, 'triangle_ids' (...) uint32, 'barycentrics' (..., 2) float64 (u, v of "
             "the second and third corners), 'feature' (...) uint8 (0 face, 1 2 3 edges v0v1 v1v2 v2v0, 4 5 6 "
             "vertices v0 v1 v2). Where nothing lies within max_distance: id 0xFFFFFFFF, distance inf, points NaN.")
        .def(
            "distance",
            [](const PyDistance& self, const py::handle& points, double max_distance, std::optional<int> threads) {
                return per_point(self, points, threads, [&](std::span<const Vec3d> rows, std::span<double> out) {
                    self.queries->distances(rows, out, max_distance);
                });
            },
            py::arg("points"), py::arg("max_distance") = kInfinity, py::kw_only(), py::arg("threads") = py::none(),
            "The distance to the mesh (inf where nothing lies within max_distance): float64 of the leading shape.")
        .def(
            "signed_distance",
            [](const PyDistance& self, const py::handle& points, const std::string& sign, std::optional<int> threads) {
                const SignRule rule = sign_rule(sign);
                return per_point(self, points, threads, [&](std::span<const Vec3d> rows, std::span<double> out) {
                    self.queries->signed_distances(rows, out, rule);
                });
            },
            py::arg("points"), py::arg("sign") = "parity", py::kw_only(), py::arg("threads") = py::none(),
            "The distance, negative inside: sign='parity' by exact containment (as RayQueries.contains, closed "
            "meshes), "
            "sign='winding' by the generalized winding number (inside where >= 0.5).")
        .def(
            "winding_number",
            [](const PyDistance& self, const py::handle& points, double accuracy, int order,
               std::optional<int> threads) {
                return per_point(self, points, threads, [&](std::span<const Vec3d> rows, std::span<double> out) {
                    self.queries->winding_numbers(rows, out, accuracy, order);
                });
            },
            py::arg("points"), py::arg("accuracy") = 0.0, py::kw_only(), py::arg("order") = kDefaultWindingOrder,
            py::arg("threads") = py::none(),
            "The generalized winding number: accuracy 0 the direct sum over every triangle (within the bound of "
            "docs/distance.md), accuracy > 0 Barill et al.'s hierarchical approximation with that beta (2 is theirs), "
            "each far cluster of triangles replaced by its expansion to Taylor order `order` (0 the dipole, 1, 2).")
        .def(
            "winding_number_bound",
            [](const PyDistance& self, const py::handle& points_arg, double accuracy, int order,
               std::optional<int> threads_arg) {
                const int threads = self.threads_for(threads_arg);
                const Points points = read_points(self, points_arg, threads);
                py::array_t<double> value(points.shape), bound(points.shape);
                double *v_out = value.mutable_data(), *b_out = bound.mutable_data();
                without_gil(threads, [&] {
                    tbb::parallel_for(tbb::blocked_range<size_t>(0, points.rows.size(), 256),
                                      [&](const tbb::blocked_range<size_t>& range) {
                                          for (size_t i = range.begin(); i < range.end(); ++i)
                                              std::tie(v_out[i], b_out[i]) =
                                                  self.queries->winding_number_bound(points.rows[i], accuracy, order);
                                      });
                });
                return py::make_tuple(value, bound);
            },
            py::arg("points"), py::arg("accuracy") = 0.0, py::kw_only(), py::arg("order") = kDefaultWindingOrder,
            py::arg("threads") = py::none(),
            "winding_number's values and a bound on their error: (value, bound), float64 of the leading shape. The "
            "bound covers rounding and, for accuracy > 0, the far field's truncation (docs/distance.md). On an edge or "
            "vertex it covers the jump of the winding number there (>= 1/2, or infinite); it is infinite where a "
            "cluster is taken from within its radius (possible for accuracy <= 1).")
        .def(
            "occupancy",
            [](const PyDistance& self, const py::handle& points_arg, std::optional<int> threads_arg) {
                const int threads = self.threads_for(threads_arg);
                const Points points = read_points(self, points_arg, threads);
                std::vector<uint8_t> inside(points.rows.size());
                without_gil(threads, [&] { self.queries->occupancies(points.rows, inside); });
                py::array_t<bool> out(points.shape);
                bool* data = out.mutable_data();
                for (size_t i = 0; i < inside.size(); ++i) data[i] = inside[i] != 0;
                return out;
            },
            py::arg("points"), py::kw_only(), py::arg("threads") = py::none(),
            "Whether each point is inside the mesh by exact parity (RayQueries.contains of the point rounded to "
            "float32): bool of the leading shape.");
}

}  // namespace spacebvh::python
