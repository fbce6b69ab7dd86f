// SPDX-License-Identifier: MIT
// Exact multi-hit queries (include/spacebvh/queries.hpp) on NumPy rays: every crossing, crossing
// counts, first and any crossing, and containment, each crossing of a surface reported once.
#include <optional>

#include <pybind11/stl.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "bindings.hpp"
#include "hit_chunks.hpp"
#include "spacebvh/queries.hpp"

namespace spacebvh::python {

std::vector<uint8_t> contained_points(const PyQueryObject<RayQueries>& self, const py::handle& points_arg,
                                      const char* what, int threads) {
    const RealRows rows = RealRows::from(points_arg, what);
    std::vector<Vec3> points(rows.rows());
    std::vector<uint8_t> answers(points.size());
    const Frame& frame = self.scene.frame;
    without_gil(threads, [&] {
        const size_t bad = read_finite_points(rows, std::span<Vec3>(points), [&](Vec3& point, int axis, double value) {
            point[axis] = frame.to_local(value, axis);
        });
        if (bad != points.size()) throw Error(std::string(what) + ": row " + std::to_string(bad) + " is not finite");
        self.queries->contains(points, answers);
    });
    return answers;
}

namespace {

using PyQueries = PyQueryObject<RayQueries>;

// Points of hits in the caller's frame, float64 (computed in double from the triangle).
void put_point(const Frame& frame, const QueryHit& hit, double* out) {
    for (int axis = 0; axis < 3; ++axis) out[axis] = hit.point[size_t(axis)] + frame.origin[size_t(axis)];
}

py::tuple first_hits(const PyQueries& self, const py::handle& origins, const py::handle& directions,
                     const py::handle& tmin, const py::handle& tmax, std::optional<int> threads_arg) {
    const int threads = self.threads_for(threads_arg);
    const std::vector<Ray> rays = rays_from_arguments(self.scene.frame, origins, directions, tmin, tmax, threads);
    std::vector<QueryHit> hits(rays.size());
    without_gil(threads, [&] { self.queries->first_hits(rays, hits); });
    const py::ssize_t n = py::ssize_t(hits.size());
    py::array_t<double> t(n), u(n), v(n), points(std::vector<py::ssize_t>{n, 3});
    py::array_t<int64_t> primitive(n);
    double *t_out = t.mutable_data(), *u_out = u.mutable_data(), *v_out = v.mutable_data(),
           *p_out = points.mutable_data();
    int64_t* id_out = primitive.mutable_data();
    {
        py::gil_scoped_release unlocked;
        const double nan = std::numeric_limits<double>::quiet_NaN();
        for (size_t i = 0; i < hits.size(); ++i) {
            const QueryHit& hit = hits[i];
            const bool is_hit = hit.is_hit();
            t_out[i] = is_hit ? hit.t : std::numeric_limits<double>::infinity();
            id_out[i] = is_hit ? int64_t(hit.primitive) : -1;
            u_out[i] = is_hit ? hit.u : 0.0;
            v_out[i] = is_hit ? hit.v : 0.0;
            if (is_hit)
                put_point(self.scene.frame, hit, p_out + 3 * i);
            else
                p_out[3 * i] = p_out[3 * i + 1] = p_out[3 * i + 2] = nan;
        }
    }
    return py::make_tuple(t, primitive, u, v, points);
}

py::array_t<int64_t> first_primitives(const PyQueries& self, const py::handle& origins, const py::handle& directions,
                                      const py::handle& tmin, const py::handle& tmax, std::optional<int> threads_arg) {
    const int threads = self.threads_for(threads_arg);
    const std::vector<Ray> rays = rays_from_arguments(self.scene.frame, origins, directions, tmin, tmax, threads);
    py::array_t<int64_t> primitive(py::ssize_t(rays.size()));
    int64_t* id_out = primitive.mutable_data();
    without_gil(threads, [&] {
        std::vector<uint32_t> ids(rays.size());
        self.queries->first_hit_ids(rays, ids);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, ids.size(), 1 << 14),
                          [&](const tbb::blocked_range<size_t>& range) {
                              for (size_t i = range.begin(); i < range.end(); ++i)
                                  id_out[i] = ids[i] == kInvalidIndex ? -1 : int64_t(ids[i]);
                          });
    });
    return primitive;
}

py::array_t<bool> any_hits(const PyQueries& self, const py::handle& origins, const py::handle& directions,
                           const py::handle& tmin, const py::handle& tmax, std::optional<int> threads_arg) {
    const int threads = self.threads_for(threads_arg);
    const std::vector<Ray> rays = rays_from_arguments(self.scene.frame, origins, directions, tmin, tmax, threads);
    std::vector<uint8_t> answers(rays.size());
    without_gil(threads, [&] { self.queries->any_hits(rays, answers); });
    return answers_as_array(answers, threads);
}

py::tuple all_hits(const PyQueries& self, const py::handle& origins, const py::handle& directions,
                   const py::handle& tmin, const py::handle& tmax, std::optional<int64_t> max_hits, bool points_wanted,
                   bool details_wanted, std::optional<int> threads_arg) {
    const int threads = self.threads_for(threads_arg);
    if (max_hits && *max_hits < 0)
        throw Error("max_hits must be >= 0 (None: no limit), not " + std::to_string(*max_hits));
    const std::vector<Ray> rays = rays_from_arguments(self.scene.frame, origins, directions, tmin, tmax, threads);
    ChunkedHits<QueryHit> lists;
    without_gil(threads, [&] {
        lists = collect_chunked_hits<QueryHit>(*self.queries, rays, max_hits ? size_t(*max_hits) : kNoHitLimit,
                                               [](const QueryHit& hit) { return hit; });
    });
    const py::ssize_t m = py::ssize_t(lists.size()), details = details_wanted ? m : 0;
    py::array_t<int64_t> index_ray(m), primitive(m);
    py::array_t<double> t(details), u(details), v(details);
    py::array_t<double> points(std::vector<py::ssize_t>{points_wanted ? m : 0, 3});
    int64_t *ray_out = index_ray.mutable_data(), *id_out = primitive.mutable_data();
    double *t_out = t.mutable_data(), *u_out = u.mutable_data(), *v_out = v.mutable_data(),
           *p_out = points.mutable_data();
    without_gil(threads, [&] {
        lists.for_each([&](uint64_t k, size_t ray, const QueryHit& hit) {
            ray_out[k] = int64_t(ray);
            id_out[k] = int64_t(hit.primitive);
            if (details_wanted) {
                t_out[k] = hit.t;
                u_out[k] = hit.u;
                v_out[k] = hit.v;
            }
            if (points_wanted) put_point(self.scene.frame, hit, p_out + 3 * k);
        });
    });
    return py::make_tuple(index_ray, primitive, t, u, v, points);
}

py::array_t<int64_t> count_hits(const PyQueries& self, const py::handle& origins, const py::handle& directions,
                                const py::handle& tmin, const py::handle& tmax, std::optional<int> threads_arg) {
    const int threads = self.threads_for(threads_arg);
    const std::vector<Ray> rays = rays_from_arguments(self.scene.frame, origins, directions, tmin, tmax, threads);
    py::array_t<int64_t> result(py::ssize_t(rays.size()));
    int64_t* out = result.mutable_data();
    without_gil(threads, [&] {
        std::vector<uint32_t> counts(rays.size());
        self.queries->count_hits(rays, counts);
        in_blocks(counts.size(), 1 << 14, [&](size_t begin, size_t end) {
            for (size_t i = begin; i < end; ++i) out[i] = counts[i];
        });
    });
    return result;
}

py::array_t<bool> contains(const PyQueries& self, const py::handle& points_arg, std::optional<int> threads_arg) {
    const int threads = self.threads_for(threads_arg);
    return answers_as_array(contained_points(self, points_arg, "points", threads), threads);
}

constexpr const char* kRaysDoc =
    "Rays from origins (k, 3) along directions (k, 3) (either may be one row shared by every ray) over the closed "
    "interval [tmin, tmax] (numbers, or arrays of one per ray). ";

}  // namespace

void bind_queries(py::module_& m) {
    bind_query_class<RayQueries>(
        m, "RayQueries",
        "Exact queries beyond the closest hit over a tree: every crossing of each ray (sorted by t), "
        "crossing counts, the first and any crossing, and point containment by parity. A ray through a "
        "shared edge or vertex of a connected surface crosses it once: the answers are those of the ray "
        "moved sideways by a fixed infinitesimal amount (docs/queries.md). Batch calls release the GIL.")
        .def(
            "first", &first_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
            py::arg("tmax") = double(kInfinity), py::kw_only(), py::arg("threads") = py::none(),
            (std::string(kRaysDoc) +
             "The first crossing of each ray: (t float64 (inf on a miss), primitive int64 (-1 on a miss), u, v float64 "
             "barycentrics of the second and third corners, points (k, 3) float64 in the caller's frame (NaN on a "
             "miss)).")
                .c_str())
        .def("first_primitive", &first_primitives, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = double(kInfinity), py::kw_only(), py::arg("threads") = py::none(),
             (std::string(kRaysDoc) +
              "The triangle of each first crossing, as first()[1] (int64, -1 on a miss), without the distances, "
              "barycentrics and points.")
                 .c_str())
        .def("any", &any_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = double(kInfinity), py::kw_only(), py::arg("threads") = py::none(),
             (std::string(kRaysDoc) + "Whether each ray crosses the mesh: a bool array.").c_str())
        .def("all", &all_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = double(kInfinity), py::kw_only(), py::arg("max_hits") = py::none(),
             py::arg("points") = true, py::arg("details") = true, py::arg("threads") = py::none(),
             (std::string(kRaysDoc) +
              "Every crossing, sorted by ray and then by t (ties by triangle), at most max_hits per ray (the nearest): "
              "(index_ray int64, primitive int64, t, u, v float64 (empty when details=False), points (m, 3) float64 "
              "in the caller's frame, or (0, 3) when points=False).")
                 .c_str())
        .def("count", &count_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = double(kInfinity), py::kw_only(), py::arg("threads") = py::none(),
             (std::string(kRaysDoc) + "The number of crossings of each ray: an int64 array.").c_str())
        .def("contains", &contains, py::arg("points"), py::kw_only(), py::arg("threads") = py::none(),
             "Whether each point (n, 3) is inside the mesh by the parity of the crossings of a fixed ray from it "
             "(exact; "
             "the same answer on every run and thread count). Meaningful for closed meshes; a point on the surface "
             "counts as the point moved infinitesimally against containment_direction().");
    m.def(
        "containment_direction",
        [] { return py::make_tuple(kContainmentDirection.x, kContainmentDirection.y, kContainmentDirection.z); },
        "The fixed direction (float32 values) of the rays RayQueries.contains counts crossings along.");
}

}  // namespace spacebvh::python
