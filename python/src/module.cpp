// SPDX-License-Identifier: MIT
// The extension module spacebvh._core: scenes from files or NumPy arrays, the named builders, tree
// metrics, and the tracers on NumPy ray arrays (re-exported by the package spacebvh). A thin layer
// over the C++ API: every check and every answer is the library's; its errors become spacebvh.Error.
#include "bindings.hpp"

#ifndef SPACEBVH_VERSION
#define SPACEBVH_VERSION "0+unknown"
#endif

namespace py = pybind11;

PYBIND11_MODULE(_core, m) {
    using namespace spacebvh::python;
    m.doc() = "spacebvh: BVHs built by space subdivision (Popov et al. 2009), their metrics and exact tracers";
    m.attr("__version__") = SPACEBVH_VERSION;

    // spacebvh.Error: a RuntimeError (what the library reports) that is also a ValueError (most of it
    // is about bad input), so either `except` catches it.
    PYBIND11_CONSTINIT static py::gil_safe_call_once_and_store<py::object> error_type;
    error_type.call_once_and_store_result([] {
        const py::tuple bases = py::make_tuple(py::handle(PyExc_RuntimeError), py::handle(PyExc_ValueError));
        PyObject* type = PyErr_NewExceptionWithDoc("spacebvh.Error",
                                                   "A library error: bad input (named with where it is), an unreadable "
                                                   "file, or an option out of range.",
                                                   bases.ptr(), nullptr);
        if (type == nullptr) throw py::error_already_set();
        return py::reinterpret_steal<py::object>(type);
    });
    m.attr("Error") = error_type.get_stored();
    py::register_exception_translator([](std::exception_ptr pointer) {
        try {
            if (pointer) std::rethrow_exception(pointer);
        } catch (const spacebvh::Error& e) {
            PyErr_SetString(error_type.get_stored().ptr(), e.what());
        }
    });

    bind_scenes(m);
    bind_settings(m);
    bind_build(m);
    py::class_<PyTracer> tracer = bind_tracer(m);
    bind_render(m, tracer);
    bind_rays(m);
    bind_embree(m);
    bind_queries(m);
    bind_float64(m);
    bind_distance(m);
    bind_render_scene(m);
    bind_geometry_map(m);
}
