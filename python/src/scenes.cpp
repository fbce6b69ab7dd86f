// SPDX-License-Identifier: MIT
// Scenes: from files and built-in names (float32, the caller's frame) or from NumPy meshes (float32 as
// given; float64 taken into a local frame centred on the mesh's bounds), and hit points computed
// from the triangles in double.
#include <algorithm>
#include <cmath>
#include <limits>

#include <cstring>

#include <pybind11/stl.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "bindings.hpp"

namespace spacebvh::python {

namespace {

SceneTransform make_transform(const std::string& rotate, float scale, const std::vector<float>& translate) {
    SceneTransform transform;
    if (!rotate.empty()) transform.rotate_degrees = SceneTransform::parse_rotation(rotate);
    transform.scale = scale;
    if (translate.size() != 3) throw Error("translate must be three numbers (x, y, z)");
    transform.translate = {translate[0], translate[1], translate[2]};
    if (const char* reason = transform.invalid_reason()) throw Error(reason);
    return transform;
}

// The frame of a mesh: float32 vertices stay as given (the kernels' answers are then the exact
// arbiter's for the caller's own triangles); float64 ones are centred on their bounds. Checks that
// every vertex is finite, and fits float32 in the frame.
template <typename V>
Frame frame_of(const V& vertex, size_t count, bool float64) {
    auto not_finite = [](size_t i) {
        return Error("vertices: vertex " + std::to_string(i) + " has a coordinate that is not finite");
    };
    Frame frame;
    frame.float64 = float64;
    std::array<double, 3> lo{}, hi{};
    lo.fill(std::numeric_limits<double>::infinity());
    hi.fill(-std::numeric_limits<double>::infinity());
    for (size_t i = 0; i < count; ++i)
        for (int axis = 0; axis < 3; ++axis) {
            const double x = vertex(i, axis);
            if (!std::isfinite(x)) throw not_finite(i);
            lo[size_t(axis)] = std::min(lo[size_t(axis)], x);
            hi[size_t(axis)] = std::max(hi[size_t(axis)], x);
        }
    if (!float64 || count == 0) return frame;
    for (size_t axis = 0; axis < 3; ++axis) frame.origin[axis] = lo[axis] + (hi[axis] - lo[axis]) * 0.5;
    for (int axis = 0; axis < 3; ++axis)
        if (!std::isfinite(frame.to_local(lo[size_t(axis)], axis)) ||
            !std::isfinite(frame.to_local(hi[size_t(axis)], axis)))
            for (size_t i = 0; i < count; ++i)
                if (!std::isfinite(frame.to_local(vertex(i, axis), axis)))
                    throw Error("vertices: vertex " + std::to_string(i) +
                                " lies beyond float32's range of its mesh's centre");
    return frame;
}

PyScene make_mesh(const py::handle& vertices_arg, const py::handle& faces_arg, const std::string& name) {
    const RealRows vertices = RealRows::from(vertices_arg, "vertices");
    const IndexRows faces = IndexRows::from(faces_arg, "faces");
    if (faces.rows() == 0) throw Error("faces: no triangles (shape (0, 3))");
    auto scene = std::make_shared<Scene>();
    scene->name = name;
    Frame frame;
    {
        py::gil_scoped_release unlocked;
        vertices.visit([&](const auto& vertex) {
            const size_t count = vertices.rows();
            frame = frame_of(vertex, count, vertices.is_float64());
            auto corner = [&](size_t triangle, int k) {
                const int64_t index = faces(triangle, k);
                if (index < 0 || uint64_t(index) >= count)
                    throw Error("faces: triangle " + std::to_string(triangle) + " uses vertex " +
                                std::to_string(index) + ", outside 0.." + std::to_string(int64_t(count) - 1));
                const size_t i = size_t(index);
                return Vec3{frame.to_local(vertex(i, 0), 0), frame.to_local(vertex(i, 1), 1),
                            frame.to_local(vertex(i, 2), 2)};
            };
            scene->triangles.reserve(faces.rows());
            for (size_t t = 0; t < faces.rows(); ++t)
                scene->triangles.push_back({corner(t, 0), corner(t, 1), corner(t, 2)});
        });
        scene->degenerate_count = size_t(std::count_if(scene->triangles.begin(), scene->triangles.end(),
                                                       [](const Triangle& t) { return t.is_degenerate(); }));
    }
    return {std::move(scene), frame};
}

// Points on the triangles at barycentrics (u, v), in the caller's frame, computed in double from the
// triangle's corners (so their precision is the mesh's, not that of o + t d in float32). NaN for a
// miss (primitive -1).
py::array hit_points(const PyScene& self, const py::handle& primitive_arg, const py::handle& u_arg,
                     const py::handle& v_arg) {
    const auto primitive = py::array_t<int64_t, py::array::forcecast>::ensure(primitive_arg);
    const auto u = py::array_t<double, py::array::forcecast>::ensure(u_arg);
    const auto v = py::array_t<double, py::array::forcecast>::ensure(v_arg);
    if (!primitive || !u || !v || primitive.ndim() != 1 || u.ndim() != 1 || v.ndim() != 1 ||
        u.shape(0) != primitive.shape(0) || v.shape(0) != primitive.shape(0))
        throw Error("primitive, u and v must be 1-D arrays of one length (intersect()'s answers)");
    const py::ssize_t n = primitive.shape(0);
    py::array_t<double> points({n, py::ssize_t(3)});
    const auto p = primitive.unchecked<1>();
    const auto uu = u.unchecked<1>(), vv = v.unchecked<1>();
    auto out = points.mutable_unchecked<2>();
    const std::vector<Triangle>& triangles = self.scene->triangles;
    for (py::ssize_t i = 0; i < n; ++i)
        if (p(i) >= 0 && size_t(p(i)) >= triangles.size())
            throw Error("primitive: hit " + std::to_string(i) + " names triangle " + std::to_string(p(i)) + " of " +
                        std::to_string(triangles.size()));
    // Checked above, so the blocks cannot fail; they write disjoint rows.
    without_gil(0, [&] {
        tbb::parallel_for(tbb::blocked_range<py::ssize_t>(0, n, 1 << 14),
                          [&](const tbb::blocked_range<py::ssize_t>& r) {
                              for (py::ssize_t i = r.begin(); i < r.end(); ++i) {
                                  if (p(i) < 0) {
                                      for (int axis = 0; axis < 3; ++axis)
                                          out(i, axis) = std::numeric_limits<double>::quiet_NaN();
                                      continue;
                                  }
                                  const Triangle& t = triangles[size_t(p(i))];
                                  for (int axis = 0; axis < 3; ++axis)
                                      out(i, axis) = point_at(t, uu(i), vv(i), self.frame, axis);
                              }
                          });
    });
    if (self.frame.float64) return points;
    return points.attr("astype")("float32").cast<py::array>();
}

py::array triangles_of(const PyScene& self) {
    const std::vector<Triangle>& triangles = self.scene->triangles;
    const py::ssize_t n = py::ssize_t(triangles.size());
    py::array result = new_real_array(self.frame.float64, {n, 3, 3});
    auto fill = [&](auto typed) {
        using T = decltype(typed);
        T* out = static_cast<T*>(result.mutable_data());
        for (size_t i = 0; i < triangles.size(); ++i)
            for (int corner = 0; corner < 3; ++corner) {
                const Vec3& p = corner == 0 ? triangles[i].v0 : corner == 1 ? triangles[i].v1 : triangles[i].v2;
                for (int axis = 0; axis < 3; ++axis) *out++ = T(self.frame.to_caller(p[axis], axis));
            }
    };
    if (self.frame.float64)
        fill(double());
    else
        fill(float());
    return result;
}

}  // namespace

Camera camera_in_frame(const PyScene& scene, const std::string& text) {
    if (text.empty()) return default_camera(*scene.scene);
    Camera camera = Camera::parse(text);
    for (int axis = 0; axis < 3; ++axis) {
        camera.eye[axis] = scene.frame.to_local(camera.eye[axis], axis);
        camera.target[axis] = scene.frame.to_local(camera.target[axis], axis);
    }
    return camera;
}

void bind_scenes(py::module_& m) {
    py::class_<PyScene>(m, "Scene",
                        "Triangles in file (or index) order; degenerate ones are kept and never hit. Scenes made from "
                        "float64 vertices hold them in a frame centred on their bounds (origin) and answer in float64 "
                        "in the caller's frame.")
        .def_property_readonly(
            "name", [](const PyScene& s) { return s.scene->name; }, "The file stem, builtin name or mesh name.")
        // Pickling: the triangles' float32 bytes (as the scene holds them) and the frame, so a scene
        // comes back bit for bit and a tree saved over it still matches its geometry hash.
        .def(py::pickle(
            [](const PyScene& s) {
                const auto& triangles = s.scene->triangles;
                const py::bytes data(reinterpret_cast<const char*>(triangles.data()),
                                     triangles.size() * sizeof(Triangle));
                return py::make_tuple(s.scene->name, data,
                                      py::make_tuple(s.frame.origin[0], s.frame.origin[1], s.frame.origin[2]),
                                      s.frame.float64);
            },
            [](const py::tuple& state) {
                if (state.size() != 4)
                    throw Error("Scene pickle: expected 4 fields, got " + std::to_string(state.size()));
                auto scene = std::make_shared<Scene>();
                scene->name = state[0].cast<std::string>();
                const std::string data = state[1].cast<std::string>();
                if (data.size() % sizeof(Triangle) != 0) throw Error("Scene pickle: triangle data of a wrong length");
                scene->triangles.resize(data.size() / sizeof(Triangle));
                std::memcpy(scene->triangles.data(), data.data(), data.size());
                (void)MeshView(scene->triangles).named(scene->name).triangles();  // refuses NaN/inf coordinates
                scene->degenerate_count = size_t(std::count_if(scene->triangles.begin(), scene->triangles.end(),
                                                               [](const Triangle& t) { return t.is_degenerate(); }));
                Frame frame;
                const auto origin = state[2].cast<std::array<double, 3>>();
                frame.origin = origin;
                frame.float64 = state[3].cast<bool>();
                return PyScene{std::move(scene), frame};
            }))
        .def_property_readonly(
            "triangle_count", [](const PyScene& s) { return s.scene->triangles.size(); },
            "Number of triangles, degenerate ones included.")
        .def_property_readonly(
            "degenerate_count", [](const PyScene& s) { return s.scene->degenerate_count; },
            "Number of zero-area triangles (never hit).")
        .def_property_readonly(
            "bounds",
            [](const PyScene& s) {
                const AABB box = s.scene->bounds();
                const Frame& f = s.frame;
                return py::make_tuple(
                    py::make_tuple(f.to_caller(box.lo.x, 0), f.to_caller(box.lo.y, 1), f.to_caller(box.lo.z, 2)),
                    py::make_tuple(f.to_caller(box.hi.x, 0), f.to_caller(box.hi.y, 1), f.to_caller(box.hi.z, 2)));
            },
            "((xmin, ymin, zmin), (xmax, ymax, zmax)) in the caller's frame.")
        .def_property_readonly(
            "origin",
            [](const PyScene& s) { return py::make_tuple(s.frame.origin[0], s.frame.origin[1], s.frame.origin[2]); },
            "Where the scene's local frame sits in the caller's: (0, 0, 0) unless made from float64 vertices.")
        .def_property_readonly(
            "dtype", [](const PyScene& s) { return py::dtype(s.frame.float64 ? "float64" : "float32"); },
            "The dtype of coordinates and distances this scene answers in: float64 for a float64 mesh, else float32.")
        .def("triangles", &triangles_of,
             "The triangles as traced, (m, 3, 3) in the caller's frame and the scene's dtype (a float64 mesh's "
             "vertices as rounded in its local frame).")
        .def("hit_points", &hit_points, py::arg("primitive"), py::arg("u"), py::arg("v"),
             "Points at barycentrics (u, v) of the triangles `primitive` (intersect()'s answers), (k, 3) in the "
             "caller's "
             "frame, computed in double from the triangles' corners; NaN rows for misses (primitive -1).")
        .def("__repr__", [](const PyScene& s) {
            return "<spacebvh.Scene '" + s.scene->name + "', " + std::to_string(s.scene->triangles.size()) +
                   " triangles" + (s.frame.float64 ? ", float64" : "") + ">";
        });

    m.def(
        "load_scene",
        [](const std::string& source, const std::string& rotate, float scale, const std::vector<float>& translate) {
            const SceneTransform transform = make_transform(rotate, scale, translate);
            auto scene = std::make_shared<Scene>();
            {
                py::gil_scoped_release unlocked;
                *scene = load_scene(source, transform);
            }
            return PyScene{std::move(scene), Frame{}};
        },
        py::arg("source"), py::kw_only(), py::arg("rotate") = "", py::arg("scale") = 1.0f,
        py::arg("translate") = std::vector<float>{0.0f, 0.0f, 0.0f},
        "Loads .obj, .ply, .gltf or .glb, or builtin:NAME (see builtin_scenes()), with the CLI's load-time transform: "
        "rotate='x:45,y:45,z:45' (degrees, R = Rz*Ry*Rx), then scale, then translate.");
    m.def("mesh", &make_mesh, py::arg("vertices"), py::arg("faces"), py::arg("name") = "mesh",
          "A scene from an indexed mesh: vertices (n, 3) float32 or float64 (other real dtypes become float64), faces "
          "(m, 3) 0-based vertex indices of any integer dtype; any memory order, read in place. float64 vertices are "
          "taken into a frame centred on their bounds before rounding to float32 (Scene.origin), so small features far "
          "from the coordinate origin keep their precision; answers come back in the caller's frame as float64.");
    m.def("builtin_scenes", &builtin_scene_names, "The names accepted by load_scene('builtin:NAME').");
}

}  // namespace spacebvh::python
