// SPDX-License-Identifier: MIT
// GeometryMap: the triangles of a mesh combined from several geometries, mapped back to (geometry
// id, primitive id) with a unit normal each, and the ray and point queries of Open3D's
// RaycastingScene answered straight into its arrays (spacebvh.open3d): rays (k, 6) as Open3D passes
// them read in place, every output array written by one pass across the threads without the GIL.
#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <cstring>
#include <limits>

#include "bindings.hpp"
#include "hit_chunks.hpp"
#include "spacebvh/queries.hpp"

namespace spacebvh::python {

namespace {

using PyQueries = PyQueryObject<RayQueries>;
using namespace pybind11::literals;

constexpr uint32_t kInvalidId = 0xFFFFFFFFu;  // Open3D's INVALID_ID, for misses

struct GeometryMap {
    // What a hit on one combined triangle reports, kept together so that a hit reads one place.
    struct Entry {
        uint32_t geometry, primitive;
        float normal[3];
    };
    std::vector<Entry> entries;  // per combined triangle

    size_t triangles() const { return entries.size(); }

    // Writes the ids and normal of combined triangle `triangle` (kInvalidIndex: a miss).
    void put(uint32_t triangle, uint32_t* geometry_out, uint32_t* primitive_out, float* normal_out) const {
        if (triangle == kInvalidIndex) {
            *geometry_out = *primitive_out = kInvalidId;
            if (normal_out != nullptr) normal_out[0] = normal_out[1] = normal_out[2] = 0.0f;
            return;
        }
        const Entry& entry = entries[triangle];
        *geometry_out = entry.geometry;
        *primitive_out = entry.primitive;
        if (normal_out != nullptr)
            for (int axis = 0; axis < 3; ++axis) normal_out[axis] = entry.normal[axis];
    }

    // Starts fetching the entry of combined triangle `triangle` (kInvalidIndex: nothing to fetch).
    void prefetch(uint32_t triangle) const {
        if (triangle != kInvalidIndex) __builtin_prefetch(&entries[triangle]);
    }

    void check_size(size_t scene_triangles, const char* what) const {
        if (scene_triangles != triangles())
            throw Error(std::string(what) + " is over " + std::to_string(scene_triangles) +
                        " triangles, the geometry map over " + std::to_string(triangles()));
    }
};

GeometryMap make_map(const std::vector<int64_t>& counts, const py::handle& normals_arg) {
    const RealRows normals = RealRows::from(normals_arg, "normals");
    uint64_t total = 0;
    for (size_t g = 0; g < counts.size(); ++g) {
        if (counts[g] < 0)
            throw Error("counts[" + std::to_string(g) + "] must be >= 0, not " + std::to_string(counts[g]));
        total += uint64_t(counts[g]);
        if (total > normals.rows())  // checked as it grows, so an absurd count fails before any work
            throw Error("normals must have one row per triangle (sum(counts) >= " + std::to_string(total) + "), not " +
                        std::to_string(normals.rows()));
    }
    if (total != normals.rows())
        throw Error("normals must have one row per triangle (" + std::to_string(total) + "), not " +
                    std::to_string(normals.rows()));
    if (total >= kInvalidIndex) throw Error("a geometry map holds fewer than 2^32 - 1 triangles");
    GeometryMap map;
    map.entries.resize(total);
    normals.visit([&](auto read) {
        size_t i = 0;
        for (size_t g = 0; g < counts.size(); ++g)
            for (int64_t p = 0; p < counts[g]; ++p, ++i) {
                GeometryMap::Entry& entry = map.entries[i];
                entry.geometry = uint32_t(g);
                entry.primitive = uint32_t(p);
                for (int axis = 0; axis < 3; ++axis) entry.normal[axis] = float(read(i, axis));
            }
    });
    return map;
}

// Rays from rows (k, 6): origin then direction, float32 or float64, any strides; read in place.
RaySource rays_from_rows(const Frame& frame, const py::handle& rows_arg, double tnear, double tfar) {
    const py::array rows = py::module_::import("numpy").attr("asarray")(rows_arg).cast<py::array>();
    const char kind = rows.dtype().kind();
    if (kind != 'f' && kind != 'i' && kind != 'u')
        throw py::type_error("rays must be an array of real numbers (float32 or float64), not dtype " +
                             py::str(rows.dtype()).cast<std::string>());
    if (rows.ndim() != 2 || rows.shape(1) != 6)
        throw Error("rays must have shape (k, 6) (origin, direction), not ndim " + std::to_string(rows.ndim()) +
                    (rows.ndim() == 2 ? " with " + std::to_string(rows.shape(1)) + " columns" : std::string()));
    const py::slice all{py::none(), py::none(), py::none()};
    const py::object origins = rows[py::make_tuple(all, py::slice(0, 3, 1))];
    const py::object directions = rows[py::make_tuple(all, py::slice(3, 6, 1))];
    return ray_source(frame, origins, directions, py::float_(tnear), py::float_(tfar));
}

// The contact queries trace the rays block by block (in_ray_blocks) and write Open3D's arrays from
// each block's answers: no array of every ray or every hit is made, filled and read again.
py::dict cast_rays(const GeometryMap& map, const PyTracer& tracer, const py::handle& rows, int threads) {
    map.check_size(tracer.scene.scene->triangles.size(), "the tracer");
    const RaySource source = rays_from_rows(tracer.scene.frame, rows, 0.0, double(kInfinity));
    const py::ssize_t n = py::ssize_t(source.size());
    py::array_t<float> t(n), uvs(std::vector<py::ssize_t>{n, 2}), normals(std::vector<py::ssize_t>{n, 3});
    py::array_t<uint32_t> geometry(n), primitive(n);
    float *t_out = t.mutable_data(), *uv_out = uvs.mutable_data(), *normal_out = normals.mutable_data();
    uint32_t *geometry_out = geometry.mutable_data(), *primitive_out = primitive.mutable_data();
    without_gil(threads, [&] {
        in_ray_blocks(source, [&](size_t first, std::span<const Ray> rays) {
            std::array<Hit, kRayBlock> hits;
            tracer.tracer->intersect(rays, std::span<Hit>(hits.data(), rays.size()));
            // The entries of a large mesh (20 bytes a triangle) miss the cache at every hit: their
            // fetches are started together, before the writes that wait on them.
            for (size_t k = 0; k < rays.size(); ++k) map.prefetch(hits[k].primitive);
            for (size_t k = 0; k < rays.size(); ++k) {
                const Hit& hit = hits[k];
                const size_t i = first + k;
                const bool is_hit = hit.is_hit();
                t_out[i] = is_hit ? hit.t : std::numeric_limits<float>::infinity();
                uv_out[2 * i] = is_hit ? hit.u : 0.0f;
                uv_out[2 * i + 1] = is_hit ? hit.v : 0.0f;
                map.put(hit.primitive, geometry_out + i, primitive_out + i, normal_out + 3 * i);
            }
        });
    });
    return py::dict("t_hit"_a = t, "geometry_ids"_a = geometry, "primitive_ids"_a = primitive, "primitive_uvs"_a = uvs,
                    "primitive_normals"_a = normals);
}

py::array_t<bool> test_occlusions(const GeometryMap& map, const PyTracer& tracer, const py::handle& rows, double tnear,
                                  double tfar, int threads) {
    map.check_size(tracer.scene.scene->triangles.size(), "the tracer");
    return occluded_in_blocks(*tracer.tracer, rays_from_rows(tracer.scene.frame, rows, tnear, tfar), threads);
}

py::array_t<int32_t> count_intersections(const GeometryMap& map, const PyQueries& queries, const py::handle& rows,
                                         int threads) {
    map.check_size(queries.queries->triangle_count(), "the ray queries");
    const RaySource source = rays_from_rows(queries.scene.frame, rows, 0.0, double(kInfinity));
    py::array_t<int32_t> counts(py::ssize_t(source.size()));
    // uint32 and int32 may alias; a count never reaches 2^31 (it is at most the triangle count).
    uint32_t* out = reinterpret_cast<uint32_t*>(counts.mutable_data());
    without_gil(threads, [&] {
        in_ray_blocks(source, [&](size_t first, std::span<const Ray> rays) {
            queries.queries->count_hits(rays, std::span<uint32_t>(out + first, rays.size()));
        });
    });
    return counts;
}

// One crossing as Open3D lists it.
struct ListedHit {
    uint32_t triangle;
    float t, u, v;
};

py::dict list_intersections(const GeometryMap& map, const PyQueries& queries, const py::handle& rows, int threads) {
    map.check_size(queries.queries->triangle_count(), "the ray queries");
    const RaySource source = rays_from_rows(queries.scene.frame, rows, 0.0, double(kInfinity));
    std::vector<Ray> rays;
    ChunkedHits<ListedHit> lists;
    without_gil(threads, [&] {
        rays = make_rays(source);
        lists = collect_chunked_hits<ListedHit>(*queries.queries, rays, kNoHitLimit, [](const QueryHit& hit) {
            return ListedHit{hit.primitive, float(hit.t), float(hit.u), float(hit.v)};
        });
    });
    if (lists.size() > std::numeric_limits<uint32_t>::max())
        throw Error("list_intersections: " + std::to_string(lists.size()) +
                    " crossings do not fit Open3D's uint32 ray_splits; pass fewer rays at a time");
    const py::ssize_t n = py::ssize_t(rays.size()), m = py::ssize_t(lists.size());
    py::array_t<uint32_t> splits(n + 1), ray_ids(m), geometry(m), primitive(m);
    py::array_t<float> uvs(std::vector<py::ssize_t>{m, 2}), t(m);
    uint32_t *split_out = splits.mutable_data(), *ray_out = ray_ids.mutable_data(),
             *geometry_out = geometry.mutable_data(), *primitive_out = primitive.mutable_data();
    float *uv_out = uvs.mutable_data(), *t_out = t.mutable_data();
    without_gil(threads, [&] {
        in_blocks(size_t(n) + 1, 1 << 13, [&](size_t begin, size_t end) {
            for (size_t i = begin; i < end; ++i) split_out[i] = uint32_t(lists.offsets[i]);
        });
        lists.for_each([&](uint64_t k, size_t ray, const ListedHit& hit) {
            ray_out[k] = uint32_t(ray);
            map.put(hit.triangle, geometry_out + k, primitive_out + k, nullptr);
            uv_out[2 * k] = hit.u;
            uv_out[2 * k + 1] = hit.v;
            t_out[k] = hit.t;
        });
    });
    return py::dict("ray_splits"_a = splits, "ray_ids"_a = ray_ids, "geometry_ids"_a = geometry,
                    "primitive_ids"_a = primitive, "primitive_uvs"_a = uvs, "t_hit"_a = t);
}

py::array_t<float> compute_occupancy(const GeometryMap& map, const PyQueries& queries, const py::handle& points_arg,
                                     int threads) {
    map.check_size(queries.queries->triangle_count(), "the ray queries");
    const std::vector<uint8_t> inside = contained_points(queries, points_arg, "query_points", threads);
    py::array_t<float> result(py::ssize_t(inside.size()));
    float* out = result.mutable_data();
    without_gil(threads, [&] {
        in_blocks(inside.size(), 1 << 13, [&](size_t begin, size_t end) {
            for (size_t i = begin; i < end; ++i) out[i] = inside[i] ? 1.0f : 0.0f;
        });
    });
    return result;
}

constexpr const char* kRowsDoc =
    "Rays (k, 6) float32 or float64 (origin, direction; any strides), as Open3D passes them. ";

}  // namespace

void bind_geometry_map(py::module_& m) {
    py::class_<GeometryMap>(
        m, "GeometryMap",
        "The triangles of a mesh combined from several geometries (in order), mapped back to (geometry id, primitive "
        "id) with a unit normal each, and Open3D's RaycastingScene queries answered straight into its arrays "
        "(spacebvh.open3d): one pass over the rays without the GIL, misses as INVALID_ID (0xFFFFFFFF).")
        .def(py::init(&make_map), py::arg("counts"), py::arg("normals"),
             "counts: the triangles of each geometry; normals (sum(counts), 3): the unit normal of each combined "
             "triangle (zero for a degenerate one).")
        .def_property_readonly("triangles", &GeometryMap::triangles, "The number of combined triangles.")
        .def("cast_rays", &cast_rays, py::arg("tracer"), py::arg("rays"), py::kw_only(), py::arg("threads") = 0,
             (std::string(kRowsDoc) +
              "The nearest contact of each ray over the Tracer `tracer` of the combined mesh: {'t_hit' float32 (inf on "
              "a miss), 'geometry_ids', 'primitive_ids' uint32, 'primitive_uvs' (k, 2), 'primitive_normals' (k, 3) "
              "float32}.")
                 .c_str())
        .def("test_occlusions", &test_occlusions, py::arg("tracer"), py::arg("rays"), py::arg("tnear") = 0.0,
             py::arg("tfar") = double(kInfinity), py::kw_only(), py::arg("threads") = 0,
             (std::string(kRowsDoc) + "Whether each ray touches the mesh for t in [tnear, tfar]: bool (k,).").c_str())
        .def("count_intersections", &count_intersections, py::arg("queries"), py::arg("rays"), py::kw_only(),
             py::arg("threads") = 0,
             (std::string(kRowsDoc) + "The crossings of each ray (RayQueries `queries`, t >= 0): int32 (k,).").c_str())
        .def("list_intersections", &list_intersections, py::arg("queries"), py::arg("rays"), py::kw_only(),
             py::arg("threads") = 0,
             (std::string(kRowsDoc) +
              "Every crossing (RayQueries `queries`, t >= 0) by ray and then by t: {'ray_splits' uint32 (k + 1), "
              "'ray_ids', 'geometry_ids', 'primitive_ids' uint32, 'primitive_uvs' (m, 2), 't_hit' float32}.")
                 .c_str())
        .def("compute_occupancy", &compute_occupancy, py::arg("queries"), py::arg("query_points"), py::kw_only(),
             py::arg("threads") = 0,
             "1.0 where a point (k, 3) is inside by the exact parity of crossings (RayQueries `queries`), else "
             "0.0: float32 (k,).");
}

}  // namespace spacebvh::python
