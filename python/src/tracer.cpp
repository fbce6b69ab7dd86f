// SPDX-License-Identifier: MIT
// Tracers: a named traversal kernel over a tree, closest and any hits for batches of NumPy rays.
#include <tbb/blocked_range.h>

#include <algorithm>
#include <array>
#include <numeric>
#include <optional>

#include "bindings.hpp"
#include "spacebvh/presets.hpp"

namespace spacebvh::python {

namespace {

// The arrays closest hits are returned in: t in the frame's dtype (inf on a miss), primitive int64 (-1
// on a miss), u, v float32; put(i, hit) writes row i (without the GIL: the arrays are made first).
struct HitArrays {
    py::array t;
    py::array_t<float> u, v;
    py::array_t<int64_t> primitive;
    bool float64;
    void* t_out;
    float *u_out, *v_out;
    int64_t* primitive_out;

    HitArrays(const Frame& frame, size_t count)
        : t(new_real_array(frame.float64, {py::ssize_t(count)})),
          u(py::ssize_t(count)),
          v(py::ssize_t(count)),
          primitive(py::ssize_t(count)),
          float64(frame.float64),
          t_out(t.mutable_data()),
          u_out(u.mutable_data()),
          v_out(v.mutable_data()),
          primitive_out(primitive.mutable_data()) {}

    // t needs no change of frame: the frame moves origins, not directions.
    void put(size_t i, const Hit& hit) const {
        if (float64)
            static_cast<double*>(t_out)[i] = hit.t;
        else
            static_cast<float*>(t_out)[i] = hit.t;
        primitive_out[i] = hit.is_hit() ? int64_t(hit.primitive) : -1;
        u_out[i] = hit.u;
        v_out[i] = hit.v;
    }

    py::tuple as_tuple() const { return py::make_tuple(t, primitive, u, v); }
};

}  // namespace

py::tuple hits_as_arrays(const Frame& frame, const std::vector<Hit>& hits, int threads) {
    const HitArrays arrays(frame, hits.size());
    without_gil(threads, [&] {
        in_blocks(hits.size(), 1 << 13, [&](size_t begin, size_t end) {
            for (size_t i = begin; i < end; ++i) arrays.put(i, hits[i]);
        });
    });
    return arrays.as_tuple();
}

py::array_t<bool> occluded_in_blocks(const Tracer& tracer, const RaySource& source, int threads) {
    py::array_t<bool> answers(py::ssize_t(source.size()));
    bool* out = answers.mutable_data();
    without_gil(threads, [&] {
        in_ray_blocks(source, [&](size_t first, std::span<const Ray> rays) {
            std::array<uint8_t, kRayBlock> occluded;
            tracer.occluded(rays, std::span<uint8_t>(occluded.data(), rays.size()));
            for (size_t k = 0; k < rays.size(); ++k) out[first + k] = occluded[k] != 0;
        });
    });
    return answers;
}

py::array_t<bool> answers_as_array(const std::vector<uint8_t>& answers, int threads) {
    py::array_t<bool> result(py::ssize_t(answers.size()));
    bool* out = result.mutable_data();
    without_gil(threads, [&] {
        in_blocks(answers.size(), 1 << 14, [&](size_t begin, size_t end) {
            for (size_t i = begin; i < end; ++i) out[i] = answers[i] != 0;
        });
    });
    return result;
}

namespace {

int threads_for(const PyTracer& self, std::optional<int> threads) { return threads ? *threads : self.threads; }

py::tuple closest_hits(const PyTracer& self, const py::handle& origins, const py::handle& directions,
                       const py::handle& tmin, const py::handle& tmax, std::optional<int> threads_arg) {
    const int threads = threads_for(self, threads_arg);
    const RaySource source = ray_source(self.scene.frame, origins, directions, tmin, tmax);
    const HitArrays arrays(self.scene.frame, source.size());
    // Block by block (in_ray_blocks): each block's hits go straight into the arrays.
    without_gil(threads, [&] {
        in_ray_blocks(source, [&](size_t first, std::span<const Ray> rays) {
            std::array<Hit, kRayBlock> hits;
            self.tracer->intersect(rays, std::span<Hit>(hits.data(), rays.size()));
            for (size_t k = 0; k < rays.size(); ++k) arrays.put(first + k, hits[k]);
        });
    });
    return arrays.as_tuple();
}

// The rays that hit, in ray order: (index_ray, primitive, points or None). Filtering the misses and
// computing the points here, in one pass over the hits, spares a caller that wants only the hits
// (trimesh's intersects_location) the per-ray arrays and NumPy's filtering and gathers. Blocks of
// rays count their hits, then write from their prefix offsets: the same order for any thread count.
py::tuple compact_hits(const PyTracer& self, const py::handle& origins, const py::handle& directions,
                       const py::handle& tmin, const py::handle& tmax, bool points, std::optional<int> threads_arg) {
    constexpr size_t kBlock = size_t(1) << 13;
    const int threads = threads_for(self, threads_arg);
    const std::vector<Ray> rays = rays_from_arguments(self.scene.frame, origins, directions, tmin, tmax, threads);
    std::vector<Hit> hits(rays.size());
    const size_t blocks = (hits.size() + kBlock - 1) / kBlock;
    std::vector<size_t> offsets(blocks + 1, 0);
    auto each_block = [&](auto&& work) {
        in_blocks(blocks, 1, [&](size_t first, size_t last) {
            for (size_t b = first; b < last; ++b) work(b, b * kBlock, std::min(hits.size(), (b + 1) * kBlock));
        });
    };
    without_gil(threads, [&] {
        self.tracer->intersect(std::span<const Ray>(rays), std::span<Hit>(hits));
        each_block([&](size_t b, size_t begin, size_t end) {
            offsets[b + 1] = size_t(std::count_if(hits.begin() + ptrdiff_t(begin), hits.begin() + ptrdiff_t(end),
                                                  [](const Hit& hit) { return hit.is_hit(); }));
        });
    });
    std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
    const py::ssize_t m = py::ssize_t(offsets.back());
    const Frame& frame = self.scene.frame;
    py::array_t<int64_t> index_ray(m), primitive(m);
    py::object point_array = py::none();
    void* point_out = nullptr;
    if (points) {
        py::array fresh = new_real_array(frame.float64, {m, 3});
        point_out = fresh.mutable_data();
        point_array = std::move(fresh);
    }
    int64_t* ray_out = index_ray.mutable_data();
    int64_t* primitive_out = primitive.mutable_data();
    const std::vector<Triangle>& triangles = self.scene.scene->triangles;
    without_gil(threads, [&] {
        each_block([&](size_t b, size_t begin, size_t end) {
            size_t k = offsets[b];
            for (size_t i = begin; i < end; ++i) {
                const Hit& hit = hits[i];
                if (!hit.is_hit()) continue;
                ray_out[k] = int64_t(i);
                primitive_out[k] = int64_t(hit.primitive);
                for (int axis = 0; point_out && axis < 3; ++axis) {
                    const double x = point_at(triangles[hit.primitive], hit.u, hit.v, frame, axis);
                    if (frame.float64)
                        static_cast<double*>(point_out)[3 * k + size_t(axis)] = x;
                    else
                        static_cast<float*>(point_out)[3 * k + size_t(axis)] = float(x);
                }
                ++k;
            }
        });
    });
    return py::make_tuple(index_ray, primitive, point_array);
}

py::array_t<bool> any_hits(const PyTracer& self, const py::handle& origins, const py::handle& directions,
                           const py::handle& tmin, const py::handle& tmax, std::optional<int> threads_arg) {
    const int threads = threads_for(self, threads_arg);
    const RaySource source = ray_source(self.scene.frame, origins, directions, tmin, tmax);
    return occluded_in_blocks(*self.tracer, source, threads);
}

}  // namespace

py::class_<PyTracer> bind_tracer(py::module_& m) {
    m.def("kernels", &kernel_names, "The kernel names Tracer accepts on this CPU.");

    py::class_<PyTracer> tracer(m, "Tracer",
                                "A traversal kernel over a tree; answers equal the exact arbiter of rays.md.");
    tracer
        .def(py::init([](const PyBvh& tree, const std::string& kernel, int threads) {
                 check_threads(threads);
                 std::unique_ptr<Tracer> chosen;
                 {
                     py::gil_scoped_release unlocked;
                     chosen = make_tracer(kernel, *tree.scene.scene, *tree.bvh);
                 }
                 return PyTracer{tree.scene, tree.bvh, std::move(chosen), threads};
             }),
             py::arg("bvh"), py::arg("kernel") = "auto", py::arg("threads") = 0,
             "A tracer over `bvh` with a named kernel (kernels(); 'auto' = the fastest single-ray one). Batch calls "
             "release the GIL and use `threads` threads (0 = every core) unless they say otherwise.")
        .def_property_readonly(
            "kernel", [](const PyTracer& self) { return self.tracer->name(); }, "The kernel's name.")
        .def_property_readonly(
            "memory_bytes", [](const PyTracer& self) { return self.tracer->memory_bytes(); },
            "Bytes of the kernel's nodes and leaf triangle data.")
        .def_property_readonly(
            "scene", [](const PyTracer& self) { return self.scene; }, "The scene traced.")
        .def_property_readonly(
            "threads", [](const PyTracer& self) { return self.threads; },
            "The default thread limit of batch calls (0 = every core).")
        .def("intersect", &closest_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = double(kInfinity), py::kw_only(), py::arg("threads") = py::none(),
             "Closest hits within [tmin, tmax] (numbers, or arrays of one per ray) of rays from origins (k, 3) along "
             "directions (k, 3); either may be one row (3,) or (1, 3) shared by every ray. Returns arrays t (the "
             "scene's dtype, inf on a miss), primitive (int64, -1 on a miss), u, v (float32 barycentrics of the "
             "triangle's second and third corners); Scene.hit_points(primitive, u, v) gives the points.")
        .def("hits", &compact_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = double(kInfinity), py::kw_only(), py::arg("points") = true,
             py::arg("threads") = py::none(),
             "Closest hits as intersect(), only of the rays that hit, in ray order: (index_ray int64, primitive int64, "
             "points), points (m, 3) in the scene's dtype as Scene.hit_points gives them (None unless `points`).")
        .def("occluded", &any_hits, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
             py::arg("tmax") = double(kInfinity), py::kw_only(), py::arg("threads") = py::none(),
             "Any hit within [tmin, tmax] (numbers, or arrays of one per ray), rays as for intersect(): a bool array.");
    return tracer;
}

}  // namespace spacebvh::python
