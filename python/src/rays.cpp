// SPDX-License-Identifier: MIT
// Rays of docs/rays.md (random, primary, diffuse) in the caller's frame, and ray and hit
// files (float32, as the files are).
#include <cmath>

#include "bindings.hpp"
#include "spacebvh/tools/rays.hpp"

namespace spacebvh::python {

using namespace spacebvh::tools;

namespace {

// (origins, directions) of rays in a scene's local frame, origins in the caller's frame and both in
// the scene's dtype; with_range adds their (tmin, tmax) arrays, as ray files carry them.
py::tuple rays_as_arrays(const Frame& frame, const std::vector<Ray>& rays, bool with_range = false) {
    const py::ssize_t n = py::ssize_t(rays.size());
    py::array origins = new_real_array(frame.float64, {n, 3}), directions = new_real_array(frame.float64, {n, 3});
    py::array_t<float> tmin(n), tmax(n);
    auto fill = [&](auto typed) {
        using T = decltype(typed);
        T* o = static_cast<T*>(origins.mutable_data());
        T* d = static_cast<T*>(directions.mutable_data());
        float* low = tmin.mutable_data();
        float* high = tmax.mutable_data();
        for (size_t i = 0; i < rays.size(); ++i) {
            const Ray& ray = rays[i];
            for (int axis = 0; axis < 3; ++axis) {
                o[3 * i + size_t(axis)] = T(frame.to_caller(ray.org[axis], axis));
                d[3 * i + size_t(axis)] = T(ray.dir[axis]);
            }
            low[i] = ray.tmin;
            high[i] = ray.tmax;
        }
    };
    if (frame.float64)
        fill(double());
    else
        fill(float());
    if (with_range) return py::make_tuple(origins, directions, tmin, tmax);
    return py::make_tuple(origins, directions);
}

// Hit records (docs/rays.md) from t and primitive arrays (-1 = a miss, t = inf).
std::vector<HitRecord> make_hit_records(const py::handle& t_arg, const py::handle& primitive_arg) {
    const auto t = py::array_t<float, py::array::forcecast>::ensure(t_arg);
    const auto primitive = py::array_t<int64_t, py::array::forcecast>::ensure(primitive_arg);
    if (!t || !primitive || t.ndim() != 1 || primitive.ndim() != 1 || t.shape(0) != primitive.shape(0))
        throw Error("t and primitive must be arrays of one length");
    std::vector<HitRecord> records(size_t(t.shape(0)));
    const auto distances = t.unchecked<1>();
    const auto ids = primitive.unchecked<1>();
    for (size_t i = 0; i < records.size(); ++i) {
        const float distance = distances(py::ssize_t(i));
        const int64_t id = ids(py::ssize_t(i));
        if (std::isnan(distance)) throw Error("hit " + std::to_string(i) + ": t is NaN");
        if (id < -1 || id >= int64_t(kInvalidIndex))
            throw Error("hit " + std::to_string(i) + ": primitive " + std::to_string(id) +
                        " out of range (-1 = a miss)");
        records[i] = {distance, id < 0 ? kInvalidIndex : uint32_t(id)};
    }
    return records;
}

py::tuple hit_records_as_arrays(const std::vector<HitRecord>& records) {
    const py::ssize_t n = py::ssize_t(records.size());
    py::array_t<float> t(n);
    py::array_t<int64_t> primitive(n);
    float* t_out = t.mutable_data();
    int64_t* primitive_out = primitive.mutable_data();
    for (size_t i = 0; i < records.size(); ++i) {
        t_out[i] = records[i].t;
        primitive_out[i] = records[i].primitive == kInvalidIndex ? -1 : int64_t(records[i].primitive);
    }
    return py::make_tuple(t, primitive);
}

py::tuple diffuse_rays(const PyScene& scene, const py::handle& origins, const py::handle& directions,
                       const py::handle& t, const py::handle& primitive, uint64_t seed, float epsilon) {
    if (!(std::isfinite(epsilon) && epsilon >= 0.0f))
        throw Error("epsilon must be finite and >= 0 (0: the spec's default, 1e-4 x |scene diagonal|), not " +
                    std::to_string(epsilon));
    const std::vector<Ray> primary =
        rays_from_arguments(scene.frame, origins, directions, py::float_(0.0), py::float_(double(kInfinity)), 0);
    const std::vector<HitRecord> records = make_hit_records(t, primitive);
    std::vector<Hit> hits(records.size());
    for (size_t i = 0; i < records.size(); ++i) {
        if (records[i].primitive == kInvalidIndex) continue;
        if (!std::isfinite(records[i].t) || records[i].t < 0.0f)
            throw Error("hit " + std::to_string(i) + ": a hit needs a finite t >= 0, not " +
                        std::to_string(records[i].t));
        hits[i].t = records[i].t;
        hits[i].primitive = records[i].primitive;
    }
    std::vector<Ray> rays;
    {
        py::gil_scoped_release unlocked;
        rays = generate_diffuse_rays(*scene.scene, primary, hits, seed, epsilon);
    }
    return rays_as_arrays(scene.frame, rays);
}

}  // namespace

void bind_rays(py::module_& m) {
    m.def(
        "random_rays",
        [](const PyScene& scene, size_t count, uint64_t seed) {
            std::vector<Ray> rays;
            {
                py::gil_scoped_release unlocked;
                rays = generate_random_rays(scene.scene->bounds(), count, seed);
            }
            return rays_as_arrays(scene.frame, rays);
        },
        py::arg("scene"), py::arg("count"), py::arg("seed") = 1,
        "The random rays of docs/rays.md: (origins, directions) arrays in the caller's frame and the scene's dtype.");
    m.def(
        "primary_rays",
        [](const PyScene& scene, uint32_t width, uint32_t height, const std::string& camera) {
            const Camera view = camera_in_frame(scene, camera);
            std::vector<Ray> rays;
            {
                py::gil_scoped_release unlocked;
                rays = generate_primary_rays(view, width, height);
            }
            return rays_as_arrays(scene.frame, rays);
        },
        py::arg("scene"), py::arg("width") = 1024u, py::arg("height") = 1024u, py::arg("camera") = "",
        "The primary rays of docs/rays.md, row by row from the top: (origins, directions) arrays. camera: "
        "'ex,ey,ez,tx,ty,tz,ux,uy,uz,fovy' (the MANIFEST's values, in the caller's frame), default the spec's camera "
        "for the scene.");
    m.def("diffuse_rays", &diffuse_rays, py::arg("scene"), py::arg("origins"), py::arg("directions"), py::arg("t"),
          py::arg("primitive"), py::arg("seed") = 1, py::arg("epsilon") = 0.0f,
          "The diffuse rays of docs/rays.md: one cosine-distributed bounce per primary ray that hits (t, "
          "primitive: intersect()'s answers for those rays, primitive -1 = a miss), in primary order, leaving the "
          "surface at epsilon along its normal (0: the spec's default). Returns (origins, directions) arrays.");
    m.def(
        "read_rays",
        [](const std::string& path) {
            std::vector<Ray> rays;
            {
                py::gil_scoped_release unlocked;
                rays = read_ray_file(path);
            }
            return rays_as_arrays(Frame{}, rays, true);
        },
        py::arg("path"), "A ray file of docs/rays.md: (origins, directions, tmin, tmax) float32 arrays.");
    m.def(
        "write_rays",
        [](const std::string& path, const py::handle& origins, const py::handle& directions, const py::handle& tmin,
           const py::handle& tmax) {
            const std::vector<Ray> rays = rays_from_arguments(Frame{}, origins, directions, tmin, tmax, 0);
            py::gil_scoped_release unlocked;
            write_ray_file(path, rays);
        },
        py::arg("path"), py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
        py::arg("tmax") = double(kInfinity),
        "Writes a ray file of docs/rays.md (float32; tmin, tmax: numbers or one per ray).");
    m.def(
        "read_hits",
        [](const std::string& path) {
            std::vector<HitRecord> records;
            {
                py::gil_scoped_release unlocked;
                records = read_hit_file(path);
            }
            return hit_records_as_arrays(records);
        },
        py::arg("path"),
        "A hit file of docs/rays.md: (t, primitive) arrays, primitive -1 for a miss (occlusion files: t = 0 "
        "occluded, inf free).");
    m.def(
        "write_hits",
        [](const std::string& path, const py::handle& t, const py::handle& primitive) {
            const std::vector<HitRecord> records = make_hit_records(t, primitive);
            py::gil_scoped_release unlocked;
            write_hit_file(path, records);
        },
        py::arg("path"), py::arg("t"), py::arg("primitive"),
        "Writes a hit file of docs/rays.md from t and primitive arrays (-1 = a miss), e.g. intersect()'s.");
}

}  // namespace spacebvh::python
