// SPDX-License-Identifier: MIT
// Tracer64: float64 meshes and rays traced exactly (docs/float64.md), on NumPy arrays.
#include <optional>

#include "bindings.hpp"
#include "spacebvh/float64.hpp"
#include "spacebvh/presets.hpp"

namespace spacebvh::python {

namespace {

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

struct PyTracer64 {
    std::unique_ptr<Tracer64> tracer;
    size_t triangle_count = 0;
    int threads = 0;
};

// An (n, 3) array (or one (3,) row) of float64, checked.
Doubles rows_of_three(const py::handle& object, const char* what) {
    Doubles array = Doubles::ensure(object);
    if (!array) throw Error(std::string(what) + " must be an array of numbers");
    if (array.ndim() == 1 && array.shape(0) == 3) array = array.reshape({py::ssize_t(1), py::ssize_t(3)});
    if (array.ndim() != 2 || array.shape(1) != 3) throw Error(std::string(what) + " must have shape (n, 3)");
    return array;
}

// tmin/tmax: None (the default), a number, or one per ray.
std::vector<double> per_ray(const py::handle& object, size_t rays, double fallback, const char* what) {
    if (object.is_none()) return std::vector<double>(rays, fallback);
    Doubles array = Doubles::ensure(object);
    if (!array) throw Error(std::string(what) + " must be None, a number or an array of numbers");
    if (array.ndim() == 0) return std::vector<double>(rays, *array.data());
    if (array.ndim() != 1 || size_t(array.shape(0)) != rays)
        throw Error(std::string(what) + " must be a number or have one value per ray (" + std::to_string(rays) + ")");
    return {array.data(), array.data() + rays};
}

std::vector<Ray64> rays_from(const py::handle& origins, const py::handle& directions, const py::handle& tmin,
                             const py::handle& tmax) {
    const Doubles org = rows_of_three(origins, "origins"), dir = rows_of_three(directions, "directions");
    if (org.shape(0) != dir.shape(0))
        throw Error("origins and directions differ in length (" + std::to_string(org.shape(0)) + " and " +
                    std::to_string(dir.shape(0)) + ")");
    const size_t count = size_t(org.shape(0));
    const std::vector<double> lo = per_ray(tmin, count, 0.0, "tmin");
    const std::vector<double> hi = per_ray(tmax, count, std::numeric_limits<double>::infinity(), "tmax");
    std::vector<Ray64> rays(count);
    for (size_t i = 0; i < count; ++i) {
        for (int a = 0; a < 3; ++a) {
            rays[i].org[a] = org.data()[3 * i + a];
            rays[i].dir[a] = dir.data()[3 * i + a];
        }
        rays[i].tmin = lo[i];
        rays[i].tmax = hi[i];
    }
    return rays;
}

}  // namespace

void bind_float64(py::module_& m) {
    py::class_<PyTracer64>(m, "Tracer64",
                           "A float64 mesh traced exactly with float64 rays: coordinates are never rounded to float32 "
                           "on the way to a decision (docs/float64.md).")
        .def(py::init([](const py::handle& vertices, const py::handle& faces, const std::string& builder, int threads) {
                 check_threads(threads);
                 const Doubles xyz = rows_of_three(vertices, "vertices");
                 using Indices = py::array_t<int64_t, py::array::c_style | py::array::forcecast>;
                 const Indices indices = Indices::ensure(faces);
                 if (!indices || indices.ndim() != 2 || indices.shape(1) != 3)
                     throw Error("faces must be an integer array of shape (m, 3)");
                 const BuildConfig config = config_for(builder);
                 PyTracer64 self;
                 self.threads = threads;
                 self.triangle_count = size_t(indices.shape(0));
                 const MeshView mesh(std::span<const double>(xyz.data(), size_t(xyz.size())),
                                     std::span<const int64_t>(indices.data(), size_t(indices.size())));
                 without_gil(threads, [&] { self.tracer = std::make_unique<Tracer64>(mesh, config); });
                 return self;
             }),
             py::arg("vertices"), py::arg("faces"), py::arg("builder") = "binned", py::arg("threads") = 0,
             "Builds the tree (a builder of builders()) over the mesh: vertices (n, 3) float64, faces (m, 3) "
             "vertex indices.")
        .def(
            "intersect",
            [](const PyTracer64& self, const py::handle& origins, const py::handle& directions, const py::handle& tmin,
               const py::handle& tmax) {
                const std::vector<Ray64> rays = rays_from(origins, directions, tmin, tmax);
                std::vector<Hit64> hits(rays.size());
                without_gil(self.threads, [&] { self.tracer->intersect(rays, hits); });
                const py::ssize_t n = py::ssize_t(hits.size());
                py::array_t<double> t(n), u(n), v(n);
                py::array_t<int64_t> primitive(n);
                double *t_out = t.mutable_data(), *u_out = u.mutable_data(), *v_out = v.mutable_data();
                int64_t* id_out = primitive.mutable_data();
                for (py::ssize_t i = 0; i < n; ++i) {
                    t_out[i] = hits[i].t;
                    id_out[i] = hits[i].is_hit() ? int64_t(hits[i].primitive) : -1;
                    u_out[i] = hits[i].u;
                    v_out[i] = hits[i].v;
                }
                return py::make_tuple(t, primitive, u, v);
            },
            py::arg("origins"), py::arg("directions"), py::arg("tmin") = py::none(), py::arg("tmax") = py::none(),
            "Closest hits: (t float64, inf on a miss; primitive int64, -1 on a miss; u, v float64 barycentrics of "
            "the second and third corner). Exact for t in [tmin, tmax].")
        .def(
            "occluded",
            [](const PyTracer64& self, const py::handle& origins, const py::handle& directions, const py::handle& tmin,
               const py::handle& tmax) {
                const std::vector<Ray64> rays = rays_from(origins, directions, tmin, tmax);
                std::vector<uint8_t> answers(rays.size());
                without_gil(self.threads, [&] { self.tracer->occluded(rays, answers); });
                return answers_as_array(answers, self.threads);
            },
            py::arg("origins"), py::arg("directions"), py::arg("tmin") = py::none(), py::arg("tmax") = py::none(),
            "Whether each ray hits anything for t in [tmin, tmax] (exact).")
        .def_property_readonly(
            "triangle_count", [](const PyTracer64& self) { return self.triangle_count; },
            "The number of triangles traced.")
        .def_property_readonly(
            "frame_origin",
            [](const PyTracer64& self) {
                const Vec3d& o = self.tracer->frame_origin();
                return py::make_tuple(o[0], o[1], o[2]);
            },
            "The centre of the local frame the tree's float32 boxes are built in (float64 x, y, z in the "
            "caller's frame); hits are decided on the float64 triangles, not in this frame.");
}

}  // namespace spacebvh::python
