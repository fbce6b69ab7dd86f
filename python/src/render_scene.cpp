// SPDX-License-Identifier: MIT
// RenderScene (docs/scenes.md): meshes from spacebvh.Scene objects, instances placed by NumPy 3x4 or
// 4x4 transforms, masks, hits with ids as arrays, filters-free batches on oneTBB, refit.
#include <cmath>
#include <deque>
#include <optional>

#include "bindings.hpp"
#include "spacebvh/presets.hpp"
#include "spacebvh/scene.hpp"

namespace spacebvh::python {

namespace {

// The triangles the scene's meshes view: owned here, at fixed addresses (a deque never moves its
// elements), and kept alive by the RenderScene's deleter as long as any scene instances it.
struct MeshBuffers {
    std::deque<std::vector<Triangle>> meshes;
};

struct PyRenderScene {
    std::shared_ptr<RenderScene> scene;
    std::shared_ptr<MeshBuffers> buffers;
    std::vector<std::vector<Triangle>*> by_id;  // a mesh's buffer by geometry id (null for instances)
    int threads = 0;
};

PyRenderScene make_scene(const std::string& builder, const std::string& kernel, const std::string& name, int threads) {
    check_threads(threads);
    SceneConfig config;
    config.recipe = TreeRecipe::for_builder(builder);
    config.tracer = parse_kernel(kernel);
    auto buffers = std::make_shared<MeshBuffers>();
    std::shared_ptr<RenderScene> scene(new RenderScene(config, name), [buffers](RenderScene* s) { delete s; });
    return {std::move(scene), std::move(buffers), {}, threads};
}

uint32_t mask_of(const py::handle& value, const char* what) {
    const py::int_ number = py::reinterpret_borrow<py::object>(value);
    const long long m = number.cast<long long>();
    if (m < 0 || m > 0xFFFFFFFFll)
        throw Error(std::string(what) + ": a mask is a 32-bit unsigned integer, in [0, 2^32), not " +
                    std::to_string(m));
    return uint32_t(m);
}

// The triangles of a spacebvh.Scene in the caller's coordinates as float32: scenes made from float64
// vertices sit in a frame of their own, which a RenderScene does not take.
const std::vector<Triangle>& triangles_of_mesh(const PyScene& mesh) {
    if (mesh.frame.origin != std::array<double, 3>{0.0, 0.0, 0.0})
        throw Error("mesh '" + mesh.scene->name +
                    "': made from float64 vertices in a frame of its own; a RenderScene takes float32 vertices "
                    "(pass vertices.astype(numpy.float32) to spacebvh.mesh)");
    return mesh.scene->triangles;
}

Affine transform_of(const py::handle& arg) {
    const auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(arg);
    if (!array) throw Error("transform: expected a (3, 4) or (4, 4) array of numbers");
    const bool shaped = array.ndim() == 2 && array.shape(1) == 4 && (array.shape(0) == 3 || array.shape(0) == 4);
    if (!shaped) {
        std::string shape;
        for (py::ssize_t d = 0; d < array.ndim(); ++d) shape += (d ? ", " : "") + std::to_string(array.shape(d));
        throw Error("transform: shape (" + shape + "), expected (3, 4) or (4, 4)");
    }
    float rows[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
    for (py::ssize_t i = 0; i < array.shape(0) * 4; ++i) rows[i] = float(array.data()[i]);
    return Affine::from_4x4(std::span<const float, 16>(rows));
}

// One mask for every ray (a Python int) or one per ray (a 1-D integer array); `arg_name` and `item`
// name the argument and what it gives masks to ("mask" and "ray" for traces).
std::vector<uint32_t> masks_of(const py::handle& arg, size_t count, uint32_t& shared,
                               const std::string& arg_name = "mask", const std::string& item = "ray") {
    if (py::isinstance<py::int_>(arg)) {
        shared = mask_of(arg, arg_name.c_str());
        return {};
    }
    const auto array = py::array::ensure(arg);
    if (!array || (array.dtype().kind() != 'i' && array.dtype().kind() != 'u'))
        throw py::type_error(arg_name + ": expected an int or a 1-D array of integers");
    if (array.ndim() != 1 || size_t(array.shape(0)) != count)
        throw Error(arg_name + ": " + std::to_string(array.ndim() == 1 ? array.shape(0) : -1) + " masks for " +
                    std::to_string(count) + " " + item + "s (give one per " + item + ", or one int)");
    const auto values = py::array_t<long long, py::array::forcecast>::ensure(array);
    std::vector<uint32_t> masks(count);
    for (size_t i = 0; i < count; ++i) {
        const long long m = values.at(py::ssize_t(i));
        if (m < 0 || m > 0xFFFFFFFFll)
            throw Error(arg_name + ": " + item + " " + std::to_string(i) + " has " + std::to_string(m) +
                        ", outside [0, 2^32)");
        masks[i] = uint32_t(m);
    }
    return masks;
}

py::array_t<int64_t> ids_array(const std::vector<SceneHit>& hits, size_t column) {
    const py::ssize_t n = py::ssize_t(hits.size());
    const bool path = column != size_t(-1);
    py::array_t<int64_t> out =
        path ? py::array_t<int64_t>({n, py::ssize_t(kMaxInstanceLevels)}) : py::array_t<int64_t>(n);
    int64_t* data = out.mutable_data();
    const auto id = [](uint32_t v) { return v == kInvalidIndex ? int64_t(-1) : int64_t(v); };
    for (size_t i = 0; i < hits.size(); ++i) {
        if (!path) {
            data[i] = id(hits[i].geometry);
            continue;
        }
        for (size_t level = 0; level < kMaxInstanceLevels; ++level)
            data[i * kMaxInstanceLevels + level] = id(hits[i].instance[level]);
    }
    return out;
}

py::tuple intersect(const PyRenderScene& self, const py::handle& origins, const py::handle& directions,
                    const py::handle& tmin, const py::handle& tmax, const py::handle& mask) {
    const std::vector<Ray> rays = rays_from_arguments(Frame{}, origins, directions, tmin, tmax, self.threads);
    TraceContext context;
    const std::vector<uint32_t> masks = masks_of(mask, rays.size(), context.mask);
    std::vector<SceneHit> hits(rays.size());
    without_gil(self.threads, [&] { self.scene->intersect(rays, hits, context, masks); });
    std::vector<Hit> plain(hits.size());
    for (size_t i = 0; i < hits.size(); ++i) plain[i] = Hit{hits[i].t, hits[i].primitive, hits[i].u, hits[i].v};
    const py::tuple first = hits_as_arrays(Frame{}, plain, self.threads);
    return py::make_tuple(first[0], first[1], first[2], first[3], ids_array(hits, size_t(-1)), ids_array(hits, 0));
}

py::array_t<bool> occluded(const PyRenderScene& self, const py::handle& origins, const py::handle& directions,
                           const py::handle& tmin, const py::handle& tmax, const py::handle& mask) {
    const std::vector<Ray> rays = rays_from_arguments(Frame{}, origins, directions, tmin, tmax, self.threads);
    TraceContext context;
    const std::vector<uint32_t> masks = masks_of(mask, rays.size(), context.mask);
    std::vector<uint8_t> answers(rays.size());
    without_gil(self.threads, [&] { self.scene->occluded(rays, answers, context, masks); });
    return answers_as_array(answers, self.threads);
}

uint32_t attach_mesh(PyRenderScene& self, const PyScene& mesh, const py::handle& mask) {
    const uint32_t m = mask_of(mask, "mask");
    std::vector<Triangle>& buffer = self.buffers->meshes.emplace_back(triangles_of_mesh(mesh));
    try {
        uint32_t id;
        {
            py::gil_scoped_release unlocked;
            id = self.scene->attach_mesh(MeshView(buffer).named(mesh.scene->name), m);
        }
        self.by_id.resize(id + 1, nullptr);
        self.by_id[id] = &buffer;
        return id;
    } catch (...) {
        self.buffers->meshes.pop_back();
        throw;
    }
}

// transforms (n, 3, 4) or (n, 4, 4), scene_index None or n integers, masks one int or n integers: one
// placement each; an error names the placement's index. Returns the n ids.
py::array_t<int64_t> attach_instances(PyRenderScene& self, const py::handle& scenes_arg, const py::handle& transforms,
                                      const py::handle& scene_index, const py::handle& masks_arg) {
    std::vector<std::shared_ptr<const RenderScene>> scenes;
    if (py::isinstance<PyRenderScene>(scenes_arg))
        scenes.push_back(scenes_arg.cast<const PyRenderScene&>().scene);
    else
        for (const py::handle item : scenes_arg.cast<py::sequence>())
            scenes.push_back(item.cast<const PyRenderScene&>().scene);
    const auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(transforms);
    if (!array || array.ndim() != 3 || array.shape(2) != 4 || (array.shape(1) != 3 && array.shape(1) != 4))
        throw Error("transforms: expected an (n, 3, 4) or (n, 4, 4) array of numbers");
    const size_t n = size_t(array.shape(0)), rows = size_t(array.shape(1));
    std::vector<InstancePlacement> placements(n);
    for (size_t k = 0; k < n; ++k) {
        float m[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
        for (size_t i = 0; i < rows * 4; ++i) m[i] = float(array.data()[k * rows * 4 + i]);
        try {
            placements[k].transform = Affine::from_4x4(std::span<const float, 16>(m));
        } catch (const Error& e) {
            throw Error("transforms[" + std::to_string(k) + "]: " + e.what());
        }
    }
    if (!scene_index.is_none()) {
        const auto index = py::array_t<long long, py::array::forcecast>::ensure(scene_index);
        if (!index || index.ndim() != 1 || size_t(index.shape(0)) != n)
            throw Error("scene_index: expected " + std::to_string(n) + " integers, one per transform");
        for (size_t k = 0; k < n; ++k) {
            const long long i = index.at(py::ssize_t(k));
            if (i < 0 || i >= (long long)scenes.size())
                throw Error("scene_index[" + std::to_string(k) + "]: " + std::to_string(i) + ", not in [0, " +
                            std::to_string(scenes.size()) + ")");
            placements[k].scene = uint32_t(i);
        }
    }
    uint32_t shared = 0xFFFFFFFFu;
    const std::vector<uint32_t> masks = masks_of(masks_arg, n, shared, "masks", "transform");
    for (size_t k = 0; k < n; ++k) placements[k].mask = masks.empty() ? shared : masks[k];
    uint32_t first;
    {
        py::gil_scoped_release unlocked;
        first = self.scene->attach_instances(scenes, placements);
    }
    self.by_id.resize(first + n, nullptr);
    py::array_t<int64_t> ids(static_cast<py::ssize_t>(n));
    for (size_t k = 0; k < n; ++k) ids.mutable_data()[k] = int64_t(first + k);
    return ids;
}

void refit(PyRenderScene& self, const std::optional<uint32_t>& id, const std::optional<PyScene>& moved) {
    if (!id) {
        if (moved) throw Error("refit: a moved mesh needs the id of the mesh it replaces");
        self.scene->refit();
        return;
    }
    std::vector<Triangle>* buffer = *id < self.by_id.size() ? self.by_id[*id] : nullptr;
    if (moved) {
        if (!buffer) throw Error("refit: geometry " + std::to_string(*id) + " is not a mesh of this scene");
        const std::vector<Triangle>& triangles = triangles_of_mesh(*moved);
        if (triangles.size() != buffer->size())
            throw Error("refit: the moved mesh has " + std::to_string(triangles.size()) + " triangles, mesh " +
                        std::to_string(*id) + " has " + std::to_string(buffer->size()));
        const std::vector<Triangle> before = *buffer;
        *buffer = triangles;
        try {
            self.scene->refit(*id);
        } catch (...) {
            *buffer = before;
            throw;
        }
        return;
    }
    self.scene->refit(*id);
}

}  // namespace

void bind_render_scene(py::module_& m) {
    py::class_<PyRenderScene>(m, "RenderScene",
                              "A scene of meshes and instances of other scenes (docs/scenes.md); spacebvh.Scene is one "
                              "triangle mesh, a RenderScene many, placed.")
        .def(py::init(&make_scene), py::arg("builder") = "binned", py::arg("kernel") = "auto",
             py::arg("name") = "scene", py::arg("threads") = 0,
             "Each mesh's tree is built by `builder`; `kernel` is a single-ray kernel name (kernels()).")
        .def("attach_mesh", &attach_mesh, py::arg("mesh"), py::arg("mask") = 0xFFFFFFFFu,
             "Adds a spacebvh.Scene (float32 coordinates) as a mesh; returns its geometry id.")
        .def(
            "attach_instance",
            [](PyRenderScene& self, const PyRenderScene& child, const py::handle& transform, const py::handle& mask) {
                const uint32_t id =
                    self.scene->attach_instance(child.scene, transform_of(transform), mask_of(mask, "mask"));
                self.by_id.resize(id + 1, nullptr);
                return id;
            },
            py::arg("scene"), py::arg("transform"), py::arg("mask") = 0xFFFFFFFFu,
            "Places a committed RenderScene by a (3, 4) or (4, 4) transform (parent = A local + b); returns its id.")
        .def("attach_instances", &attach_instances, py::arg("scenes"), py::arg("transforms"),
             py::arg("scene_index") = py::none(), py::arg("masks") = 0xFFFFFFFFu,
             "Places committed RenderScenes by (n, 3, 4) or (n, 4, 4) transforms at once: scenes is one scene or a "
             "list, scene_index (n integers, default all 0) picks each one's scene, masks is one int or n; returns "
             "the n consecutive ids. An error names the first bad entry; nothing is attached then.")
        .def(
            "detach", [](PyRenderScene& self, uint32_t id) { self.scene->detach(id); }, py::arg("id"),
            "Removes geometry `id` (its id is not reused); refused while other scenes instance this one.")
        .def(
            "set_mask",
            [](PyRenderScene& self, uint32_t id, const py::handle& mask) {
                self.scene->set_mask(id, mask_of(mask, "mask"));
            },
            py::arg("id"), py::arg("mask"), "Sets the 32-bit mask of geometry `id`.")
        .def(
            "commit", [](PyRenderScene& self) { self.scene->commit(); }, "Builds the top level over the geometries.")
        .def("refit", &refit, py::arg("id") = py::none(), py::arg("mesh") = py::none(),
             "refit(id, mesh): mesh `id` takes the moved triangles of `mesh` (same count) and its tree is refitted; "
             "refit(): the top level follows the instanced scenes' refits.")
        .def("intersect", &intersect, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = INFINITY, py::arg("mask") = 0xFFFFFFFFu,
             "Closest hits: (t, primitive, u, v, geometry, instance) with instance (n, 4) ids from this scene down; "
             "-1 (and t = inf) where nothing is hit.")
        .def("occluded", &occluded, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = INFINITY, py::arg("mask") = 0xFFFFFFFFu, "Whether anything lies in [tmin, tmax].")
        .def_property_readonly(
            "name", [](const PyRenderScene& self) { return self.scene->name(); }, "The name given, used in errors.")
        .def_property_readonly(
            "committed", [](const PyRenderScene& self) { return self.scene->committed(); },
            "Whether the top level is built over the current geometries.")
        .def_property_readonly(
            "depth", [](const PyRenderScene& self) { return self.scene->depth(); },
            "Instance levels below this scene (0 with meshes only).")
        .def_property_readonly(
            "geometry_count", [](const PyRenderScene& self) { return self.scene->geometry_count(); },
            "Attached meshes and instances.")
        .def_property_readonly(
            "bounds",
            [](const PyRenderScene& self) {
                const AABB b = self.scene->bounds();
                return py::make_tuple(py::make_tuple(b.lo.x, b.lo.y, b.lo.z), py::make_tuple(b.hi.x, b.hi.y, b.hi.z));
            },
            "((xmin, ymin, zmin), (xmax, ymax, zmax)) of the committed top level.");
}

}  // namespace spacebvh::python
