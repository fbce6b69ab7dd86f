// SPDX-License-Identifier: MIT
// Embree 3's own scene and kernel on the same rays: the yardstick of every benchmark. Single rays
// (rtcIntersect1 / rtcOccluded1) or 16-wide packets (rtcIntersect16 / rtcOccluded16). Embree is not
// watertight: near edges and vertices its answers may differ from ours (the arbiter of rays.md
// settles such cases in our favour).
// A build without Embree (SPACEBVH_WITH_EMBREE off: the self-contained wheel) has no EmbreeTracer.
#include <optional>

#include "bindings.hpp"

#ifndef SPACEBVH_WITH_EMBREE
namespace spacebvh::python {
void bind_embree(py::module_&) {}
}  // namespace spacebvh::python
#else
#include "spacebvh/tools/embree_scene.hpp"

namespace spacebvh::python {

using namespace spacebvh::tools;

namespace {

struct PyEmbreeTracer {
    PyScene scene;
    std::unique_ptr<EmbreeScene> embree;
    bool packets = false;
    int threads = 0;
};

int threads_for(const PyEmbreeTracer& self, std::optional<int> threads) { return threads ? *threads : self.threads; }

py::tuple closest_hits(const PyEmbreeTracer& self, const py::handle& origins, const py::handle& directions,
                       const py::handle& tmin, const py::handle& tmax, std::optional<int> threads_arg) {
    const int threads = threads_for(self, threads_arg);
    const std::vector<Ray> rays = rays_from_arguments(self.scene.frame, origins, directions, tmin, tmax, threads);
    std::vector<Hit> hits(rays.size());
    without_gil(threads,
                [&] { self.packets ? self.embree->intersect16(rays, hits) : self.embree->intersect(rays, hits); });
    return hits_as_arrays(self.scene.frame, hits, threads);
}

py::array_t<bool> any_hits(const PyEmbreeTracer& self, const py::handle& origins, const py::handle& directions,
                           const py::handle& tmin, const py::handle& tmax, std::optional<int> threads_arg) {
    const int threads = threads_for(self, threads_arg);
    const std::vector<Ray> rays = rays_from_arguments(self.scene.frame, origins, directions, tmin, tmax, threads);
    std::vector<uint8_t> answers(rays.size());
    without_gil(threads,
                [&] { self.packets ? self.embree->occluded16(rays, answers) : self.embree->occluded(rays, answers); });
    return answers_as_array(answers, threads);
}

}  // namespace

void bind_embree(py::module_& m) {
    py::class_<PyEmbreeTracer>(m, "EmbreeTracer",
                               "Embree 3's own BVH and kernel over a scene, on the same numpy rays (not watertight).")
        .def(py::init([](const PyScene& scene, const std::string& quality, bool packets, int threads) {
                 const EmbreeQuality level = parse_embree_quality(quality);
                 std::unique_ptr<EmbreeScene> embree;
                 without_gil(threads, [&] { embree = std::make_unique<EmbreeScene>(*scene.scene, level); });
                 return PyEmbreeTracer{scene, std::move(embree), packets, threads};
             }),
             py::arg("scene"), py::arg("quality") = "high", py::arg("packets") = false, py::arg("threads") = 0,
             "quality: 'low', 'medium' or 'high' (RTC_BUILD_QUALITY_*); packets: rtcIntersect16/rtcOccluded16 over "
             "groups of 16 consecutive rays instead of single rays; threads: as Tracer's.")
        .def_property_readonly(
            "kernel",
            [](const PyEmbreeTracer& self) {
                return std::string("embree-") + to_string(self.embree->quality()) +
                       (self.packets ? " rtcIntersect16" : " rtcIntersect1");
            },
            "The Embree build quality and call, e.g. 'embree-high rtcIntersect1'.")
        .def_property_readonly(
            "build_ms", [](const PyEmbreeTracer& self) { return self.embree->build_milliseconds(); },
            "Embree's build time in milliseconds.")
        .def_property_readonly(
            "memory_bytes", [](const PyEmbreeTracer& self) { return self.embree->memory_bytes(); },
            "Bytes Embree allocated for the scene.")
        .def_property_readonly(
            "scene", [](const PyEmbreeTracer& self) { return self.scene; }, "The scene traced.")
        .def("intersect", &closest_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = double(kInfinity), py::kw_only(), py::arg("threads") = py::none(),
             "As Tracer.intersect: arrays t, primitive (-1 on a miss), u, v.")
        .def("occluded", &any_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = double(kInfinity), py::kw_only(), py::arg("threads") = py::none(),
             "As Tracer.occluded: a bool array.");
}

}  // namespace spacebvh::python
#endif
