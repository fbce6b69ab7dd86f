// SPDX-License-Identifier: MIT
// What the files of the extension module spacebvh._core share: the Python-side objects (a scene with
// its frame, a tree with its scene, a tracer with both), running work on a bounded number of
// oneTBB threads, and one bind_* function per concern (module.cpp calls them in order).
#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "numpy_args.hpp"
#include "spacebvh/bvh.hpp"
#include "spacebvh/error.hpp"
#include "spacebvh/queries.hpp"
#include "spacebvh/recipe.hpp"
#include "spacebvh/tools/scene.hpp"
#include "spacebvh/trace.hpp"

namespace spacebvh::python {

using namespace spacebvh::tools;

namespace py = pybind11;

// A scene (immutable once made, shared by the trees and tracers over it) and the frame its
// coordinates are in.
struct PyScene {
    std::shared_ptr<const Scene> scene;
    Frame frame;
};

// A tree with the scene it was built over (a tracer needs both), and the recipe that built it (null
// for a tree loaded from a file).
struct PyBvh {
    PyScene scene;
    std::shared_ptr<const Bvh> bvh;
    std::shared_ptr<const TreeRecipe> recipe = nullptr;
};

struct PyTracer {
    PyScene scene;
    std::shared_ptr<const Bvh> bvh;
    std::unique_ptr<Tracer> tracer;
    int threads = 0;
};

// Checks a `threads` argument: 0 = every core, n > 0 at most n threads.
inline void check_threads(int threads) {
    if (threads < 0) throw Error("threads must be >= 0 (0 = every core), not " + std::to_string(threads));
}

// An object of a query class over one tree (RayQueries, DistanceQueries): the scene with its frame,
// the queries made from the tree, and the default thread limit of batch calls.
template <class Queries>
struct PyQueryObject {
    PyScene scene;
    std::shared_ptr<const Queries> queries;
    int threads = 0;

    // A call's `threads` argument, or the default where it is None.
    int threads_for(std::optional<int> threads_arg) const { return threads_arg ? *threads_arg : threads; }
};

// The class `name` over PyQueryObject<Queries>: made from a tree and a default thread limit (Queries
// made from the tree's triangles without the GIL), with the read-only properties `scene` and `threads`.
template <class Queries>
py::class_<PyQueryObject<Queries>> bind_query_class(py::module_& m, const char* name, const char* doc) {
    using Object = PyQueryObject<Queries>;
    py::class_<Object> bound(m, name, doc);
    bound
        .def(py::init([](const PyBvh& tree, int threads) {
                 check_threads(threads);
                 std::shared_ptr<const Queries> queries;
                 {
                     py::gil_scoped_release unlocked;
                     queries = std::make_shared<const Queries>(tree.scene.scene->triangles, *tree.bvh);
                 }
                 return Object{tree.scene, std::move(queries), threads};
             }),
             py::arg("bvh"), py::arg("threads") = 0,
             "Queries over the tree `bvh` (spacebvh.build). `threads`: the default thread limit (0 = every core).")
        .def_property_readonly(
            "scene", [](const Object& self) { return self.scene; }, "The scene queried.")
        .def_property_readonly(
            "threads", [](const Object& self) { return self.threads; },
            "The default thread limit of batch calls (0 = every core).");
    return bound;
}

// The calling thread's arena of `threads` oneTBB threads (0: the default, every core), made on the
// thread's first call with that count and kept for the thread's life. An arena made and destroyed on
// every call, from several Python threads at once, makes the process grow without bound
// (bench/python_soak.py shows it); a kept arena also saves its setup on every call.
inline tbb::task_arena& arena_of_this_thread(int threads) {
    thread_local std::map<int, std::unique_ptr<tbb::task_arena>> arenas;
    std::unique_ptr<tbb::task_arena>& arena = arenas[threads];
    // A copy of task_arena::automatic, not a reference to it: the library does not export the constant.
    const int concurrency = threads == 0 ? int(tbb::task_arena::automatic) : threads;
    if (!arena) arena = std::make_unique<tbb::task_arena>(concurrency);
    return *arena;
}

// Runs `work` in the calling thread's arena of `threads` oneTBB threads. Call without the GIL.
template <typename Work>
void in_arena(int threads, Work&& work) {
    check_threads(threads);
    arena_of_this_thread(threads).execute(std::forward<Work>(work));
}

// The same, releasing the GIL for the duration.
template <typename Work>
void without_gil(int threads, Work&& work) {
    check_threads(threads);
    py::gil_scoped_release unlocked;
    in_arena(threads, std::forward<Work>(work));
}

// Runs body(begin, end) over [0, n) in blocks of about `grain` across the calling arena (inside
// in_arena or without_gil): the answer conversions, each block writing its own rows.
template <class Body>
void in_blocks(size_t n, size_t grain, Body&& body) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, grain),
                      [&](const tbb::blocked_range<size_t>& range) { body(range.begin(), range.end()); });
}

// Coordinate `axis` of the point at barycentrics (u, v) of triangle t, in the caller's frame: computed
// in double from the triangle's corners, so its precision is the mesh's, not that of o + t d in
// float32. Scene.hit_points and Tracer.hits share it, so their points agree bit for bit.
inline double point_at(const Triangle& t, double u, double v, const Frame& frame, int axis) {
    const double w = 1.0 - u - v;
    return w * double(t.v0[axis]) + u * double(t.v1[axis]) + v * double(t.v2[axis]) + frame.origin[size_t(axis)];
}

// A camera string ('ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy') in the caller's frame, taken into the scene's;
// empty: the scene's default camera of docs/rays.md.
Camera camera_in_frame(const PyScene& scene, const std::string& text);

void bind_scenes(py::module_& m);
void bind_settings(py::module_& m);  // settings.cpp: Quality, build_settings()
void bind_build(py::module_& m);
py::class_<PyTracer> bind_tracer(py::module_& m);  // the class, for bind_render's methods
void bind_rays(py::module_& m);
void bind_render(py::module_& m, py::class_<PyTracer>& tracer);
void bind_embree(py::module_& m);
void bind_queries(py::module_& m);       // queries.cpp: RayQueries
void bind_float64(py::module_& m);       // float64.cpp: Tracer64
void bind_distance(py::module_& m);      // distance.cpp: DistanceQueries
void bind_render_scene(py::module_& m);  // render_scene.cpp: RenderScene
void bind_geometry_map(py::module_& m);  // geometry_map.cpp: GeometryMap (spacebvh.open3d)

// settings.cpp: build()'s recipe from its builder or quality and its keywords (exactly the settings
// table's names); a recipe's settings as a dict; build()'s docstring, listing the settings.
TreeRecipe recipe_from(const std::optional<std::string>& builder, const py::object& quality,
                       const py::kwargs& settings);
py::dict settings_of(const TreeRecipe& recipe);
const std::string& build_doc();

// Closest hits as (t, primitive, u, v) arrays: t in the scene's dtype (inf on a miss), primitive
// int64 (-1 on a miss), u, v float32. Used by every tracer binding. Both converters run across
// `threads` threads without the GIL.
py::tuple hits_as_arrays(const Frame& frame, const std::vector<Hit>& hits, int threads);
py::array_t<bool> answers_as_array(const std::vector<uint8_t>& answers, int threads);
// Any-hit answers of the source's rays, traced block by block (in_ray_blocks) across `threads` threads
// without the GIL, each block's answers written straight into the bool array.
py::array_t<bool> occluded_in_blocks(const Tracer& tracer, const RaySource& source, int threads);

// queries.cpp: whether each point (k, 3) of the argument `what` is inside by RayQueries::contains,
// across `threads` threads without the GIL; a point that is not finite raises Error naming its row.
std::vector<uint8_t> contained_points(const PyQueryObject<RayQueries>& self, const py::handle& points_arg,
                                      const char* what, int threads);

}  // namespace spacebvh::python
